// The material table (shaders/shared/materials.h) and what is derived from it:
// every row renders the same through its scene's specialized pipeline as
// through the generic one (a feature bit missing from a row would compile the
// model out of its own scene and fail here), and the host's names, features
// and lobe flags come from the same rows.
#include "gpu_fixture.hpp"
#include "render_fixture.hpp"
#include "scene_fixtures.hpp"
#include "temp_dir.hpp"

#include "bsdf.glsl"
#include "render/features.hpp"
#include "scene/scene.hpp"

#include <doctest/doctest.h>

#include <cmath>
#include <fstream>
#include <set>
#include <string>

using namespace vkmech;

namespace {

// One sphere of the material `plugin` (its Mitsuba defaults; `body` adds
// parameters) on a diffuse floor under a rectangle lamp.
std::string one_material_scene(const std::string& plugin, const std::string& body) {
    return testing::sphere_on_floor_xml("<bsdf type=\"" + plugin + "\">" + body + "</bsdf>");
}

double luminance_sum(const Frame& f) {
    double s = 0.0;
    for (const PixelStats& p : f.pixels) s += luminance(p.rgb_sum[0], p.rgb_sum[1], p.rgb_sum[2]);
    return s;
}

}  // namespace

TEST_CASE("material table: the rows have distinct codes and plugin names, and the host reads them") {
    std::set<std::string> names;
    for (uint32_t t = 0; t < gpu::MAT_COUNT; ++t) {
        const BsdfType type = static_cast<BsdfType>(t);
        const std::string name = to_string(type);
        CAPTURE(name);
        CHECK(name != "unknown");
        CHECK(names.insert(name).second);
        REQUIRE(bsdf_type_of(name).has_value());
        CHECK(*bsdf_type_of(name) == type);
        // blendbsdf has no lobes of its own: a hit resolves it to a component first.
        CHECK((gpu::material_lobes(t) != 0u) == (type != BsdfType::Blend));
        CHECK((gpu::material_features(t) & ~gpu::FEATURE_BITS_ALL) == 0u);
    }
    CHECK_FALSE(bsdf_type_of("phong").has_value());
    CHECK(std::string(to_string(static_cast<BsdfType>(gpu::MAT_COUNT))) == "unknown");
    CHECK(gpu::material_lobes(gpu::MAT_COUNT) == 0u);
}

// A render on the device: in the GPU suite, which the sanitizer build leaves out (lavapipe under ASan).
TEST_SUITE("gpu") {
    TEST_CASE("material table: every material renders the same through the specialized and the generic pipeline") {
        VKMECH_REQUIRE_GPU(ctx);
        testing::TempDir dir("material_table");
        struct Case {
            std::string plugin, body;
        };
        std::vector<Case> cases;
        for (uint32_t t = 0; t < gpu::MAT_COUNT; ++t) {
            const BsdfType type = static_cast<BsdfType>(t);
            // A blend needs its two components (here two families, so that its pipeline needs
            // their features and its own).
            cases.push_back({to_string(type), type != BsdfType::Blend
                                                  ? ""
                                                  : R"(<float name="weight" value="0.3"/>)"
                                                    R"(<bsdf type="diffuse"/><bsdf type="roughconductor"/>)"});
        }
        // FEATURE_TEXTURES: a textured reflectance.
        cases.push_back({"diffuse",
                         R"(<texture type="checkerboard" name="reflectance"><rgb name="color0" value="0.1"/>)"
                         R"(<rgb name="color1" value="0.8, 0.4, 0.2"/></texture>)"});
        for (const Case& c : cases) {
            CAPTURE(c.plugin);
            CAPTURE(c.body);
            const std::string path = dir.file(c.plugin + std::to_string(c.body.size()) + ".xml");
            std::ofstream(path) << one_material_scene(c.plugin, c.body);
            const Scene scene = load_scene(path);
            const Features spec = Features::from_scene(scene);
            // The sphere's model alone decides the material features (the floor is diffuse; a
            // blend's components come before it).
            uint32_t sphere = 0u;
            for (size_t i = 1; i < scene.materials.size(); ++i)
                sphere |= gpu::material_features(static_cast<uint32_t>(scene.materials[i].type));
            CHECK(spec.materials == sphere);
            testing::RenderSetup setup;
            setup.res = 24;
            setup.spp = 8;
            setup.estimator = Estimator::Mis;  // evaluation, pdf and sampling all matter
            const Frame a = testing::render_scene(*ctx, scene, setup);
            setup.generic = true;
            const Frame b = testing::render_scene(*ctx, scene, setup);
            const std::vector<double> va = testing::pixel_values(a), vb = testing::pixel_values(b);
            REQUIRE(va.size() == vb.size());
            const double total = luminance_sum(b);
            REQUIRE(total > 0.0);
            CHECK(std::abs(luminance_sum(a) - total) <= 1e-5 * total);
            CHECK(testing::max_relative_difference(va, vb) <= 1e-4);
        }
    }
}
