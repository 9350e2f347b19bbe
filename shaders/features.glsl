// Scene features as specialization constants (docs/architecture.md, "Simulate only what the
// scene calls for"): the host sets each from the loaded scene, so dead
// branches compile out of a scene's pipeline. In C++ (tests) all are on.
#ifndef VKMECH_FEATURES_GLSL
#define VKMECH_FEATURES_GLSL
#include "glsl_cpp.h"
#include "shared/bindings.h"
#ifdef __cplusplus
namespace vkmech::shader {
#endif
SPEC_CONST_BOOL(SPEC_DIELECTRIC, FEATURE_DIELECTRIC, true)   // dielectric, thindielectric, roughdielectric
SPEC_CONST_BOOL(SPEC_ROUGH, FEATURE_ROUGH, true)             // microfacet lobes: roughconductor, roughdielectric, roughplastic
SPEC_CONST_BOOL(SPEC_PLASTIC, FEATURE_PLASTIC, true)         // plastic, roughplastic
SPEC_CONST_BOOL(SPEC_PRINCIPLED, FEATURE_PRINCIPLED, true)   // principled
SPEC_CONST_BOOL(SPEC_CONDUCTOR, FEATURE_CONDUCTOR, true)     // conductor, roughconductor
SPEC_CONST_BOOL(SPEC_TEXTURES, FEATURE_TEXTURES, true)       // bitmap reflectance
SPEC_CONST_BOOL(SPEC_CAPTURE, FEATURE_CAPTURE, true)         // mechanism capture (the descriptor)
#ifdef __cplusplus
}
#endif
#endif
