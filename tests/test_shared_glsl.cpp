// The GLSL helpers of the shared subset (shaders/rng.glsl, frame.glsl,
// sampling.glsl's power_heuristic) compiled as C++, and the constants of
// shaders/shared/ read by C++: checked against values worked out
// independently (closed forms, a separate implementation of the hash).
#include "allocation/floor.hpp"
#include "experiments/study_context.hpp"
#include "frame.glsl"
#include "mechanism.glsl"
#include "rng.glsl"
#include "sampling.glsl"

#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

using namespace vkmech::shader;

namespace {

// Unit normals: the axes (both signs of z included), near-degenerate ones
// around -z (where s + n.z -> 0 would break a naive frame), and a
// Fibonacci sphere.
std::vector<vec3> test_normals() {
    std::vector<vec3> ns = {vec3(0, 0, 1), vec3(0, 0, -1), vec3(1, 0, 0),          vec3(-1, 0, 0),
                            vec3(0, 1, 0), vec3(0, -1, 0), vec3(1.0f, 0.0f, -0.0f)};
    for (float e : {1e-3f, 1e-5f, 1e-7f}) {
        ns.push_back(normalize(vec3(e, 0.0f, -1.0f)));
        ns.push_back(normalize(vec3(0.0f, -e, -1.0f)));
        ns.push_back(normalize(vec3(e, e, 1.0f)));
        ns.push_back(normalize(vec3(1.0f, e, -e)));
    }
    const int n = 500;
    for (int i = 0; i < n; ++i) {
        float z = 1.0f - 2.0f * (static_cast<float>(i) + 0.5f) / static_cast<float>(n);
        float r = std::sqrt(std::max(0.0f, 1.0f - z * z));
        float phi = 2.39996323f * static_cast<float>(i);
        ns.push_back(normalize(vec3(r * std::cos(phi), r * std::sin(phi), z)));
    }
    return ns;
}

// Chris Wellons' lowbias32 values, computed with an independent Python
// implementation of [16 7feb352d 15 846ca68b 16] (x ^= x >> 16; x *= ...).
struct HashCase {
    uint32_t in, out;
};
constexpr HashCase kLowbias32[] = {
    {0x00000000u, 0x00000000u}, {0x00000001u, 0x688990c0u}, {0x00000002u, 0xd1132181u},
    {0x00003039u, 0x912efcf7u}, {0xdeadbeefu, 0xe628c683u}, {0xffffffffu, 0x6768824au},
};

}  // namespace

TEST_CASE("shared glsl: power heuristic against its closed form a^2 / (a^2 + b^2)") {
    CHECK(power_heuristic(1.0f, 1.0f) == 0.5f);
    CHECK(power_heuristic(1.0f, 2.0f) == doctest::Approx(1.0 / 5.0));
    CHECK(power_heuristic(2.0f, 1.0f) == doctest::Approx(4.0 / 5.0));
    CHECK(power_heuristic(3.0f, 4.0f) == doctest::Approx(9.0 / 25.0));
    CHECK(power_heuristic(0.25f, 0.5f) == doctest::Approx(1.0 / 5.0));
    CHECK(power_heuristic(1e-3f, 1e3f) / 1e-12 == doctest::Approx(1.0).epsilon(1e-4));
    // The two strategies' weights sum to one.
    for (float a : {0.1f, 0.7f, 3.0f, 50.0f})
        for (float b : {0.2f, 1.0f, 9.0f}) CHECK(power_heuristic(a, b) + power_heuristic(b, a) == doctest::Approx(1.0));
    // A zero density: all weight to the other strategy; both zero: no weight.
    CHECK(power_heuristic(5.0f, 0.0f) == 1.0f);
    CHECK(power_heuristic(0.0f, 5.0f) == 0.0f);
    CHECK(power_heuristic(0.0f, 0.0f) == 0.0f);
}

TEST_CASE("shared glsl: Frame3 is orthonormal and right-handed for every normal") {
    for (vec3 n : test_normals()) {
        CAPTURE(n.x);
        CAPTURE(n.y);
        CAPTURE(n.z);
        Frame3 f = frame_from_normal(n);
        CHECK(length(f.t) == doctest::Approx(1.0).epsilon(1e-5));
        CHECK(length(f.b) == doctest::Approx(1.0).epsilon(1e-5));
        CHECK(std::abs(dot(f.t, f.b)) < 1e-5f);
        CHECK(std::abs(dot(f.t, f.n)) < 1e-5f);
        CHECK(std::abs(dot(f.b, f.n)) < 1e-5f);
        CHECK(f.n == n);
        vec3 c = cross(f.t, f.b);  // right-handed: t x b = n
        CHECK(length(c - n) < 1e-5f);
    }
}

TEST_CASE("shared glsl: to_local inverts to_world") {
    const vec3 vs[] = {vec3(1, 0, 0), vec3(0, 1, 0), vec3(0, 0, 1), vec3(0.3f, -0.5f, 0.8f), vec3(-2.0f, 4.0f, -1.5f)};
    for (vec3 n : test_normals()) {
        Frame3 f = frame_from_normal(n);
        CHECK(length(to_local(f, n) - vec3(0, 0, 1)) < 1e-5f);
        CHECK(length(to_world(f, vec3(0, 0, 1)) - n) < 1e-6f);
        for (vec3 v : vs) {
            CHECK(length(to_local(f, to_world(f, v)) - v) < 1e-5f * length(v));
            CHECK(length(to_world(f, to_local(f, v)) - v) < 1e-5f * length(v));
        }
    }
}

TEST_CASE("shared glsl: lowbias32 matches an independent implementation") {
    for (const HashCase& h : kLowbias32) {
        CAPTURE(h.in);
        CHECK(vkm_hash(h.in) == h.out);
    }
}

TEST_CASE("shared glsl: rng stream of seed 7 pixel 3 sample 5") {
    // key = h(7 ^ h(3 ^ h(5 + 0x9e3779b9))); value d = (h(key ^ h(d * 0x68e31da4
    // + 0x1b56c4e9)) >> 8) / 2^24, evaluated by the same Python implementation.
    Rng r = rng_init(7u, 3u, 5u);
    CHECK(r.dim == 0u);
    CHECK(rng_next(r) == 15551166.0f / 16777216.0f);
    CHECK(r.dim == 1u);
    CHECK(rng_next(r) == 15826019.0f / 16777216.0f);
    Rng r2 = rng_init(7u, 3u, 5u);
    vec2 u = rng_next2(r2);
    CHECK(u.x == 15551166.0f / 16777216.0f);
    CHECK(u.y == 15826019.0f / 16777216.0f);
    CHECK(r2.dim == 2u);
}

TEST_CASE("shared glsl: the bucket families and the no-label value") {
    using namespace vkmech::gpu;
    CHECK((LIGHT_BUCKETS & HEAVY_BUCKETS) == 0u);
    CHECK((((LIGHT_BUCKETS | HEAVY_BUCKETS) >> BUCKET_OTHER) & 1u) == 0u);
    CHECK(NO_LABEL >= BUCKET_COUNT);
    const std::vector<bool>& heavy = vkmech::heavy_buckets();
    const std::vector<bool>& light = vkmech::light_tailed_buckets();
    REQUIRE(heavy.size() == BUCKET_COUNT);
    REQUIRE(light.size() == BUCKET_COUNT);
    for (uint32_t b = 0; b < 256; ++b) {
        CAPTURE(b);
        bool expect_heavy = b == BUCKET_GLOSSY || b == BUCKET_DELTA_MEDIATED || b == BUCKET_SPECULAR_DIRECT;
        bool expect_light = b == BUCKET_EMITTER_DIRECT || b == BUCKET_DIRECT || b == BUCKET_DIFFUSE_INDIRECT;
        CHECK(bucket_is_heavy(b) == expect_heavy);
        CHECK(vkmech::alloc::is_heavy_tailed(static_cast<uint8_t>(b)) == expect_heavy);
        if (b < BUCKET_COUNT) {
            CHECK(heavy[b] == expect_heavy);
            CHECK(light[b] == expect_light);
        }
    }
}

TEST_CASE("shared glsl: luminance weights") {
    using namespace vkmech::gpu;
    CHECK(LUM_R + LUM_G + LUM_B == doctest::Approx(1.0));
    // The float weights the shaders use are the nearest floats to the decimals.
    CHECK(static_cast<float>(LUM_R) == 0.2126f);
    CHECK(static_cast<float>(LUM_G) == 0.7152f);
    CHECK(static_cast<float>(LUM_B) == 0.0722f);
}
