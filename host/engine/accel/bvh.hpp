// Host-built SAH BVH over triangles: a binary tree flattened depth-first
// (the CPU-side geometry queries use it), and its 4-wide quantized collapse
// that the software traversal runs (shaders/trace_bvh.glsl).
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
    // quad_next[i] != 0: BVH positions i and i + 1 are in the same leaf and
    // form a quad, triangle i = (a, b, c) and triangle i + 1 = (a, c, d) with
    // bit-identical positions and d != a (the usual split of a quad, as every
    // tessellator and mesh loader here writes it). The traversal then fetches
    // the quad's four vertices once (shaders/trace_bvh.glsl).
    std::vector<uint8_t> quad_next;
};

// The deepest a built tree may be (root at depth 0): its 4-wide collapse is
// then at most 30 interior levels deep, and the traversal keeps at most
// three deferred children per level on a 96-entry stack (BVH4_STACK_SIZE);
// the builder also recurses once per level. build_bvh guarantees it: where
// binned SAH could go deeper it splits at the object median, which needs
// only ceil(log2(count)) more levels.
constexpr uint32_t kBvhMaxDepth = 60;

// The defaults were measured on lavapipe with quads tested from one fetch
// (docs/performance.md, "The third round"): leaves of at most 2 triangles
// (4 where the split would not pay), 32 bins, one box test costing as much
// as one triangle test.
struct BvhBuildOptions {
    uint32_t max_leaf_size = 2;  // 1..BVH4_MAX_LEAF / 2 (else build_bvh fails VKM_ASSERT: InternalError)
    uint32_t bins = 32;
    float traversal_cost = 1.0f;  // an interior node's cost, in triangle tests (the leaf-or-split choice)
};

// tri_positions: 3 consecutive points per triangle, at least one (flatten_scene
// refuses a scene without triangles; none here is InternalError). Within each
// leaf, the two triangles of a quad are placed next to each other (quad_next),
// and the leaf children of each node of the 4-wide collapse hold consecutive
// triangles (collapse_bvh4).
Bvh build_bvh(const std::vector<glm::vec3>& tri_positions, const BvhBuildOptions& options = {});

// Empty string when well formed: every triangle in exactly one leaf, every
// node's box contains its children's boxes and its triangles, child links in
// range. Otherwise a description of the first fault.
// tri_positions here are in BVH order (position i is triangle order[i]).
std::string validate_bvh(const Bvh& bvh, const std::vector<glm::vec3>& tri_positions_in_bvh_order);

// The 4-wide tree the software traversal runs (gpu::GpuBvh4Node): each
// node takes its binary node's two children, opens every interior one among
// them (so an interior child of a 4-wide node is at least two binary levels
// below it), then opens the interior child of largest surface area until it
// has four. Leaves keep their triangle ranges (BVH order); a node's leaf
// children must hold consecutive triangles in child order, as build_bvh
// orders them. A node's interior children are consecutive nodes. Node 0 is
// the root (a tree that is one leaf becomes a root with that one child).
// Child boxes are quantized outwards: decode_bvh4_box contains the child's
// box. Throws std::length_error when the tree cannot be encoded: more than
// 2^28 - 16 triangles or nodes, a leaf of more than BVH4_MAX_LEAF triangles,
// or interior chains deeper than the traversal stack allows. An empty tree or a
// node whose leaf children are not consecutive is a bug (InternalError).
std::vector<gpu::GpuBvh4Node> collapse_bvh4(const Bvh& bvh);

// Child k of a 4-wide node as the traversal refers to it: BVH4_EMPTY, an
// interior node's index, or a leaf's first triangle | count << BVH4_COUNT_SHIFT.
uint32_t bvh4_child(const gpu::GpuBvh4Node& node, int k);

// Child k's box as the traversal decodes it (float arithmetic, as the shader).
void decode_bvh4_box(const gpu::GpuBvh4Node& node, int k, glm::vec3& lo, glm::vec3& hi);

struct BvhStats {
    uint32_t nodes = 0, leaves = 0, max_depth = 0, max_leaf = 0;
    double sah_cost = 0.0;
};
BvhStats bvh_stats(const Bvh& bvh);

}  // namespace vkmech
