#include "render/shader_modules.hpp"

#include <cstdint>
#include <stdexcept>

#include "shaders/spv_pathtrace_bvh.h"
#include "shaders/spv_pathtrace_counters_bvh.h"
#include "shaders/spv_pathtrace_direct_glossy_bvh.h"
#include "shaders/spv_pathtrace_direct_glossy_rayquery.h"
#include "shaders/spv_pathtrace_rayquery.h"
#include "shaders/spv_tracerays_bvh.h"
#include "shaders/spv_tracerays_counters_bvh.h"
#include "shaders/spv_tracerays_per_invocation_bvh.h"
#include "shaders/spv_tracerays_rayquery.h"

namespace vkmech {

std::span<const uint32_t> pathtrace_spirv(Traversal t) {
    if (t == Traversal::RayQuery) return spv_pathtrace_rayquery;
    return spv_pathtrace_bvh;
}

std::span<const uint32_t> pathtrace_spirv(Traversal t, bool direct_glossy, bool counters) {
    if (counters) {
        if (t != Traversal::Bvh || direct_glossy)
            throw std::invalid_argument("traversal counters exist for the software BVH's default path tracer only");
        return spv_pathtrace_counters_bvh;
    }
    if (!direct_glossy) return pathtrace_spirv(t);
    if (t == Traversal::RayQuery) return spv_pathtrace_direct_glossy_rayquery;
    return spv_pathtrace_direct_glossy_bvh;
}

std::span<const uint32_t> tracerays_spirv(Traversal t, bool counters, bool slices) {
    if (t == Traversal::RayQuery) {
        if (counters) throw std::invalid_argument("traversal counters exist for the software BVH only");
        return spv_tracerays_rayquery;
    }
    if (counters) return spv_tracerays_counters_bvh;
    if (slices) return spv_tracerays_bvh;
    return spv_tracerays_per_invocation_bvh;
}

}  // namespace vkmech
