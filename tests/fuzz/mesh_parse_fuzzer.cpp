// libFuzzer harness for every mesh parser that sees bytes from the network or
// a user's disk (STYLE.md: fuzz every parser). The first byte picks the format.
// Build: cmake -DVPR_FUZZ=ON -DCMAKE_CXX_COMPILER=clang++ ...; run:
//   build/fuzz/tests/mesh_parse_fuzzer -max_total_time=60 -rss_limit_mb=2048
#include <cstddef>
#include <cstdint>

#include "io/mesh_io.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  static const vpr::MeshFormat formats[] = {vpr::MeshFormat::kDraco, vpr::MeshFormat::kObj, vpr::MeshFormat::kPly,
                                            vpr::MeshFormat::kOff, vpr::MeshFormat::kStl};
  vpr::MeshLimits limits;
  limits.max_vertices = 1 << 20;  // keep the fuzzer's memory bounded
  limits.max_faces = 1 << 21;
  auto mesh = vpr::parse_mesh(data + 1, size - 1, formats[data[0] % 5], limits);
  if (mesh.ok() && vpr::validate_mesh(*mesh, limits).ok() == false) __builtin_trap();  // parse must validate
  return 0;
}
