// Pipeline benchmark (a program, not a test): per-stage wall times of the CPU
// pipeline on the shared models, and OpenMesh's quadric decimater on the same
// input to the same vertex count as the peer a user would pick instead.
// Prints a Markdown table.
//   vpremesh-bench [--threads N] [--repeat R] MODEL:TARGET ...
#include <tbb/global_control.h>

#include <chrono>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include "io/mesh_io.h"
#include "peers/peers.h"
#include "pipeline/pipeline.h"

namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
}

}  // namespace

int main(int argc, char** argv) {
  int threads = 0, repeat = 1;
  std::vector<std::pair<std::string, uint32_t>> jobs;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--threads" && i + 1 < argc) {
      threads = std::stoi(argv[++i]);
    } else if (a == "--repeat" && i + 1 < argc) {
      repeat = std::stoi(argv[++i]);
    } else {
      const size_t colon = a.rfind(':');
      if (colon == std::string::npos) {
        std::fprintf(stderr, "usage: vpremesh-bench [--threads N] [--repeat R] MODEL:TARGET ...\n");
        return 2;
      }
      jobs.emplace_back(a.substr(0, colon), uint32_t(std::stoul(a.substr(colon + 1))));
    }
  }
  std::unique_ptr<tbb::global_control> limit;
  if (threads > 0) limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, threads);

  const char* stages[] = {"views",          "render",   "image_saliency", "unproject",
                          "saliency_field", "sampling", "awlop",          "meshing"};
  std::printf("| model | in V | target | out V | read |");
  for (const char* s : stages) std::printf(" %s |", s);
  std::printf(" write | total ms | OpenMesh QEM ms | ratio |\n|---|---|---|---|---|");
  for (size_t i = 0; i < std::size(stages); ++i) std::printf("---|");
  std::printf("---|---|---|---|\n");

  for (const auto& [path, target] : jobs) {
    for (int r = 0; r < repeat; ++r) {
      auto start = Clock::now();
      auto mesh = vpr::read_mesh(path);
      if (!mesh.ok()) {
        std::fprintf(stderr, "%s: %s\n", path.c_str(), mesh.status().to_string().c_str());
        return 1;
      }
      const double read_ms = ms_since(start);
      vpr::PipelineOptions options;
      options.target_vertices = target;
      auto result = vpr::run_pipeline(*mesh, options);
      if (!result.ok()) {
        std::fprintf(stderr, "%s: %s\n", path.c_str(), result.status().to_string().c_str());
        return 1;
      }
      start = Clock::now();
      auto encoded = vpr::encode_draco(result->mesh, result->saliency.data(), {});
      const double write_ms = ms_since(start);
      std::map<std::string, double> ms;
      for (const auto& t : result->stages) ms[t.name] += t.ms;
      double total = read_ms + write_ms;
      std::printf("| %s | %zu | %u | %zu | %.0f |", path.substr(path.rfind('/') + 1).c_str(), mesh->vertex_count(),
                  target, result->mesh.vertex_count(), read_ms);
      for (const char* s : stages) {
        std::printf(" %.0f |", ms[s]);
        total += ms[s];
      }
      // The decimation alone, as before the peers library: conversion excluded.
      auto peer = vpr::peers::openmesh_quadric(*mesh, target);
      if (!peer.ok()) {
        std::fprintf(stderr, "%s: %s\n", path.c_str(), peer.status().to_string().c_str());
        return 1;
      }
      if (!peer->note.empty()) std::fprintf(stderr, "%s: OpenMesh QEM %s\n", path.c_str(), peer->note.c_str());
      const double qem = peer->core_ms;
      std::printf(" %.0f | %.0f | %.0f | %.2f |\n", write_ms, total, qem, qem / total);
      std::fflush(stdout);
    }
  }
  return 0;
}
