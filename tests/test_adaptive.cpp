// Adaptive rendering (docs/descriptor.md §6): the GPU renders exactly n(p) samples
// at each pixel, and the result is the mean of the first n(p) frames of the
// same seed's sample stream (the "pool").
#include "adaptive/adaptive.hpp"
#include "allocation/allocation.hpp"
#include "gpu_fixture.hpp"
#include "io/invariant.hpp"
#include "render/gpu_scene.hpp"
#include "render/session.hpp"
#include "render_fixture.hpp"
#include "scene_fixtures.hpp"

#include <doctest/doctest.h>

#include <sys/wait.h>
#include <unistd.h>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <tuple>

using namespace vkmech;
using namespace vkmech::testing;

TEST_SUITE("gpu") {
    TEST_CASE("adaptive: n(p) samples per pixel equal the first n(p) frames of the pool, bit for bit") {
        VKMECH_REQUIRE_GPU(ctx);
        const std::string scene = std::string(VKMECH_SOURCE_DIR) + "/scenes/glass_caustic.xml";
        const uint32_t pool_size = 24, seed = 1000;
        RenderSetup pool;
        pool.res = 20;
        pool.spp = pool_size;
        pool.seed = seed;
        pool.batch = 1;  // one frame per batch
        std::vector<std::vector<gpu::GpuPixelAccum>> frames;
        pool.on_batch = [&](const std::vector<gpu::GpuPixelAccum>& b) { frames.push_back(b); };
        Frame full = render_scene(*ctx, scene, pool);
        REQUIRE(frames.size() == pool_size);
        const size_t P = full.pixels.size();

        // A map with zeros, ones, the full pool and everything between.
        std::vector<uint32_t> n(P);
        uint64_t total = 0;
        for (size_t p = 0; p < P; ++p) {
            n[p] = static_cast<uint32_t>((p * 7919u + (p / 20) * 31u) % (pool_size + 1));
            total += n[p];
        }
        // Reference: merge the first n(p) frames of the pool in order, on the host.
        Frame expected;
        expected.width = full.width;
        expected.height = full.height;
        expected.pixels.assign(P, PixelStats{});
        for (uint32_t f = 0; f < pool_size; ++f) {
            std::vector<gpu::GpuPixelAccum> masked = frames[f];
            for (size_t p = 0; p < P; ++p)
                if (f >= n[p]) masked[p] = gpu::GpuPixelAccum{};
            expected.merge(masked);
        }

        RenderSetup adaptive = pool;
        adaptive.on_batch = nullptr;
        adaptive.sample_counts = n;
        Frame got = render_scene(*ctx, scene, adaptive);
        CHECK(got.samples == total);
        size_t mismatched = 0;
        for (size_t p = 0; p < P; ++p) {
            const PixelStats& a = got.pixels[p];
            const PixelStats& b = expected.pixels[p];
            CHECK(a.count + a.nonfinite == n[p]);
            if (std::memcmp(&a, &b, sizeof(PixelStats)) != 0) ++mismatched;
        }
        CHECK(mismatched == 0);

        // Batched adaptive renders agree to float rounding of the batch sums.
        adaptive.batch = 8;
        Frame batched = render_scene(*ctx, scene, adaptive);
        double worst = 0.0;
        for (size_t p = 0; p < P; ++p) {
            CHECK(batched.pixels[p].count == got.pixels[p].count);
            for (int c = 0; c < 3; ++c) {
                double x = batched.pixels[p].rgb_sum[c], y = got.pixels[p].rgb_sum[c];
                worst = std::max(worst, std::fabs(x - y) / std::max(std::fabs(y), 1e-6));
            }
        }
        CHECK(worst < 1e-5);

        // A pixel with n = pool size matches the plain (non-adaptive) render of the pool.
        for (size_t p = 0; p < P; ++p)
            if (n[p] == pool_size) CHECK(std::memcmp(&got.pixels[p], &full.pixels[p], sizeof(PixelStats)) == 0);
    }

    TEST_CASE("adaptive: a sample-count map of the wrong size is refused") {
        VKMECH_REQUIRE_GPU(ctx);
        RenderSetup s;
        s.res = 8;
        s.sample_counts = {1, 2, 3};  // a bug in the caller: the front ends size the map (InternalError)
        CHECK_THROWS_WITH_AS(render_scene(*ctx, std::string(VKMECH_SOURCE_DIR) + "/scenes/cubes_dof.xml", s),
                             doctest::Contains("3 entries for"), InternalError);
    }

    TEST_CASE("adaptive: on cubes_dof (no heavy-tailed bucket) bucket-floor allocates exactly as observed-var") {
        VKMECH_REQUIRE_GPU(ctx);
        Renderer r = project_scene_renderer(*ctx, "cubes_dof", 32);
        for (uint32_t draw = 0; draw < 3; ++draw) {
            Pilot pilot = render_pilot(r, 4, downstream_seeds::pilot(draw), false);
            for (uint8_t l : pilot.labels) CHECK_FALSE(alloc::is_heavy_tailed(l));
            alloc::ScoreInputs in;
            in.pilot_var = &pilot.var;
            in.pilot_labels = &pilot.labels;
            AdaptivePlan obs = plan_allocation(alloc::Strategy::ObservedVar, in, 32, 1, draw);
            AdaptivePlan floor = plan_allocation(alloc::Strategy::BucketFloor, in, 32, 1, draw);
            CHECK(obs.n == floor.n);
            CHECK(obs.total == floor.total);
        }
        // And on a scene with heavy-tailed pixels the floor changes the allocation, with the same total.
        Renderer gr = project_scene_renderer(*ctx, "glass_caustic", 32);
        Pilot pilot = render_pilot(gr, 4, downstream_seeds::pilot(0), false);
        alloc::ScoreInputs in;
        in.pilot_var = &pilot.var;
        in.pilot_labels = &pilot.labels;
        AdaptivePlan obs = plan_allocation(alloc::Strategy::ObservedVar, in, 32, 1, 0);
        AdaptivePlan floor = plan_allocation(alloc::Strategy::BucketFloor, in, 32, 1, 0);
        CHECK(obs.n != floor.n);
        uint64_t a = 0, b = 0;
        for (size_t p = 0; p < obs.n.size(); ++p) {
            a += obs.n[p];
            b += floor.n[p];
        }
        CHECK(a == b);
        CHECK(a == 33u * obs.n.size());
    }

    TEST_CASE("adaptive: vkmech render --adaptive writes the image and the n(p) map, and refuses MoM at N0 = 4") {
        VKMECH_REQUIRE_GPU(ctx);
        namespace fs = std::filesystem;
        fs::path out = fs::temp_directory_path() / ("vkmech_adaptive_" + std::to_string(::getpid()));
        fs::path log = out.string() + ".log";
        auto run = [&](const std::string& args) {
            int status = std::system((std::string(VKMECH_CLI) + " " + args + " > " + log.string() + " 2>&1").c_str());
            std::ifstream in(log);
            std::stringstream ss;
            ss << in.rdbuf();
            return std::make_pair(WIFEXITED(status) ? WEXITSTATUS(status) : -1, ss.str());
        };
        // Not a structured binding: clang 14 cannot capture one in INFO's lambda.
        int rc = 0;
        std::string text;
        std::tie(rc, text) =
            run("--scene glass_caustic --res 24 --adaptive bucket-floor --pilot 4 --budget 8 --out " + out.string());
        INFO(text);
        REQUIRE(rc == 0);
        CHECK(text.find("predicted label reliability") != std::string::npos);
        CHECK(text.find("(9.00 per pixel)") != std::string::npos);
        CHECK(fs::exists(out / "glass_caustic.exr"));
        CHECK(fs::exists(out / "glass_caustic_spp.png"));
        std::tie(rc, text) =
            run("--scene glass_caustic --res 24 --adaptive robust-var --pilot 4 --out " + out.string());
        CHECK(rc == 2);
        CHECK(text.find("median-of-means needs blocks of at least 3 samples") != std::string::npos);
        std::tie(rc, text) = run("--scene glass_caustic --adaptive oracle --out " + out.string());
        CHECK(rc == 2);
        CHECK(text.find("needs a converged reference") != std::string::npos);
        std::tie(rc, text) = run("--scene glass_caustic --adaptive greedy --out " + out.string());
        CHECK(rc == 2);
        CHECK(text.find("bucket-floor") != std::string::npos);
        fs::remove_all(out);
        fs::remove(log);
    }
}
