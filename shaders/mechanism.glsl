// The contribution-event label (docs/descriptor.md §2, the paper's Algorithm 1): one
// function, compiled for the GPU and, unchanged, for the C++ tests.
#ifndef VKMECH_MECHANISM_GLSL
#define VKMECH_MECHANISM_GLSL

#include "glsl_cpp.h"
#include "shared/types.h"

#ifdef __cplusplus
namespace vkmech::shader {
using namespace vkmech::gpu;
#endif

// n: surface vertices before the emitter (0: the primary ray hit it);
// end_lobe: LOBE_D/G/S of the end vertex (sampled lobe for a BSDF hit, the
// NEE flag rule for an NEE event); delta_before_end: any of V1..V(n-1)
// sampled a delta lobe. First match wins.
SHARED_FN uint classify_event(uint n, uint end_lobe, bool delta_before_end) {
    if (n == 0u) return BUCKET_EMITTER_DIRECT;
    if (end_lobe == LOBE_S) return BUCKET_SPECULAR_DIRECT;
    if (end_lobe != LOBE_D && end_lobe != LOBE_G) return BUCKET_OTHER;
    if (delta_before_end) return BUCKET_DELTA_MEDIATED;
    if (n == 1u) return BUCKET_DIRECT;
    if (end_lobe == LOBE_D) return BUCKET_DIFFUSE_INDIRECT;
    return BUCKET_GLOSSY;
}

// The end vertex of a BSDF-sampled emitter hit shot from Vn (docs/descriptor.md §2). lobe_n:
// the lobe sampled at Vn; last_nondelta_lobe: the lobe sampled at the last
// non-delta vertex of V1..V(n-1) (LOBE_NONE if every one was delta);
// delta_before_n: any of V1..V(n-1) sampled a delta lobe.
// Default reading (literal = false): the end vertex is the last non-delta
// vertex of the path, and the delta flag looks at every other vertex, so a
// caustic found by BSDF sampling (E-D-S-L) ends at the diffuse vertex with the
// glass as "other" delta vertex; only an all-delta path (E-S-L, E-S-S-L) has
// l = S. Literal reading: the end vertex is Vn itself.
SHARED_FN uint bsdf_hit_end_lobe(bool literal, uint lobe_n, uint last_nondelta_lobe) {
    if (literal || lobe_n != LOBE_S) return lobe_n;
    return last_nondelta_lobe == LOBE_NONE ? LOBE_S : last_nondelta_lobe;
}
SHARED_FN bool bsdf_hit_delta(bool literal, uint lobe_n, uint last_nondelta_lobe, bool delta_before_n) {
    if (literal || lobe_n != LOBE_S || last_nondelta_lobe == LOBE_NONE) return delta_before_n;
    return true;  // Vn itself is a delta vertex other than the end vertex
}

// Heavy-tailed family (docs/descriptor.md §2, HEAVY_BUCKETS): glossy, delta_mediated, specular_direct.
SHARED_FN bool bucket_is_heavy(uint b) {
    return b < BUCKET_COUNT && ((HEAVY_BUCKETS >> b) & 1u) != 0u;
}

#ifdef __cplusplus
}  // namespace vkmech::shader
#endif

#endif
