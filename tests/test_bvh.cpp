// The software BVH is well formed: every triangle in exactly one leaf, every
// node's bounds contain its children (and its triangles).
#include "accel/bvh.hpp"
#include "io/invariant.hpp"

#include <doctest/doctest.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cstring>
#include <random>

using namespace vkmech;

namespace {

std::vector<glm::vec3> in_bvh_order(const Bvh& bvh, const std::vector<glm::vec3>& pos) {
    std::vector<glm::vec3> out(pos.size());
    for (size_t i = 0; i < bvh.order.size(); ++i)
        for (int k = 0; k < 3; ++k) out[3 * i + k] = pos[3 * bvh.order[i] + k];
    return out;
}

std::vector<glm::vec3> triangle_soup(uint32_t n, uint32_t seed, float size) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> U(-10.0f, 10.0f), S(-size, size);
    std::vector<glm::vec3> pos;
    for (uint32_t t = 0; t < n; ++t) {
        glm::vec3 c(U(rng), U(rng), U(rng));
        for (int k = 0; k < 3; ++k) pos.push_back(c + glm::vec3(S(rng), S(rng), S(rng)));
    }
    return pos;
}

}  // namespace

TEST_CASE("bvh: random triangle soups build well-formed trees") {
    for (uint32_t n : {1u, 2u, 5u, 100u, 10000u}) {
        auto pos = triangle_soup(n, n, 0.5f);
        Bvh bvh = build_bvh(pos);
        CHECK(validate_bvh(bvh, in_bvh_order(bvh, pos)) == "");
        auto stats = bvh_stats(bvh);
        CHECK(stats.max_leaf <= 8);
        CHECK(stats.leaves >= n / 8);
    }
}

TEST_CASE("bvh: coincident centroids (all triangles identical) still split into leaves") {
    std::vector<glm::vec3> pos;
    for (int t = 0; t < 100; ++t) {
        pos.push_back({0, 0, 0});
        pos.push_back({1, 0, 0});
        pos.push_back({0, 1, 0});
    }
    Bvh bvh = build_bvh(pos);
    CHECK(validate_bvh(bvh, in_bvh_order(bvh, pos)) == "");
    CHECK(bvh_stats(bvh).max_leaf <= 4);
}

TEST_CASE("bvh: the validator detects a corrupted tree") {
    auto pos = triangle_soup(500, 7, 0.5f);
    Bvh bvh = build_bvh(pos);
    auto ordered = in_bvh_order(bvh, pos);
    REQUIRE(validate_bvh(bvh, ordered) == "");
    SUBCASE("a shrunken child box") {
        bvh.nodes[1].bmax.x = bvh.nodes[1].bmin.x - 1.0f;
        CHECK(validate_bvh(bvh, ordered) != "");
    }
    SUBCASE("a triangle moved out of its leaf's box") {
        ordered[0] += glm::vec3(100.0f);
        CHECK(validate_bvh(bvh, ordered) != "");
    }
    SUBCASE("a duplicated order entry") {
        bvh.order[1] = bvh.order[0];
        CHECK(validate_bvh(bvh, ordered) != "");
    }
}

#include "render/gpu_scene.hpp"
#include "scene_fixtures.hpp"

TEST_CASE("bvh: the BVH of every project scene is well formed") {
    for (const auto& path : testing::project_scene_paths()) {
        CAPTURE(path);
        SceneArrays a = flatten_scene(load_scene(path), Traversal::Bvh);
        std::vector<glm::vec3> pos(a.tri_positions.size());
        for (size_t i = 0; i < pos.size(); ++i) pos[i] = glm::vec3(a.tri_positions[i]);  // already in BVH order
        CHECK(validate_bvh(a.bvh, pos) == "");
        CHECK(bvh_stats(a.bvh).max_leaf <= 8);
        // The w components carry a quad's fourth vertex, else the first vertex again.
        for (size_t i = 0; i < a.bvh.order.size(); ++i) {
            const glm::vec3 w(a.tri_positions[3 * i].w, a.tri_positions[3 * i + 1].w, a.tri_positions[3 * i + 2].w);
            const glm::vec3 expect = a.bvh.quad_next[i] ? pos[3 * i + 5] : pos[3 * i];
            REQUIRE(std::bit_cast<glm::uvec3>(w) == std::bit_cast<glm::uvec3>(expect));
        }
    }
}

namespace {

// The leaf of the binary tree holding BVH position i: {offset, count}.
std::pair<uint32_t, uint32_t> leaf_of(const Bvh& bvh, uint32_t i) {
    for (const auto& n : bvh.nodes) {
        uint32_t count = std::bit_cast<uint32_t>(n.bmax.w), offset = std::bit_cast<uint32_t>(n.bmin.w);
        if (count > 0 && i >= offset && i < offset + count) return {offset, count};
    }
    return {0, 0};
}

bool same_bits(const glm::vec3& p, const glm::vec3& q) {
    return std::bit_cast<glm::uvec3>(p) == std::bit_cast<glm::uvec3>(q);
}

template <class T>
bool same_bytes(const std::vector<T>& a, const std::vector<T>& b) {
    return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0);
}

// The scene arrays that do not depend on the triangle order, to the bit.
bool same_unordered(const SceneArrays& a, const SceneArrays& b) {
    return same_bytes(a.vertices, b.vertices) && same_bytes(a.materials, b.materials) &&
           same_bytes(a.texels, b.texels) && same_bytes(a.textures, b.textures) && same_bits(a.bbox_lo, b.bbox_lo) &&
           same_bits(a.bbox_hi, b.bbox_hi);
}

// Every scene array and the tree, to the bit.
bool same_arrays(const SceneArrays& a, const SceneArrays& b) {
    return same_unordered(a, b) && same_bytes(a.bvh.order, b.bvh.order) && same_bytes(a.bvh4, b.bvh4) &&
           same_bytes(a.triangles, b.triangles) && same_bytes(a.triangle_mesh, b.triangle_mesh) &&
           same_bytes(a.tri_positions, b.tri_positions) && same_bytes(a.light_triangles, b.light_triangles) &&
           same_bytes(a.emitters, b.emitters) &&
           std::bit_cast<uint32_t>(a.light_weight_total) == std::bit_cast<uint32_t>(b.light_weight_total);
}

}  // namespace

TEST_CASE("bvh: flattening alone builds no BVH, the software BVH traversal's flattening builds it and reorders") {
    for (const auto& path : testing::project_scene_paths()) {
        CAPTURE(path);
        const Scene scene = load_scene(path);
        // Flattening alone, and for ray query: the scene's own triangle order, mesh by mesh, no tree.
        const SceneArrays own = flatten_scene(scene);
        CHECK_FALSE(own.has_bvh());
        CHECK(own.bvh.nodes.empty());
        CHECK(own.bvh.order.empty());
        CHECK(std::is_sorted(own.triangle_mesh.begin(), own.triangle_mesh.end()));
        CHECK(same_arrays(flatten_scene(scene, Traversal::RayQuery), own));

        // The software BVH: the tree, and the same triangles in its order.
        const SceneArrays bvh = flatten_scene(scene, Traversal::Bvh);
        REQUIRE(bvh.has_bvh());
        REQUIRE(bvh.bvh.order.size() == own.triangles.size());
        CHECK(same_unordered(bvh, own));
        size_t moved = 0;
        for (size_t i = 0; i < bvh.bvh.order.size(); ++i) {
            const uint32_t src = bvh.bvh.order[i];
            moved += src != i;
            REQUIRE(bvh.triangles[i] == own.triangles[src]);
            REQUIRE(bvh.triangle_mesh[i] == own.triangle_mesh[src]);
            for (int k = 0; k < 3; ++k)
                REQUIRE(same_bits(glm::vec3(bvh.tri_positions[3 * i + k]), glm::vec3(own.tri_positions[3 * src + k])));
        }
        // The light table lists the same emissive triangles (in the arrays' order) with the same areas.
        REQUIRE(bvh.light_triangles.size() == own.light_triangles.size());
        std::vector<std::pair<uint32_t, float>> lights_bvh, lights_own;
        for (const auto& lt : bvh.light_triangles) lights_bvh.emplace_back(bvh.bvh.order[lt.info.x], lt.cdf.y);
        for (const auto& lt : own.light_triangles) lights_own.emplace_back(lt.info.x, lt.cdf.y);
        std::sort(lights_bvh.begin(), lights_bvh.end());
        std::sort(lights_own.begin(), lights_own.end());
        CHECK(lights_bvh == lights_own);
        REQUIRE(bvh.emitters.size() == own.emitters.size());
        for (size_t e = 0; e < own.emitters.size(); ++e) {
            CHECK(bvh.emitters[e].radiance.w == doctest::Approx(own.emitters[e].radiance.w).epsilon(1e-5));
            CHECK(bvh.emitters[e].info.x == own.emitters[e].info.x);
            CHECK(bvh.emitters[e].info.z == own.emitters[e].info.z);
        }
        CHECK(bvh.light_weight_total == doctest::Approx(own.light_weight_total).epsilon(1e-5));
        if (own.triangles.size() > 100) CHECK(moved > 0);

        // build_scene_bvh on flattened arrays is the software BVH's flattening, to the bit.
        SceneArrays later = own;
        build_scene_bvh(later, scene.source);
        CHECK(same_arrays(later, bvh));
    }
}

TEST_CASE("bvh: the two triangles of a quad end up next to each other in their leaf") {
    // A 24 x 24 height field of quads, each split as (a, b, c), (a, c, d), the
    // triangles shuffled; and as many quads split the other way round,
    // (a, b, c) and (a, d, c), which are not the pattern and stay single.
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> H(-0.3f, 0.3f);
    const int n = 24;
    std::vector<glm::vec3> grid((n + 1) * (n + 1));
    for (int y = 0; y <= n; ++y)
        for (int x = 0; x <= n; ++x) grid[y * (n + 1) + x] = glm::vec3(float(x), float(y), H(rng));
    std::vector<std::array<glm::vec3, 3>> tris;
    for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
            glm::vec3 a = grid[y * (n + 1) + x], b = grid[y * (n + 1) + x + 1];
            glm::vec3 c = grid[(y + 1) * (n + 1) + x + 1], d = grid[(y + 1) * (n + 1) + x];
            tris.push_back({a, b, c});
            if ((x + y) % 2 == 0)
                tris.push_back({a, c, d});
            else
                tris.push_back({a, d, c});  // winding flipped: not (a, c, d)
        }
    std::shuffle(tris.begin(), tris.end(), rng);
    std::vector<glm::vec3> pos;
    for (const auto& t : tris) pos.insert(pos.end(), t.begin(), t.end());

    Bvh bvh = build_bvh(pos);
    auto ordered = in_bvh_order(bvh, pos);
    REQUIRE(validate_bvh(bvh, ordered) == "");
    REQUIRE(bvh.quad_next.size() == bvh.order.size());
    size_t pairs = 0;
    for (uint32_t i = 0; i < bvh.order.size(); ++i) {
        if (!bvh.quad_next[i]) continue;
        CAPTURE(i);
        ++pairs;
        auto [offset, count] = leaf_of(bvh, i);
        REQUIRE(i + 1 < offset + count);  // the partner is in the same leaf
        CHECK(!bvh.quad_next[i + 1]);
        CHECK(same_bits(ordered[3 * i + 3], ordered[3 * i]));      // shares a
        CHECK(same_bits(ordered[3 * i + 4], ordered[3 * i + 2]));  // and c
        CHECK(!same_bits(ordered[3 * i + 5], ordered[3 * i]));     // d is not a
    }
    // Half the quads have the pattern; the builder keeps most of them in one leaf.
    MESSAGE("quads paired: " << pairs << " of " << n * n / 2);
    CHECK(pairs >= n * n / 2 * 6 / 10);
    CHECK(pairs <= n * n / 2);
}

TEST_CASE("bvh: an empty triangle list is refused rather than encoded") {
    // flatten_scene refuses a scene without triangles first: reaching build_bvh with none is a bug.
    CHECK_THROWS_AS(build_bvh({}), InternalError);
}

TEST_CASE("bvh: geometrically graded triangles do not make a tree deeper than the traversal stack") {
    // Triangles whose sizes and positions shrink geometrically towards a point (a fractal, or a scene mixing
    // kilometres and millimetres): binned SAH peels a few off per level, so without a depth bound the tree is
    // as deep as there are scales, and the traversal stack (then 64 entries; BVH4_STACK_SIZE since) would drop
    // subtrees silently.
    for (float ratio : {0.5f, 0.9f, 0.98f, 0.99f}) {
        const std::vector<glm::vec3> pos = testing::graded_triangles(20000, ratio);
        Bvh bvh = build_bvh(pos);
        CHECK(validate_bvh(bvh, in_bvh_order(bvh, pos)) == "");
        const BvhStats st = bvh_stats(bvh);
        INFO("ratio ", ratio, ": ", pos.size() / 3, " triangles, depth ", st.max_depth);
        CHECK(st.max_depth <= kBvhMaxDepth);
    }
}

namespace {

// Walks a 4-wide tree (gpu::GpuBvh4Node) from the root and returns "" when
// every triangle 0..n-1 is in exactly one leaf, every child box (as the
// traversal decodes it) contains every triangle below it, every interior reference is in range and no node
// is reached twice; otherwise the first fault. depth_out: the deepest chain
// of interior nodes (the root is 1).
// worst_steps: the largest gap between a decoded child box and the exact box
// of its triangles, in quantization steps of that axis (2^(e - 127)).
std::string check_bvh4(const std::vector<gpu::GpuBvh4Node>& nodes, const std::vector<glm::vec3>& pos_bvh_order,
                       uint32_t* depth_out = nullptr, double* worst_steps = nullptr) {
    double worst = 0.0;
    const size_t n = pos_bvh_order.size() / 3;
    std::vector<int> seen(n, 0);
    std::vector<int> visited(nodes.size(), 0);
    uint32_t deepest = 0;
    std::string fault;
    // Returns the box of everything below node `i`, checking each child box contains its part.
    auto walk = [&](auto& self, uint32_t i, uint32_t depth, glm::vec3& lo, glm::vec3& hi) -> void {
        if (!fault.empty()) return;
        if (i >= nodes.size()) {
            fault = "interior reference out of range";
            return;
        }
        if (visited[i]++) {
            fault = "node reached twice";
            return;
        }
        deepest = std::max(deepest, depth);
        const auto& nd = nodes[i];
        for (int k = 0; k < 4; ++k) {
            const uint32_t c = bvh4_child(nd, k);
            if (c == gpu::BVH4_EMPTY) continue;
            glm::vec3 clo(std::numeric_limits<float>::max()), chi(-std::numeric_limits<float>::max());
            const uint32_t count = c >> gpu::BVH4_COUNT_SHIFT, index = c & gpu::BVH4_INDEX_MASK;
            if (count == 0) {
                self(self, index, depth + 1, clo, chi);
            } else {
                for (uint32_t t = index; t < index + count; ++t) {
                    if (t >= n) {
                        fault = "leaf triangle out of range";
                        return;
                    }
                    seen[t] += 1;
                    for (int v = 0; v < 3; ++v) {
                        clo = glm::min(clo, pos_bvh_order[3 * t + v]);
                        chi = glm::max(chi, pos_bvh_order[3 * t + v]);
                    }
                }
            }
            glm::vec3 blo, bhi;
            decode_bvh4_box(nd, k, blo, bhi);
            if (glm::any(glm::lessThan(clo, blo)) || glm::any(glm::greaterThan(chi, bhi))) {
                if (fault.empty()) fault = "a child box does not contain its triangles";
                return;
            }
            for (int a = 0; a < 3; ++a) {
                const uint32_t e = (std::bit_cast<uint32_t>(nd.origin.w) >> (8 * a)) & 0xFFu;
                const double step = std::ldexp(1.0, static_cast<int>(e) - 127);
                worst = std::max(worst, (static_cast<double>(clo[a]) - blo[a]) / step);
                worst = std::max(worst, (static_cast<double>(bhi[a]) - chi[a]) / step);
            }
            lo = glm::min(lo, clo);
            hi = glm::max(hi, chi);
        }
    };
    if (nodes.empty()) return "no nodes";
    glm::vec3 lo(std::numeric_limits<float>::max()), hi(-std::numeric_limits<float>::max());
    walk(walk, 0, 1, lo, hi);
    if (!fault.empty()) return fault;
    for (size_t t = 0; t < n; ++t)
        if (seen[t] != 1) return "triangle " + std::to_string(t) + " is in " + std::to_string(seen[t]) + " leaves";
    if (depth_out) *depth_out = deepest;
    if (worst_steps) *worst_steps = worst;
    return "";
}

}  // namespace

TEST_CASE("bvh: the 4-wide tree holds every triangle once inside every box above it") {
    for (uint32_t n : {1u, 2u, 4u, 5u, 100u, 10000u}) {
        CAPTURE(n);
        auto pos = triangle_soup(n, n + 11, 0.5f);
        Bvh bvh = build_bvh(pos);
        auto nodes = collapse_bvh4(bvh);
        uint32_t depth = 0;
        CHECK(check_bvh4(nodes, in_bvh_order(bvh, pos), &depth) == "");
        // Opening interior children two levels at a time roughly halves the depth.
        CHECK(2 * depth <= bvh_stats(bvh).max_depth + 2);
        if (n <= BvhBuildOptions{}.max_leaf_size) CHECK(bvh.nodes.size() == 1);
        if (bvh.nodes.size() == 1) {  // the binary tree is one leaf: a root with one child
            CHECK(nodes.size() == 1);
            CHECK(bvh4_child(nodes[0], 0) == (0u | (n << gpu::BVH4_COUNT_SHIFT)));
            CHECK(bvh4_child(nodes[0], 1) == gpu::BVH4_EMPTY);
        } else {
            // A node has an empty slot only when it had no interior child left to open.
            size_t short_with_interior = 0;
            for (const auto& nd : nodes) {
                if (bvh4_child(nd, 3) != gpu::BVH4_EMPTY) continue;
                for (int k = 0; k < 4; ++k)
                    short_with_interior +=
                        bvh4_child(nd, k) != gpu::BVH4_EMPTY && (bvh4_child(nd, k) >> gpu::BVH4_COUNT_SHIFT) == 0;
            }
            CHECK(short_with_interior == 0);
        }
    }
}

TEST_CASE("bvh: the 4-wide checker detects a corrupted tree") {
    auto pos = triangle_soup(500, 3, 0.5f);
    Bvh bvh = build_bvh(pos);
    auto nodes = collapse_bvh4(bvh);
    auto ordered = in_bvh_order(bvh, pos);
    REQUIRE(check_bvh4(nodes, ordered) == "");
    SUBCASE("a shrunken child box") {
        nodes[0].q0[3] &= ~0xFF00u;  // child 1's hi_x decodes to the node's lower corner
        CHECK(check_bvh4(nodes, ordered) != "");
    }
    SUBCASE("a dropped child") {
        nodes[0].q1[2] &= gpu::BVH4_INDEX_MASK;  // child 2's code: empty
        CHECK(check_bvh4(nodes, ordered) != "");
    }
    SUBCASE("a leaf child one triangle short") {
        // The first node with a leaf child of two or more triangles.
        size_t i = nodes.size();
        int k = 0;
        for (size_t n = 0; n < nodes.size() && i == nodes.size(); ++n)
            for (int j = 0; j < 4; ++j)
                if ((bvh4_child(nodes[n], j) >> gpu::BVH4_COUNT_SHIFT) >= 2) {
                    i = n;
                    k = j;
                    break;
                }
        REQUIRE(i < nodes.size());
        auto& nd = nodes[i];
        if (k < 2) {  // its code is in origin.w's bits 24..27 or 28..31
            const uint32_t w = std::bit_cast<uint32_t>(nd.origin.w) - (1u << (24u + 4u * static_cast<uint32_t>(k)));
            nd.origin.w = std::bit_cast<float>(w);
        } else {  // in q1.z's or q1.w's bits 28..31
            nd.q1[k] -= 1u << 28;
        }
        CHECK(check_bvh4(nodes, ordered) != "");
    }
}

TEST_CASE("bvh: the 4-wide tree of every project scene and of a graded deep tree is well formed") {
    for (const auto& path : testing::project_scene_paths()) {
        CAPTURE(path);
        SceneArrays a = flatten_scene(load_scene(path), Traversal::Bvh);
        std::vector<glm::vec3> pos(a.tri_positions.size());
        for (size_t i = 0; i < pos.size(); ++i) pos[i] = glm::vec3(a.tri_positions[i]);
        CHECK(check_bvh4(a.bvh4, pos) == "");
    }
    // The deepest binary trees the builder makes (kBvhMaxDepth) still fit the traversal stack.
    const std::vector<glm::vec3> pos = testing::graded_triangles(20000, 0.99f);
    Bvh bvh = build_bvh(pos);
    uint32_t depth = 0;
    auto nodes = collapse_bvh4(bvh);
    CHECK(check_bvh4(nodes, in_bvh_order(bvh, pos), &depth) == "");
    INFO("binary depth ", bvh_stats(bvh).max_depth, ", 4-wide depth ", depth);
    CHECK(3 * depth <= gpu::BVH4_STACK_SIZE);
}

TEST_CASE("bvh: a leaf too large for the 4-wide encoding is refused") {
    Bvh bvh;
    gpu::GpuBvhNode leaf;
    leaf.bmin = glm::vec4(0.0f, 0.0f, 0.0f, std::bit_cast<float>(0u));
    leaf.bmax = glm::vec4(1.0f, 1.0f, 1.0f, std::bit_cast<float>(gpu::BVH4_MAX_LEAF + 1));
    bvh.nodes.push_back(leaf);
    bvh.order.resize(gpu::BVH4_MAX_LEAF + 1);
    CHECK_THROWS_AS(collapse_bvh4(bvh), std::length_error);
    bvh.nodes[0].bmax.w = std::bit_cast<float>(gpu::BVH4_MAX_LEAF);
    bvh.order.resize(gpu::BVH4_MAX_LEAF);
    const auto nodes = collapse_bvh4(bvh);
    REQUIRE(nodes.size() == 1);
    CHECK(bvh4_child(nodes[0], 0) == (gpu::BVH4_MAX_LEAF << gpu::BVH4_COUNT_SHIFT));
}

TEST_CASE("bvh: a leaf size the 4-wide encoding cannot hold is refused at build time") {
    auto pos = triangle_soup(50, 5, 0.5f);
    CHECK_THROWS_AS(build_bvh(pos, BvhBuildOptions{.max_leaf_size = 0}), InternalError);
    CHECK_THROWS_AS(build_bvh(pos, BvhBuildOptions{.max_leaf_size = gpu::BVH4_MAX_LEAF / 2 + 1}), InternalError);
    Bvh bvh = build_bvh(pos, BvhBuildOptions{.max_leaf_size = gpu::BVH4_MAX_LEAF / 2});
    CHECK(check_bvh4(collapse_bvh4(bvh), in_bvh_order(bvh, pos)) == "");
}

TEST_CASE("bvh: the 4-wide encoding's consecutive children") {
    // A node refers to its first interior child and its first leaf triangle only, so
    // build_bvh orders the triangles such that each node's leaf children follow each
    // other, and collapse_bvh4 places each node's interior children side by side.
    auto pos = triangle_soup(3000, 17, 0.5f);
    Bvh bvh = build_bvh(pos);
    CHECK(validate_bvh(bvh, in_bvh_order(bvh, pos)) == "");
    const auto nodes = collapse_bvh4(bvh);
    REQUIRE(check_bvh4(nodes, in_bvh_order(bvh, pos)) == "");
    size_t mixed = 0;
    for (const auto& nd : nodes) {
        uint32_t next_node = 0, next_tri = 0, interior = 0, leaves = 0;
        for (int k = 0; k < 4; ++k) {
            const uint32_t c = bvh4_child(nd, k);
            if (c == gpu::BVH4_EMPTY) continue;
            const uint32_t count = c >> gpu::BVH4_COUNT_SHIFT, index = c & gpu::BVH4_INDEX_MASK;
            if (count == 0) {
                if (interior++) CHECK(index == next_node);
                next_node = index + 1;
            } else {
                if (leaves++) CHECK(index == next_tri);
                next_tri = index + count;
            }
        }
        mixed += interior > 0 && leaves > 0;
    }
    CHECK(mixed > 0);  // nodes with both kinds of children exist, so the codes' prefix sums are exercised
    // A hand-made tree whose two leaves are in the wrong order for the encoding is refused.
    Bvh bad;
    auto node = [](float lo, float hi, uint32_t offset, uint32_t count) {
        gpu::GpuBvhNode n;
        n.bmin = glm::vec4(lo, 0.0f, 0.0f, std::bit_cast<float>(offset));
        n.bmax = glm::vec4(hi, 1.0f, 1.0f, std::bit_cast<float>(count));
        return n;
    };
    bad.nodes = {node(0.0f, 2.0f, 2u, 0u), node(0.0f, 1.0f, 2u, 1u), node(1.0f, 2.0f, 0u, 2u)};
    bad.order = {0u, 1u, 2u};
    CHECK_THROWS_AS(collapse_bvh4(bad), InternalError);
    bad.nodes[1].bmin.w = std::bit_cast<float>(0u);
    bad.nodes[2].bmin.w = std::bit_cast<float>(1u);
    CHECK_NOTHROW(collapse_bvh4(bad));
}

TEST_CASE("bvh: quantized child boxes contain their children within one step at every scale") {
    // The same soup scaled from 1e-30 to 1e37 and moved away from the origin: every decoded
    // box contains its triangles (check_bvh4) and lies within one quantization step of
    // their exact box on every side (the encoder rounds each bound outwards to the nearest
    // step; float rounding of origin + q * step can add an ulp).
    for (float scale : {1e-30f, 1e-6f, 1.0f, 1e6f, 1e30f, 1e37f}) {
        for (float offset : {0.0f, 9.0f, -3e7f}) {
            CAPTURE(scale);
            CAPTURE(offset);
            auto pos = triangle_soup(2000, 5, 0.3f);
            bool finite = true;
            for (auto& p : pos) {
                p = p * scale + glm::vec3(offset * scale, -offset * scale, offset);
                finite = finite && glm::all(glm::lessThan(glm::abs(p), glm::vec3(std::numeric_limits<float>::max())));
            }
            if (!finite) continue;  // -3e7 x 1e37 overflows float; 9 x 1e37 + 10.3 x 1e37 does not
            Bvh bvh = build_bvh(pos);
            double worst = 0.0;
            CHECK(check_bvh4(collapse_bvh4(bvh), in_bvh_order(bvh, pos), nullptr, &worst) == "");
            CHECK(worst < 1.01);
        }
    }
}

TEST_CASE("bvh: a child bound far below the node's extent rounds outwards too (review case)") {
    // The node's extent on x, 1e-15 - (-255), rounds in double to exactly 255: a code chosen
    // from that rounded extent decoded to 0 < 1e-15. Found in review of the quantizer.
    std::vector<glm::vec3> pos = {{-255.0f, 0.0f, 0.0f}, {1e-15f, 0.0f, 0.0f}, {0.0f, 1.0f, 1.0f},
                                  {-255.0f, 0.0f, 0.0f}, {1e-15f, 0.0f, 0.0f}, {0.0f, 2.0f, 1.0f}};
    for (int copies = 0; copies < 3; ++copies) pos.insert(pos.end(), pos.begin(), pos.begin() + 6);
    Bvh bvh = build_bvh(pos);
    CHECK(check_bvh4(collapse_bvh4(bvh), in_bvh_order(bvh, pos)) == "");
    // And on random nodes whose corners sit at exact multiples of the step: every decoded
    // box contains its child under rounding to nearest (check_bvh4) ...
    std::mt19937 rng(3);
    std::uniform_int_distribution<int> ex(-20, 100);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    for (int trial = 0; trial < 200; ++trial) {
        const float step = std::ldexp(1.0f, ex(rng));
        std::vector<glm::vec3> p;
        for (int t = 0; t < 6; ++t) {
            const glm::vec3 c(-255.0f * step * u(rng), step * u(rng) * 1e-6f, -step * 7.0f * u(rng));
            for (int v = 0; v < 3; ++v) p.push_back(c + glm::vec3(u(rng), u(rng), u(rng)) * (step * 1e-7f));
        }
        Bvh b = build_bvh(p);
        CAPTURE(trial);
        CHECK(check_bvh4(collapse_bvh4(b), in_bvh_order(b, p)) == "");
    }
}
