// Orthonormal tangent frame around a unit normal, written once for GLSL and
// C++ (docs/architecture.md, "One code, two compilers"): t, b, n right-handed (t x b = n).
#ifndef VKMECH_FRAME_GLSL
#define VKMECH_FRAME_GLSL

#include "glsl_cpp.h"

#ifdef __cplusplus
namespace vkmech::shader {
#endif

struct Frame3 {
    vec3 t, b, n;
};

// Duff et al. 2017, "Building an orthonormal basis, revisited".
SHARED_FN Frame3 frame_from_normal(vec3 n) {
    float s = n.z >= 0.0 ? 1.0 : -1.0;
    float a = -1.0 / (s + n.z);
    float b = n.x * n.y * a;
    Frame3 f;
    f.t = vec3(1.0 + s * n.x * n.x * a, s * b, -s * n.x);
    f.b = vec3(b, s + n.y * n.y * a, -n.y);
    f.n = n;
    return f;
}
SHARED_FN vec3 to_local(Frame3 f, vec3 v) { return vec3(dot(v, f.t), dot(v, f.b), dot(v, f.n)); }
SHARED_FN vec3 to_world(Frame3 f, vec3 v) { return v.x * f.t + v.y * f.b + v.z * f.n; }

#ifdef __cplusplus
}  // namespace vkmech::shader
#endif

#endif
