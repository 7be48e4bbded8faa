// Counter-based random numbers: Philox4x32-10 (Salmon et al., "Parallel random
// numbers: as easy as 1, 2, 3", SC 2011). The stream is keyed by (seed, element)
// and indexed by a counter, so the CPU, the GPU and any thread count draw
// exactly the same numbers for the same element.
#pragma once

#include <cstdint>

#include "core/vec3.h"

namespace vpr {

struct Philox4 {
  uint32_t v[4];
};

VPR_HD inline uint32_t mulhilo32(uint32_t a, uint32_t b, uint32_t* hi) {
  const uint64_t p = uint64_t(a) * uint64_t(b);
  *hi = uint32_t(p >> 32);
  return uint32_t(p);
}

// counter: (c0, c1, c2, c3); key: (k0, k1).
VPR_HD inline Philox4 philox4x32_10(uint32_t c0, uint32_t c1, uint32_t c2, uint32_t c3, uint32_t k0, uint32_t k1) {
  for (int round = 0; round < 10; ++round) {
    uint32_t hi0, hi1;
    const uint32_t lo0 = mulhilo32(0xD2511F53u, c0, &hi0);
    const uint32_t lo1 = mulhilo32(0xCD9E8D57u, c2, &hi1);
    const uint32_t n0 = hi1 ^ c1 ^ k0, n2 = hi0 ^ c3 ^ k1;
    c0 = n0;
    c1 = lo1;
    c2 = n2;
    c3 = lo0;
    k0 += 0x9E3779B9u;
    k1 += 0xBB67AE85u;
  }
  return {{c0, c1, c2, c3}};
}

// Uniform float in [0, 1) from the top 24 bits: exact in float on every device.
VPR_HD inline float uniform01(uint32_t bits) {
  return float(bits >> 8) * (1.0f / 16777216.0f);
}

// Four uniforms for sample `index` of element `element` under `seed`.
VPR_HD inline Philox4 random4(uint64_t seed, uint64_t element, uint64_t index) {
  return philox4x32_10(uint32_t(index), uint32_t(index >> 32), uint32_t(element), uint32_t(element >> 32),
                       uint32_t(seed), uint32_t(seed >> 32));
}

}  // namespace vpr
