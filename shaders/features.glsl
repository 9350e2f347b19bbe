// Scene features as specialization constants (DESIGN "simulate only what the
// scene calls for"): the host sets each from the loaded scene, so dead
// branches compile out of a scene's pipeline. In C++ (tests) all are on.
#ifndef VKMECH_FEATURES_GLSL
#define VKMECH_FEATURES_GLSL
#include "glsl_cpp.h"
#ifdef __cplusplus
namespace vkmech::shader {
#endif
// constant_id 0 is HAS_THIN_LENS (camera.glsl).
SPEC_CONST_BOOL(1, FEATURE_DIELECTRIC, true)   // dielectric, thindielectric, roughdielectric
SPEC_CONST_BOOL(2, FEATURE_ROUGH, true)        // microfacet lobes: roughconductor, roughdielectric, roughplastic
SPEC_CONST_BOOL(3, FEATURE_PLASTIC, true)      // plastic, roughplastic
SPEC_CONST_BOOL(4, FEATURE_PRINCIPLED, true)   // principled
SPEC_CONST_BOOL(5, FEATURE_CONDUCTOR, true)    // conductor, roughconductor
SPEC_CONST_BOOL(6, FEATURE_TEXTURES, true)     // bitmap reflectance
SPEC_CONST_BOOL(7, FEATURE_CAPTURE, true)      // mechanism capture (the descriptor)
#ifdef __cplusplus
}
#endif
#endif
