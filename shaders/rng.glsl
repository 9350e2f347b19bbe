// Counter-based random numbers (docs/architecture.md, "Deterministic sampling"): every value
// is a pure function of (seed, pixel, sample index, dimension), so sample i
// of seed s is identical whatever the batching or the device (docs/descriptor.md §4).
// Written once for GLSL and C++ (analysis/experiments/separation.cpp, tests).
#ifndef VKMECH_RNG_GLSL
#define VKMECH_RNG_GLSL

#include "glsl_cpp.h"

#ifdef __cplusplus
namespace vkmech::shader {
#endif

// Chris Wellons' "lowbias32" integer hash (bias ~0.17, public domain idea).
SHARED_FN uint vkm_hash(uint x) {
    x ^= x >> 16;
    x *= 0x7feb352du;
    x ^= x >> 15;
    x *= 0x846ca68bu;
    x ^= x >> 16;
    return x;
}

struct Rng {
    uint key;  // hash of (seed, pixel, sample)
    uint dim;  // next dimension
};

SHARED_FN Rng rng_init(uint seed, uint pixel, uint sample_index) {
    Rng r;
    r.key = vkm_hash(seed ^ vkm_hash(pixel ^ vkm_hash(sample_index + 0x9e3779b9u)));
    r.dim = 0u;
    return r;
}

// Uniform in [0, 1): 24 high-quality bits.
SHARED_FN float rng_next(INOUT(Rng) r) {
    uint h = vkm_hash(r.key ^ vkm_hash(r.dim * 0x68e31da4u + 0x1b56c4e9u));
    r.dim += 1u;
    return float(h >> 8) * (1.0 / 16777216.0);
}

SHARED_FN vec2 rng_next2(INOUT(Rng) r) {
    float a = rng_next(r);
    float b = rng_next(r);
    return vec2(a, b);
}

#ifdef __cplusplus
}  // namespace vkmech::shader
#endif

#endif
