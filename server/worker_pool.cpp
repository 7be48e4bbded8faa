#include "server/worker_pool.h"

#include <spdlog/spdlog.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <new>

#include "io/mesh_io.h"
#include "server/job_process.h"
#include "server/job_process_init.h"
#include "server/job_spec.h"
#include "server/status_mapping.h"
#ifdef VPR_HAVE_CUDA
#include "gpu/cuda_device.h"
#endif

namespace vpr::service {
namespace {

double ms_since(Clock::time_point t) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
}

v1::JobEvent failed_event(const Status& s) {
  v1::JobEvent e;
  *e.mutable_failed() = to_failure(s);
  return e;
}

// The job's outcome when the pipeline (or a step around it) stops: a
// cancellation request wins over the error it caused.
v1::JobEvent end_event(JobQueue& queue, const std::string& id, const Status& s) {
  if (std::optional<Status> why = queue.cancellation(id)) {
    v1::JobEvent e;
    *e.mutable_cancelled() = to_failure(*why);
    return e;
  }
  return failed_event(s);
}

// Streams a float array as FloatChunk events of at most 1 MiB each.
template <class Setter>
uint64_t publish_floats(JobQueue& queue, const std::string& id, const std::vector<float>& values, Setter chunk_of,
                        uint32_t level = 0) {
  for (size_t offset = 0; offset < values.size(); offset += kFloatsPerChunk) {
    const size_t n = std::min(kFloatsPerChunk, values.size() - offset);
    v1::JobEvent e;
    v1::FloatChunk* c = chunk_of(&e);
    c->set_offset(offset);
    c->set_total(values.size());
    c->set_level(level);
    c->mutable_values()->Add(values.begin() + offset, values.begin() + offset + n);
    queue.publish(id, std::move(e));
  }
  return values.size() * sizeof(float);
}

// A fresh directory under the system's temporary directory for one job's
// debug output, removed with everything in it when the job is done (whatever
// happens).
class TempDir {
 public:
  static StatusOr<std::unique_ptr<TempDir>> create(const std::string& job_id) {
    static std::atomic<uint64_t> counter{0};
    std::error_code ec;
    const std::filesystem::path base = std::filesystem::temp_directory_path(ec);
    if (ec) return internal_error("no temporary directory for the debug images: " + ec.message());
    std::string safe_id = job_id;  // the queue's ids are file-safe already; be sure
    for (char& c : safe_id)
      if (!std::isalnum(static_cast<unsigned char>(c)) && c != '-' && c != '_') c = '_';
    const std::filesystem::path dir =
        base / ("vpremesh-debug-" + safe_id + "-" + std::to_string(getpid()) + "-" + std::to_string(counter++));
    // create_directory is false when the path already exists: never reuse one.
    if (!std::filesystem::create_directory(dir, ec) || ec)
      return internal_error("cannot create " + dir.string() + " for the debug images" +
                            (ec ? ": " + ec.message() : ": it exists"));
    return std::unique_ptr<TempDir>(new TempDir(dir));
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
    if (ec) spdlog::warn("cannot remove {}: {}", path_.string(), ec.message());
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::filesystem::path& path() const { return path_; }

 private:
  explicit TempDir(std::filesystem::path p) : path_(std::move(p)) {}
  std::filesystem::path path_;
};

// Sends every PNG in `dir` (by name) as a `debug_image` event. One event must
// stay under the message limit, so an image over kMaxChunkBytes is left out
// (logged). Returns the bytes sent.
uint64_t publish_debug_images(JobQueue& queue, const std::string& id, const std::filesystem::path& dir) {
  std::vector<std::filesystem::path> pngs;
  for (const auto& entry : std::filesystem::directory_iterator(dir))
    if (entry.is_regular_file() && entry.path().extension() == ".png") pngs.push_back(entry.path());
  std::sort(pngs.begin(), pngs.end());
  uint64_t sent = 0;
  for (const std::filesystem::path& png : pngs) {
    const uintmax_t size = std::filesystem::file_size(png);
    if (size > kMaxChunkBytes) {
      spdlog::warn("job {}: debug image {} is {} bytes, over the {} byte limit of one event: not sent", id,
                   png.filename().string(), size, kMaxChunkBytes);
      continue;
    }
    std::ifstream f(png, std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    if (f.bad()) throw std::runtime_error("cannot read debug image " + png.string());
    v1::JobEvent e;
    e.mutable_debug_image()->set_name(png.filename().string());
    e.mutable_debug_image()->set_png(std::move(bytes));
    sent += size;
    queue.publish(id, std::move(e));
  }
  return sent;
}

void run_job_or_throw(JobQueue& queue, ClaimedJob& job, const WorkerContext& ctx) {
  const auto run_start = Clock::now();
  const std::string& id = job.id;
  {
    v1::JobEvent e;
    e.mutable_started()->set_worker(ctx.name);
    e.mutable_started()->set_device(ctx.device);
    e.mutable_started()->set_queue_ms(job.queue_ms);
    queue.publish(id, std::move(e));
  }
  auto step = [&](const std::string& name) {
    if (ctx.on_step) ctx.on_step(name);
  };
  if (!ctx.crash_on_label.empty() && job.spec.label() == ctx.crash_on_label) {
    spdlog::critical("job {}: label '{}' matches VPREMESH_FAULT_CRASH_ON_LABEL: aborting (fault injection)", id,
                     job.spec.label());
    std::abort();
  }
  auto stopped = [&]() { return queue.cancellation(id).has_value(); };

  JobOptions options;
  if (Status s = job_options_from_spec(job.spec, &options); !s.ok()) return queue.publish(id, failed_event(s));
  PipelineOptions& po = options.pipeline;
  po.shared_renderer = ctx.renderer;
  po.device = options.device == v1::DEVICE_CPU    ? DevicePolicy::kCpu
              : options.device == v1::DEVICE_CUDA ? DevicePolicy::kCuda
                                                  : ctx.device_policy;
  po.cuda_device = ctx.cuda_device;
  po.max_level_vertices = ctx.limits.max_target_vertices;  // fractions and visual targets, found at run time
  DeviceBudget budget;  // this job's device memory, released with the job
  if (ctx.gpu_job_bytes > 0) {
    budget.limit = ctx.gpu_job_bytes;
    po.device_budget = &budget;
  }
  po.keep_going = [&]() { return !stopped(); };
  po.on_stage_begin = [&](const char* name) { step(name); };
  // Stage events go out live, as each stage ends.
  const bool chain = !options.levels.empty();
  po.on_stage = [&](const StageTiming& t) {
    v1::JobEvent e;
    v1::Stage* st = e.mutable_stage();
    st->set_name(t.name);
    st->set_ms(t.ms);
    st->set_device(t.device);
    st->set_note(t.note);
    if (chain) {  // a one-target job's events stay as they were
      st->set_level(t.level == kFrontHalf ? 0 : uint32_t(t.level));
      st->set_front_half(t.level == kFrontHalf);
    }
    queue.publish(id, std::move(e));
    if (ctx.metrics) ctx.metrics->stage_seconds(t.name).observe(t.ms / 1000.0);
  };

  std::unique_ptr<TempDir> debug_dir;  // removed when the job ends, however it ends
  if (job.spec.return_debug_images()) {
    auto dir = TempDir::create(id);
    if (!dir.ok()) return queue.publish(id, failed_event(dir.status()));
    debug_dir = std::move(dir).value();
    po.debug_dir = debug_dir->path().string();
  }

  if (stopped()) return queue.publish(id, end_event(queue, id, Status()));
  v1::Completed summary;
  uint64_t bytes_out = 0;
  // Each level's payloads go out as soon as it is done (a chain's level 0
  // can be used while the next ones run); level 0 also fills the summary.
  auto publish_level = [&](PipelineResult&& result) -> Status {
    if (stopped()) return Status(StatusCode::kCancelled, "cancelled");
    const uint32_t level = uint32_t(result.level);
    v1::LevelSummary* ls = chain ? summary.add_levels() : nullptr;
    if (returns_mesh(job.spec)) {
      // The same encoder settings as `vpremesh local -o out.drc` (saliency as
      // the generic attribute "saliency"), so both give the same file.
      step("encode");
      DracoOptions draco;
      draco.position_bits = options.result_quantization_bits;
      VPR_ASSIGN_OR_RETURN(const std::vector<uint8_t> bytes, encode_draco(result.mesh, result.saliency.data(), draco));
      if (level == 0) summary.set_result_bytes(bytes.size());
      if (ls) ls->set_result_bytes(bytes.size());
      for (size_t offset = 0; offset < bytes.size(); offset += kMaxChunkBytes) {
        const size_t n = std::min(kMaxChunkBytes, bytes.size() - offset);
        v1::JobEvent e;
        v1::BytesChunk* c = e.mutable_result();
        c->set_offset(offset);
        c->set_total(bytes.size());
        c->set_data(bytes.data() + offset, n);
        c->set_level(level);
        queue.publish(id, std::move(e));
      }
      bytes_out += bytes.size();
    }
    step("results");
    if (returns_saliency(job.spec))
      bytes_out += publish_floats(
          queue, id, result.saliency, [](v1::JobEvent* e) { return e->mutable_saliency(); }, level);
    if (ls) {
      ls->set_level(level);
      ls->set_target_vertices(result.target);
      ls->set_output_vertices(uint32_t(result.mesh.vertex_count()));
      ls->set_output_faces(uint32_t(result.mesh.face_count()));
      ls->set_min_ssim(result.search.min_ssim);
      ls->set_ssim(result.search.ssim);
      ls->set_tries(uint32_t(result.search.tries));
      ls->set_ms(ms_since(run_start));
    }
    if (level != 0) return Status::Ok();
    if (job.spec.return_saliency_points())
      bytes_out += publish_floats(queue, id, result.saliency_point_positions,
                                  [](v1::JobEvent* e) { return e->mutable_saliency_points(); });
    if (job.spec.return_input_saliency())
      bytes_out += publish_floats(queue, id, result.input_importance,
                                  [](v1::JobEvent* e) { return e->mutable_input_saliency(); });
    if (debug_dir) bytes_out += publish_debug_images(queue, id, debug_dir->path());
    debug_dir.reset();  // gone before `completed` (on the other paths, as the function returns)
    summary.set_output_vertices(uint32_t(result.mesh.vertex_count()));
    summary.set_output_faces(uint32_t(result.mesh.face_count()));
    summary.set_saliency_points(result.saliency_points);
    summary.set_ignored_vertices(uint32_t(result.ignored_vertices));
    summary.set_dropped_parts(uint32_t(result.dropped_parts));
    summary.set_parts_below_minimum(uint32_t(result.cvt.parts_below_minimum));
    summary.set_renderer(result.renderer);
    return Status::Ok();
  };
  {
    // The upload is freed as soon as it is decoded, the input mesh when the
    // pipeline returns.
    step("decode");
    auto mesh = parse_mesh(job.mesh.data(), job.mesh.size(), options.input_format, ctx.limits.mesh_limits());
    job.mesh = {};
    job.mesh.shrink_to_fit();
    if (!mesh.ok()) return queue.publish(id, failed_event(explain_mesh_limit(mesh.status(), ctx.limits)));
    summary.set_input_vertices(uint32_t(mesh->vertex_count()));
    summary.set_input_faces(uint32_t(mesh->face_count()));
    if (stopped()) return queue.publish(id, end_event(queue, id, Status()));
    std::vector<LevelTarget> levels = options.levels;
    if (levels.empty()) {
      levels.emplace_back();
      levels[0].vertices = po.target_vertices;
    }
    Status run = run_pipeline_levels(*mesh, po, levels, publish_level);
    if (stopped()) return queue.publish(id, end_event(queue, id, Status()));
    if (!run.ok()) {
      // An encoder failure is the job's failure, like the pipeline's own.
      return queue.publish(id, end_event(queue, id, run));
    }
  }
  if (stopped()) return queue.publish(id, end_event(queue, id, Status()));

  summary.set_queue_ms(job.queue_ms);
  summary.set_run_ms(ms_since(run_start));
  summary.set_total_ms(job.queue_ms + summary.run_ms());
  if (ctx.metrics) {
    ctx.metrics->bytes_out.inc(double(bytes_out));
    ctx.metrics->job_seconds().observe(summary.total_ms() / 1000.0);
  }
  v1::JobEvent e;
  *e.mutable_completed() = summary;
  queue.publish(id, std::move(e));
}

}  // namespace

void init_cuda(const WorkerContext& ctx) {
#ifdef VPR_HAVE_CUDA
  if (ctx.device_policy == DevicePolicy::kCpu || ctx.device.rfind("cuda:", 0) != 0) return;
  if (Status s = init_cuda_device(ctx.cuda_device); !s.ok())
    spdlog::warn("{}: cannot initialise {}: {}", ctx.name, ctx.device, s.message());
#else
  (void)ctx;
#endif
}

int renderer_gpu(const WorkerContext& ctx) {
  return ctx.device_policy != DevicePolicy::kCpu && ctx.device.rfind("cuda:", 0) == 0 ? ctx.cuda_device : -1;
}

void run_job(JobQueue& queue, ClaimedJob job, const WorkerContext& ctx) {
  const std::string id = job.id;
  try {
    run_job_or_throw(queue, job, ctx);
  } catch (const std::bad_alloc&) {
    std::string limit;
    if (ctx.memory_limit_bytes > 0)
      limit = " (its process may hold " + std::to_string(ctx.memory_limit_bytes >> 20) + " MiB, --job-memory-mib)";
    queue.publish(id, failed_event(resource_exhausted("out of memory while running the job" + limit)));
  } catch (const std::exception& e) {
    queue.publish(id, failed_event(internal_error(std::string("unexpected error: ") + e.what())));
  }
}

WorkerPool::WorkerPool(JobQueue& queue, WorkerPoolOptions options, ServiceMetrics* metrics)
    : queue_(queue), options_(std::move(options)), metrics_(metrics) {
  if (options_.process.exe.empty()) return;
  auto count = HostJobCount::create();
  if (count.ok()) {
    host_jobs_ = std::move(count).value();
    options_.process.host_jobs_fd = host_jobs_->fd();
  } else {
    spdlog::warn("job processes will split their loops as if each ran alone: {}", count.status().message());
  }
}

WorkerPool::~WorkerPool() {
  join();
}

size_t WorkerPool::start(std::string* why) {
  running_.assign(size_t(options_.workers), "");
  for (int i = 0; i < options_.workers; ++i) threads_.emplace_back([this, i] { worker_main(i); });
  std::unique_lock<std::mutex> lock(mu_);
  changed_.wait(lock, [&] { return ready_ == size_t(options_.workers); });
  if (why) {
    why->clear();
    for (const std::string& f : failures_) *why += (why->empty() ? "" : "; ") + f;
  }
  return live_;
}

WorkerContext WorkerPool::make_context(int index) {
  char host[256] = "localhost";
  gethostname(host, sizeof host - 1);
  WorkerContext ctx;
  ctx.name = std::string(host) + ":" + std::to_string(getpid()) + "/worker-" + std::to_string(index);
  ctx.device_policy = options_.device;
  ctx.renderer_kind = options_.renderer;
  ctx.limits = options_.limits;
  ctx.metrics = metrics_;
  ctx.crash_on_label = options_.crash_on_label;
  std::vector<int> ids = options_.gpu_ids;
  for (int g = 0; ids.empty() && g < options_.cuda_devices; ++g) ids.push_back(g);
  if (options_.device != DevicePolicy::kCpu && !ids.empty()) {
    ctx.cuda_device = ids[size_t(index) % ids.size()];
    ctx.device = "cuda:" + std::to_string(ctx.cuda_device);
#ifdef VPR_HAVE_CUDA
    std::string why;
    const std::vector<CudaDeviceInfo> gpus = cuda_devices(&why);
    if (size_t(ctx.cuda_device) < gpus.size()) {
      ctx.device += " " + gpus[size_t(ctx.cuda_device)].name;
      // Workers sharing this GPU split its memory unless a budget was given.
      int sharing = 0;
      for (int w = 0; w < options_.workers; ++w) sharing += ids[size_t(w) % ids.size()] == ctx.cuda_device;
      ctx.gpu_job_bytes = options_.gpu_job_bytes > 0
                              ? options_.gpu_job_bytes
                              : gpus[size_t(ctx.cuda_device)].total_memory / size_t(std::max(sharing, 1));
    }
#endif
  }
  return ctx;
}

void WorkerPool::share_threads() {
  thread_cap_.reset();  // the old cap goes before the new one is set
  thread_cap_.emplace(shared_process_threads(host_threads(), int(busy_)));
}

void WorkerPool::worker_main(int index) {
  WorkerContext ctx = make_context(index);
  const bool isolated = !options_.process.exe.empty();
  std::unique_ptr<JobProcess> process;  // isolated: where the jobs run
  std::unique_ptr<Renderer> renderer;   // otherwise: this thread's own
  Status ready;
  std::string description;
  if (isolated) {
    auto started = JobProcess::start(options_.process, ctx);
    if (started.ok()) {
      process = std::move(started).value();
      description = process->renderer_description() + ", jobs in process " + std::to_string(process->pid());
    } else {
      ready = started.status();
    }
  } else {
    init_cuda(ctx);
    auto created = create_renderer(options_.renderer, renderer_gpu(ctx));
    if (created.ok()) {
      renderer = std::move(created).value();
      ctx.renderer = renderer.get();
      description = ctx.renderer->description();
    } else {
      ready = created.status();
    }
  }
  {
    std::lock_guard<std::mutex> lock(mu_);
    if (ready.ok()) {
      ++live_;
      spdlog::info("{} ready: device {}, renderer {}", ctx.name, ctx.device, description);
    } else {
      failures_.push_back(ctx.name + ": " + ready.message());
      spdlog::error("{} cannot create a renderer: {}", ctx.name, ready.message());
    }
    ++ready_;
    if (metrics_) metrics_->live_workers.set(double(live_));
  }
  changed_.notify_all();
  if (!ready.ok()) return;

  while (std::optional<ClaimedJob> job = queue_.claim(ctx.name)) {
    {
      std::lock_guard<std::mutex> lock(mu_);
      running_[size_t(index)] = job->id;
      ++busy_;
      if (host_jobs_) host_jobs_->set(int(busy_));
      else
        share_threads();
      if (metrics_) metrics_->busy_workers.set(double(busy_));
    }
    if (!isolated) {
      run_job(queue_, std::move(*job), ctx);
    } else {
      const std::string id = job->id;
      const std::string frame = encode_job(&*job);
      // A process found dead before it took the job (killed while idle) costs
      // no job: the job runs in a new one, once.
      for (int attempt = 0; attempt < 2; ++attempt) {
        if (process && !process->alive()) process.reset();
        if (!process) {
          auto started = JobProcess::start(options_.process, ctx);
          if (!started.ok()) {
            spdlog::error("{}: cannot start a job process: {}", ctx.name, started.status().message());
            queue_.publish(id, failed_event(unavailable("no job process can run jobs on " + ctx.name + ": " +
                                                        started.status().message())));
            break;
          }
          process = std::move(started).value();
        }
        const JobProcess::Outcome outcome = process->run(queue_, id, frame, metrics_, attempt == 1);
        if (outcome == JobProcess::Outcome::kEnded) break;
        process.reset();
        if (outcome == JobProcess::Outcome::kProcessDied) break;
      }
      if (!process) {  // replace the dead process now, not when the next job waits for it
        auto started = JobProcess::start(options_.process, ctx);
        if (started.ok()) {
          process = std::move(started).value();
          spdlog::info("{}: job process replaced by process {}", ctx.name, process->pid());
        } else {
          spdlog::error("{}: cannot replace the job process: {}", ctx.name, started.status().message());
        }
      }
    }
    {
      std::lock_guard<std::mutex> lock(mu_);
      running_[size_t(index)].clear();
      --busy_;
      if (host_jobs_) host_jobs_->set(int(busy_));
      else
        share_threads();
      if (metrics_) metrics_->busy_workers.set(double(busy_));
    }
    changed_.notify_all();
  }
  std::lock_guard<std::mutex> lock(mu_);
  --live_;
  if (metrics_) metrics_->live_workers.set(double(live_));
}

bool WorkerPool::wait_idle(std::chrono::milliseconds timeout) {
  std::unique_lock<std::mutex> lock(mu_);
  return changed_.wait_for(lock, timeout, [&] { return busy_ == 0; });
}

void WorkerPool::cancel_running(const Status& reason) {
  std::vector<std::string> ids;
  {
    std::lock_guard<std::mutex> lock(mu_);
    for (const std::string& id : running_)
      if (!id.empty()) ids.push_back(id);
  }
  for (const std::string& id : ids) (void)queue_.cancel(id, reason);
}

void WorkerPool::join() {
  for (std::thread& t : threads_)
    if (t.joinable()) t.join();
  threads_.clear();
}

}  // namespace vpr::service
