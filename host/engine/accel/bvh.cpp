#include "accel/bvh.hpp"
#include "io/invariant.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>

namespace vkmech {

namespace {

struct Box {
    glm::vec3 lo{std::numeric_limits<float>::max()};
    glm::vec3 hi{-std::numeric_limits<float>::max()};
    void grow(const glm::vec3& p) {
        lo = glm::min(lo, p);
        hi = glm::max(hi, p);
    }
    void grow(const Box& b) {
        lo = glm::min(lo, b.lo);
        hi = glm::max(hi, b.hi);
    }
    bool empty() const { return lo.x > hi.x; }
    float area() const {
        if (empty()) return 0.0f;
        glm::vec3 d = hi - lo;
        return 2.0f * (d.x * d.y + d.y * d.z + d.z * d.x);
    }
};

struct Builder {
    const std::vector<glm::vec3>& pos;
    BvhBuildOptions opt;
    std::vector<Box> tri_box;
    std::vector<glm::vec3> centroid;
    std::vector<uint32_t> order;
    std::vector<gpu::GpuBvhNode> nodes;

    static float as_float(uint32_t u) { return std::bit_cast<float>(u); }

    uint32_t make_node(const Box& b, uint32_t offset, uint32_t count) {
        gpu::GpuBvhNode n;
        n.bmin = glm::vec4(b.lo, as_float(offset));
        n.bmax = glm::vec4(b.hi, as_float(count));
        nodes.push_back(n);
        return static_cast<uint32_t>(nodes.size() - 1);
    }

    static uint32_t ceil_log2(uint32_t x) {
        uint32_t k = 0;
        while (k < 32 && (uint64_t{1} << k) < x) ++k;
        return k;
    }

    void build(uint32_t begin, uint32_t end, uint32_t depth = 0) {
        Box bounds, cbounds;
        for (uint32_t i = begin; i < end; ++i) {
            bounds.grow(tri_box[order[i]]);
            cbounds.grow(centroid[order[i]]);
        }
        uint32_t count = end - begin;
        uint32_t self = make_node(bounds, begin, count);
        if (count <= opt.max_leaf_size) return;

        // Depth bound (kBvhMaxDepth): when SAH could take this subtree past it, split at the object
        // median of the widest centroid axis instead; halving keeps depth + ceil(log2(count)) constant.
        if (depth + ceil_log2(count) + 1 >= kBvhMaxDepth) {
            int axis = 0;
            const glm::vec3 ext = cbounds.hi - cbounds.lo;
            if (ext.y > ext[axis]) axis = 1;
            if (ext.z > ext[axis]) axis = 2;
            const uint32_t mid = begin + count / 2;
            std::nth_element(order.begin() + begin, order.begin() + mid, order.begin() + end,
                             [&](uint32_t a, uint32_t b) { return centroid[a][axis] < centroid[b][axis]; });
            nodes[self].bmax.w = as_float(0u);
            build(begin, mid, depth + 1);
            const uint32_t second = static_cast<uint32_t>(nodes.size());
            nodes[self].bmin.w = as_float(second);
            build(mid, end, depth + 1);
            return;
        }

        // Binned SAH over the axis of largest centroid extent, then all axes.
        float best_cost = std::numeric_limits<float>::max();
        int best_axis = -1;
        uint32_t best_split = 0;
        const uint32_t nb = opt.bins;
        for (int axis = 0; axis < 3; ++axis) {
            float lo = cbounds.lo[axis], hi = cbounds.hi[axis];
            if (!(hi > lo)) continue;
            // In double: hi - lo of finite floats near +-3e38 overflows float.
            const double scale = nb / (static_cast<double>(hi) - lo);
            std::vector<Box> bin_box(nb);
            std::vector<uint32_t> bin_count(nb, 0);
            for (uint32_t i = begin; i < end; ++i) {
                uint32_t t = order[i];
                // A centroid that overflowed float (inf, or NaN from inf - inf) falls in an end bin.
                const double x = (static_cast<double>(centroid[t][axis]) - lo) * scale;
                const uint32_t b = x >= 0.0 && x < nb ? static_cast<uint32_t>(x) : (x >= nb ? nb - 1 : 0);
                bin_box[b].grow(tri_box[t]);
                bin_count[b] += 1;
            }
            std::vector<float> left_area(nb), right_area(nb);
            std::vector<uint32_t> left_count(nb), right_count(nb);
            Box acc;
            uint32_t c = 0;
            for (uint32_t b = 0; b < nb; ++b) {
                acc.grow(bin_box[b]);
                c += bin_count[b];
                left_area[b] = acc.area();
                left_count[b] = c;
            }
            acc = Box{};
            c = 0;
            for (uint32_t b = nb; b-- > 0;) {
                acc.grow(bin_box[b]);
                c += bin_count[b];
                right_area[b] = acc.area();
                right_count[b] = c;
            }
            for (uint32_t b = 0; b + 1 < nb; ++b) {
                if (left_count[b] == 0 || right_count[b + 1] == 0) continue;
                float cost = left_area[b] * left_count[b] + right_area[b + 1] * right_count[b + 1];
                if (cost < best_cost) {
                    best_cost = cost;
                    best_axis = axis;
                    best_split = b;
                }
            }
        }
        uint32_t mid;
        if (best_axis < 0) {
            // All centroids coincide: split the range in half.
            mid = begin + count / 2;
        } else {
            // SAH: splitting costs a node visit plus the children's tests, each
            // weighted by the chance (surface area) that a ray meets it.
            float leaf_cost = bounds.area() * count;
            float split_cost = best_cost + opt.traversal_cost * bounds.area();
            if (split_cost >= leaf_cost && count <= 2 * opt.max_leaf_size) return;  // stays a leaf
            float lo = cbounds.lo[best_axis], hi = cbounds.hi[best_axis];
            // In double: hi - lo of finite floats near +-3e38 overflows float.
            const double scale = nb / (static_cast<double>(hi) - lo);
            auto it = std::partition(order.begin() + begin, order.begin() + end, [&](uint32_t t) {
                uint32_t b = std::min(nb - 1, static_cast<uint32_t>((centroid[t][best_axis] - lo) * scale));
                return b <= best_split;
            });
            mid = static_cast<uint32_t>(it - order.begin());
            if (mid == begin || mid == end) mid = begin + count / 2;
        }
        // Interior: first child follows immediately, second child index in offset.
        nodes[self].bmax.w = as_float(0u);
        build(begin, mid, depth + 1);
        uint32_t second = static_cast<uint32_t>(nodes.size());
        nodes[self].bmin.w = as_float(second);
        build(mid, end, depth + 1);
    }
};

// Bit-identical points: a shared quad vertex is the same float triple.
bool same_point(const glm::vec3& p, const glm::vec3& q) {
    return std::bit_cast<glm::uvec3>(p) == std::bit_cast<glm::uvec3>(q);
}

// Reorders each leaf's range of bvh.order so that the triangles (a, b, c) and
// (a, c, d) of a quad are adjacent, the first of them first, and marks them in
// bvh.quad_next. Greedy in leaf order; a leaf holds at most a few triangles.
void pair_quads(Bvh& bvh, const std::vector<glm::vec3>& pos) {
    bvh.quad_next.assign(bvh.order.size(), 0);
    auto vertex = [&](uint32_t tri, int k) -> const glm::vec3& { return pos[3 * size_t{tri} + k]; };
    std::vector<uint32_t> leaf;
    std::vector<bool> used;
    for (const auto& node : bvh.nodes) {
        uint32_t count = std::bit_cast<uint32_t>(node.bmax.w);
        if (count < 2) continue;  // interior (0) or a single triangle
        uint32_t offset = std::bit_cast<uint32_t>(node.bmin.w);
        leaf.assign(bvh.order.begin() + offset, bvh.order.begin() + offset + count);
        used.assign(count, false);
        uint32_t out = offset;
        for (uint32_t i = 0; i < count; ++i) {
            if (used[i]) continue;
            uint32_t t = leaf[i];
            for (uint32_t j = 0; j < count; ++j) {
                uint32_t u = leaf[j];
                if (j == i || used[j] || !same_point(vertex(u, 0), vertex(t, 0)) ||
                    !same_point(vertex(u, 1), vertex(t, 2)) || same_point(vertex(u, 2), vertex(t, 0)))
                    continue;
                used[i] = used[j] = true;
                bvh.quad_next[out] = 1;
                bvh.order[out++] = t;
                bvh.order[out++] = u;
                break;
            }
        }
        for (uint32_t i = 0; i < count; ++i)
            if (!used[i]) bvh.order[out++] = leaf[i];
    }
}

}  // namespace

namespace {

// x - origin of two floats, bracketed: `lo` <= the exact difference <= `hi`
// (equal when the double subtraction is exact, which TwoSum detects).
struct Gap {
    double lo, hi;
};
Gap gap(float x, float origin) {
    const double a = x, b = -static_cast<double>(origin);
    const double sum = a + b;
    const double bb = sum - a;
    const double err = (a - (sum - bb)) + (b - bb);
    if (err == 0.0) return {sum, sum};
    return {std::nextafter(sum, -HUGE_VAL), std::nextafter(sum, HUGE_VAL)};
}

// The decoded bound origin + q * scale in float, as the shader computes it (q * scale is exact).
float dequantize(float origin, float scale, uint32_t q) { return origin + static_cast<float>(q) * scale; }

// A code is safe when the exact origin + q * scale bounds x, so that the decode
// in float bounds it under any monotone rounding (to nearest, toward zero, a
// fused multiply-add: Vulkan does not fix the rounding mode), and when the
// float decode as this host rounds it (to nearest; inf on overflow) does too.
bool safe_up(float origin, double scale, float x, const Gap& g, uint32_t q) {
    return q * scale >= g.hi && dequantize(origin, static_cast<float>(scale), q) >= x;
}
bool safe_down(float origin, double scale, float x, const Gap& g, uint32_t q) {
    return q == 0 || (q * scale <= g.lo && dequantize(origin, static_cast<float>(scale), q) <= x);
}

// The smallest e (a normal float's exponent, -126..127) whose code 255 safely
// bounds every child's upper bound `his[0..n)` from the node's lower corner.
int quantization_exponent(float lo, const float* his, size_t n) {
    double widest = 0.0;
    for (size_t k = 0; k < n; ++k) widest = std::max(widest, gap(his[k], lo).hi);
    int e = -126;
    if (widest > 0.0) e = std::max(-126, static_cast<int>(std::ceil(std::log2(widest / 255.0))) - 1);
    auto all_safe = [&](int ex) {
        for (size_t k = 0; k < n; ++k)
            if (!safe_up(lo, std::ldexp(1.0, ex), his[k], gap(his[k], lo), 255)) return false;
        return true;
    };
    while (e < 127 && !all_safe(e)) ++e;
    return e;  // at 127, 255 * 2^127 exceeds every float extent (and decodes to inf)
}

// The largest safe q for a lower bound x (q = 0 decodes to origin <= x exactly).
uint32_t quantize_down(float origin, double scale, float x) {
    const Gap g = gap(x, origin);
    uint32_t u = static_cast<uint32_t>(std::clamp(std::floor(g.lo / scale), 0.0, 255.0));
    while (u < 255 && safe_down(origin, scale, x, g, u + 1)) ++u;
    while (!safe_down(origin, scale, x, g, u)) --u;
    return u;
}

// The smallest safe q for an upper bound x (q = 255 is safe: quantization_exponent).
uint32_t quantize_up(float origin, double scale, float x) {
    const Gap g = gap(x, origin);
    uint32_t u = static_cast<uint32_t>(std::clamp(std::ceil(g.hi / scale), 0.0, 255.0));
    while (u < 255 && !safe_up(origin, scale, x, g, u)) ++u;
    while (u > 0 && safe_up(origin, scale, x, g, u - 1)) --u;
    return u;
}

}  // namespace

void decode_bvh4_box(const gpu::GpuBvh4Node& node, int k, glm::vec3& lo, glm::vec3& hi) {
    const uint32_t e = std::bit_cast<uint32_t>(node.origin.w);
    const uint32_t shift = 8u * static_cast<uint32_t>(k);
    const uint32_t qlo[3] = {node.q0[0], node.q0[1], node.q0[2]};
    const uint32_t qhi[3] = {node.q0[3], node.q1[0], node.q1[1]};
    for (int a = 0; a < 3; ++a) {
        const float scale = std::bit_cast<float>(((e >> (8 * a)) & 0xFFu) << 23);
        lo[a] = dequantize(node.origin[a], scale, (qlo[a] >> shift) & 0xFFu);
        hi[a] = dequantize(node.origin[a], scale, (qhi[a] >> shift) & 0xFFu);
    }
}

namespace {

uint32_t leaf_offset(const Bvh& bvh, uint32_t n) { return std::bit_cast<uint32_t>(bvh.nodes[n].bmin.w); }
uint32_t leaf_count(const Bvh& bvh, uint32_t n) { return std::bit_cast<uint32_t>(bvh.nodes[n].bmax.w); }

// The binary nodes a 4-wide node takes as children, from the binary node's
// two children `kids`: every interior one opened once (replaced by its two
// children), then the interior one of largest surface area until there are
// four.
std::vector<uint32_t> bvh4_children(const Bvh& bvh, std::vector<uint32_t> kids) {
    auto area = [&](uint32_t n) {
        glm::vec3 d = glm::vec3(bvh.nodes[n].bmax) - glm::vec3(bvh.nodes[n].bmin);
        return d.x * d.y + d.y * d.z + d.z * d.x;
    };
    auto open = [&](size_t k) {
        const uint32_t c = kids[k];
        kids[k] = c + 1;
        kids.push_back(leaf_offset(bvh, c));
    };
    for (size_t k = 0, n = kids.size(); k < n && kids.size() < 4; ++k)
        if (leaf_count(bvh, kids[k]) == 0) open(k);
    while (kids.size() < 4) {
        int best = -1;
        for (size_t k = 0; k < kids.size(); ++k)
            if (leaf_count(bvh, kids[k]) == 0 && (best < 0 || area(kids[k]) > area(kids[static_cast<size_t>(best)])))
                best = static_cast<int>(k);
        if (best < 0) break;
        open(static_cast<size_t>(best));
    }
    return kids;
}

// The root 4-wide node's starting children: the root's two, or the root
// itself when the tree is one leaf.
std::vector<uint32_t> bvh4_root_kids(const Bvh& bvh) {
    if (leaf_count(bvh, 0) > 0) return {0u};
    return {1u, leaf_offset(bvh, 0)};
}

// Reorders the triangles so that the leaf children of every 4-wide node
// (bvh4_children) hold consecutive triangles in child order, as the node
// encoding needs (one first triangle per node); leaves are moved whole, so
// quad pairs stay together (after pair_quads: quad_next has an entry per
// triangle).
void group_bvh4_leaves(Bvh& bvh) {
    std::vector<uint32_t> order;
    std::vector<uint8_t> quad_next;
    order.reserve(bvh.order.size());
    quad_next.reserve(bvh.quad_next.size());
    auto walk = [&](auto& self, const std::vector<uint32_t>& start) -> void {
        const std::vector<uint32_t> kids = bvh4_children(bvh, start);
        for (uint32_t c : kids) {
            const uint32_t count = leaf_count(bvh, c);
            if (count == 0) continue;
            const uint32_t from = leaf_offset(bvh, c);
            bvh.nodes[c].bmin.w = std::bit_cast<float>(static_cast<uint32_t>(order.size()));
            order.insert(order.end(), bvh.order.begin() + from, bvh.order.begin() + from + count);
            quad_next.insert(quad_next.end(), bvh.quad_next.begin() + from, bvh.quad_next.begin() + from + count);
        }
        for (uint32_t c : kids)
            if (leaf_count(bvh, c) == 0) self(self, std::vector<uint32_t>{c + 1, leaf_offset(bvh, c)});
    };
    walk(walk, bvh4_root_kids(bvh));
    bvh.order = std::move(order);
    bvh.quad_next = std::move(quad_next);
}

}  // namespace

uint32_t bvh4_child(const gpu::GpuBvh4Node& node, int k) {
    const uint32_t w = std::bit_cast<uint32_t>(node.origin.w);
    const uint32_t code[4] = {(w >> 24) & 0xFu, w >> 28, node.q1[2] >> 28, node.q1[3] >> 28};
    uint32_t node_rank = 0, tri_offset = 0;
    for (int j = 0; j < k; ++j) {
        node_rank += code[j] == gpu::BVH4_CODE_INTERIOR;
        tri_offset += code[j] > gpu::BVH4_CODE_INTERIOR ? code[j] - 1 : 0;
    }
    const uint32_t c = code[k];
    if (c == gpu::BVH4_CODE_EMPTY) return gpu::BVH4_EMPTY;
    if (c == gpu::BVH4_CODE_INTERIOR) return (node.q1[2] & gpu::BVH4_INDEX_MASK) + node_rank;
    return ((node.q1[3] & gpu::BVH4_INDEX_MASK) + tri_offset) | ((c - 1) << gpu::BVH4_COUNT_SHIFT);
}

std::vector<gpu::GpuBvh4Node> collapse_bvh4(const Bvh& bvh) {
    VKM_ASSERT(!bvh.nodes.empty(), "collapse_bvh4: empty tree (build_bvh never returns one)");
    const auto& nodes = bvh.nodes;
    constexpr uint32_t kLimit = gpu::BVH4_INDEX_MASK - 16u;
    if (bvh.order.size() > kLimit) throw std::length_error("collapse_bvh4: too many triangles for the 4-wide encoding");
    std::vector<gpu::GpuBvh4Node> out;
    out.reserve(nodes.size() / 2 + 1);
    uint32_t deepest = 0;
    // emit(start, index, depth): writes the 4-wide node `index` whose children
    // come from the binary nodes `start` (bvh4_children), its interior
    // children as consecutive new nodes.
    auto emit = [&](auto& self, const std::vector<uint32_t>& start, uint32_t index, uint32_t depth) -> void {
        deepest = std::max(deepest, depth);
        if (3u * deepest > gpu::BVH4_STACK_SIZE)
            throw std::length_error("collapse_bvh4: tree deeper than the traversal stack");
        const std::vector<uint32_t> kids = bvh4_children(bvh, start);
        gpu::GpuBvh4Node node{};
        std::array<glm::vec3, 4> lo{}, hi{};
        glm::vec3 nlo(std::numeric_limits<float>::max()), nhi(-std::numeric_limits<float>::max());
        for (size_t k = 0; k < kids.size(); ++k) {
            lo[k] = glm::vec3(nodes[kids[k]].bmin);
            hi[k] = glm::vec3(nodes[kids[k]].bmax);
            nlo = glm::min(nlo, lo[k]);
            nhi = glm::max(nhi, hi[k]);
        }
        node.origin = glm::vec4(nlo, 0.0f);
        uint32_t exponents = 0;
        for (int a = 0; a < 3; ++a) {
            float his[4] = {};
            for (size_t k = 0; k < kids.size(); ++k) his[k] = hi[k][a];
            const int e = quantization_exponent(nlo[a], his, kids.size());
            exponents |= static_cast<uint32_t>(e + 127) << (8 * a);
            const double scale = std::ldexp(1.0, e);
            for (size_t k = 0; k < kids.size(); ++k) {
                const uint32_t qlo = quantize_down(nlo[a], scale, lo[k][a]);
                const uint32_t qhi = quantize_up(nlo[a], scale, hi[k][a]);
                const uint32_t shift = 8u * static_cast<uint32_t>(k);
                node.q0[a] |= qlo << shift;
                if (a == 0)
                    node.q0[3] |= qhi << shift;
                else
                    node.q1[a - 1] |= qhi << shift;
            }
        }
        // The children's codes, the first interior child and the first leaf triangle.
        uint32_t code[4] = {gpu::BVH4_CODE_EMPTY, gpu::BVH4_CODE_EMPTY, gpu::BVH4_CODE_EMPTY, gpu::BVH4_CODE_EMPTY};
        std::vector<uint32_t> interior;
        uint32_t first_tri = 0, next_tri = 0;
        bool any_leaf = false;
        for (size_t k = 0; k < kids.size(); ++k) {
            const uint32_t c = kids[k];
            if (leaf_count(bvh, c) == 0) {
                code[k] = gpu::BVH4_CODE_INTERIOR;
                interior.push_back(c);
                continue;
            }
            if (leaf_count(bvh, c) > gpu::BVH4_MAX_LEAF)
                throw std::length_error("collapse_bvh4: a leaf of more than " + std::to_string(gpu::BVH4_MAX_LEAF) +
                                        " triangles");
            if (!any_leaf)
                first_tri = leaf_offset(bvh, c);
            else
                VKM_ASSERT(leaf_offset(bvh, c) == next_tri,
                           "collapse_bvh4: a node's leaf children do not hold consecutive triangles (build_bvh orders "
                           "them so)");
            any_leaf = true;
            next_tri = leaf_offset(bvh, c) + leaf_count(bvh, c);
            code[k] = 1u + leaf_count(bvh, c);
        }
        const uint32_t first_node = static_cast<uint32_t>(out.size());
        if (first_node + interior.size() >= kLimit)
            throw std::length_error("collapse_bvh4: too many nodes for the 4-wide encoding");
        out.resize(first_node + interior.size());
        node.origin.w = std::bit_cast<float>(exponents | code[0] << 24 | code[1] << 28);
        node.q1[2] = (interior.empty() ? 0u : first_node) | code[2] << 28;
        node.q1[3] = first_tri | code[3] << 28;
        out[index] = node;
        for (size_t j = 0; j < interior.size(); ++j)
            self(self, std::vector<uint32_t>{interior[j] + 1, leaf_offset(bvh, interior[j])},
                 first_node + static_cast<uint32_t>(j), depth + 1);
    };
    out.emplace_back();
    emit(emit, bvh4_root_kids(bvh), 0u, 1u);
    return out;
}

Bvh build_bvh(const std::vector<glm::vec3>& tri_positions, const BvhBuildOptions& options) {
    VKM_ASSERT(options.max_leaf_size != 0 && 2 * options.max_leaf_size <= gpu::BVH4_MAX_LEAF,
               "build_bvh: max_leaf_size must be 1.." + std::to_string(gpu::BVH4_MAX_LEAF / 2) +
                   " (leaves of up to twice that must fit the 4-wide encoding)");
    Builder b{tri_positions, options, {}, {}, {}, {}};
    uint32_t n = static_cast<uint32_t>(tri_positions.size() / 3);
    b.tri_box.resize(n);
    b.centroid.resize(n);
    for (uint32_t t = 0; t < n; ++t) {
        for (int k = 0; k < 3; ++k) b.tri_box[t].grow(tri_positions[3 * t + k]);
        b.centroid[t] = (b.tri_box[t].lo + b.tri_box[t].hi) * 0.5f;
    }
    b.order.resize(n);
    std::iota(b.order.begin(), b.order.end(), 0u);
    b.nodes.reserve(2 * n / std::max(1u, options.max_leaf_size) + 2);
    // flatten_scene rejects scenes without triangles (SceneError); an empty
    // tree has no valid encoding (count 0 means "interior").
    VKM_ASSERT(n != 0, "build_bvh: no triangles");
    b.build(0, n);
    Bvh bvh{std::move(b.nodes), std::move(b.order), {}};
    pair_quads(bvh, tri_positions);
    group_bvh4_leaves(bvh);
    return bvh;
}

std::string validate_bvh(const Bvh& bvh, const std::vector<glm::vec3>& pos) {
    uint32_t n = static_cast<uint32_t>(pos.size() / 3);
    if (bvh.order.size() != n)
        return "order has " + std::to_string(bvh.order.size()) + " entries for " + std::to_string(n) + " triangles";
    std::vector<uint32_t> seen_order(n, 0);
    for (uint32_t t : bvh.order) {
        if (t >= n) return "order names triangle " + std::to_string(t) + " out of range";
        if (seen_order[t]++) return "order names triangle " + std::to_string(t) + " twice";
    }
    if (n == 0) return {};
    std::vector<uint32_t> in_leaf(n, 0);
    const auto& nodes = bvh.nodes;
    auto offset = [&](uint32_t i) { return std::bit_cast<uint32_t>(nodes[i].bmin.w); };
    auto count = [&](uint32_t i) { return std::bit_cast<uint32_t>(nodes[i].bmax.w); };
    auto contains = [&](uint32_t outer, const glm::vec3& lo, const glm::vec3& hi) {
        glm::vec3 olo(nodes[outer].bmin), ohi(nodes[outer].bmax);
        return glm::all(glm::lessThanEqual(olo, lo)) && glm::all(glm::lessThanEqual(hi, ohi));
    };
    std::vector<uint32_t> stack{0};
    std::vector<uint32_t> visits(nodes.size(), 0);
    while (!stack.empty()) {
        uint32_t i = stack.back();
        stack.pop_back();
        if (i >= nodes.size()) return "child link " + std::to_string(i) + " out of range";
        if (visits[i]++) return "node " + std::to_string(i) + " reached twice";
        if (count(i) > 0) {
            if (offset(i) + count(i) > n) return "leaf " + std::to_string(i) + " range past the end";
            for (uint32_t k = offset(i); k < offset(i) + count(i); ++k) {
                if (in_leaf[k]++) return "triangle slot " + std::to_string(k) + " in two leaves";
                for (int v = 0; v < 3; ++v)
                    if (!contains(i, pos[3 * k + v], pos[3 * k + v]))
                        return "leaf " + std::to_string(i) + " does not contain its triangle " + std::to_string(k);
            }
        } else {
            uint32_t a = i + 1, b = offset(i);
            for (uint32_t c : {a, b}) {
                if (c >= nodes.size() || c <= i)
                    return "node " + std::to_string(i) + " has a bad child " + std::to_string(c);
                if (!contains(i, glm::vec3(nodes[c].bmin), glm::vec3(nodes[c].bmax)))
                    return "node " + std::to_string(i) + " does not contain child " + std::to_string(c);
                stack.push_back(c);
            }
        }
    }
    for (uint32_t k = 0; k < n; ++k)
        if (in_leaf[k] != 1) return "triangle slot " + std::to_string(k) + " is in no leaf";
    for (size_t i = 0; i < nodes.size(); ++i)
        if (!visits[i]) return "node " + std::to_string(i) + " is unreachable";
    return {};
}

BvhStats bvh_stats(const Bvh& bvh) {
    BvhStats s;
    s.nodes = static_cast<uint32_t>(bvh.nodes.size());
    if (bvh.nodes.empty()) return s;
    auto area = [&](uint32_t i) {
        glm::vec3 d = glm::max(glm::vec3(bvh.nodes[i].bmax) - glm::vec3(bvh.nodes[i].bmin), glm::vec3(0.0f));
        return 2.0 * (d.x * d.y + d.y * d.z + d.z * d.x);
    };
    double root = std::max(area(0), 1e-30);
    std::vector<std::pair<uint32_t, uint32_t>> stack{{0, 1}};
    while (!stack.empty()) {
        auto [i, depth] = stack.back();
        stack.pop_back();
        s.max_depth = std::max(s.max_depth, depth);
        uint32_t count = std::bit_cast<uint32_t>(bvh.nodes[i].bmax.w);
        if (count > 0) {
            s.leaves++;
            s.max_leaf = std::max(s.max_leaf, count);
            s.sah_cost += area(i) / root * count;
        } else {
            s.sah_cost += area(i) / root;
            stack.push_back({i + 1, depth + 1});
            stack.push_back({std::bit_cast<uint32_t>(bvh.nodes[i].bmin.w), depth + 1});
        }
    }
    return s;
}

}  // namespace vkmech
