// Scene features as specialization constants (docs/architecture.md, "Simulate only what the
// scene calls for"): the host sets each from the loaded scene, so dead
// branches compile out of a scene's pipeline. In C++ (tests) all are on.
#ifndef VKMECH_FEATURES_GLSL
#define VKMECH_FEATURES_GLSL
#include "glsl_cpp.h"
#include "shared/bindings.h"
#include "shared/types.h"
#ifdef __cplusplus
namespace vkmech::shader {
using namespace vkmech::gpu;
#endif
// FEATURE_<NAME> of every material feature (shared/materials.h).
#define VKM_X(NAME, name, bit, spec_id) SPEC_CONST_BOOL(SPEC_##NAME, FEATURE_##NAME, true)
VKM_MATERIAL_FEATURES(VKM_X)
#undef VKM_X
SPEC_CONST_BOOL(SPEC_TEXTURES, FEATURE_TEXTURES, true)       // bitmap reflectance
SPEC_CONST_BOOL(SPEC_CAPTURE, FEATURE_CAPTURE, true)         // mechanism capture (the descriptor)
SPEC_CONST_BOOL(SPEC_ENVIRONMENT, FEATURE_ENVIRONMENT, true) // emitters at infinity (environment, directional)
SPEC_CONST_BOOL(SPEC_TANGENTS, FEATURE_TANGENTS, true)       // normal maps on the file's tangents (TRI_TANGENT_BIT)

// Whether every feature of `mask` (FEATURE_BIT_*) is compiled in: the guard of
// a material's code (material_features(type), shaders/bsdf.glsl).
SHARED_FN bool features_on(uint mask) {
#define VKM_X(NAME, name, bit, spec_id) \
    if ((mask & FEATURE_BIT_##NAME) != 0u && !FEATURE_##NAME) return false;
    VKM_MATERIAL_FEATURES(VKM_X)
#undef VKM_X
    return true;
}
#ifdef __cplusplus
}
#endif
#endif
