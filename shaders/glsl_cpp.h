// "One code, two compilers" (docs/architecture.md): shader modules written in the common
// subset of GLSL and GLM-based C++, so doctest runs the very functions the GPU
// runs. Rules for shared code: no swizzle assignment, no swizzle reads beyond
// what glm offers without GLM_FORCE_SWIZZLE (use .x/.y/.z and vec3(v) casts),
// parameters that are written use INOUT/OUT.
#ifndef VKMECH_GLSL_CPP_H
#define VKMECH_GLSL_CPP_H

#ifdef __cplusplus
#include <glm/glm.hpp>
#include <cmath>
#include <cstdint>
namespace vkmech::shader {
using namespace glm;
typedef uint32_t uint;
}  // namespace vkmech::shader
#define INOUT(T) T&
#define OUT(T) T&
#define SHARED_FN inline
#define SPEC_CONST_BOOL(id, name, value) constexpr bool name = value;
#else
#define INOUT(T) inout T
#define OUT(T) out T
#define SHARED_FN
#define SPEC_CONST_BOOL(id, name, value) layout(constant_id = id) const bool name = value;
#endif

#endif
