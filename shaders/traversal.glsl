// Selects the traversal module: a module that declares RayQueryKHR cannot be
// created on a device without it, so each is its own SPIR-V (docs/architecture.md, "Simulate only what the scene calls for").
#if defined(TRAVERSAL_RAYQUERY)
#include "trace_rayquery.glsl"
#elif defined(TRAVERSAL_BVH)
#include "trace_bvh.glsl"
#else
#error "define TRAVERSAL_RAYQUERY or TRAVERSAL_BVH"
#endif
