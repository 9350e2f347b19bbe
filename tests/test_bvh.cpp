// The software BVH is well formed: every triangle in exactly one leaf, every
// node's bounds contain its children (and its triangles).
#include "accel/bvh.hpp"

#include <doctest/doctest.h>

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
        SceneArrays a = flatten_scene(load_scene(path));
        std::vector<glm::vec3> pos(a.tri_positions.size());
        for (size_t i = 0; i < pos.size(); ++i) pos[i] = glm::vec3(a.tri_positions[i]);  // already in BVH order
        CHECK(validate_bvh(a.bvh, pos) == "");
        CHECK(bvh_stats(a.bvh).max_leaf <= 8);
    }
}

TEST_CASE("bvh: an empty triangle list is refused rather than encoded") {
    CHECK_THROWS_AS(build_bvh({}), std::invalid_argument);
}

TEST_CASE("bvh: geometrically graded triangles do not make a tree deeper than the traversal stack") {
    // Triangles whose sizes and positions shrink geometrically towards a point (a fractal, or a scene mixing
    // kilometres and millimetres): binned SAH peels a few off per level, so without a depth bound the tree is
    // as deep as there are scales, and the shaders' 64-entry traversal stack (trace_bvh.glsl) would drop
    // subtrees silently.
    for (float ratio : {0.5f, 0.9f, 0.98f, 0.99f}) {
        std::vector<glm::vec3> pos;
        float s = 1.0f;
        for (int i = 0; i < 20000 && s > 1e-30f; ++i, s *= ratio) {
            const glm::vec3 c(s, 0.3f * s, 0.0f);
            for (glm::vec3 v : {glm::vec3(0, 0, 0), glm::vec3(0.1f, 0, 0), glm::vec3(0, 0.1f, 0.05f)}) pos.push_back(c + s * v);
        }
        Bvh bvh = build_bvh(pos);
        CHECK(validate_bvh(bvh, in_bvh_order(bvh, pos)) == "");
        const BvhStats st = bvh_stats(bvh);
        INFO("ratio ", ratio, ": ", pos.size() / 3, " triangles, depth ", st.max_depth);
        CHECK(st.max_depth <= kBvhMaxDepth);
    }
}
