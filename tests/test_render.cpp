// The docs/descriptor.md §1-§3 estimator and descriptor on the device (lavapipe in CI).
#include "gpu_fixture.hpp"
#include "io/invariant.hpp"
#include "render/session.hpp"
#include "render/shader_modules.hpp"
#include "render_fixture.hpp"
#include "scene_fixtures.hpp"
#include "scoped_env.hpp"

#include "mechanism.glsl"

#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <functional>
#include <glm/gtc/matrix_inverse.hpp>
#include <numeric>
#include <set>

using namespace vkmech;
using testing::RenderSetup;

namespace {

std::string test_scene(const std::string& name) { return std::string(VKMECH_TEST_DATA) + "/render/" + name + ".xml"; }
std::string project_scene(const std::string& name) {
    return std::string(VKMECH_SOURCE_DIR) + "/scenes/" + name + ".xml";
}

struct ImageStats {
    double mean_lum = 0.0;   // mean over pixels of the per-pixel mean luminance
    double std_error = 0.0;  // its standard error from the per-pixel sample variances
};

ImageStats image_stats(const Frame& f) {
    ImageStats s;
    double var_sum = 0.0;
    for (const auto& p : f.pixels) {
        s.mean_lum += p.lum_mean;
        var_sum += p.lum_var() / std::max(1.0, p.count);
    }
    double n = static_cast<double>(f.pixels.size());
    s.mean_lum /= n;
    s.std_error = std::sqrt(var_sum) / n;
    return s;
}

}  // namespace

TEST_CASE("render: the workgroup order is a permutation that spreads every thread's range over the image") {
    CHECK_THROWS_AS(workgroup_stride(0), InternalError);
    CHECK_THROWS_AS(workgroup_stride((uint64_t{1} << 24) + 1), InternalError);
    for (uint64_t n : {uint64_t{1}, uint64_t{2}, uint64_t{3}, uint64_t{15}, uint64_t{25}, uint64_t{1024},
                       uint64_t{4096}, uint64_t{65535} * 3, (uint64_t{1} << 24) - 1, uint64_t{1} << 24}) {
        uint64_t s = workgroup_stride(n);
        CHECK(s < std::max<uint64_t>(n, 1));
        CHECK(std::gcd(s, n) == 1);
    }
    // A 32 x 32 tile film split into contiguous index ranges as lavapipe
    // splits a dispatch among 2, 4 or 8 threads: every range gets between 40
    // and 60% of its tiles in the top half and in the left half (the plain
    // row-major order would give one thread the whole top half).
    const uint64_t gx = 32, n = gx * gx, s = workgroup_stride(n);
    std::vector<int> seen(n, 0);
    for (uint64_t w = 0; w < n; ++w) seen[(w * s) % n] += 1;
    CHECK(std::all_of(seen.begin(), seen.end(), [](int c) { return c == 1; }));
    for (uint64_t threads : {2, 4, 8}) {
        const uint64_t chunk = n / threads;
        for (uint64_t t = 0; t < threads; ++t) {
            int top = 0, left = 0;
            for (uint64_t w = t * chunk; w < (t + 1) * chunk; ++w) {
                uint64_t tile = (w * s) % n;
                top += tile / gx < gx / 2;
                left += tile % gx < gx / 2;
            }
            CAPTURE(threads);
            CAPTURE(t);
            CHECK(top >= 0.4 * chunk);
            CHECK(top <= 0.6 * chunk);
            CHECK(left >= 0.4 * chunk);
            CHECK(left <= 0.6 * chunk);
        }
    }
}

TEST_SUITE("gpu") {
    TEST_CASE(
        "render: bucket energies sum to the pixel luminance, their RGB to the pixel's RGB, and `other` gets nothing - "
        "on every scene") {
        VKMECH_REQUIRE_GPU(ctx);
        for (const auto& path : testing::project_scene_paths()) {
            CAPTURE(path);
            RenderSetup setup;
            setup.res = 24;
            setup.spp = 4;
            Frame f = testing::render_scene(*ctx, path, setup);
            Descriptor d = derive_descriptor(f);
            DescriptorSummary s = summarize(f, d);
            CHECK(s.other_energy == 0.0);
            CHECK(s.nonfinite_samples == 0);
            CHECK(s.labelled_pixels > 0);
            for (size_t i = 0; i < f.pixels.size(); ++i) {
                double lum = f.pixels[i].lum_mean;
                double sum = d.total_energy[i];
                if (std::abs(sum - lum) > 1e-4 * std::max(lum, 1e-6)) {
                    CAPTURE(i);
                    CHECK(sum == doctest::Approx(lum).epsilon(1e-4));
                    break;
                }
            }
            // The seven buckets' RGB add up to the image's R, G, B: over the image within 1e-5
            // relative (float sums of the same non-negative contributions in two orders), and
            // every pixel within 1e-4.
            REQUIRE(f.bucket_rgb_sum.size() == f.pixels.size() * Frame::kBucketRgb);
            for (int c = 0; c < 3; ++c) {
                CAPTURE(c);
                double image = 0.0, deviation = 0.0, channels_used = 0.0;
                size_t bad_pixels = 0;
                for (size_t i = 0; i < f.pixels.size(); ++i) {
                    double sum = 0.0;
                    for (uint32_t b = 0; b < kBucketCount; ++b) {
                        const double v = f.bucket_rgb_sum[i * Frame::kBucketRgb + 3 * b + c];
                        CHECK(v >= 0.0);
                        sum += v;
                        channels_used += v > 0.0;
                    }
                    const double rgb = f.pixels[i].rgb_sum[c];
                    image += rgb;
                    deviation += std::abs(sum - rgb);
                    bad_pixels += std::abs(sum - rgb) > 1e-4 * std::max(rgb, 1e-6);
                }
                CHECK(image > 0.0);
                CHECK(deviation <= 1e-5 * image);
                CHECK(bad_pixels == 0);
                CHECK(channels_used > 0.0);
            }
        }
    }

    TEST_CASE("render: integrator furnace (albedo 0.5 - Le 0.5 inside a closed sphere) gives 1 - 0.5^12") {
        VKMECH_REQUIRE_GPU(ctx);
        RenderSetup setup;
        setup.res = 16;
        setup.spp = 256;
        setup.batch = 64;
        Frame f = testing::render_scene(*ctx, test_scene("furnace"), setup);
        ImageStats s = image_stats(f);
        double expected = 1.0 - std::pow(0.5, 12);
        CAPTURE(s.mean_lum);
        CAPTURE(s.std_error);
        CHECK(std::abs(s.mean_lum - expected) < 4.0 * s.std_error + 1e-4);
        // Event labels: the primary hit is emitter_direct (half the energy),
        // NEE at V1 is direct, deeper NEE is diffuse_indirect.
        Descriptor d = derive_descriptor(f);
        double e[kBucketCount] = {};
        for (const auto& b : d.bucket_energy)
            for (uint32_t k = 0; k < kBucketCount; ++k) e[k] += b[k] / d.bucket_energy.size();
        CHECK(e[gpu::BUCKET_EMITTER_DIRECT] == doctest::Approx(0.5).epsilon(1e-4));
        CHECK(e[gpu::BUCKET_DIRECT] == doctest::Approx(0.25).epsilon(0.02));
        CHECK(e[gpu::BUCKET_DIFFUSE_INDIRECT] == doctest::Approx(0.25 - std::pow(0.5, 12)).epsilon(0.04));
        CHECK(e[gpu::BUCKET_GLOSSY] + e[gpu::BUCKET_DELTA_MEDIATED] + e[gpu::BUCKET_SPECULAR_DIRECT] +
                  e[gpu::BUCKET_OTHER] ==
              0.0);
    }

    TEST_CASE("render: the same seed gives bit-identical frames - batching changes only float rounding") {
        VKMECH_REQUIRE_GPU(ctx);
        RenderSetup setup;
        setup.res = 24;
        setup.spp = 64;
        setup.batch = 64;
        std::string path = project_scene("glass_caustic");
        Frame a = testing::render_scene(*ctx, path, setup);
        Frame b = testing::render_scene(*ctx, path, setup);
        setup.batch = 32;
        Frame c = testing::render_scene(*ctx, path, setup);
        bool identical = true;
        double worst = 0.0;
        for (size_t i = 0; i < a.pixels.size(); ++i) {
            const auto &pa = a.pixels[i], &pb = b.pixels[i], &pc = c.pixels[i];
            identical = identical && std::memcmp(&pa, &pb, sizeof(PixelStats)) == 0;
            for (int k = 0; k < 3; ++k)
                worst =
                    std::max(worst, std::abs(pa.rgb_sum[k] - pc.rgb_sum[k]) / std::max(1e-6, std::abs(pa.rgb_sum[k])));
            CHECK(pa.count == pc.count);
        }
        CHECK(identical);
        CHECK(worst < 1e-5);  // 64 in one batch == 2 x 32, to float rounding
        setup.seed = 1;
        Frame d = testing::render_scene(*ctx, path, setup);
        CHECK(std::memcmp(&a.pixels[0], &d.pixels[0], sizeof(PixelStats) * a.pixels.size()) != 0);
    }

    TEST_CASE(
        "render: a 137x137 film takes every pixel once - tiles and claimed pixels and the adaptive pixel list agree "
        "bit for bit") {
        VKMECH_REQUIRE_GPU(ctx);
        RenderSetup setup;
        // 18 x 18 tiles of 8 x 8, the last row and column partly outside; more
        // tiles than the 256 workgroups a claimed dispatch starts, so
        // invocations claim several slots each.
        setup.res = 137;
        // Two batches of one sample: a pixel that a batch skipped would keep
        // the previous batch's moments in the reused buffer and count its
        // first sample twice, so it would differ from the tiled frame.
        setup.spp = 2;
        setup.batch = 1;
        setup.pixel_order = PixelOrder::Tiles;
        std::string path = project_scene("glass_caustic");
        Frame a = testing::render_scene(*ctx, path, setup);
        REQUIRE(a.pixels.size() == 137u * 137u);
        std::vector<Frame> others;
        setup.pixel_order = PixelOrder::Claimed;
        others.push_back(testing::render_scene(*ctx, path, setup));
        setup.sample_counts.assign(a.pixels.size(), setup.spp);  // the 1D adaptive mapping, every pixel
        others.push_back(testing::render_scene(*ctx, path, setup));
        setup.pixel_order = PixelOrder::Tiles;
        others.push_back(testing::render_scene(*ctx, path, setup));
        for (size_t k = 0; k < others.size(); ++k) {
            CAPTURE(k);
            const Frame& b = others[k];
            REQUIRE(b.pixels.size() == a.pixels.size());
            size_t wrong_count = 0, differ = 0;
            for (size_t i = 0; i < a.pixels.size(); ++i) {
                wrong_count += a.pixels[i].count != setup.spp || b.pixels[i].count != setup.spp;
                differ += std::memcmp(&a.pixels[i], &b.pixels[i], sizeof(PixelStats)) != 0;
            }
            CHECK(wrong_count == 0);
            CHECK(differ == 0);
        }
    }

    TEST_CASE("render: ray query and BVH images agree on every scene") {
        VKMECH_REQUIRE_GPU(ctx);
        if (!ctx->ray_query_enabled()) {
            MESSAGE("skipped: device has no ray query");
            return;
        }
        for (const auto& path : testing::project_scene_paths()) {
            CAPTURE(path);
            RenderSetup setup;
            setup.res = 24;
            setup.spp = 8;
            Frame a = testing::render_scene(*ctx, path, setup);
            setup.traversal = Traversal::RayQuery;
            // Ray query on the BVH's arrays: identical sample streams; a path
            // may only diverge where the two traversals legitimately differ
            // (ties at shared edges, float rounding of hit points feeding a
            // chain of bounces).
            setup.bvh_arrays = true;
            Frame b = testing::render_scene(*ctx, path, setup);
            // Ray query as it renders (flatten_scene(scene, Traversal::RayQuery):
            // the scene's triangle order, no BVH built). The light table lists
            // the emissive triangles in that order, so a sample may pick
            // another one of them: the same estimator, per pixel the same only
            // where both tables list the same triangles in the same order.
            setup.bvh_arrays = false;
            Frame c = testing::render_scene(*ctx, path, setup);
            const Scene scene = load_scene(path);
            const SceneArrays by_bvh = flatten_scene(scene, Traversal::Bvh), own = flatten_scene(scene);
            bool same_lights = by_bvh.light_triangles.size() == own.light_triangles.size();
            for (size_t i = 0; same_lights && i < own.light_triangles.size(); ++i)
                same_lights = by_bvh.bvh.order[by_bvh.light_triangles[i].info.x] == own.light_triangles[i].info.x;
            CAPTURE(same_lights);
            auto count_differing = [&](const Frame& x) {
                size_t differing = 0;
                for (size_t i = 0; i < a.pixels.size(); ++i) {
                    double la = a.pixels[i].lum_mean, lx = x.pixels[i].lum_mean;
                    if (std::abs(la - lx) > 1e-3 * std::max({la, lx, 1e-3})) differing++;
                }
                return differing;
            };
            const size_t differing = count_differing(b);
            CAPTURE(differing);
            CHECK(differing <= a.pixels.size() / 20);
            const ImageStats sa = image_stats(a), sb = image_stats(b), sc = image_stats(c);
            CHECK(sa.mean_lum == doctest::Approx(sb.mean_lum).epsilon(0.02));
            if (same_lights) CHECK(count_differing(c) <= a.pixels.size() / 20);
            CAPTURE(sa.mean_lum);
            CAPTURE(sc.mean_lum);
            CHECK(std::abs(sa.mean_lum - sc.mean_lum) <= 5.0 * std::hypot(sa.std_error, sc.std_error));
        }
    }

    TEST_CASE("render: the CPU and GPU kernels give the same images on every scene") {
        VKMECH_REQUIRE_GPU(ctx);
        // Same sample streams, same shading code; the kernels differ in the
        // tree they traverse (4-wide quantized or binary), how they read the
        // scene and how pixels are scheduled. A path may diverge only where
        // the trees pick different triangles of a tie; every other pixel is
        // the same to float rounding of the accumulation order (none: each
        // pixel's samples are summed in the same order by one invocation).
        for (const auto& path : testing::project_scene_paths()) {
            CAPTURE(path);
            RenderSetup setup;
            setup.res = 24;
            setup.spp = 8;
            setup.kernel = vkmech::vk::KernelClass::Cpu;
            Frame a = testing::render_scene(*ctx, path, setup);
            setup.kernel = vkmech::vk::KernelClass::Gpu;
            Frame b = testing::render_scene(*ctx, path, setup);
            REQUIRE(a.bucket_rgb_sum.size() == a.pixels.size() * Frame::kBucketRgb);
            REQUIRE(b.bucket_rgb_sum.size() == a.bucket_rgb_sum.size());
            size_t identical = 0, differing = 0;
            double sum_a = 0.0, sum_b = 0.0;
            for (size_t i = 0; i < a.pixels.size(); ++i) {
                const PixelStats &pa = a.pixels[i], &pb = b.pixels[i];
                sum_a += pa.lum_mean;
                sum_b += pb.lum_mean;
                identical += pa.rgb_sum == pb.rgb_sum && pa.bucket_sum == pb.bucket_sum && pa.lum_m2 == pb.lum_m2 &&
                             std::equal(a.bucket_rgb_sum.begin() + i * Frame::kBucketRgb,
                                        a.bucket_rgb_sum.begin() + (i + 1) * Frame::kBucketRgb,
                                        b.bucket_rgb_sum.begin() + i * Frame::kBucketRgb);
                if (std::abs(pa.lum_mean - pb.lum_mean) > 1e-5 * std::max({pa.lum_mean, pb.lum_mean, 1e-3}))
                    differing++;
            }
            MESSAGE(path << ": " << identical << " of " << a.pixels.size() << " pixels bit-identical, " << differing
                         << " differ by more than 1e-5");
            CAPTURE(identical);
            CAPTURE(differing);
            // (Bit-identical on lavapipe and on the H200; another GPU compiler may
            // contract the two modules' arithmetic differently: float tolerance.)
            CHECK(differing <= a.pixels.size() / 100);
            CHECK(sum_a == doctest::Approx(sum_b).epsilon(0.005));
        }
        CHECK(ctx->validation_messages() == 0);
    }

    TEST_CASE("render: the GPU kernel's bucket tally in shared memory gives the register tally's frames bit for bit") {
        VKMECH_REQUIRE_GPU(ctx);
        // VKMECH_GPU_TALLY=shared (docs/gpu.md) moves the GPU kernel's per-sample
        // and per-pixel bucket sums from registers to shared memory; the same adds
        // in the same order, so every sum must be bit-identical.
        // Three scenes (every bucket but `other` between them, and the hard
        // cases' extreme radiances); each costs two pipelines on lavapipe.
        std::vector<std::string> paths;
        for (const auto& path : testing::project_scene_paths())
            if (path.find("glass_caustic") != std::string::npos || path.find("snooker") != std::string::npos)
                paths.push_back(path);
        REQUIRE(paths.size() == 2);
        paths.push_back(test_scene("hard_cases"));
        for (const auto& path : paths) {
            CAPTURE(path);
            RenderSetup setup;
            setup.res = 24;
            setup.spp = 8;
            setup.batch = 4;  // two batches: the per-pixel sums start again at zero
            setup.kernel = vkmech::vk::KernelClass::Gpu;
            Frame a = testing::render_scene(*ctx, path, setup);
            Frame b;
            {
                testing::ScopedEnv shared("VKMECH_GPU_TALLY", "shared");
                b = testing::render_scene(*ctx, path, setup);
            }
            REQUIRE(a.bucket_rgb_sum.size() == a.pixels.size() * Frame::kBucketRgb);
            REQUIRE(b.bucket_rgb_sum.size() == a.bucket_rgb_sum.size());
            CHECK(a.bucket_rgb_sum == b.bucket_rgb_sum);
            size_t differing = 0;
            double energy = 0.0;
            for (size_t i = 0; i < a.pixels.size(); ++i) {
                const PixelStats &pa = a.pixels[i], &pb = b.pixels[i];
                differing += !(pa.rgb_sum == pb.rgb_sum && pa.bucket_sum == pb.bucket_sum && pa.lum_m2 == pb.lum_m2 &&
                               pa.count == pb.count && pa.nonfinite == pb.nonfinite);
                for (double e : pa.bucket_sum) energy += e;
            }
            CHECK(differing == 0);
            CHECK(energy > 0.0);  // the buckets were filled, so the comparison compared something
        }
        {
            testing::ScopedEnv bad("VKMECH_GPU_TALLY", "stack");
            RenderSetup setup;
            setup.res = 8;
            setup.spp = 1;
            setup.kernel = vkmech::vk::KernelClass::Gpu;
            CHECK_THROWS_WITH_AS(testing::render_scene(*ctx, test_scene("hard_cases"), setup),
                                 doctest::Contains("expected 'registers' (the default), 'shared' or 'direct'"),
                                 std::invalid_argument);
        }
        CHECK(ctx->validation_messages() == 0);
    }

    TEST_CASE("render: VKMECH_GPU_TALLY=direct selects a module of its own for the software BVH's GPU kernel only") {
        const auto bvh = pathtrace_spirv(Traversal::Bvh, vkmech::vk::KernelClass::Gpu),
                   rq = pathtrace_spirv(Traversal::RayQuery, vkmech::vk::KernelClass::Gpu),
                   cpu = pathtrace_spirv(Traversal::Bvh, vkmech::vk::KernelClass::Cpu);
        testing::ScopedEnv direct("VKMECH_GPU_TALLY", "direct");
        CHECK(pathtrace_spirv(Traversal::Bvh, vkmech::vk::KernelClass::Gpu).data() != bvh.data());
        CHECK(pathtrace_spirv(Traversal::RayQuery, vkmech::vk::KernelClass::Gpu).data() == rq.data());
        CHECK(pathtrace_spirv(Traversal::Bvh, vkmech::vk::KernelClass::Cpu).data() == cpu.data());
        // The instrumented and direct_glossy variants keep the register tally.
        CHECK(pathtrace_spirv(Traversal::Bvh, vkmech::vk::KernelClass::Gpu, true).data() !=
              pathtrace_spirv(Traversal::Bvh, vkmech::vk::KernelClass::Gpu).data());
    }

    TEST_CASE(
        "render: the GPU kernel's direct tally gives the register tally's frames to float rounding - and keeps "
        "non-finite samples' events out") {
        VKMECH_REQUIRE_GPU(ctx);
        // VKMECH_GPU_TALLY=direct (docs/gpu.md) adds each event to the pixel's sums at once, in another
        // order than per sample, and traces a batch with a non-finite sample again to take that sample's
        // events back out. Everything but the bucket sums is computed as before, bit for bit.
        // One scene (each tally is a pipeline of its own, about 20 s to compile on lavapipe).
        // A lamp of radiance 5e37 facing the camera: seven samples of a pixel that sees it fill the float
        // sums, and the later ones are non-finite (counted, not added); a lamp of radiance 1 lights the floor.
        Scene lamps = testing::quad_scene();
        lamps.meshes[0].positions = {{-4, -4, 0}, {-4, 4, 0}, {4, 4, 0}, {4, -4, 0}};  // the floor faces the camera
        Material lamp_material;
        lamps.materials.push_back(lamp_material);
        testing::add_square_lamp(lamps, "bright", -0.7f, -2.0f, /*faces_minus_z=*/true, 5e37f, 1);  // the camera
        testing::add_square_lamp(lamps, "dim", 1.2f, -2.0f, /*faces_minus_z=*/false, 1.0f, 1);      // the floor
        lamps.camera.to_world[3] = glm::vec4(0, 0, -6, 1);
        // Batches of 32 (the first pass's decisions all in the redo's mask) and of 96 (non-finite samples past
        // the 64th: the redo decides again).
        for (uint32_t batch : {32u, 96u}) {
            CAPTURE(batch);
            RenderSetup setup;
            setup.res = 16;
            setup.spp = 2 * batch;  // two batches: the sums start again at zero
            setup.batch = batch;
            setup.kernel = vkmech::vk::KernelClass::Gpu;
            Frame a = testing::render_scene(*ctx, lamps, setup);
            Frame b;
            {
                testing::ScopedEnv direct("VKMECH_GPU_TALLY", "direct");
                b = testing::render_scene(*ctx, lamps, setup);
            }
            REQUIRE(b.pixels.size() == a.pixels.size());
            size_t differing = 0, off = 0, mixed = 0;
            double nonfinite = 0.0, energy = 0.0;
            for (size_t i = 0; i < a.pixels.size(); ++i) {
                const PixelStats &pa = a.pixels[i], &pb = b.pixels[i];
                differing += !(pa.rgb_sum == pb.rgb_sum && pa.lum_m2 == pb.lum_m2 && pa.count == pb.count &&
                               pa.nonfinite == pb.nonfinite);
                nonfinite += pa.nonfinite;
                size_t filled = 0;
                for (size_t k = 0; k < pa.bucket_sum.size(); ++k) {
                    // Every contribution is >= 0, so a sum in another order is within n eps of itself.
                    off += !(std::isfinite(pb.bucket_sum[k]) &&
                             std::abs(pb.bucket_sum[k] - pa.bucket_sum[k]) <= 1e-5 * std::abs(pa.bucket_sum[k]));
                    energy += pa.bucket_sum[k];
                    filled += pa.bucket_sum[k] > 0.0;
                }
                mixed += pa.nonfinite > 0.0 && filled >= 2;
            }
            CHECK(differing == 0);
            CHECK(off == 0);
            CHECK(energy > 0.0);       // the buckets were filled, so the comparison compared something
            CHECK(nonfinite > 100.0);  // the bright lamp's pixels: the redo was exercised
            CHECK(mixed > 0);          // and redone pixels whose counted samples fill two buckets or more
        }
        CHECK(ctx->validation_messages() == 0);
    }

    TEST_CASE("render: hard cases stay finite and lum_var matches a two-pass double reference over 4096 samples") {
        VKMECH_REQUIRE_GPU(ctx);
        const int res = 6;
        RenderSetup setup;
        setup.res = res;
        setup.spp = 4096;
        setup.batch = 64;
        Frame f = testing::render_scene(*ctx, test_scene("hard_cases"), setup);
        for (const auto& p : f.pixels) {
            CHECK(p.nonfinite == 0.0);
            CHECK(p.count == 4096.0);
            for (double c : p.rgb_sum) CHECK((std::isfinite(c) && c >= 0.0));
            for (double e : p.bucket_sum) CHECK((std::isfinite(e) && e >= 0.0));
        }
        // Two-pass reference in double: batches of one sample hand over each
        // sample's luminance exactly (the batch mean of one value).
        setup.batch = 1;
        std::vector<std::vector<double>> per_sample(f.pixels.size());
        setup.on_batch = [&](const std::vector<gpu::GpuPixelAccum>& batch) {
            for (size_t i = 0; i < batch.size(); ++i)
                if (batch[i].rgb.w > 0.0f) per_sample[i].push_back(batch[i].lum.x);
        };
        testing::render_scene(*ctx, test_scene("hard_cases"), setup);
        for (size_t i = 0; i < f.pixels.size(); ++i) {
            CAPTURE(i);
            const auto& v = per_sample[i];
            REQUIRE(v.size() == 4096);
            double mean = 0.0;
            for (double x : v) mean += x;
            mean /= v.size();
            double ss = 0.0;
            for (double x : v) ss += (x - mean) * (x - mean);
            double var = ss / (v.size() - 1);
            CHECK(f.pixels[i].lum_mean == doctest::Approx(mean).epsilon(1e-5));
            CHECK(f.pixels[i].lum_var() == doctest::Approx(var).epsilon(1e-4));
        }
    }

    TEST_CASE("render: nee and mis agree within statistical error (unbiasedness cross-check)") {
        VKMECH_REQUIRE_GPU(ctx);
        for (const char* name : {"glass_caustic", "kitchen_counter"}) {
            CAPTURE(name);
            RenderSetup setup;
            setup.res = 16;
            setup.spp = 512;
            setup.batch = 64;
            ImageStats nee = image_stats(testing::render_scene(*ctx, project_scene(name), setup));
            setup.estimator = Estimator::Mis;
            setup.seed = 1;
            ImageStats mis = image_stats(testing::render_scene(*ctx, project_scene(name), setup));
            setup.estimator = Estimator::MisRestricted;
            setup.seed = 2;
            ImageStats mres = image_stats(testing::render_scene(*ctx, project_scene(name), setup));
            CAPTURE(nee.mean_lum);
            CAPTURE(mis.mean_lum);
            CAPTURE(mres.mean_lum);
            double se = std::sqrt(nee.std_error * nee.std_error + mis.std_error * mis.std_error);
            CHECK(std::abs(nee.mean_lum - mis.mean_lum) < 4.0 * se);
            double se2 = std::sqrt(nee.std_error * nee.std_error + mres.std_error * mres.std_error);
            CHECK(std::abs(nee.mean_lum - mres.mean_lum) < 4.0 * se2);
        }
    }
}

TEST_SUITE("gpu") {
    TEST_CASE(
        "render: an emitter whose winding disagrees with its normals emits on the normals' side for NEE and for hits "
        "alike") {
        VKMECH_REQUIRE_GPU(ctx);
        // A 2x2 diffuse floor at z = 0 under a 0.6 x 0.6 emitting quad at z = 1, seen from z = 3 looking down.
        // The light's winding faces up (+z); its authored normals face down, at the floor. Mitsuba emits on the
        // side of the shading normal, so the floor is lit; it must be lit equally whether the light is reached by
        // light sampling (NEE) or by BSDF sampling (the MIS estimator's emitter hits).
        auto make = [](bool normals_down) {
            Scene s;
            s.source = "<winding test>";
            Material white;
            white.id = "white";
            s.materials.push_back(white);
            Mesh floor;
            floor.name = "floor";
            floor.positions = {{-1, -1, 0}, {1, -1, 0}, {1, 1, 0}, {-1, 1, 0}};
            floor.indices = {{0, 1, 2}, {0, 2, 3}};
            floor.material = 0;
            s.meshes.push_back(floor);
            Mesh light;
            light.name = "light";
            light.positions = {{-0.3f, -0.3f, 1}, {0.3f, -0.3f, 1}, {0.3f, 0.3f, 1}, {-0.3f, 0.3f, 1}};
            light.indices = {{0, 1, 2}, {0, 2, 3}};  // counter-clockwise seen from +z: winding normal +z
            const glm::vec3 n = normals_down ? glm::vec3(0, 0, -1) : glm::vec3(0, 0, 1);
            light.normals = {n, n, n, n};
            light.material = 0;
            light.emitter = 0;
            s.meshes.push_back(light);
            AreaEmitter e;
            e.radiance = glm::vec3(4.0f);
            e.mesh = 1;
            s.emitters.push_back(e);
            s.camera.to_world = glm::mat4(1.0f);
            s.camera.to_world[1] = glm::vec4(0, -1, 0, 0);
            s.camera.to_world[2] = glm::vec4(0, 0, -1, 0);
            s.camera.to_world[3] = glm::vec4(0, 0, 3, 1);
            s.camera.width = s.camera.height = 16;
            return s;
        };
        for (bool down : {true, false}) {
            CAPTURE(down);
            RenderSetup setup;
            setup.res = 16;
            setup.spp = 256;
            setup.batch = 64;
            ImageStats nee = image_stats(testing::render_scene(*ctx, make(down), setup));
            setup.estimator = Estimator::Mis;
            setup.seed = 1;
            ImageStats mis = image_stats(testing::render_scene(*ctx, make(down), setup));
            CAPTURE(nee.mean_lum);
            CAPTURE(mis.mean_lum);
            double se = std::sqrt(nee.std_error * nee.std_error + mis.std_error * mis.std_error);
            CHECK(std::abs(nee.mean_lum - mis.mean_lum) < 4.0 * se);
            // Normals down: the camera sees the light's dark back, so the image's light is the lit floor's.
            if (down) CHECK(nee.mean_lum > 0.05);
        }
    }

    TEST_CASE("render: bitmap reflectance is looked up per hit (2x2 texture, one texel per quadrant)") {
        VKMECH_REQUIRE_GPU(ctx);
        RenderSetup setup;
        setup.res = 32;
        setup.spp = 64;
        Frame f = testing::render_scene(*ctx, test_scene("texture"), setup);
        std::vector<float> rgb = f.rgb_mean();
        // Pixels 6 and 26 look at uv 0.25 and 0.75: texel centres, no blending.
        auto colour_at = [&](int x, int y) {
            size_t i = static_cast<size_t>(y) * 32 + x;
            glm::vec3 c(rgb[3 * i], rgb[3 * i + 1], rgb[3 * i + 2]);
            return c / std::max(1e-6f, c.r + c.g + c.b);
        };
        auto kind = [&](glm::vec3 c) {
            if (c.r > 0.85f) return 'r';
            if (c.g > 0.85f) return 'g';
            if (c.b > 0.85f) return 'b';
            if (std::abs(c.r - c.g) < 0.05f && std::abs(c.g - c.b) < 0.05f) return 'w';
            return '?';
        };
        char q00 = kind(colour_at(6, 6)), q10 = kind(colour_at(26, 6)), q01 = kind(colour_at(6, 26)),
             q11 = kind(colour_at(26, 26));
        std::string all = {q00, q10, q01, q11};
        CAPTURE(all);
        std::string sorted = all;
        std::sort(sorted.begin(), sorted.end());
        CHECK(sorted == "bgrw");
        // The texture's neighbourhoods survive: red is beside green and blue, diagonal to grey.
        auto diag = [&](char c) { return c == q00 ? q11 : c == q11 ? q00 : c == q10 ? q01 : q10; };
        CHECK(diag('r') == 'w');
        CHECK(diag('g') == 'b');
    }
}

TEST_SUITE("gpu") {
    TEST_CASE("render: an orthographic camera sees the same extent at every distance") {
        VKMECH_REQUIRE_GPU(ctx);
        for (const char* height : {"2", "7"}) {
            CAPTURE(height);
            RenderSetup setup;
            setup.res = 32;
            setup.spp = 4;
            setup.load.params["height"] = height;
            Frame f = testing::render_scene(*ctx, test_scene("orthographic"), setup);
            std::vector<float> rgb = f.rgb_mean();
            // The square spans camera x, y in [-0.25, 0.25] of [-0.5, 0.5]:
            // columns and rows 8..23 are lit (radiance 1), the rest black.
            int lit = 0, wrong = 0;
            for (int y = 0; y < 32; ++y)
                for (int x = 0; x < 32; ++x) {
                    float v = rgb[3 * (static_cast<size_t>(y) * 32 + x)];
                    bool inside = x >= 8 && x < 24 && y >= 8 && y < 24;
                    bool edge = x == 7 || x == 8 || x == 23 || x == 24 || y == 7 || y == 8 || y == 23 || y == 24;
                    if (v > 0.5f) ++lit;
                    if (!edge && (inside ? std::abs(v - 1.0f) > 1e-3f : v != 0.0f)) ++wrong;
                }
            CHECK(wrong == 0);
            CHECK(lit >= 14 * 14);
            CHECK(lit <= 18 * 18);
        }
    }

    // Both scenes show a 4 x 4 red/blue checkerboard (to_uv scales the 2 x 2
    // pattern by 2): on a diffuse reflectance and on a mirror's
    // specular_reflectance. Image columns 1, 10, 21 (and rows alike) fall in
    // the cells u in [0, .25), [.25, .5), [.5, .75): neighbouring cells differ,
    // diagonal ones agree, and with no uv scaling columns 1 and 10 would agree.
    TEST_CASE("render: checkerboard textures with to_uv on reflectance and on specular_reflectance") {
        VKMECH_REQUIRE_GPU(ctx);
        for (const char* name : {"checkerboard", "textured_mirror"}) {
            CAPTURE(name);
            RenderSetup setup;
            setup.res = 32;
            setup.spp = 16;
            Frame f = testing::render_scene(*ctx, test_scene(name), setup);
            std::vector<float> rgb = f.rgb_mean();
            auto cell = [&](int x, int y) {
                size_t i = static_cast<size_t>(y) * 32 + x;
                float r = rgb[3 * i], g = rgb[3 * i + 1], b = rgb[3 * i + 2];
                CAPTURE(r);
                CAPTURE(g);
                CAPTURE(b);
                CHECK(g < 0.05f * (r + b));  // no green anywhere: pure colour0 or colour1
                CHECK(r + b > 0.05f);
                return r > b ? 'r' : 'b';
            };
            char c11 = cell(10, 10), c21 = cell(21, 10), c12 = cell(10, 21), c22 = cell(21, 21), c01 = cell(1, 10);
            CHECK(c11 != c21);
            CHECK(c11 != c12);
            CHECK(c11 == c22);
            CHECK(c21 == c12);
            CHECK(c01 != c11);
        }
    }

    TEST_CASE(
        "render: the GPU labels recorded events exactly as the C++ cascade does (debug event mode) under both "
        "end-vertex readings") {
        VKMECH_REQUIRE_GPU(ctx);
        for (const EndVertex reading : {EndVertex::LastNonDelta, EndVertex::Literal})
            for (const char* name : {"snooker", "glass_caustic", "kitchen_counter", "ring_caustic"}) {
                CAPTURE(name);
                CAPTURE(static_cast<int>(reading));
                Scene scene = load_scene(project_scene(name));
                scene.camera.width = scene.camera.height = 32;
                RenderSession session(*ctx, scene, Traversal::Bvh);
                Features f = session.features();
                f.debug_events = true;
                f.end_vertex = reading;
                Renderer r = session.renderer(f);
                RenderSpec spec;
                spec.spp = 64;
                // Pick the pixels carrying the most heavy-tailed energy, plus the centre.
                Frame probe = r.render(spec);
                std::vector<uint32_t> pixels = {32 * 16 + 16};
                for (uint32_t bucket : {gpu::BUCKET_DELTA_MEDIATED, gpu::BUCKET_GLOSSY, gpu::BUCKET_SPECULAR_DIRECT}) {
                    uint32_t best = 0;
                    for (uint32_t i = 0; i < probe.pixels.size(); ++i)
                        if (probe.pixels[i].bucket_sum[bucket] > probe.pixels[best].bucket_sum[bucket]) best = i;
                    if (probe.pixels[best].bucket_sum[bucket] > 0.0) pixels.push_back(best);
                }
                std::set<uint32_t> seen_buckets;
                for (uint32_t px : pixels) {
                    CAPTURE(px);
                    Frame frame;
                    auto events = r.render_debug_events(spec, px, 65536, &frame);
                    REQUIRE(events.size() < 65536);
                    std::array<double, kBucketCount> sums{};
                    for (const auto& e : events) {
                        uint32_t expected = shader::classify_event(e.label.x, e.label.y, e.label.z != 0);
                        CHECK(e.label.w == expected);
                        CHECK(e.energy.x >= 0.0f);
                        sums[e.label.w] += e.energy.x;
                        seen_buckets.insert(e.label.w);
                    }
                    // The recorded events are exactly what the pixel accumulated.
                    for (uint32_t b = 0; b < kBucketCount; ++b)
                        CHECK(sums[b] == doctest::Approx(frame.pixels[px].bucket_sum[b]).epsilon(1e-4));
                }
                CHECK(seen_buckets.size() >= 2);
            }
    }
}

namespace {

// Pixel (x, y) where a world point projects (Mitsuba's camera convention:
// camera +X is image left, +Y image up, looking along +Z).
glm::ivec2 project(const Scene& s, glm::vec3 p) {
    glm::vec3 c = glm::vec3(glm::inverse(s.camera.to_world) * glm::vec4(p, 1.0f));
    glm::vec2 t = camera_tangents(s.camera);
    float u = 0.5f * (1.0f - c.x / (c.z * t.x)), v = 0.5f * (1.0f - c.y / (c.z * t.y));
    return {static_cast<int>(u * s.camera.width), static_cast<int>(v * s.camera.height)};
}

struct LabelledRender {
    Scene scene;
    Frame frame;
    Descriptor d;
    DescriptorSummary summary;
    size_t count(uint32_t bucket) const { return std::count(d.dominant.begin(), d.dominant.end(), bucket); }
};

LabelledRender render_labelled(vkmech::vk::Context& ctx, const std::string& name, int res, uint32_t spp) {
    LabelledRender r;
    r.scene = load_scene(project_scene(name));
    r.scene.camera.width = r.scene.camera.height = res;
    RenderSession session(ctx, r.scene, Traversal::Bvh);
    Renderer renderer = session.renderer(session.features());
    RenderSpec spec;
    spec.spp = spp;
    r.frame = renderer.render(spec);
    r.d = derive_descriptor(r.frame);
    r.summary = summarize(r.frame, r.d);
    return r;
}

}  // namespace

TEST_SUITE("gpu") {
    TEST_CASE("scenes at 128^2: cubes_dof is mostly direct with no heavy-tailed bucket") {
        VKMECH_REQUIRE_GPU(ctx);
        auto r = render_labelled(*ctx, "cubes_dof", 128, 16);
        CHECK(r.summary.pixel_share[gpu::BUCKET_DIRECT] > 0.8);
        for (uint32_t b :
             {gpu::BUCKET_GLOSSY, gpu::BUCKET_DELTA_MEDIATED, gpu::BUCKET_SPECULAR_DIRECT, gpu::BUCKET_OTHER}) {
            CHECK(r.summary.pixel_share[b] == 0.0);
            CHECK(r.summary.energy_share[b] == 0.0);
        }
    }

    TEST_CASE("scenes at 128^2: delta_mediated under glass_caustic's sphere and on snooker's chrome and glass balls") {
        VKMECH_REQUIRE_GPU(ctx);
        {
            auto r = render_labelled(*ctx, "glass_caustic", 128, 16);
            const Mesh* sphere = nullptr;
            for (const auto& m : r.scene.meshes)
                if (m.kind == ShapeKind::Sphere) sphere = &m;
            REQUIRE(sphere);
            glm::ivec2 c = project(r.scene, sphere->center);
            CAPTURE(c.x);
            CAPTURE(c.y);
            REQUIRE((c.x >= 0 && c.x < 128 && c.y >= 0 && c.y < 128));
            CHECK(r.d.dominant[c.y * 128 + c.x] == gpu::BUCKET_DELTA_MEDIATED);
            CHECK(r.count(gpu::BUCKET_DELTA_MEDIATED) > 200);
        }
        {
            auto r = render_labelled(*ctx, "snooker", 128, 16);
            for (const auto& m : r.scene.meshes) {
                if (m.kind != ShapeKind::Sphere) continue;
                BsdfType t = r.scene.materials[m.material].type;
                if (t != BsdfType::Conductor && t != BsdfType::Dielectric) continue;
                CAPTURE(m.name);
                glm::ivec2 c = project(r.scene, m.center);
                // The ball's projected disk (radius from projecting a point on
                // its silhouette): its labelled pixels are mostly delta-mediated
                // (part of a chrome ball reflects the black surroundings: no
                // energy, no label).
                glm::vec3 up = glm::normalize(glm::vec3(r.scene.camera.to_world[1]));
                glm::ivec2 e = project(r.scene, m.center + 0.9f * m.radius * up);
                int rad = std::max(1, static_cast<int>(glm::length(glm::vec2(e - c))));
                int delta = 0, labelled = 0;
                for (int dy = -rad; dy <= rad; ++dy)
                    for (int dx = -rad; dx <= rad; ++dx) {
                        int x = c.x + dx, y = c.y + dy;
                        if (dx * dx + dy * dy > rad * rad || x < 0 || y < 0 || x >= 128 || y >= 128) continue;
                        uint8_t b = r.d.dominant[y * 128 + x];
                        labelled += b != kNoLabel;
                        delta += b == gpu::BUCKET_DELTA_MEDIATED;
                    }
                CAPTURE(rad);
                CAPTURE(delta);
                CAPTURE(labelled);
                CHECK(labelled >= 10);
                CHECK(delta * 2 > labelled);
            }
        }
    }

    TEST_CASE("scenes at 256^2: kitchen_counter's glossy population is in the thousands of pixels") {
        VKMECH_REQUIRE_GPU(ctx);
        auto r = render_labelled(*ctx, "kitchen_counter", 256, 8);
        CAPTURE(r.count(gpu::BUCKET_GLOSSY));
        CHECK(r.count(gpu::BUCKET_GLOSSY) >= 1000);
    }
}
