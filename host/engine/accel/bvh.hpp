// Host-built SAH BVH over triangles, flattened depth-first for the software
// traversal (shaders/trace_bvh.glsl).
#pragma once

#include "shared/types.h"

#include <glm/glm.hpp>

#include <string>
#include <vector>

namespace vkmech {

struct Bvh {
    std::vector<gpu::GpuBvhNode> nodes;
    // order[i]: the input triangle stored at BVH position i. Leaves reference
    // contiguous ranges of this order.
    std::vector<uint32_t> order;
};

// The deepest a built tree may be (root at depth 0): the traversal shaders
// keep at most depth - 1 deferred nodes on a 64-entry stack
// (shaders/trace_bvh.glsl BVH_STACK_SIZE), and the builder recurses once per
// level. build_bvh guarantees it: where binned SAH could go deeper it splits
// at the object median, which needs only ceil(log2(count)) more levels.
constexpr uint32_t kBvhMaxDepth = 60;

struct BvhBuildOptions {
    uint32_t max_leaf_size = 4;
    uint32_t bins = 16;
};

// tri_positions: 3 consecutive points per triangle; throws std::invalid_argument
// when there are none.
Bvh build_bvh(const std::vector<glm::vec3>& tri_positions, const BvhBuildOptions& options = {});

// Empty string when well formed: every triangle in exactly one leaf, every
// node's box contains its children's boxes and its triangles, child links in
// range. Otherwise a description of the first fault.
// tri_positions here are in BVH order (position i is triangle order[i]).
std::string validate_bvh(const Bvh& bvh, const std::vector<glm::vec3>& tri_positions_in_bvh_order);

struct BvhStats {
    uint32_t nodes = 0, leaves = 0, max_depth = 0, max_leaf = 0;
    double sah_cost = 0.0;
};
BvhStats bvh_stats(const Bvh& bvh);

}  // namespace vkmech
