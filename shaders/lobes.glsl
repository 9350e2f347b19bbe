// The lobe classes each material can sample (docs/descriptor.md §2): Mitsuba's
// BSDF flags reduced to the three classes D (diffuse), G (glossy) and S
// (delta reflection or transmission), as a set of bits LOBE_BIT_x. Written
// once for GLSL and C++: the renderer's NEE lobe and delta-only test
// (bsdf_nee_lobe, bsdf_is_delta_only in bsdf.glsl), the host's
// Material::lobe_flags (`vkmech check`, Material::has_diffuse /
// is_delta_only) and the separation families (analysis/experiments/
// separation.hpp) all read this one table.
#ifndef VKMECH_LOBES_GLSL
#define VKMECH_LOBES_GLSL

#include "glsl_cpp.h"
#include "shared/types.h"
#include "sampling.glsl"

#ifdef __cplusplus
namespace vkmech::shader {
using namespace vkmech::gpu;
#endif

// type: MAT_*; metallic and spec_trans: the principled parameters (unused by
// the other types). The classes of each type are the `lobes` column of the
// material table (shared/materials.h), which follows what the type's sampling
// routine in bsdf.glsl can return:
// - diffuse: D.
// - plastic: S (the smooth dielectric coat, a mirror reflection: bsdf_make_delta)
//   and D (the base).
// - roughplastic: G (the microfacet coat) and D (the base).
// - conductor, dielectric, thindielectric: S only.
// - roughconductor, roughdielectric: G only (microfacet_make keeps alpha >=
//   MF_MIN_ALPHA, so the lobe is never a delta in disguise).
// - principled: G always (the GGX specular lobe, alpha >= 0.001, and the
//   GTR1 clearcoat; never a delta lobe), plus D while the diffuse weight
//   (1 - metallic)(1 - spec_trans) is positive: the one row its parameters refine.
// Unknown types: no lobe (0u).
// Flags describe what a material can sample, not with what weight: a plastic
// whose specular_reflectance is 0 still has its S bit, as in Mitsuba.
SHARED_FN uint material_lobe_flags(uint type, float metallic, float spec_trans) {
    uint flags = material_lobes(type);
    if (type == MAT_PRINCIPLED) {
        float w_brdf = (1.0 - saturate(metallic)) * (1.0 - saturate(spec_trans));
        if (!(w_brdf > 0.0)) flags &= ~LOBE_BIT_D;
    }
    return flags;
}

#ifdef __cplusplus
}  // namespace vkmech::shader
#endif

#endif
