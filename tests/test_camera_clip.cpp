// The camera's clip planes on the device: Mitsuba's near_clip and far_clip (glTF's znear and
// zfar) are depths along the camera's +Z axis, and a camera ray sees only what lies between
// them (Mitsuba 3's perspective, thinlens and orthographic sensors). Every scene here is black
// geometry (reflectance 0, no emitter) in front of a constant environment of radiance 1, so a
// pixel is 1 exactly where its camera rays pass the geometry (clipped) and 0 where they stop
// on it.
#include "gpu_fixture.hpp"
#include "render_fixture.hpp"

#include "scene/primitives.hpp"

#include <doctest/doctest.h>

#include <glm/gtc/matrix_transform.hpp>

#include <string>

using namespace vkmech;

namespace {

// A camera at the origin looking along +z, 90 degrees across (tan = 1 on both axes of the
// square film), in front of an environment of radiance 1; no geometry yet.
Scene open_scene() {
    Scene s;
    s.source = "<camera clip>";
    Material black;
    black.id = "black";
    black.reflectance.value = glm::vec3(0.0f);
    s.materials.push_back(black);
    s.environment.kind = EnvironmentKind::Constant;
    s.environment.radiance = glm::vec3(1.0f);
    s.camera.to_world = glm::mat4(1.0f);
    s.camera.fov_deg = 90.0f;
    s.camera.fov_axis = "x";
    s.camera.width = s.camera.height = 8;
    return s;
}

// A black wall at depth z = `depth`, square, 8 wide: it fills the whole view (the view spans
// x, y in [-depth, depth] there), so the corner rays meet it sqrt(3) x depth from the camera.
void add_wall(Scene& s, float depth) {
    Mesh wall = make_rectangle(glm::scale(glm::translate(glm::mat4(1.0f), glm::vec3(0, 0, depth)), glm::vec3(4.0f)));
    wall.name = "wall";
    wall.material = 0;
    s.meshes.push_back(wall);
}

// How many of the frame's pixels read 1 (the environment) and how many 0 (black geometry), of
// its width x height; anything else is neither.
struct Counts {
    int sky = 0, black = 0, total = 0;
};
Counts count(const Frame& f) {
    Counts c;
    for (const PixelStats& p : f.pixels) {
        ++c.total;
        if (std::abs(p.lum_mean - 1.0) < 1e-5) ++c.sky;
        if (p.lum_mean == 0.0) ++c.black;
    }
    return c;
}

Counts render_counts(vkmech::vk::Context& ctx, const Scene& s) {
    testing::RenderSetup setup;
    setup.res = 8;
    setup.spp = 4;
    return count(testing::render_scene(ctx, s, setup));
}

}  // namespace

TEST_SUITE("gpu") {
    TEST_CASE("camera clip: a box around the camera nearer than near_clip is cut away and the scene beyond shows") {
        VKMECH_REQUIRE_GPU(ctx);
        // A closed black box, faces at depth 0.5 (its far corners 0.87 from the camera), and
        // behind it a black wall at depth 3 covering the left half of the view (x > 0 is the
        // image's left), the sky in the right half.
        Scene s = open_scene();
        Mesh box = make_cube(glm::scale(glm::mat4(1.0f), glm::vec3(0.5f)));
        box.name = "box";
        box.material = 0;
        s.meshes.push_back(box);
        Mesh wall =
            make_rectangle(glm::scale(glm::translate(glm::mat4(1.0f), glm::vec3(5.0f, 0, 3.0f)), glm::vec3(5.0f)));
        wall.name = "wall";
        wall.material = 0;
        s.meshes.push_back(wall);

        Counts inside = render_counts(*ctx, s);  // the default near_clip (0.01): the box
        CHECK(inside.black == inside.total);

        s.camera.near_clip = 0.9f;  // beyond the box's nearest face on every ray
        testing::RenderSetup setup;
        setup.res = 8;
        setup.spp = 4;
        Frame f = testing::render_scene(*ctx, s, setup);
        for (int y = 0; y < 8; ++y)
            for (int x = 0; x < 8; ++x) {
                CAPTURE(x);
                CAPTURE(y);
                const double v = f.pixels[static_cast<size_t>(y) * 8 + x].lum_mean;
                if (x < 4)
                    CHECK(v == 0.0);  // the wall
                else
                    CHECK(v == doctest::Approx(1.0).epsilon(1e-5));  // the sky
            }
    }

    TEST_CASE("camera clip: near_clip and far_clip are depths along the view axis - not distances along the ray") {
        VKMECH_REQUIRE_GPU(ctx);
        // A wall at depth 1 filling a 90-degree view: its corner rays meet it at distance
        // sqrt(3), the centre ray at 1. Clip planes at depth 1 +- 2 % keep or remove all of it;
        // a clip at distance 1.02 along each ray would keep the wall's outer parts.
        Scene base = open_scene();
        add_wall(base, 1.0f);
        Scene plain = base;
        Counts seen = render_counts(*ctx, plain);
        REQUIRE(seen.black == seen.total);

        struct Case {
            const char* what;
            float near_clip, far_clip;
            bool wall_seen;
        };
        const Case cases[] = {{"near_clip before the wall", 0.98f, 100.0f, true},
                              {"near_clip past the wall", 1.02f, 100.0f, false},
                              {"far_clip past the wall", 0.01f, 1.02f, true},
                              {"far_clip before the wall", 0.01f, 0.98f, false}};
        for (const char* type : {"perspective", "thinlens", "orthographic"}) {
            for (const Case& c : cases) {
                const std::string camera = type, what = c.what;
                CAPTURE(camera);
                CAPTURE(what);
                Scene s = base;
                s.camera.near_clip = c.near_clip;
                s.camera.far_clip = c.far_clip;
                if (camera == "thinlens") {
                    // Rays from a wide lens converging at depth 0.7: far from the pinhole's.
                    s.camera.type = CameraType::ThinLens;
                    s.camera.aperture_radius = 0.3f;
                    s.camera.focus_distance = 0.7f;
                } else if (camera == "orthographic") {
                    s.camera.type = CameraType::Orthographic;  // x, y in [-1, 1], all at depth 1
                }
                Counts n = render_counts(*ctx, s);
                if (c.wall_seen)
                    CHECK(n.black == n.total);
                else
                    CHECK(n.sky == n.total);
            }
        }
    }
}
