// Pipeline benchmark (a program, not a test; docs/performance.md is made with
// it). For each MODEL:TARGET, in one warm process on one machine:
//   1. per-stage wall times of our pipeline on each device asked for, the
//      service's path included: Draco decode of the upload, the pipeline,
//      Draco encode of the result with its saliency attribute;
//   2. the peers a user would pick instead on the same input to the same
//      vertex count (OpenMesh QEM, meshoptimizer, CGAL isotropic remeshing),
//      and their time over ours;
//   3. with --concurrency C: throughput of C jobs at once against one at a time.
// MODEL may end in @1M (or @<N>M): the model midpoint-subdivided to at least
// N million triangles. Prints Markdown tables; progress goes to stderr.
//   vpremesh-bench [--device cpu|cuda|both] [--repeat R] [--threads N] [--density MODE]
//                  [--cvt-sweeps auto|rounds|slabs] [--render-prep auto|host]
//                  [--render-readback auto|host] [--dual-projection auto|host]
//                  [--peers all|none|LIST] [--concurrency C] [--jobs J] MODEL[@1M]:TARGET ...
// --density: the jobs' density mode (uniform, curvature, perception, paper;
// the pipeline's default when not given).
#include <sys/resource.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "core/thread_share.h"
#include "io/mesh_io.h"
#include "peers/peers.h"
#include "pipeline/pipeline.h"
#include "subdivide.h"
#include "surface/surface_density.h"

namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
}

// Processor seconds this process has used (user and system, every thread).
double cpu_seconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return double(u.ru_utime.tv_sec + u.ru_stime.tv_sec) + 1e-6 * double(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

// Both back halves' stages (the surface CVT's by default, the paper's with
// --density paper); a stage a run did not have reads 0.
const char* kStages[] = {"views", "render", "image_saliency", "unproject", "visibility", "saliency_field",
                         "density", "cvt", "sampling", "awlop", "meshing"};

struct Args {
  std::vector<vpr::DevicePolicy> devices{vpr::DevicePolicy::kCpu};
  int repeat = 3, threads = 0, concurrency = 0, jobs = 0;
  std::string peers = "all";
  std::optional<vpr::DensityMode> density;
  vpr::CvtSweeps cvt_sweeps = vpr::CvtSweeps::kAuto;
  bool render_prep_on_gpu = true;
  bool render_interop = true;
  bool dual_projection_on_gpu = true;
  double cvt_elements = 0, cvt_rim_band = -1;  // the pipeline's defaults unless given
  std::vector<std::pair<std::string, uint32_t>> inputs;
};

struct Input {
  std::string name;
  vpr::Mesh mesh;
  std::vector<uint8_t> draco;  // the upload the service would receive
  uint32_t target = 0;
};

// One job as the service runs it: decode, pipeline, encode.
struct JobTimes {
  double decode = 0, encode = 0, total = 0;
  std::map<std::string, double> stage;
  // Processor ms of the whole process (every thread) between one stage's end
  // and the next's: a job's own where it runs alone. Work a stage starts
  // beside the others (the refinement made ahead) counts where it is spent.
  std::map<std::string, double> stage_cpu;
  double total_cpu = 0;
  std::string device_note;
  size_t out_vertices = 0;
};

vpr::StatusOr<JobTimes> run_job(const Input& in, vpr::DevicePolicy device, vpr::Renderer* renderer, const Args& args) {
  JobTimes t;
  const auto start = Clock::now();
  const double cpu_start = cpu_seconds();
  double cpu_mark = cpu_start;
  auto cpu_lap = [&](const std::string& name) {
    const double now = cpu_seconds();
    t.stage_cpu[name] += 1000 * (now - cpu_mark);
    cpu_mark = now;
  };
  auto mesh = vpr::parse_mesh(in.draco.data(), in.draco.size(), vpr::MeshFormat::kDraco);
  if (!mesh.ok()) return mesh.status();
  t.decode = ms_since(start);
  cpu_lap("decode");
  vpr::PipelineOptions options;
  options.target_vertices = in.target;
  options.device = device;
  options.shared_renderer = renderer;
  if (args.density) options.density = *args.density;
  options.cvt_sweeps = args.cvt_sweeps;
  options.render_prep_on_gpu = args.render_prep_on_gpu;
  options.render_interop = args.render_interop;
  options.dual_projection_on_gpu = args.dual_projection_on_gpu;
  if (args.cvt_elements > 0) options.cvt_elements_per_vertex = args.cvt_elements;
  if (args.cvt_rim_band >= 0) options.cvt_rim_band = args.cvt_rim_band;
  options.on_stage = [&](const vpr::StageTiming& s) { cpu_lap(s.name); };
  auto result = vpr::run_pipeline(*mesh, options);
  if (!result.ok()) return result.status();
  cpu_lap("pipeline's end");
  const auto encode_start = Clock::now();
  auto encoded = vpr::encode_draco(result->mesh, result->saliency.data(), {});
  if (!encoded.ok()) return encoded.status();
  t.encode = ms_since(encode_start);
  cpu_lap("encode");
  t.total = ms_since(start);
  t.total_cpu = 1000 * (cpu_seconds() - cpu_start);
  for (const auto& s : result->stages) {
    t.stage[s.name] += s.ms;
    if (!s.note.empty()) t.device_note += s.name + ": " + s.note + "; ";
  }
  t.out_vertices = result->mesh.vertex_count();
  return t;
}

const char* device_label(vpr::DevicePolicy d) {
  return d == vpr::DevicePolicy::kCuda ? "cuda" : "cpu";
}

int parse_args(int argc, char** argv, Args* a) {
  for (int i = 1; i < argc; ++i) {
    const std::string s = argv[i];
    auto next = [&]() -> std::string { return i + 1 < argc ? argv[++i] : ""; };
    if (s == "--device") {
      const std::string d = next();
      if (d == "cpu") a->devices = {vpr::DevicePolicy::kCpu};
      else if (d == "cuda") a->devices = {vpr::DevicePolicy::kCuda};
      else if (d == "both") a->devices = {vpr::DevicePolicy::kCpu, vpr::DevicePolicy::kCuda};
      else return 2;
    } else if (s == "--repeat") {
      a->repeat = std::max(1, std::stoi(next()));
    } else if (s == "--threads") {
      a->threads = std::stoi(next());
    } else if (s == "--density") {
      auto mode = vpr::parse_density_mode(next());
      if (!mode.ok()) {
        std::fprintf(stderr, "%s\n", mode.status().to_string().c_str());
        return 2;
      }
      a->density = *mode;
    } else if (s == "--cvt-sweeps") {
      const std::string m = next();
      if (m == "auto")
        a->cvt_sweeps = vpr::CvtSweeps::kAuto;
      else if (m == "rounds")
        a->cvt_sweeps = vpr::CvtSweeps::kColourRounds;
      else if (m == "slabs")
        a->cvt_sweeps = vpr::CvtSweeps::kSlabs;
      else
        return 2;
    } else if (s == "--render-prep") {
      const std::string m = next();
      if (m != "auto" && m != "host") return 2;
      a->render_prep_on_gpu = m == "auto";
    } else if (s == "--render-readback") {
      const std::string m = next();
      if (m != "auto" && m != "host") return 2;
      a->render_interop = m == "auto";
    } else if (s == "--dual-projection") {
      const std::string m = next();
      if (m != "auto" && m != "host") return 2;
      a->dual_projection_on_gpu = m == "auto";
    } else if (s == "--cvt-elements") {  // surface elements per output vertex away from rims
      a->cvt_elements = std::stod(next());
    } else if (s == "--cvt-rim-band") {
      a->cvt_rim_band = std::stod(next());
    } else if (s == "--peers") {
      a->peers = next();
    } else if (s == "--concurrency") {
      a->concurrency = std::stoi(next());
    } else if (s == "--jobs") {
      a->jobs = std::stoi(next());
    } else {
      const size_t colon = s.rfind(':');
      if (colon == std::string::npos) return 2;
      a->inputs.emplace_back(s.substr(0, colon), uint32_t(std::stoul(s.substr(colon + 1))));
    }
  }
  return a->inputs.empty() ? 2 : 0;
}

vpr::StatusOr<Input> load_input(const std::string& spec, uint32_t target) {
  Input in;
  in.target = target;
  std::string path = spec;
  size_t million = 0;
  if (const size_t at = spec.rfind('@'); at != std::string::npos) {
    path = spec.substr(0, at);
    million = std::stoul(spec.substr(at + 1));  // "1M" -> 1
  }
  auto mesh = vpr::read_mesh(path);
  if (!mesh.ok()) return mesh.status();
  in.mesh = std::move(mesh).value();
  in.name = path.substr(path.rfind('/') + 1);
  if (million > 0) {
    in.mesh = vpr::bench::subdivide_to(std::move(in.mesh), million * 1'000'000);
    in.name += " subdivided";
  }
  vpr::DracoOptions lossless;
  lossless.position_bits = 0;  // the upload keeps the input exactly
  lossless.speed = 10;
  auto draco = vpr::encode_draco(in.mesh, nullptr, lossless);
  if (!draco.ok()) return draco.status();
  in.draco = std::move(draco).value();
  return in;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  Args args;
  if (parse_args(argc, argv, &args) != 0) {
    std::fprintf(stderr,
                 "usage: vpremesh-bench [--device cpu|cuda|both] [--repeat R] [--threads N] [--density MODE]\n"
                 "                      [--cvt-sweeps auto|rounds|slabs] [--render-prep auto|host]\n"
                 "                      [--render-readback auto|host] [--dual-projection auto|host]\n"
                 "                      [--cvt-elements K] [--cvt-rim-band SPACINGS]\n"
                 "                      [--peers all|none|LIST] [--concurrency C] [--jobs J] MODEL[@1M]:TARGET ...\n");
    return 2;
  }
  std::unique_ptr<tbb::global_control> limit;
  if (args.threads > 0)
    limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, args.threads);
  auto renderer = vpr::create_renderer(vpr::RendererKind::kAuto);
  if (!renderer.ok()) {
    std::fprintf(stderr, "%s\n", renderer.status().to_string().c_str());
    return 1;
  }
  std::fprintf(stderr, "renderer: %s\n", (*renderer)->description().c_str());

  std::vector<Input> inputs;
  for (const auto& [spec, target] : args.inputs) {
    auto in = load_input(spec, target);
    if (!in.ok()) {
      std::fprintf(stderr, "%s: %s\n", spec.c_str(), in.status().to_string().c_str());
      return 1;
    }
    inputs.push_back(std::move(in).value());
  }

  // 1. Per-stage times: one warm-up job per input and device, then the median
  //    of `repeat` jobs (stage columns are from the median-total run).
  std::printf("| model | in V | in F | target | device | out V | decode |");
  for (const char* s : kStages) std::printf(" %s |", s);
  std::printf(" encode | total ms (median of %d) | min ms |\n|---|---|---|---|---|---|---|", args.repeat);
  for (size_t i = 0; i < std::size(kStages); ++i) std::printf("---|");
  std::printf("---|---|---|\n");
  // (input's place in the list, device) -> median total: one model may come
  // at several targets, each its own row.
  std::map<std::pair<size_t, std::string>, double> ours;
  std::vector<std::string> cpu_rows;  // the median run's processor ms per stage
  for (size_t i = 0; i < inputs.size(); ++i) {
    const Input& in = inputs[i];
    for (vpr::DevicePolicy device : args.devices) {
      auto warm = run_job(in, device, renderer->get(), args);
      if (!warm.ok()) {
        std::fprintf(stderr, "%s on %s: %s\n", in.name.c_str(), device_label(device), warm.status().to_string().c_str());
        continue;
      }
      std::vector<JobTimes> runs;
      for (int r = 0; r < args.repeat; ++r) {
        auto t = run_job(in, device, renderer->get(), args);
        if (t.ok()) runs.push_back(std::move(t).value());
      }
      if (runs.empty()) continue;
      std::sort(runs.begin(), runs.end(), [](const JobTimes& a, const JobTimes& b) { return a.total < b.total; });
      const JobTimes& m = runs[runs.size() / 2];
      std::fprintf(stderr, "%s on %s: render (last run): %s\n", in.name.c_str(), device_label(device),
                   (*renderer)->last_breakdown().c_str());
      if (!m.device_note.empty()) std::fprintf(stderr, "%s on %s: %s\n", in.name.c_str(), device_label(device),
                                               m.device_note.c_str());
      std::printf("| %s | %zu | %zu | %u | %s | %zu | %.1f |", in.name.c_str(), in.mesh.vertex_count(),
                  in.mesh.face_count(), in.target, device_label(device), m.out_vertices, m.decode);
      for (const char* s : kStages) std::printf(" %.1f |", m.stage.count(s) ? m.stage.at(s) : 0.0);
      std::printf(" %.1f | %.1f | %.1f |\n", m.encode, m.total, runs.front().total);
      std::fflush(stdout);
      std::string row = "| " + in.name + " | " + std::to_string(in.target) + " | " + device_label(device) + " |";
      auto cell = [&](const std::string& name) {
        const auto it = m.stage_cpu.find(name);
        char text[32];
        std::snprintf(text, sizeof text, " %.0f |", it == m.stage_cpu.end() ? 0.0 : it->second);
        row += text;
      };
      cell("decode");
      for (const char* s : kStages) cell(s);
      cell("pipeline's end");
      cell("encode");
      char total[64];
      std::snprintf(total, sizeof total, " %.0f | %.0f |", m.total_cpu, m.total);
      cpu_rows.push_back(row + total);
      ours[{i, device_label(device)}] = m.total;
    }
  }

  // 1b. Where the median runs' processor time went (every thread of the
  //     process, from one stage's end to the next): what bounds the jobs per
  //     second when concurrent jobs keep every core busy.
  std::printf("\n| model | target | device | CPU ms: decode |");
  for (const char* s : kStages) std::printf(" %s |", s);
  std::printf(" rest of the pipeline | encode | CPU ms in all | wall ms |\n|---|---|---|---|");
  for (size_t i = 0; i < std::size(kStages); ++i) std::printf("---|");
  std::printf("---|---|---|---|\n");
  for (const std::string& row : cpu_rows) std::printf("%s\n", row.c_str());
  std::fflush(stdout);

  // 2. Peers on the same input to the same vertex count (their algorithm's
  //    own time, conversions excluded; one run each, after ours).
  if (args.peers != "none") {
    std::printf("\n| model | target | method | out V | ms | time / ours (%s) |\n|---|---|---|---|---|---|\n",
                device_label(args.devices.back()));
    for (size_t i = 0; i < inputs.size(); ++i) {
      const Input& in = inputs[i];
      const auto it = ours.find({i, device_label(args.devices.back())});
      const double reference = it == ours.end() ? 0 : it->second;
      for (const auto& [key, ms] : ours)
        if (key.first == i)
          std::printf("| %s | %u | vpremesh (%s) | | %.1f | %.2f |\n", in.name.c_str(), in.target, key.second.c_str(),
                      ms, reference > 0 ? ms / reference : 0);
      for (const auto& peer : vpr::peers::all_peers()) {
        if (args.peers != "all" && args.peers.find(peer.name) == std::string::npos) continue;
        std::fprintf(stderr, "%s: %s...\n", in.name.c_str(), peer.name.c_str());
        auto r = peer.run(in.mesh, in.target);
        if (!r.ok()) {
          std::printf("| %s | %u | %s | failed: %s | | |\n", in.name.c_str(), in.target, peer.name.c_str(),
                      r.status().message().c_str());
          continue;
        }
        std::printf("| %s | %u | %s | %zu | %.1f | %.2f |\n", in.name.c_str(), in.target, peer.name.c_str(),
                    r->mesh.vertex_count(), r->core_ms, reference > 0 ? r->core_ms / reference : 0);
        std::fflush(stdout);
      }
    }
  }

  // 3. Throughput: `jobs` jobs on `concurrency` threads (each with its own
  //    renderer and, on the GPU, its own stream) against one at a time, and
  //    the processor seconds a job took: when the cores are all busy, the
  //    throughput is the cores over that.
  if (args.concurrency > 1) {
    const int jobs = args.jobs > 0 ? args.jobs : 4 * args.concurrency;
    std::printf("\n| model | device | concurrency | jobs | wall s | jobs/s | speedup over 1 | CPU s per job |\n|---|---|---|---|---|---|---|---|\n");
    for (const Input& in : inputs)
      for (vpr::DevicePolicy device : args.devices) {
        double rate1 = 0;
        for (int c : {1, args.concurrency}) {
          std::vector<std::unique_ptr<vpr::Renderer>> renderers;
          for (int i = 0; i < c; ++i) renderers.push_back(std::move(vpr::create_renderer(vpr::RendererKind::kAuto)).value());
          for (int i = 0; i < c; ++i)
            (void)run_job(in, device, renderers[i].get(), args);  // warm each thread's renderer
          std::atomic<int> next{0}, failed{0};
          std::mutex lock;
          std::map<std::string, double> stage_sum;  // over the jobs that finished
          // TBB's threads shared with the c jobs' own, as the service's pool
          // does with jobs in threads (core/thread_share.h), unless --threads.
          std::optional<vpr::ThreadCap> share;
          if (args.threads == 0) share.emplace(vpr::shared_process_threads(vpr::host_threads(), c));
          const auto start = Clock::now();
          const double cpu_start = cpu_seconds();
          std::vector<std::thread> pool;
          for (int i = 0; i < c; ++i)
            pool.emplace_back([&, i] {
              while (next.fetch_add(1) < jobs) {
                auto t = run_job(in, device, renderers[i].get(), args);
                if (!t.ok()) {
                  ++failed;
                  continue;
                }
                const std::lock_guard<std::mutex> hold(lock);
                stage_sum["decode"] += t->decode;
                stage_sum["encode"] += t->encode;
                for (const auto& [name, ms] : t->stage) stage_sum[name] += ms;
              }
            });
          for (auto& t : pool) t.join();
          const double wall = ms_since(start) / 1000.0;
          const double cpu = cpu_seconds() - cpu_start;
          const double rate = (jobs - failed) / wall;
          if (c == 1) rate1 = rate;
          std::printf("| %s | %s | %d | %d | %.2f | %.2f | %.2f | %.3f |\n", in.name.c_str(), device_label(device), c,
                      jobs, wall, rate, rate1 > 0 ? rate / rate1 : 0, cpu / jobs);
          std::fflush(stdout);
          // Which stages stretch when the jobs share the machine (stderr:
          // the table above stays one row per run).
          const int done = jobs - failed;
          std::fprintf(stderr, "%s on %s, %d at once, mean stage ms:", in.name.c_str(), device_label(device), c);
          for (const auto& [name, ms] : stage_sum) std::fprintf(stderr, " %s %.1f", name.c_str(), done > 0 ? ms / done : 0);
          std::fprintf(stderr, "; render (one thread's last): %s\n", renderers[0]->last_breakdown().c_str());
        }
      }
  }
  return 0;
}
