// Issue 10, "never silent garbage" (numerics): scene scale, radiance scale,
// and the warnings a render's outputs carry when they come out empty or
// beyond float's range.
#include "gpu_fixture.hpp"
#include "render_fixture.hpp"

#include <doctest/doctest.h>

#include <cmath>

using namespace vkmech;
using testing::RenderSetup;

namespace {

std::string test_scene(const std::string& name) { return std::string(VKMECH_TEST_DATA) + "/render/" + name + ".xml"; }

// Every shape and the camera position scaled by k about the origin; the
// radiance stays.
Scene scaled(Scene s, float k) {
    for (auto& m : s.meshes) {
        for (auto& p : m.positions) p *= k;
        m.center *= k;
        m.radius *= k;
    }
    s.camera.to_world[3] = glm::vec4(glm::vec3(s.camera.to_world[3]) * k, 1.0f);
    return s;
}

double mean_luminance(const Frame& f) {
    double sum = 0.0;
    for (const auto& p : f.pixels) sum += p.lum_mean;
    return sum / static_cast<double>(f.pixels.size());
}

double nonfinite_samples(const Frame& f) {
    double n = 0.0;
    for (const auto& p : f.pixels) n += p.nonfinite;
    return n;
}

}  // namespace

TEST_SUITE("gpu") {
    // The ray offsets must follow the scene's scale (no absolute epsilon):
    // the same samples at 1e-6 and 1e12 give the native image.
    TEST_CASE("numerics: a box scaled by 1e-6 and by 1e12 renders its native image - both traversals") {
        VKMECH_REQUIRE_GPU(ctx);
        Scene native = load_scene(test_scene("scale_box"));
        std::vector<Traversal> travs = {Traversal::Bvh};
        if (ctx->ray_query_enabled()) travs.push_back(Traversal::RayQuery);
        for (Traversal t : travs) {
            CAPTURE(std::string(to_string(t)));
            RenderSetup setup;
            setup.res = 24;
            setup.spp = 16;
            setup.traversal = t;
            Frame ref = testing::render_scene(*ctx, native, setup);
            double ref_mean = mean_luminance(ref);
            REQUIRE(ref_mean > 0.1);
            for (float k : {1e-6f, 1e12f}) {
                CAPTURE(k);
                Frame f = testing::render_scene(*ctx, scaled(native, k), setup);
                CHECK(nonfinite_samples(f) == 0.0);
                CHECK(mean_luminance(f) == doctest::Approx(ref_mean).epsilon(0.02));
            }
        }
    }

    // Per-pixel Welford moments in float overflowed (M2 ~ 1e60: lum_var inf)
    // or underflowed (M2 ~ 1e-60: lum_var 0) at extreme radiance; the same
    // samples scaled by k must give mean * k and variance * k^2.
    TEST_CASE("numerics: luminance mean and variance scale exactly with radiance 1e30 and 1e-30") {
        VKMECH_REQUIRE_GPU(ctx);
        Scene base = load_scene(test_scene("scale_box"));
        RenderSetup setup;
        setup.res = 16;
        setup.spp = 32;
        Frame ref = testing::render_scene(*ctx, base, setup);
        for (float k : {1e30f, 1e-30f}) {
            CAPTURE(k);
            Scene s = base;
            for (auto& e : s.emitters) e.radiance *= k;
            double ratio = static_cast<double>(s.emitters[0].radiance.x) / base.emitters[0].radiance.x;
            Frame f = testing::render_scene(*ctx, s, setup);
            size_t bad_mean = 0, bad_var = 0, with_var = 0;
            for (size_t i = 0; i < f.pixels.size(); ++i) {
                const PixelStats& a = f.pixels[i];
                const PixelStats& b = ref.pixels[i];
                CHECK(a.nonfinite == 0.0);
                if (!(std::abs(a.lum_mean - b.lum_mean * ratio) <= 1e-4 * b.lum_mean * ratio)) ++bad_mean;
                if (b.lum_var() > 0.0) ++with_var;
                double var = b.lum_var() * ratio * ratio;
                if (!(std::isfinite(a.lum_var()) && std::abs(a.lum_var() - var) <= 1e-3 * var)) ++bad_var;
            }
            CHECK(with_var > f.pixels.size() / 2);
            CHECK(bad_mean == 0);
            CHECK(bad_var == 0);
        }
    }
}
