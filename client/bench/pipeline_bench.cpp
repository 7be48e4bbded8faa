// Pipeline benchmark (a program, not a test): per-stage wall times of the CPU
// pipeline on the shared models, and OpenMesh's quadric decimater on the same
// input to the same vertex count as the peer a user would pick instead.
// Prints a Markdown table.
//   vpremesh-bench [--threads N] [--repeat R] MODEL:TARGET ...
#include <tbb/global_control.h>

#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
#include <OpenMesh/Tools/Decimater/DecimaterT.hh>
#include <OpenMesh/Tools/Decimater/ModQuadricT.hh>
#include <chrono>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include "io/mesh_io.h"
#include "pipeline/pipeline.h"

namespace {

using Clock = std::chrono::steady_clock;
using OmMesh = OpenMesh::TriMesh_ArrayKernelT<>;

double ms_since(Clock::time_point t) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
}

// OpenMesh needs a manifold; faces it refuses are counted and skipped.
double openmesh_quadric_ms(const vpr::Mesh& in, uint32_t target, size_t* out_vertices) {
  OmMesh mesh;
  std::vector<OmMesh::VertexHandle> vh(in.vertex_count());
  for (size_t v = 0; v < in.vertex_count(); ++v)
    vh[v] = mesh.add_vertex(OmMesh::Point(in.positions[3 * v], in.positions[3 * v + 1], in.positions[3 * v + 2]));
  size_t refused = 0;
  for (size_t f = 0; f < in.face_count(); ++f)
    refused += !mesh.add_face(vh[in.indices[3 * f]], vh[in.indices[3 * f + 1]], vh[in.indices[3 * f + 2]]).is_valid();
  if (refused) std::fprintf(stderr, "OpenMesh refused %zu non-manifold faces\n", refused);
  const auto start = Clock::now();
  OpenMesh::Decimater::DecimaterT<OmMesh> decimater(mesh);
  OpenMesh::Decimater::ModQuadricT<OmMesh>::Handle quadric;
  decimater.add(quadric);
  decimater.initialize();
  decimater.decimate_to(target);
  mesh.garbage_collection();
  const double ms = ms_since(start);
  *out_vertices = mesh.n_vertices();
  return ms;
}

}  // namespace

int main(int argc, char** argv) {
  omerr().disable();  // OpenMesh's per-face complaints would break the table; we count them instead
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
      size_t qem_vertices = 0;
      const double qem = openmesh_quadric_ms(*mesh, target, &qem_vertices);
      std::printf(" %.0f | %.0f | %.0f | %.2f |\n", write_ms, total, qem, qem / total);
      std::fflush(stdout);
    }
  }
  return 0;
}
