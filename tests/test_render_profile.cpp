// `bench render --profile` (docs/performance.md): the renderer's per-batch time split.
#include "gpu_fixture.hpp"
#include "render/renderer.hpp"
#include "render_fixture.hpp"

#include <doctest/doctest.h>

using namespace vkmech;

TEST_SUITE("gpu") {
    TEST_CASE("render profile: one entry per batch and the steps sum to at most the render time") {
        VKMECH_REQUIRE_GPU(ctx);
        Renderer r = testing::project_scene_renderer(*ctx, "cubes_dof", 16);
        RenderSpec spec;
        spec.spp = 9;
        spec.batch_spp = 2;  // 2 + 2 + 2 + 2 + 1: five batches
        const Frame plain = r.render(spec);
        RenderProfile prof;
        spec.profile = &prof;
        const Frame profiled = r.render(spec);
        CHECK(prof.batches == 5);
        CHECK(prof.dispatch > 0.0);
        for (double x : {prof.upload, prof.dispatch, prof.readback, prof.accumulate, prof.callbacks}) CHECK(x >= 0.0);
        CHECK(prof.upload + prof.dispatch + prof.readback + prof.accumulate + prof.callbacks <=
              profiled.seconds + 1e-6);
        // Profiling changes no pixel.
        REQUIRE(plain.pixels.size() == profiled.pixels.size());
        bool same = true;
        for (size_t i = 0; i < plain.pixels.size(); ++i)
            same = same && plain.pixels[i].rgb_sum == profiled.pixels[i].rgb_sum &&
                   plain.pixels[i].lum_m2 == profiled.pixels[i].lum_m2;
        CHECK(same);
    }
}
