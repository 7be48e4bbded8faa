// Levels of detail (issue 20): the front half once, the back half per level,
// each level what the same target run alone gives; visual targets.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <memory>
#include <cmath>
#include <cstdio>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <tbb/global_control.h>

#include "eval/visual_similarity.h"
#include "io/mesh_io.h"
#include "pipeline/pipeline.h"
#include "test_meshes.h"

namespace vpr {
namespace {

Mesh bumpy_sphere() {
  const std::string obj = testing::bumpy_sphere_obj(1.0, 0.0, 0);
  auto mesh = parse_mesh(reinterpret_cast<const uint8_t*>(obj.data()), obj.size(), MeshFormat::kObj);
  EXPECT_TRUE(mesh.ok()) << mesh.status().to_string();
  return std::move(mesh).value();
}

PipelineOptions small_views() {
  PipelineOptions o;
  o.views.resolution = 256;
  return o;
}

LevelTarget count(uint32_t n) {
  LevelTarget l;
  l.vertices = n;
  return l;
}

std::vector<PipelineResult> run_levels(const Mesh& mesh, const PipelineOptions& o, const std::vector<LevelTarget>& l,
                                       std::vector<StageTiming>* live = nullptr) {
  PipelineOptions options = o;
  if (live) options.on_stage = [live](const StageTiming& t) { live->push_back(t); };
  std::vector<PipelineResult> out;
  Status s = run_pipeline_levels(mesh, options, l, [&](PipelineResult&& r) {
    out.push_back(std::move(r));
    return Status::Ok();
  });
  EXPECT_TRUE(s.ok()) << s.to_string();
  return out;
}

TEST(LodChain, ThreeLevelsInOrderWithTheFrontHalfOnceEachAsIfRunAlone) {
  const Mesh mesh = bumpy_sphere();  // 2,562 vertices
  LevelTarget quarter;
  quarter.fraction = 0.25;
  std::vector<StageTiming> live;
  // One at a time (LevelsSideBySide... below checks the default against it).
  PipelineOptions serial = small_views();
  serial.levels_side_by_side = false;
  const std::vector<PipelineResult> levels = run_levels(mesh, serial, {count(1500), count(600), quarter}, &live);
  ASSERT_EQ(levels.size(), 3u);
  const uint32_t asked[3] = {1500, 600, 641};  // 0.25 x 2,562, rounded
  const std::set<std::string> front = {"views",     "render",     "image_saliency",
                                       "unproject", "visibility", "saliency_field"};
  for (int i = 0; i < 3; ++i) {
    const PipelineResult& r = levels[size_t(i)];
    EXPECT_EQ(r.level, i);
    EXPECT_EQ(r.target, asked[i]);
    EXPECT_NEAR(double(r.mesh.vertex_count()), asked[i], 0.02 * asked[i]);
    EXPECT_EQ(r.saliency.size(), r.mesh.vertex_count());
    EXPECT_EQ(r.input_importance.size(), mesh.vertex_count());
    for (const StageTiming& t : r.stages) {
      if (front.count(t.name)) {
        EXPECT_EQ(i, 0) << t.name << " reported again with level " << i;
        EXPECT_EQ(t.level, kFrontHalf) << t.name;
      } else {
        EXPECT_EQ(t.level, i) << t.name;
      }
    }
  }
  // Live stage events: each front-half stage once, then the back halves in level order.
  for (const std::string& name : front)
    EXPECT_EQ(std::count_if(live.begin(), live.end(), [&](const StageTiming& t) { return t.name == name; }), 1) << name;
  for (size_t k = 1; k < live.size(); ++k) EXPECT_LE(live[k - 1].level, live[k].level);
  // Every level's refinement was made ahead, beside the stages before it
  // (the first beside the front half, each next beside the level before).
  for (int i = 0; i < 3; ++i) {
    const auto& stages = levels[size_t(i)].stages;
    auto density = std::find_if(stages.begin(), stages.end(), [](const StageTiming& t) { return t.name == "density"; });
    ASSERT_NE(density, stages.end()) << "level " << i;
    EXPECT_NE(density->note.find("refined ahead"), std::string::npos) << "level " << i << ": " << density->note;
  }

  // Each level is the same level run alone, bit for bit: made ahead beside
  // the level before in the chain, beside the front half alone.
  for (int i = 0; i < 3; ++i) {
    PipelineOptions alone = small_views();
    alone.target_vertices = asked[i];
    auto single = run_pipeline(mesh, alone);
    ASSERT_TRUE(single.ok()) << single.status().to_string();
    EXPECT_EQ(single->mesh.indices, levels[size_t(i)].mesh.indices) << "level " << i;
    EXPECT_EQ(single->mesh.positions, levels[size_t(i)].mesh.positions) << "level " << i;
    EXPECT_EQ(single->saliency, levels[size_t(i)].saliency) << "level " << i;
  }
}

TEST(LodChain, BadLevelListsAreRefusedNamingTheProblem) {
  const Mesh mesh = testing::icosphere(2);  // 162 vertices
  auto refused = [&](const std::vector<LevelTarget>& levels, const std::string& words) {
    Status s = run_pipeline_levels(mesh, PipelineOptions{}, levels, [](PipelineResult&&) { return Status::Ok(); });
    EXPECT_EQ(s.code(), StatusCode::kInvalidArgument) << words;
    EXPECT_NE(s.message().find(words), std::string::npos) << s.message();
  };
  refused({}, "level list is empty");
  refused({count(500), LevelTarget{}}, "level 1: no target");
  refused(std::vector<LevelTarget>(17, count(500)), "17 levels asked; at most 16");
  LevelTarget too_much;
  too_much.fraction = 1.5;
  refused({too_much}, "level 0: fraction 1.5");
  LevelTarget tiny;
  tiny.fraction = 0.1;  // 16 of 162 vertices
  refused({count(120), tiny}, "level 1: fraction 0.1");
  LevelTarget both = count(300);
  both.min_ssim = 0.9;
  refused({both}, "not several");
  refused({count(50)}, "level 0: target of 50 vertices");

  // A server's --max-target-vertices holds for counts found at run time.
  PipelineOptions capped;
  capped.max_level_vertices = 150;
  LevelTarget all;
  all.fraction = 1.0;  // 162
  Status s = run_pipeline_levels(mesh, capped, {all}, [](PipelineResult&&) { return Status::Ok(); });
  EXPECT_EQ(s.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("is 162, outside the supported range [100, 150]"), std::string::npos) << s.message();
}

// A visual target on a synthetic shape lands within 2% of the smallest count
// a sweep finds passing, and says how many tries it took.
TEST(LodChain, VisualTargetFindsTheFewestVerticesThatKeepTheBound) {
  const Mesh mesh = bumpy_sphere();
  PipelineOptions o = small_views();
  std::string tries;  // each try's count and score, for the failure messages
  o.on_stage = [&](const StageTiming& st) {
    if (st.name == "visual_target") tries += st.note + "\n";
  };
  constexpr double kBound = 0.95;  // the remesh at the input's 2,562 vertices reaches 0.981
  LevelTarget visual;
  visual.min_ssim = kBound;
  const std::vector<PipelineResult> found = run_levels(mesh, o, {visual});
  o.on_stage = nullptr;
  ASSERT_EQ(found.size(), 1u);
  const PipelineResult& r = found[0];
  ASSERT_GT(r.search.tries, 0);
  // Well inside the search's limit of 12. How many it takes depends on the
  // scores' noise near the bound: over sampling seeds 1-7 this sphere took
  // 4-9 tries (9 where five passing tries walk down a plateau 2% at a time).
  EXPECT_LE(r.search.tries, 9) << tries;
  EXPECT_DOUBLE_EQ(r.search.min_ssim, kBound);
  ASSERT_GE(r.search.ssim, kBound) << "not reached: " << r.target << " vertices";
  EXPECT_EQ(r.mesh.vertex_count(), size_t(r.target)) << "the level is the chosen count's output";

  // The sweep: 2% steps from 60% of the chosen count up to it, judged from
  // the same views. The score is not monotone in the count at the 0.005
  // level (each count's cells are their own local minimum: on this sphere
  // 491 vertices reach 0.9515 and 500 only 0.9466), so "the smallest count
  // that reaches the bound" is taken as the threshold above which every
  // count measured (swept or tried by the search) reaches it; the chosen
  // count must be within 2% of that.
  auto renderer = create_renderer(RendererKind::kAuto);
  ASSERT_TRUE(renderer.ok());
  VisualSimilarityOptions judge;
  judge.views = o.views.count;
  judge.resolution = o.views.resolution;
  auto reference = VisualReference::create(mesh, renderer->get(), judge);
  ASSERT_TRUE(reference.ok()) << reference.status().to_string();
  std::vector<std::pair<uint32_t, double>> measured;
  std::istringstream lines(tries);
  for (std::string line; std::getline(lines, line);) {
    unsigned n = 0;
    double ssim = 0;
    if (std::sscanf(line.c_str(), "%u vertices: SSIM %lf", &n, &ssim) == 2) measured.push_back({uint32_t(n), ssim});
  }
  ASSERT_EQ(measured.size(), size_t(r.search.tries)) << tries;
  std::vector<LevelTarget> sweep;
  for (double n = 0.6 * r.target; n < r.target / 1.02; n *= 1.02) sweep.push_back(count(uint32_t(n)));
  for (size_t start = 0; start < sweep.size(); start += kMaxLevels) {
    const std::vector<LevelTarget> part(sweep.begin() + long(start),
                                        sweep.begin() + long(std::min(sweep.size(), start + kMaxLevels)));
    for (const PipelineResult& level : run_levels(mesh, o, part)) {
      auto score = reference->compare(level.mesh);
      ASSERT_TRUE(score.ok());
      measured.push_back({level.target, score->ssim_mean});
    }
  }
  uint32_t threshold = 0;  // one past the largest count below the chosen one that fails
  std::string table;
  for (const auto& [n, ssim] : measured) {
    table += std::to_string(n) + ": " + std::to_string(ssim) + "\n";
    if (n < r.target && ssim < kBound) threshold = std::max(threshold, n + 1);
  }
  EXPECT_GT(threshold, 0u) << "nothing below the chosen count fails: the search did not bracket it\n" << table;
  EXPECT_LE(double(r.target), 1.02 * threshold + 1) << "every count from " << threshold << " up passes\n" << table;
  // And the bulk of the sweep fails: the counts more than 2% below the
  // chosen one that pass are isolated.
  size_t below = 0, passing = 0;
  for (const auto& [n, ssim] : measured)
    if (n < r.target / 1.02) ++below, passing += ssim >= kBound;
  EXPECT_LE(passing * 4, below) << table;
}

// A visual target's tries made ahead (beside the try the search runs) leave
// the outcome as it is: the same count, score, tries and mesh bits, and the
// same stage events in the same order, as without.
TEST(LodChain, VisualTargetTriesMadeAheadGiveTheSameOutcome) {
  const Mesh mesh = bumpy_sphere();
  LevelTarget visual;
  visual.min_ssim = 0.95;
  auto run = [&](int ahead, std::vector<std::string>* events) {
    PipelineOptions o = small_views();
    o.visual_target_ahead = ahead;
    o.visual_target_warm = false;  // every try cold, made ahead or not
    // The level's stages with their notes (counts, sweeps, scores); the front
    // half's by name (a note there may hold a wait in ms).
    o.on_stage = [events](const StageTiming& t) {
      events->push_back(t.name + " " + std::to_string(t.level) + (t.level == kFrontHalf ? "" : " " + t.note));
    };
    const std::vector<PipelineResult> found = run_levels(mesh, o, {visual});
    EXPECT_EQ(found.size(), 1u);
    return found.empty() ? PipelineResult() : found[0];
  };
  std::vector<std::string> without_events, with_events;
  const PipelineResult without = run(0, &without_events);
  const PipelineResult with = run(1, &with_events);
  EXPECT_EQ(with.target, without.target);
  EXPECT_EQ(with.search.tries, without.search.tries);
  EXPECT_EQ(with.search.ssim, without.search.ssim);
  EXPECT_EQ(with.mesh.positions, without.mesh.positions);
  EXPECT_EQ(with.mesh.indices, without.mesh.indices);
  EXPECT_EQ(with.saliency, without.saliency);
  // The events in order; the last, the search's summary, says how many
  // tries were made ahead.
  ASSERT_FALSE(with_events.empty());
  ASSERT_EQ(with_events.size(), without_events.size());
  EXPECT_EQ(std::vector<std::string>(with_events.begin(), with_events.end() - 1),
            std::vector<std::string>(without_events.begin(), without_events.end() - 1));
  EXPECT_EQ(without.search.made_ahead, 0);
  EXPECT_GE(with.search.made_ahead, 1);
  EXPECT_LE(with.search.made_ahead, with.search.tries);  // one per try at most: the try after a pass
  EXPECT_GE(with.search.taken, 1) << with_events.back();  // on this sphere the search takes one
  EXPECT_LE(with.search.taken, with.search.made_ahead);
  EXPECT_NE(with_events.back().find("made ahead"), std::string::npos) << with_events.back();
  // The tries after both outcomes made ahead: the same outcome, more tries
  // made ahead than the search ran.
  std::vector<std::string> both_events;
  const PipelineResult both = run(2, &both_events);
  EXPECT_EQ(both.target, without.target);
  EXPECT_EQ(both.mesh.positions, without.mesh.positions);
  EXPECT_GT(both.search.made_ahead, both.search.tries) << both_events.back();
}

// A visual target's tries below a passing one (within 15%), or above a
// failing one (within 10%), start from its surface and cells
// (PipelineOptions::visual_target_warm): the CVT's note says from which try
// and how many cells merged or were cut in two, the warm try runs fewer
// sweeps than the cold try at the same count, the level keeps the bound,
// and the outcome is the same bit for bit on another run and on one thread.
TEST(LodChain, VisualTargetTriesNearAnEarlierTryStartWarm) {
  const Mesh mesh = bumpy_sphere();
  LevelTarget visual;
  visual.min_ssim = 0.95;
  struct Try {
    uint32_t from = 0, merged = 0, cut = 0;
    int sweeps = 0;
  };
  auto run = [&](bool warm, int threads, std::vector<Try>* tries) {
    PipelineOptions o = small_views();
    o.visual_target_warm = warm;
    o.visual_target_ahead = 0;
    o.on_stage = [tries](const StageTiming& t) {
      if (t.name != "cvt") return;
      Try x;
      unsigned from = 0, merged = 0, cut = 0;
      if (std::sscanf(t.note.c_str(), "from the cells of the try at %u vertices, %u merged; %d sweeps", &from, &merged,
                      &x.sweeps) == 3) {
        x.from = from, x.merged = merged;
      } else if (std::sscanf(t.note.c_str(), "from the cells of the try at %u vertices, %u cut in two; %d sweeps", &from,
                             &cut, &x.sweeps) == 3) {
        x.from = from, x.cut = cut;
      } else {
        EXPECT_EQ(std::sscanf(t.note.c_str(), "%d sweeps", &x.sweeps), 1) << t.note;
      }
      tries->push_back(x);
    };
    std::unique_ptr<tbb::global_control> limit;
    if (threads > 0) limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, threads);
    const std::vector<PipelineResult> found = run_levels(mesh, o, {visual});
    EXPECT_EQ(found.size(), 1u);
    return found.empty() ? PipelineResult() : found[0];
  };
  std::vector<Try> warm_tries, again_tries, one_tries;
  const PipelineResult warm = run(true, 0, &warm_tries);
  ASSERT_GE(warm.search.ssim, visual.min_ssim);
  EXPECT_EQ(warm.mesh.vertex_count(), size_t(warm.target));
  size_t started_warm = 0, started_cut = 0;
  for (const Try& t : warm_tries) {
    if (t.from == 0) continue;
    ++started_warm;
    started_cut += t.cut > 0;
    const uint32_t n = t.from - t.merged + t.cut;  // every surplus cell merged (or missing one cut) on this sphere
    EXPECT_LE(double(std::max(t.from, n)), 1.15 * std::min(t.from, n) + 1) << "a source more than 15% from the try";
    // The same count from scratch.
    PipelineOptions o = small_views();
    std::vector<StageTiming> stages;
    const std::vector<PipelineResult> cold = run_levels(mesh, o, {count(n)}, &stages);
    ASSERT_EQ(cold.size(), 1u);
    EXPECT_LT(t.sweeps, cold[0].cvt.sweeps) << "a warm try at " << n;
  }
  EXPECT_GE(started_warm, 1u) << "no try started warm";
  EXPECT_GE(started_cut, 1u) << "no try started from a failing one below it";
  const PipelineResult again = run(true, 0, &again_tries);
  const PipelineResult one = run(true, 1, &one_tries);
  for (const PipelineResult* r : {&again, &one}) {
    EXPECT_EQ(r->target, warm.target);
    EXPECT_EQ(r->search.tries, warm.search.tries);
    EXPECT_EQ(r->mesh.positions, warm.mesh.positions);
    EXPECT_EQ(r->mesh.indices, warm.mesh.indices);
  }
}

// A cut start that fails near the bound is run again from scratch at the
// same count (PipelineOptions::visual_target_confirm), and the search takes
// that try's score, which is a cold job's at that count; with no margin
// nothing runs again, and every try is counted either way.
TEST(LodChain, AFailingCutStartNearTheBoundIsConfirmedFromScratch) {
  const Mesh mesh = bumpy_sphere();
  LevelTarget visual;
  visual.min_ssim = 0.97;
  struct Judged {
    uint32_t count = 0;
    double ssim = 0;
    bool cut = false, again = false;
  };
  auto options = [](uint32_t seed) {
    PipelineOptions o = small_views();
    o.sampling.seed = seed;
    // 16 surface elements per output vertex, as when this case was found: with
    // the default 10 the first search with a failing cut start is seed 34's,
    // and what is tested here (the search's confirmation) does not depend on
    // the elements.
    o.cvt_elements_per_vertex = 16;
    return o;
  };
  auto run = [&](double confirm, uint32_t seed, std::vector<Judged>* tries) {
    PipelineOptions o = options(seed);
    o.visual_target_ahead = 0;
    o.visual_target_confirm = confirm;
    o.on_stage = [tries](const StageTiming& t) {
      Judged j;
      unsigned n = 0;
      if (t.name != "visual_target" || std::sscanf(t.note.c_str(), "%u vertices: SSIM %lf", &n, &j.ssim) != 2) return;
      j.count = n;
      j.cut = t.note.find("(a cut start)") != std::string::npos;
      j.again = t.note.find("again, from scratch") != std::string::npos;
      tries->push_back(j);
    };
    const std::vector<PipelineResult> found = run_levels(mesh, o, {visual});
    EXPECT_EQ(found.size(), 1u);
    return found.empty() ? PipelineResult() : found[0];
  };
  auto failing_cut = [&](const Judged& j) { return j.cut && j.ssim < visual.min_ssim; };
  // A margin of 1: every failing cut start runs again. Not every search
  // has one (on this sphere the first is seed 4's, of seeds 1-7).
  std::vector<Judged> all;
  PipelineResult confirmed;
  uint32_t seed = 1;
  for (; seed <= 7; ++seed) {
    all.clear();
    confirmed = run(1.0, seed, &all);
    if (std::any_of(all.begin(), all.end(), failing_cut)) break;
  }
  ASSERT_LE(seed, 7u) << "no cut start failed on this sphere";
  ASSERT_EQ(size_t(confirmed.search.tries), all.size());
  auto renderer = create_renderer(RendererKind::kAuto);
  ASSERT_TRUE(renderer.ok());
  VisualSimilarityOptions judge;
  judge.views = small_views().views.count;
  judge.resolution = small_views().views.resolution;
  auto reference = VisualReference::create(mesh, renderer->get(), judge);
  ASSERT_TRUE(reference.ok()) << reference.status().to_string();
  int failing_cuts = 0;
  for (size_t i = 0; i < all.size(); ++i) {
    if (!failing_cut(all[i])) {
      EXPECT_FALSE(all[i].again && !(i > 0 && failing_cut(all[i - 1])))
          << "the try at " << all[i].count << " ran again after no failing cut start";
      continue;
    }
    ++failing_cuts;
    ASSERT_LT(i + 1, all.size()) << "the last try was a failing cut start";
    EXPECT_TRUE(all[i + 1].again) << "the failing cut start at " << all[i].count << " did not run again";
    EXPECT_EQ(all[i + 1].count, all[i].count);
    // The count again from scratch is a cold job at that count (the note
    // gives four decimals).
    const std::vector<PipelineResult> cold = run_levels(mesh, options(seed), {count(all[i].count)});
    ASSERT_EQ(cold.size(), 1u);
    auto score = reference->compare(cold[0].mesh);
    ASSERT_TRUE(score.ok());
    EXPECT_NEAR(all[i + 1].ssim, score->ssim_mean, 0.00005) << all[i].count;
  }
  EXPECT_EQ(confirmed.search.confirmed, failing_cuts);
  ASSERT_GE(confirmed.search.ssim, visual.min_ssim);
  // No margin: nothing runs again.
  std::vector<Judged> none;
  const PipelineResult trusted = run(0, seed, &none);
  EXPECT_EQ(trusted.search.confirmed, 0);
  EXPECT_EQ(size_t(trusted.search.tries), none.size());
  EXPECT_TRUE(std::any_of(none.begin(), none.end(), failing_cut)) << "the same search's cut start, trusted";
  for (const Judged& j : none) EXPECT_FALSE(j.again) << j.count;
}

// Levels side by side (the default for count levels) give the bits one at a
// time gives, are delivered in order, and the callbacks never overlap (each
// sleeps a little, so an overlap would be caught); a level callback's error
// stops the chain there.
TEST(LodChain, LevelsSideBySideMatchOneAtATimeWithCallbacksOneAtATime) {
  const Mesh mesh = bumpy_sphere();
  const std::vector<LevelTarget> asked = {count(1200), count(400), count(800), count(150)};
  PipelineOptions serial = small_views();
  serial.levels_side_by_side = false;
  const std::vector<PipelineResult> one_at_a_time = run_levels(mesh, serial, asked);

  std::atomic<int> inside{0}, overlaps{0};
  auto guarded = [&](auto&& body) {
    if (inside.fetch_add(1) != 0) ++overlaps;
    std::this_thread::sleep_for(std::chrono::microseconds(200));
    body();
    inside.fetch_sub(1);
  };
  PipelineOptions o = small_views();
  o.on_stage_begin = [&](const char*) { guarded([] {}); };
  o.keep_going = [&]() {
    bool go = true;
    guarded([] {});
    return go;
  };
  std::vector<StageTiming> live;
  o.on_stage = [&](const StageTiming& t) { guarded([&] { live.push_back(t); }); };
  std::vector<PipelineResult> side_by_side;
  Status s = run_pipeline_levels(mesh, o, asked, [&](PipelineResult&& r) {
    guarded([&] { side_by_side.push_back(std::move(r)); });
    return Status::Ok();
  });
  ASSERT_TRUE(s.ok()) << s.to_string();
  EXPECT_EQ(overlaps.load(), 0);
  // Live events as one at a time sends them: the front half, then each
  // level's stages in level order (a later level's are held back).
  const std::vector<std::string> back = {"density", "cvt", "meshing"};
  for (size_t k = 1; k < live.size(); ++k) EXPECT_LE(live[k - 1].level, live[k].level) << live[k].name;
  for (size_t i = 0; i < asked.size(); ++i) {
    std::vector<std::string> names;
    for (const StageTiming& t : live)
      if (t.level == int(i)) names.push_back(t.name);
    EXPECT_EQ(names, back) << "level " << i;
  }
  ASSERT_EQ(side_by_side.size(), asked.size());
  ASSERT_EQ(one_at_a_time.size(), asked.size());
  for (size_t i = 0; i < asked.size(); ++i) {
    EXPECT_EQ(side_by_side[i].level, int(i));
    EXPECT_EQ(side_by_side[i].mesh.positions, one_at_a_time[i].mesh.positions) << "level " << i;
    EXPECT_EQ(side_by_side[i].mesh.indices, one_at_a_time[i].mesh.indices) << "level " << i;
    EXPECT_EQ(side_by_side[i].saliency, one_at_a_time[i].saliency) << "level " << i;
  }

  // The second level's delivery fails: the first was delivered, nothing after.
  std::vector<int> delivered;
  s = run_pipeline_levels(mesh, small_views(), asked, [&](PipelineResult&& r) {
    delivered.push_back(r.level);
    return r.level == 1 ? Status(StatusCode::kInternal, "the client went away") : Status::Ok();
  });
  EXPECT_EQ(s.code(), StatusCode::kInternal);
  EXPECT_EQ(delivered, (std::vector<int>{0, 1}));
}

// A screen-size target judges the views at the model's size on screen: seen
// at 64 px the same bound needs fewer vertices than at 256 px, and each
// level reaches its bound.
TEST(LodChain, AScreenSizeTargetNeedsFewerVerticesWhenSeenSmaller) {
  const Mesh mesh = bumpy_sphere();
  LevelTarget large, small;
  large.min_ssim = small.min_ssim = 0.95;
  large.screen_px = 256;
  small.screen_px = 64;
  const std::vector<PipelineResult> found = run_levels(mesh, small_views(), {large, small});
  ASSERT_EQ(found.size(), 2u);
  EXPECT_GE(found[0].search.ssim, 0.95);
  EXPECT_GE(found[1].search.ssim, 0.95);
  EXPECT_LT(found[1].target, found[0].target);
  EXPECT_EQ(found[1].mesh.vertex_count(), size_t(found[1].target));

  LevelTarget alone;
  alone.screen_px = 128;  // no bound to keep at that size
  Status s = run_pipeline_levels(mesh, PipelineOptions{}, {alone}, [](PipelineResult&&) { return Status::Ok(); });
  EXPECT_NE(s.message().find("needs a minimum SSIM"), std::string::npos) << s.to_string();
  small.screen_px = 10;
  s = run_pipeline_levels(mesh, PipelineOptions{}, {small}, [](PipelineResult&&) { return Status::Ok(); });
  EXPECT_NE(s.message().find("[64, 4096]"), std::string::npos) << s.to_string();
}

}  // namespace
}  // namespace vpr
