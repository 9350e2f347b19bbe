// Ray query and the software BVH agree on the closest hit (same primitive,
// distance within 1e-4 relative) for 100k random rays on every scene, and the
// software BVH agrees with a brute-force search in double on any device.
#include "gpu_fixture.hpp"
#include "scene_fixtures.hpp"

#include "io/invariant.hpp"
#include "render/gpu_scene.hpp"
#include "render/ray_caster.hpp"
#include "render/renderer.hpp"
#include "render/session.hpp"
#include "scene/scene.hpp"

#include <doctest/doctest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <functional>
#include <random>

using namespace vkmech;

namespace {

struct Agreement {
    uint32_t rays = 0, both_miss = 0, same = 0, edge_ties = 0, mismatches = 0;
    std::string first_mismatch;
};

// Double-precision ray/triangle distance (Möller–Trumbore), NaN when the
// ray is parallel to the plane; `margin` is min(u, v, 1 - u - v), how far
// inside the triangle (negative: outside) the point lies in barycentrics.
double cpu_plane_hit(const SceneArrays& a, size_t prim, const gpu::GpuRay& r, double& margin) {
    glm::dvec3 o(r.origin), d(r.direction);
    glm::dvec3 v0(a.tri_positions[3 * prim]), v1(a.tri_positions[3 * prim + 1]), v2(a.tri_positions[3 * prim + 2]);
    glm::dvec3 e1 = v1 - v0, e2 = v2 - v0, p = glm::cross(d, e2);
    double det = glm::dot(e1, p);
    glm::dvec3 s = o - v0, q = glm::cross(s, e1);
    double u = glm::dot(s, p) / det, v = glm::dot(d, q) / det;
    margin = std::min({u, v, 1.0 - u - v});
    return det == 0.0 ? std::nan("") : glm::dot(e2, q) / det;
}

// Float traversal may accept hits this close outside an edge (barycentrics).
constexpr double kEdgeSlack = 1e-5;

// The edge slack where triangles are tiny against the ray's coordinates (the
// deep-tree test): float rounding of the ray and the vertices, about
// FLT_EPSILON x (|origin| + |vertex| + t), over the triangle's smallest
// altitude, times a safety factor of 16. kEdgeSlack where that is smaller.
double scaled_edge_slack(const SceneArrays& a, size_t prim, const gpu::GpuRay& r, double t) {
    glm::dvec3 v0(a.tri_positions[3 * prim]), v1(a.tri_positions[3 * prim + 1]), v2(a.tri_positions[3 * prim + 2]);
    const double twice_area = glm::length(glm::cross(v1 - v0, v2 - v0));
    const double longest = std::max({glm::length(v1 - v0), glm::length(v2 - v1), glm::length(v0 - v2)});
    if (!(twice_area > 0.0)) return kEdgeSlack;
    const double altitude = twice_area / longest;
    auto max_abs = [](glm::dvec3 v) { return std::max({std::abs(v.x), std::abs(v.y), std::abs(v.z)}); };
    const double reach = max_abs(glm::dvec3(r.origin)) + max_abs(v0) + std::abs(t);
    return std::max(kEdgeSlack, 16.0 * 1.1920929e-7 * reach / altitude);
}

// The edge slack a judge allows: kEdgeSlack, or scaled_edge_slack for tiny triangles.
double edge_slack(bool scaled, const SceneArrays& a, size_t prim, const gpu::GpuRay& r, double t) {
    return scaled ? scaled_edge_slack(a, prim, r, t) : kEdgeSlack;
}

// The distance to `prim`, -1 on a miss: the independent judge of ties.
double cpu_hit(const SceneArrays& a, uint32_t prim, const gpu::GpuRay& r, bool scaled_slack = false) {
    double margin;
    double t = cpu_plane_hit(a, prim, r, margin);
    return std::isnan(t) || margin < -edge_slack(scaled_slack, a, prim, r, t) ? -1.0 : t;
}

// Every project scene, loaded and flattened with the software BVH (the ray
// query cases trace the same arrays, so hits name the same triangles).
void for_each_project_scene(const std::function<void(const std::string&, const SceneArrays&)>& fn) {
    auto paths = testing::project_scene_paths();
    REQUIRE(!paths.empty());
    for (const auto& path : paths) {
        CAPTURE(path);
        fn(path, flatten_scene(load_scene(path), Traversal::Bvh));
    }
}

Agreement compare(const SceneArrays& arrays, const std::vector<gpu::GpuRay>& rays, const std::vector<gpu::GpuHit>& a,
                  const std::vector<gpu::GpuHit>& b) {
    Agreement r;
    r.rays = static_cast<uint32_t>(a.size());
    // Distances agree within 1e-4 relative; below 1% of the scene's size the
    // float resolution of the coordinates themselves dominates, so the
    // tolerance is relative to max(t, scene size / 100).
    double extent = glm::length(arrays.bbox_hi - arrays.bbox_lo);
    auto close = [&](double x, double y) { return std::abs(x - y) <= 1e-4 * std::max({x, y, extent * 0.01}); };
    for (size_t i = 0; i < a.size(); ++i) {
        bool ha = a[i].hit.x >= 0.0f, hb = b[i].hit.x >= 0.0f;
        if (!ha && !hb) {
            r.both_miss++;
            continue;
        }
        uint32_t pa = std::bit_cast<uint32_t>(a[i].hit.w), pb = std::bit_cast<uint32_t>(b[i].hit.w);
        float ta = a[i].hit.x, tb = b[i].hit.x;
        bool t_ok = ha && hb && close(ta, tb);
        if (t_ok && pa == pb) {
            r.same++;
        } else if (t_ok && close(cpu_hit(arrays, pa, rays[i]), tb) && close(cpu_hit(arrays, pb, rays[i]), ta)) {
            // A tie: both primitives are hit at the same distance (a shared
            // edge, or coplanar overlapping faces); either is the closest hit.
            r.edge_ties++;
        } else {
            if (r.mismatches++ == 0)
                r.first_mismatch = "ray " + std::to_string(i) + ": rayquery t=" + std::to_string(ta) + " prim " +
                                   std::to_string(pa) + ", bvh t=" + std::to_string(tb) + " prim " + std::to_string(pb);
        }
    }
    return r;
}

// Two ray casters of one scene agree on 100k random rays: the same closest
// hits except verified ties (both primitives hit at the same distance, checked
// in double precision, so any number of them is correct), and the same
// any-hit answers. `a` traces with `schedule_a`, `b` with its default.
void check_casters_agree(const std::string& path, const SceneArrays& arrays, RayCaster& a, RaySchedule schedule_a,
                         RayCaster& b) {
    auto rays = random_rays(arrays, 100000, 42);
    auto hits_a = a.trace(rays, false, nullptr, schedule_a);
    auto hits_b = b.trace(rays, false);
    Agreement g = compare(arrays, rays, hits_a, hits_b);
    INFO(g.first_mismatch);
    CHECK(g.mismatches == 0);
    MESSAGE(path << ": " << g.same << " same hits, " << g.edge_ties << " verified ties, " << g.both_miss << " misses");
    CHECK(g.same + g.both_miss + g.edge_ties == g.rays);
    CHECK(g.same > g.rays / 10);  // the rays really hit the scene
    auto any_a = a.trace(rays, true, nullptr, schedule_a);
    auto any_b = b.trace(rays, true);
    uint32_t any_diff = 0;
    for (size_t i = 0; i < rays.size(); ++i) any_diff += (any_a[i].hit.x > 0.0f) != (any_b[i].hit.x > 0.0f);
    CHECK(any_diff == 0);
}

// The brute-force judge of one ray: every triangle tested in double. A hit
// is *clear* when the point lies inside the triangle by kEdgeSlack (float
// traversal must find it) and *possible* when it lies at most kEdgeSlack
// outside an edge (float traversal may report it).
struct BruteForce {
    double clear = -1.0;     // nearest clear hit, -1: none
    double possible = -1.0;  // nearest possible hit, -1: none
};

BruteForce brute_force(const SceneArrays& a, const gpu::GpuRay& r, bool scaled_slack = false) {
    BruteForce b;
    for (size_t prim = 0; prim < a.tri_positions.size() / 3; ++prim) {
        double margin;
        double t = cpu_plane_hit(a, prim, r, margin);
        if (!(t > r.origin.w && t < r.direction.w)) continue;  // also NaN
        const double slack = edge_slack(scaled_slack, a, prim, r, t);
        if (margin >= -slack && (b.possible < 0.0 || t < b.possible)) b.possible = t;
        if (margin >= slack && (b.clear < 0.0 || t < b.clear)) b.clear = t;
    }
    return b;
}

// The software BVH's closest and any hits of `rays` judged against brute
// force: bad counts the rays where a hit is missed, misreported or not the
// nearest clear one, or where any-hit disagrees.
struct Judged {
    uint32_t clear_hits = 0, bad = 0;
    std::string first_bad;
};

// caster: a RayCaster on the software-BVH GpuScene of `arrays`.
// scaled_slack: the edge slack of scaled_edge_slack (tiny triangles).
Judged judge_bvh(RayCaster& caster, const SceneArrays& arrays, const std::vector<gpu::GpuRay>& rays,
                 bool scaled_slack = false) {
    const size_t tris = arrays.tri_positions.size() / 3;
    auto closest = caster.trace(rays, false);
    auto any = caster.trace(rays, true);
    double extent = glm::length(arrays.bbox_hi - arrays.bbox_lo);
    auto tol = [&](double t) { return 1e-4 * std::max(t, extent * 0.01); };
    Judged j;
    for (size_t i = 0; i < rays.size(); ++i) {
        BruteForce b = brute_force(arrays, rays[i], scaled_slack);
        const double t = closest[i].hit.x;
        const uint32_t prim = std::bit_cast<uint32_t>(closest[i].hit.w);
        std::string why;
        if (t < 0.0) {
            if (b.clear >= 0.0) why = "missed a clear hit at t=" + std::to_string(b.clear);
        } else if (prim >= tris || std::abs(cpu_hit(arrays, prim, rays[i], scaled_slack) - t) > tol(t)) {
            why = "reported prim " + std::to_string(prim) + " at t=" + std::to_string(t) +
                  ", which it does not hit there";
        } else if (b.clear >= 0.0 && b.clear < t - tol(t)) {
            why = "reported t=" + std::to_string(t) + " past a clear hit at t=" + std::to_string(b.clear);
        }
        const bool any_hit = any[i].hit.x > 0.0f;
        if (why.empty() && b.clear >= 0.0 && !any_hit) why = "any-hit missed a clear hit";
        if (why.empty() && b.possible < 0.0 && any_hit) why = "any-hit reported a hit where there is none";
        j.clear_hits += b.clear >= 0.0;
        if (!why.empty() && j.bad++ == 0) j.first_bad = "ray " + std::to_string(i) + ": " + why;
    }
    return j;
}

}  // namespace

TEST_SUITE("gpu") {
    TEST_CASE("traversal: the BVH agrees with a brute-force search in double on every scene (any device)") {
        // The ray-query comparison above needs a device with ray query; this
        // one checks the software BVH alone wherever it runs (the NVIDIA
        // machines without ray query run exactly this path).
        VKMECH_REQUIRE_GPU(ctx);
        for_each_project_scene([&](const std::string& path, const SceneArrays& arrays) {
            const size_t tris = arrays.tri_positions.size() / 3;
            // About 5e7 ray-triangle tests a scene: 500 to 4000 rays.
            const uint32_t count =
                static_cast<uint32_t>(std::clamp<size_t>(50000000 / std::max<size_t>(tris, 1), 500, 4000));
            auto rays = random_rays(arrays, count, 7);
            GpuScene bvh(*ctx, arrays, Traversal::Bvh);
            RayCaster caster(*ctx, bvh);
            const Judged j = judge_bvh(caster, arrays, rays);
            INFO(j.first_bad);
            CHECK(j.bad == 0);
            CHECK(j.clear_hits > count / 10);  // the rays really hit the scene
            MESSAGE(path << ": " << count << " rays, " << j.clear_hits << " clear hits, all agree with brute force");
        });
        CHECK(ctx->validation_messages() == 0);
    }

    TEST_CASE("traversal: a tree deeper than the stack's registers agrees with brute force (the stack's memory part)") {
        // Triangles shrinking geometrically towards a point: the builder's deepest trees (tests/test_bvh.cpp),
        // and rays aimed into the cluster descend through them deferring siblings level after level, so the
        // traversal stack grows past its eight registers into memory (spills of one, two and three children
        // at once, refills on pop).
        VKMECH_REQUIRE_GPU(ctx);
        Scene scene = testing::quad_scene();
        Mesh& m = scene.meshes[0];
        m.kind = ShapeKind::Mesh;
        m.indices.clear();
        m.positions = testing::graded_triangles(3000, 0.995f, 0.1f);
        for (uint32_t i = 0; 3 * i < m.positions.size(); ++i) m.indices.push_back({3 * i, 3 * i + 1, 3 * i + 2});
        SceneArrays arrays = flatten_scene(scene, Traversal::Bvh);
        // Rays from around the cluster (unit distance) towards points near it, concentrated towards its small
        // end: they pass through level after level of boxes. The triangles they meet may be tiny against
        // their coordinates (down to 3e-7), so hits are judged with an edge slack scaled to float rounding.
        std::mt19937 rng(11);
        std::uniform_real_distribution<float> u(0.0f, 1.0f);
        std::vector<gpu::GpuRay> rays;
        for (int k = 0; k < 3000; ++k) {
            const glm::vec3 target = glm::vec3(u(rng), 0.3f * u(rng), 0.1f * u(rng)) * std::pow(u(rng), 4.0f);
            const glm::vec3 from = target + glm::vec3(2.0f * u(rng) - 1.0f, 2.0f * u(rng) - 1.0f, 2.0f * u(rng) - 1.0f);
            rays.push_back({glm::vec4(from, 0.0f), glm::vec4(glm::normalize(target - from), 1e30f)});
        }
        // The CPU kernel's stack (the GPU kernel's is an ordinary array, checked against brute force below).
        GpuScene g(*ctx, arrays, Traversal::Bvh, vkmech::vk::KernelClass::Cpu);
        RayCaster caster(*ctx, g);
        uint32_t deepest = 0, past_registers = 0;
        for (const auto& w : caster.trace_work(rays)) {
            deepest = std::max(deepest, w.stack);
            past_registers += w.stack > 8;
        }
        MESSAGE("deepest stack " << deepest << ", " << past_registers << " of " << rays.size()
                                 << " rays past the eight registers");
        CHECK(deepest > 16);  // twice the registers: spills of up to three at once, many levels into memory
        CHECK(past_registers >= 20);
        const Judged j = judge_bvh(caster, arrays, rays, true);
        INFO(j.first_bad);
        CHECK(j.bad == 0);
        CHECK(j.clear_hits > rays.size() / 10);
        // The GPU kernel's binary tree on the same deep cluster.
        GpuScene g2(*ctx, arrays, Traversal::Bvh, vkmech::vk::KernelClass::Gpu);
        RayCaster caster2(*ctx, g2);
        uint32_t deepest2 = 0;
        for (const auto& w : caster2.trace_work(rays)) deepest2 = std::max(deepest2, w.stack);
        MESSAGE("GPU kernel: deepest stack " << deepest2);
        CHECK(deepest2 > 16);
        const Judged j2 = judge_bvh(caster2, arrays, rays, true);
        INFO(j2.first_bad);
        CHECK(j2.bad == 0);
        CHECK(j2.clear_hits > rays.size() / 10);
        CHECK(ctx->validation_messages() == 0);
    }

    TEST_CASE("traversal: ray query and BVH agree on every scene (100k random rays)") {
        VKMECH_REQUIRE_GPU(ctx);
        if (!ctx->ray_query_enabled()) {
            MESSAGE("skipped: device has no ray query; the BVH alone is tested elsewhere");
            return;
        }
        for_each_project_scene([&](const std::string& path, const SceneArrays& arrays) {
            GpuScene rq(*ctx, arrays, Traversal::RayQuery);
            GpuScene bvh(*ctx, arrays, Traversal::Bvh);
            RayCaster crq(*ctx, rq), cbvh(*ctx, bvh);
            check_casters_agree(path, arrays, crq, RaySchedule::Auto, cbvh);
        });
        CHECK(ctx->validation_messages() == 0);
    }

    TEST_CASE("traversal: a session builds the software BVH only for the BVH traversal") {
        VKMECH_REQUIRE_GPU(ctx);
        const Scene scene = testing::quad_scene();
        RenderSession bvh(*ctx, scene, Traversal::Bvh);
        CHECK(bvh.arrays().has_bvh());
        CHECK(bvh.arrays().bvh.order.size() == 2);
        // The software BVH cannot traverse arrays that were only flattened.
        CHECK_THROWS_AS(GpuScene(*ctx, flatten_scene(scene), Traversal::Bvh), InternalError);
        if (!ctx->ray_query_enabled()) {
            MESSAGE("skipped: device has no ray query");
            return;
        }
        RenderSession rq(*ctx, scene, Traversal::RayQuery);
        CHECK_FALSE(rq.arrays().has_bvh());
        CHECK(rq.arrays().bvh.nodes.empty());
        CHECK(rq.arrays().bvh4.empty());
        // Ray query on the scene's own order finds the quad as on the BVH's.
        RayCaster caster(*ctx, rq.gpu());
        const std::vector<gpu::GpuRay> rays = {{glm::vec4(0.3f, 0.2f, 2.0f, 0.0f), glm::vec4(0, 0, -1, 1e30f)},
                                               {glm::vec4(-0.3f, -0.2f, 2.0f, 0.0f), glm::vec4(0, 0, -1, 1e30f)}};
        for (const auto& h : caster.trace(rays, false)) CHECK(h.hit.x == doctest::Approx(2.0f).epsilon(1e-6));
        CHECK(ctx->validation_messages() == 0);
    }

    TEST_CASE("traversal: the GPU kernel's tree gives the CPU kernel's hits on every scene (100k random rays)") {
        VKMECH_REQUIRE_GPU(ctx);
        // The two kernels' software traversals on one device: the 4-wide
        // quantized tree through texel buffers and the binary tree through
        // storage buffers. They test triangles with the same function, so a
        // hit may differ only where two triangles tie (verified in double).
        for_each_project_scene([&](const std::string& path, const SceneArrays& arrays) {
            GpuScene cpu(*ctx, arrays, Traversal::Bvh, vkmech::vk::KernelClass::Cpu);
            GpuScene gpu(*ctx, arrays, Traversal::Bvh, vkmech::vk::KernelClass::Gpu);
            RayCaster ccpu(*ctx, cpu), cgpu(*ctx, gpu);
            check_casters_agree(path, arrays, ccpu, RaySchedule::PerInvocation, cgpu);
        });
        CHECK(ctx->validation_messages() == 0);
    }

    TEST_CASE("traversal: the instrumented shaders count the work derived by hand and leave the image unchanged") {
        VKMECH_REQUIRE_GPU(ctx);
        // The quad is two triangles: one binary leaf, so the 4-wide root holds one leaf child.
        // A ray onto the quad fetches the root, visits that leaf and tests both triangles; a
        // ray beside it fetches the root only; a ray pointing away fetches the root only.
        // The GPU kernel's binary tree is that one leaf: its root box test counts as the one
        // node step, then the same leaf and triangles.
        SceneArrays arrays = flatten_scene(testing::quad_scene(), Traversal::Bvh);
        REQUIRE(arrays.bvh4.size() == 1);
        REQUIRE(arrays.bvh.nodes.size() == 1);
        std::vector<gpu::GpuRay> rays = {{glm::vec4(0.3f, 0.2f, 2.0f, 0.0f), glm::vec4(0, 0, -1, 1e30f)},
                                         {glm::vec4(3.0f, 0.2f, 2.0f, 0.0f), glm::vec4(0, 0, -1, 1e30f)},
                                         {glm::vec4(0.3f, 0.2f, 2.0f, 0.0f), glm::vec4(0, 0, 1, 1e30f)}};
        for (auto kernel : {vkmech::vk::KernelClass::Cpu, vkmech::vk::KernelClass::Gpu}) {
            CAPTURE(vkmech::vk::to_string(kernel));
            GpuScene g(*ctx, arrays, Traversal::Bvh, kernel);
            RayCaster caster(*ctx, g);
            auto work = caster.trace_work(rays);
            REQUIRE(work.size() == 3);
            CHECK(work[0].nodes == 1);
            CHECK(work[0].leaves == 1);
            CHECK(work[0].triangles == 2);
            CHECK(work[0].stack == 0);
            for (int i : {1, 2}) {
                CAPTURE(i);
                CHECK(work[i].nodes == 1);
                CHECK(work[i].leaves == 0);
                CHECK(work[i].triangles == 0);
            }
        }
        if (ctx->ray_query_enabled()) {
            GpuScene rq(*ctx, arrays, Traversal::RayQuery);
            RayCaster c(*ctx, rq);
            // (the same rays as above)
            CHECK_THROWS_AS(c.trace_work(rays), InternalError);
        }

        // The path tracer's variant times its phases with the shader clock.
        if (!ctx->shader_clock_enabled()) {
            MESSAGE("no VK_KHR_shader_clock on " << ctx->info().name << ": the path tracer's counters are not tested");
            CHECK(ctx->validation_messages() == 0);
            return;
        }
        // The path tracer's variant: the same samples give the same image, and the totals are
        // consistent: every path traces its camera ray, at most two traces per vertex
        // (closest hit and shadow ray), every trace fetches the root.
        const std::string path = std::string(VKMECH_SOURCE_DIR) + "/scenes/cubes_dof.xml";
        Scene scene = load_scene(path);
        scene.camera.set_film_width(24);
        RenderSession session(*ctx, scene, Traversal::Bvh);
        Features plain = session.features();
        Features counted = plain;
        counted.counters = true;
        RenderSpec spec;
        spec.spp = 4;
        Renderer ra = session.renderer(plain);
        Renderer rb = session.renderer(counted);
        Frame fa = ra.render(spec);
        Frame fb = rb.render(spec);
        REQUIRE(fa.pixels.size() == fb.pixels.size());
        size_t differ = 0;
        for (size_t i = 0; i < fa.pixels.size(); ++i) differ += fa.pixels[i].rgb_sum != fb.pixels[i].rgb_sum;
        CHECK(differ == 0);
        CHECK(ra.counters().rays == 0.0);
        const TraversalCounters c = rb.counters();
        const double paths = 4.0 * scene.camera.width * scene.camera.height;
        CHECK(c.rays >= paths);
        CHECK(c.rays <= paths * 2.0 * scene.integrator.max_depth);
        CHECK(c.nodes >= c.rays);
        CHECK(c.triangles >= c.leaves);
        CHECK(c.leaves > 0.0);
        CHECK(c.deepest_stack > 0);
        CHECK(c.deepest_stack <= gpu::BVH4_STACK_SIZE);
        // Counts add up over renders.
        rb.render(spec);
        CHECK(rb.counters().rays == 2.0 * c.rays);

        // The phases' clock ticks nest as the shader's intervals do in every invocation
        // (shared/types.h), whatever the clock's rate. A render large enough that the
        // batch's sums pass 2^32 on a CPU device (ticks at the CPU's GHz rate, times every
        // invocation) checks that the 32-bit halves carry. The intervals left out because
        // the clock went backwards (a thread moved to another core) are rare; the sums'
        // margins (NEE's shading, the wait for longer paths, accumulation) are far larger.
        scene.camera.set_film_width(256);
        RenderSession big_session(*ctx, scene, Traversal::Bvh);
        Renderer rc = big_session.renderer(counted);
        RenderSpec big;
        big.spp = 32;
        big.batch_spp = 32;
        rc.render(big);
        for (const TraversalCounters& t : {c, rc.counters()})
            for (uint32_t p = 0; p < gpu::PHASE_COUNT; ++p) {
                CAPTURE(p);
                CHECK(t.clock[p] > 0.0);
            }
        {  // on the large render only, whose margins dwarf an interval left out
            using namespace gpu;
            const auto& k = rc.counters().clock;
            CHECK(k[PHASE_SHADOW] <= k[PHASE_NEE]);
            CHECK(k[PHASE_PRIMARY] + k[PHASE_BOUNCE] + k[PHASE_NEE] <= k[PHASE_BUSY]);
            CHECK(k[PHASE_BUSY] <= k[PHASE_PATH]);
            CHECK(k[PHASE_CAMERA] + k[PHASE_PATH] <= k[PHASE_SLOT]);
        }
        MESSAGE("clock ticks, whole slots: " << rc.counters().clock[gpu::PHASE_SLOT] << " (" << ctx->info().type
                                             << ")");
        if (ctx->info().type == "cpu") CHECK(rc.counters().clock[gpu::PHASE_SLOT] > 0x1p32);
        CHECK(rc.counters().clock_backwards < 0.01 * rc.counters().rays);
        CHECK(ctx->validation_messages() == 0);
    }

    TEST_CASE("traversal: a ray's hit does not depend on the other rays of its batch, and every ray gets one") {
        // The software BVH's ray kernel hands each subgroup a slice of the rays and
        // an invocation whose ray is done the slice's next one (tracerays.comp): a ray's
        // hit must be the same bits whichever invocation traces it, at any batch size
        // (one ray, a slice and one, a partial last slice), and no ray may be skipped.
        // RaySchedule::Slices runs them on a GPU too (by default only CPU devices use
        // them), so that the GPU check tests them there. The per-invocation kernel,
        // another compilation of the same traversal, must find the same hits.
        VKMECH_REQUIRE_GPU(ctx);
        std::string path;
        for (const auto& p : testing::project_scene_paths())
            if (p.find("glass_caustic") != std::string::npos) path = p;
        REQUIRE(!path.empty());
        SceneArrays arrays = flatten_scene(load_scene(path), Traversal::Bvh);
        auto rays = random_rays(arrays, 6000, 11);
        GpuScene g(*ctx, arrays, Traversal::Bvh);
        RayCaster caster(*ctx, g);
        const RaySchedule schedule = caster.slices_supported() ? RaySchedule::Slices : RaySchedule::Auto;
        if (!caster.slices_supported())
            MESSAGE("no subgroup ballot on " << ctx->info().name << ": one ray per invocation");
        for (bool any_hit : {false, true}) {
            CAPTURE(any_hit);
            const auto all = caster.trace(rays, any_hit, nullptr, schedule);
            const auto per_invocation = caster.trace(rays, any_hit, nullptr, RaySchedule::PerInvocation);
            uint32_t prim_differ = 0;
            for (size_t i = 0; i < rays.size(); ++i) {
                CAPTURE(i);
                prim_differ +=
                    std::bit_cast<uint32_t>(all[i].hit.w) != std::bit_cast<uint32_t>(per_invocation[i].hit.w);
                CHECK(all[i].hit.x == doctest::Approx(per_invocation[i].hit.x).epsilon(1e-6));
            }
            // lavapipe compiles both alike (the same bits); a GPU compiler may contract the
            // two modules' arithmetic differently, flipping a rare tie at a shared edge.
            if (ctx->info().type == "cpu")
                CHECK(prim_differ == 0);
            else
                CHECK(prim_differ <= rays.size() / 1000);
            uint32_t hits = 0;
            for (const auto& h : all) {
                CHECK(h.hit.x != 0.0f);  // written: a hit's t is positive, a miss -1 (the buffer starts as zeros)
                hits += h.hit.x > 0.0f;
            }
            CHECK(hits > rays.size() / 10);
            const std::pair<size_t, size_t> batches[] = {{0, 1}, {4321, 1}, {5, 7}, {3, 2049}, {100, 4099}, {1, 5999}};
            for (const auto& batch : batches) {
                const size_t first = batch.first,
                             count = batch.second;  // not a structured binding: CAPTURE takes it in a lambda
                CAPTURE(first);
                CAPTURE(count);
                std::vector<gpu::GpuRay> part(rays.begin() + first, rays.begin() + first + count);
                const auto got = caster.trace(part, any_hit, nullptr, schedule);
                uint32_t differ = 0;
                for (size_t i = 0; i < count; ++i)
                    differ += std::memcmp(&got[i], &all[first + i], sizeof(gpu::GpuHit)) != 0;
                CHECK(differ == 0);
            }
        }
        if (ctx->ray_query_enabled()) {  // slices are a software-BVH kernel: asking for them on ray query is an error
            GpuScene rq(*ctx, arrays, Traversal::RayQuery);
            RayCaster rq_caster(*ctx, rq);
            CHECK_FALSE(rq_caster.slices_supported());
            CHECK_THROWS_AS(rq_caster.trace(rays, false, nullptr, RaySchedule::Slices), InternalError);
        }
        CHECK(ctx->validation_messages() == 0);
    }

    TEST_CASE("traversal: the BVH finds the analytic hit on a unit quad") {
        VKMECH_REQUIRE_GPU(ctx);
        Scene scene = testing::quad_scene();
        SceneArrays arrays = flatten_scene(scene, Traversal::Bvh);
        for (Traversal t : {Traversal::Bvh, Traversal::RayQuery}) {
            if (t == Traversal::RayQuery && !ctx->ray_query_enabled()) continue;
            CAPTURE(to_string(t));
            GpuScene g(*ctx, arrays, t);
            RayCaster caster(*ctx, g);
            std::vector<gpu::GpuRay> rays;
            // Straight down onto z = 0 from z = 2 at a grid of points; outside [-1,1]^2 misses.
            for (int i = 0; i < 21; ++i)
                for (int j = 0; j < 21; ++j) {
                    float x = -1.5f + 0.15f * i + 0.0123f, y = -1.5f + 0.15f * j + 0.0071f;
                    rays.push_back({glm::vec4(x, y, 2.0f, 0.0f), glm::vec4(0, 0, -1, 1e30f)});
                }
            auto hits = caster.trace(rays, false);
            for (size_t k = 0; k < rays.size(); ++k) {
                float x = rays[k].origin.x, y = rays[k].origin.y;
                bool inside = std::abs(x) < 1.0f && std::abs(y) < 1.0f;
                CAPTURE(x);
                CAPTURE(y);
                if (inside)
                    CHECK(hits[k].hit.x == doctest::Approx(2.0f).epsilon(1e-6));
                else
                    CHECK(hits[k].hit.x < 0.0f);
            }
        }
    }
}
