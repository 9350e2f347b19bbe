// Emitters at infinity (docs/descriptor.md §1): the environment map's sampling
// against its own density (chi-square, on the CPU, from the very GLSL the GPU
// runs), the light table's selection, the Mitsuba loader, and on the device a
// white furnace under a constant environment, NEE against MIS under a map, and
// a directional light's exact irradiance.
#include "chi2.hpp"
#include "gpu_fixture.hpp"
#include "render_fixture.hpp"
#include "scene_fixtures.hpp"
#include "temp_dir.hpp"

#include "io/exr.hpp"
#include "render/descriptor.hpp"
#include "render/gpu_scene.hpp"
#include "scene/environment.hpp"
#include "scene/primitives.hpp"

#include <doctest/doctest.h>

#include <glm/gtc/matrix_transform.hpp>

#include <algorithm>
#include <bit>
#include <cmath>
#include <fstream>
#include <tuple>
#include <utility>
#include <vector>

namespace {
// The texel array the shared environment code reads in these tests.
const std::vector<glm::vec4>* g_env_texels = nullptr;
}  // namespace
#define ENV_TEXEL(i) ((*g_env_texels)[i])
#include "environment.glsl"

using namespace vkmech;
using shader::env_dir_to_uv;
using shader::env_eval;
using shader::env_pdf;
using shader::env_sample;
using shader::env_uv_to_dir;
using testing::RenderSetup;

namespace {

constexpr double kPi = 3.14159265358979323846;

// A w x h lat-long map made for the tests: a sky brighter towards the zenith,
// a small hot spot 1000x brighter, and a black band (rows the sampler must
// never choose) below the horizon.
Texture test_map(int w, int h) {
    Texture t;
    t.width = w;
    t.height = h;
    t.rgb.resize(3 * static_cast<size_t>(w) * h);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            float* c = &t.rgb[3 * (static_cast<size_t>(y) * w + x)];
            float sky = y < h / 2 ? 0.2f + 0.8f * (1.0f - float(y) / (h / 2)) : (y < 3 * h / 4 ? 0.0f : 0.1f);
            c[0] = sky * (1.0f + 0.5f * std::sin(6.28f * x / w));
            c[1] = sky;
            c[2] = sky * 1.5f;
        }
    for (int y = h / 8; y < h / 8 + 2; ++y)
        for (int x = w / 3; x < w / 3 + 2; ++x)
            for (int c = 0; c < 3; ++c) t.rgb[3 * (static_cast<size_t>(y) * w + x) + c] = 1000.0f;
    return t;
}

Scene scene_with_map(const glm::mat3& to_world, float scale = 1.0f) {
    Scene s = testing::quad_scene();
    s.environment.kind = EnvironmentKind::Map;
    s.environment.map = test_map(24, 12);
    s.environment.scale = scale;
    s.environment.to_world = to_world;
    return s;
}

// A lat-long cell grid aligned with the map's pixels (2 x 2 pixels a cell): the
// density is constant in (u, v) inside each pixel, so a midpoint rule over
// sub-cells that never straddle a pixel edge integrates env_pdf exactly.
struct Chi2Result {
    double chi2 = 0.0, pval = 0.0, mass = 0.0;
    int dof = 0;
    long outside = 0;  // samples in cells of zero expected mass
};

Chi2Result env_chi2(const SceneArrays& a, int n, uint64_t seed) {
    g_env_texels = &a.texels;
    const gpu::GpuEnvironment& e = a.environment;
    const int w = static_cast<int>(e.map.z), h = static_cast<int>(e.map.w);
    const int cw = w / 2, ch = h / 2, sub = 4;
    std::vector<double> expected(static_cast<size_t>(cw) * ch, 0.0), observed(expected.size(), 0.0);
    const glm::mat3 to_world(glm::vec3(e.to_world0), glm::vec3(e.to_world1), glm::vec3(e.to_world2));
    const glm::mat3 world = glm::transpose(to_world);  // rows -> glm columns
    Chi2Result r;
    for (int cy = 0; cy < ch; ++cy)
        for (int cx = 0; cx < cw; ++cx)
            for (int sy = 0; sy < 2 * sub; ++sy)
                for (int sx = 0; sx < 2 * sub; ++sx) {
                    double du = 1.0 / (w * sub), dv = 1.0 / (h * sub);
                    double u = (2 * cx + (sx + 0.5) / sub) / w, v = (2 * cy + (sy + 0.5) / sub) / h;
                    glm::vec3 dir = world * env_uv_to_dir(glm::vec2(float(u), float(v)));
                    double jac = 2.0 * kPi * kPi * std::sin(kPi * v);
                    double p = env_pdf(e, dir) * jac * du * dv;
                    expected[static_cast<size_t>(cy) * cw + cx] += p;
                    r.mass += p;
                }
    testing::TestRng rng(seed);
    for (int i = 0; i < n; ++i) {
        glm::vec3 d = env_sample(e, glm::vec2(rng.next(), rng.next()));
        glm::vec3 l = glm::transpose(world) * d;
        glm::vec2 uv = env_dir_to_uv(l);
        int cx = std::min(int(uv.x * cw), cw - 1), cy = std::min(int(uv.y * ch), ch - 1);
        observed[static_cast<size_t>(cy) * cw + cx] += 1.0;
    }
    double pooled_obs = 0.0, pooled_exp = 0.0;
    for (size_t i = 0; i < expected.size(); ++i) {
        double ex = expected[i] * n;
        if (ex == 0.0) {
            r.outside += static_cast<long>(observed[i]);
        } else if (ex < 5.0) {
            pooled_obs += observed[i];
            pooled_exp += ex;
        } else {
            r.chi2 += (observed[i] - ex) * (observed[i] - ex) / ex;
            ++r.dof;
        }
    }
    if (pooled_exp > 0.0) {
        r.chi2 += (pooled_obs - pooled_exp) * (pooled_obs - pooled_exp) / pooled_exp;
        ++r.dof;
    }
    r.dof -= 1;
    r.pval = testing::gamma_q(0.5 * r.dof, 0.5 * r.chi2);
    return r;
}

// The image's mean luminance and its standard error (from the pixels' sample variances).
std::pair<double, double> image_mean(const Frame& f) {
    double sum = 0.0, var = 0.0;
    for (const auto& p : f.pixels) {
        sum += p.lum_mean;
        var += p.lum_var() / p.count;
    }
    return {sum / f.pixels.size(), std::sqrt(var) / f.pixels.size()};
}

Frame render_with(vkmech::vk::Context& ctx, const Scene& s, Estimator est, int res, uint32_t spp) {
    RenderSetup setup;
    setup.res = res;
    setup.spp = spp;
    setup.batch = 128;
    setup.estimator = est;
    return testing::render_scene(ctx, s, setup);
}

}  // namespace

TEST_CASE("environment: the lat-long frame is Mitsuba 3's (+y up, u = 0 towards -z, u = 1/4 towards +x)") {
    auto near = [](glm::vec3 a, glm::vec3 b) { return glm::length(a - b) < 1e-5f; };
    CHECK(near(env_uv_to_dir({0.0f, 0.5f}), {0, 0, -1}));
    CHECK(near(env_uv_to_dir({0.25f, 0.5f}), {1, 0, 0}));
    CHECK(near(env_uv_to_dir({0.5f, 0.5f}), {0, 0, 1}));
    CHECK(near(env_uv_to_dir({0.3f, 0.0f}), {0, 1, 0}));
    testing::TestRng rng(5);
    for (int i = 0; i < 1000; ++i) {
        glm::vec2 uv(rng.next(), 0.01f + 0.98f * rng.next());
        glm::vec2 back = env_dir_to_uv(env_uv_to_dir(uv));
        CHECK(std::abs(back.x - uv.x) < 2e-5f);
        CHECK(std::abs(back.y - uv.y) < 2e-5f);
    }
}

TEST_CASE("environment: a texel's centre direction evaluates to the texel times the scale (bilinear between centres)") {
    SceneArrays a = flatten_scene(scene_with_map(glm::mat3(1.0f), 2.0f));
    g_env_texels = &a.texels;
    Texture t = test_map(24, 12);
    for (auto [x, y] : {std::pair{0, 0}, std::pair{5, 3}, std::pair{8, 1}, std::pair{23, 11}}) {
        glm::vec3 d = env_uv_to_dir({(x + 0.5f) / 24.0f, (y + 0.5f) / 12.0f});
        glm::vec3 c = env_eval(a.environment, d);
        for (int k = 0; k < 3; ++k) CHECK(c[k] == doctest::Approx(2.0f * t.rgb[3 * (y * 24 + x) + k]).epsilon(1e-4));
    }
    // Half-way between two texel centres: their mean (away from the hot spot).
    glm::vec3 mid = env_eval(a.environment, env_uv_to_dir({6.0f / 24.0f, 4.5f / 12.0f}));
    CHECK(mid.y == doctest::Approx(0.5f * 2.0f * (t.rgb[3 * (4 * 24 + 5) + 1] + t.rgb[3 * (4 * 24 + 6) + 1])));
}

TEST_CASE("environment: map sampling follows its density (chi-square), which integrates to 1 and covers the radiance") {
    const glm::mat3 turned(glm::rotate(glm::mat4(1.0f), 0.7f, glm::normalize(glm::vec3(0.3f, 1.0f, -0.2f))));
    for (const glm::mat3& to_world : {glm::mat3(1.0f), turned}) {
        SceneArrays a = flatten_scene(scene_with_map(to_world));
        Chi2Result r = env_chi2(a, 400000, 11);
        CAPTURE(r.chi2);
        CAPTURE(r.dof);
        CHECK(r.mass == doctest::Approx(1.0).epsilon(1e-4));
        CHECK(r.outside == 0);
        CHECK(r.dof > 50);
        CHECK(r.pval > 1e-3);
        // Wherever the map sends light, the density is positive.
        testing::TestRng rng(17);
        long uncovered = 0, lit = 0;
        for (int i = 0; i < 20000; ++i) {
            float z = 1.0f - 2.0f * rng.next(), phi = 6.2831853f * rng.next(), s = std::sqrt(1.0f - z * z);
            glm::vec3 d(s * std::cos(phi), s * std::sin(phi), z);
            if (glm::length(env_eval(a.environment, d)) > 0.0f) {
                ++lit;
                if (!(env_pdf(a.environment, d) > 0.0f)) ++uncovered;
            }
        }
        CHECK(lit > 10000);
        CHECK(uncovered == 0);
    }
}

TEST_CASE("environment: the light table selects the environment and each directional light like any emitter") {
    Scene s = scene_with_map(glm::mat3(1.0f));
    Mesh panel = make_rectangle(glm::translate(glm::mat4(1.0f), {0, 0, -2}));
    panel.material = 0;
    panel.emitter = 0;
    s.emitters.push_back({glm::vec3(1.0f), static_cast<int>(s.meshes.size())});
    s.meshes.push_back(panel);
    s.directional_lights.push_back({glm::vec3(0, 0, 1), glm::vec3(3.0f)});
    s.directional_lights.push_back({glm::vec3(0, 0, 1), glm::vec3(0.0f)});  // emits nothing: never selected
    SceneArrays a = flatten_scene(s, LightSelection::Uniform);
    // Uniform: area emitter, environment and the lit directional light each 1/3.
    CHECK(a.environment.radiance.w == doctest::Approx(1.0 / 3.0).epsilon(1e-6));
    CHECK(a.directional[0].direction.w == doctest::Approx(1.0 / 3.0).epsilon(1e-6));
    CHECK(a.directional[1].direction.w == 0.0f);
    CHECK(std::bit_cast<float>(a.emitters[0].info.w) == doctest::Approx(1.0 / 3.0 / 4.0).epsilon(1e-5));
    REQUIRE(a.light_triangles.size() == 4);  // two triangles, the environment, one directional light
    CHECK(a.light_triangles[2].info.x == gpu::LIGHT_INFINITE);
    CHECK(a.light_triangles.back().cdf.x == 1.0f);
    // Power: r^2 x 4 pi x mean luminance for the environment, r^2 x luminance(E) for the light, against
    // the panel's luminance x area = 4 (r: the scene's bounding-sphere radius).
    SceneArrays p = flatten_scene(s, LightSelection::Power);
    glm::dvec3 ext = glm::dvec3(p.bbox_hi - p.bbox_lo);
    double r2 = 0.25 * glm::dot(ext, ext);
    double env = r2 * 4.0 * kPi * p.environment_luminance, dir = r2 * 3.0, total = 4.0 + env + dir;
    CHECK(p.environment.radiance.w == doctest::Approx(env / total).epsilon(1e-5));
    CHECK(p.directional[0].direction.w == doctest::Approx(dir / total).epsilon(1e-5));
}

TEST_CASE("environment: the Mitsuba loader reads envmap, constant and directional, one environment per scene") {
    testing::TempDir dir("envload");
    Texture t = test_map(8, 4);
    std::vector<ExrChannel> ch = {{"R", {}}, {"G", {}}, {"B", {}}};
    for (size_t i = 0; i < t.rgb.size(); ++i) ch[i % 3].data.push_back(t.rgb[i]);
    write_exr_layers(dir.file("sky.exr"), 8, 4, ch);
    auto scene_xml = [&](const std::string& emitters) {
        std::ofstream(dir.file("s.xml")) << "<scene version=\"3.0.0\"><sensor type=\"perspective\"/>"
                                            "<shape type=\"sphere\"/>"
                                         << emitters << "</scene>";
        return dir.file("s.xml");
    };
    Scene s =
        load_scene(scene_xml("<emitter type=\"envmap\"><string name=\"filename\" value=\"sky.exr\"/>"
                             "<float name=\"scale\" value=\"2\"/><transform name=\"to_world\">"
                             "<rotate y=\"1\" angle=\"90\"/></transform></emitter>"
                             "<emitter type=\"directional\"><vector name=\"direction\" value=\"0,-2,0\"/>"
                             "<rgb name=\"irradiance\" value=\"1,2,3\"/></emitter>"));
    REQUIRE(s.environment.kind == EnvironmentKind::Map);
    CHECK(s.environment.map.width == 8);
    CHECK(s.environment.scale == 2.0f);
    // A rotation by 90 degrees about +y takes +x to -z.
    glm::vec3 x = s.environment.to_world * glm::vec3(1, 0, 0);
    CHECK(glm::length(x - glm::vec3(0, 0, -1)) < 1e-5f);
    REQUIRE(s.directional_lights.size() == 1);
    CHECK(glm::length(s.directional_lights[0].direction - glm::vec3(0, -1, 0)) < 1e-6f);
    CHECK(s.directional_lights[0].irradiance == glm::vec3(1, 2, 3));
    CHECK(s.warnings.empty());

    Scene c =
        load_scene(scene_xml("<emitter type=\"constant\"><rgb name=\"radiance\" value=\"0.5\"/><float name=\"scale\" "
                             "value=\"3\"/></emitter>"));
    CHECK(c.environment.kind == EnvironmentKind::Constant);
    CHECK(c.environment.radiance == glm::vec3(1.5f));

    CHECK_THROWS_WITH_AS(load_scene(scene_xml("<emitter type=\"constant\"/><emitter type=\"constant\"/>")),
                         doctest::Contains("a second environment emitter"), SceneError);
    CHECK_THROWS_WITH_AS(
        load_scene(scene_xml("<emitter type=\"envmap\"><string name=\"filename\" value=\"none.exr\"/></emitter>")),
        doctest::Contains("cannot open environment map 'none.exr'"), SceneError);

    // The paper's treatment on request: an overhead panel of the mean radiance x scale, recorded.
    LoadOptions panel;
    panel.environment_panel = true;
    Scene p =
        load_scene(scene_xml("<emitter type=\"constant\"><rgb name=\"radiance\" value=\"0.5\"/></emitter>"), panel);
    CHECK(p.environment.kind == EnvironmentKind::None);
    REQUIRE(p.emitters.size() == 1);
    CHECK(p.emitters[0].radiance == glm::vec3(0.5f));
    REQUIRE(p.substitutions.size() == 1);
    CHECK(p.substitutions[0].find("overhead area panel") != std::string::npos);

    // --environment lights a scene with no light of its own, replacing nothing.
    LoadOptions env;
    env.environment_file = dir.file("sky.exr");
    env.environment_scale = 0.5f;
    Scene e = load_scene(scene_xml(""), env);
    CHECK(e.environment.kind == EnvironmentKind::Map);
    CHECK(e.environment.scale == 0.5f);
    CHECK(e.warnings.empty());
    CHECK(describe_lights_at_infinity(e).find("sky.exr") != std::string::npos);
}

TEST_SUITE("gpu") {
    TEST_CASE("environment: white furnace - a white diffuse sphere under a constant environment is invisible") {
        VKMECH_REQUIRE_GPU(ctx);
        Scene s;
        s.source = "<furnace>";
        Material white;
        white.reflectance.value = glm::vec3(1.0f);
        s.materials.push_back(white);
        Mesh sphere = make_sphere(glm::vec3(0.0f), 1.0f, glm::mat4(1.0f));
        sphere.material = 0;
        sphere.normals.clear();  // flat facets: a convex polyhedron, whose furnace is exact
        s.meshes.push_back(sphere);
        s.camera.to_world = glm::mat4(1.0f);
        s.camera.to_world[3] = glm::vec4(0, 0, -3.5f, 1);
        s.environment.kind = EnvironmentKind::Constant;
        s.environment.radiance = glm::vec3(0.8f);
        s.integrator.max_depth = 64;
        s.integrator.rr_depth = 64;  // no roulette: every path ends by escaping
        for (Estimator est : {Estimator::Nee, Estimator::Mis}) {
            Frame f = render_with(*ctx, s, est, 16, 256);
            // Not a structured binding: clang 14 cannot capture one in CAPTURE's lambda.
            const std::pair<double, double> ms = image_mean(f);
            const double mean = ms.first, se = ms.second;
            CAPTURE(std::string(to_string(est)));
            CAPTURE(mean);
            CAPTURE(se);
            CHECK(std::abs(mean - 0.8) < 4.0 * se + 1e-4);
            // A corner pixel sees the environment only: all of it emitter_direct.
            const PixelStats& corner = f.pixels[0];
            CHECK(corner.lum_mean == doctest::Approx(0.8).epsilon(1e-5));
            CHECK(corner.bucket_sum[gpu::BUCKET_EMITTER_DIRECT] / corner.count == doctest::Approx(0.8).epsilon(1e-5));
        }
    }

    TEST_CASE("environment: under a map, NEE and MIS agree (its sampling density is the one MIS weighs with)") {
        VKMECH_REQUIRE_GPU(ctx);
        const glm::mat3 turned(glm::rotate(glm::mat4(1.0f), 0.5f, glm::vec3(0, 1, 0)));
        Scene s = scene_with_map(turned);
        // A glossy sphere above a diffuse floor, seen from the side.
        s.meshes.clear();
        Material rough;
        rough.type = BsdfType::RoughConductor;
        rough.alpha_u = rough.alpha_v = 0.25f;
        s.materials.push_back(rough);
        Mesh sphere = make_sphere(glm::vec3(0, 1, 0), 1.0f, glm::mat4(1.0f));
        sphere.material = 1;
        s.meshes.push_back(sphere);
        Mesh floor =
            make_rectangle(glm::scale(glm::rotate(glm::mat4(1.0f), -1.5707963f, glm::vec3(1, 0, 0)), glm::vec3(4.0f)));
        floor.material = 0;
        s.meshes.push_back(floor);
        s.camera.to_world = glm::inverse(glm::lookAt(glm::vec3(0, 2, -6), glm::vec3(0, 0.7f, 0), glm::vec3(0, 1, 0)));
        s.camera.to_world[0] = -s.camera.to_world[0];  // Mitsuba's camera: +z forward (lookAt's is -z)
        s.camera.to_world[2] = -s.camera.to_world[2];
        double mean[2], se[2];
        int i = 0;
        for (Estimator est : {Estimator::Nee, Estimator::Mis}) {
            std::tie(mean[i], se[i]) = image_mean(render_with(*ctx, s, est, 24, 512));
            ++i;
        }
        CAPTURE(mean[0]);
        CAPTURE(mean[1]);
        CAPTURE(se[0]);
        CAPTURE(se[1]);
        CHECK(mean[0] > 0.05);
        CHECK(std::abs(mean[0] - mean[1]) < 4.0 * std::hypot(se[0], se[1]));
    }

    TEST_CASE("environment: a directional light gives a diffuse plane exactly albedo x irradiance x cos / pi") {
        VKMECH_REQUIRE_GPU(ctx);
        Scene s = testing::quad_scene();
        // The quad, 20 x 20, facing the camera (normal -z).
        s.meshes[0].positions = {{-10, -10, 0}, {-10, 10, 0}, {10, 10, 0}, {10, -10, 0}};
        s.materials[0].reflectance.value = glm::vec3(0.5f);
        const float theta = 1.0471976f;  // 60 degrees from the normal
        s.directional_lights.push_back({glm::vec3(std::sin(theta), 0.0f, std::cos(theta)), glm::vec3(2.0f)});
        RenderSetup setup;
        setup.res = 8;
        setup.spp = 8;
        Frame f = testing::render_scene(*ctx, s, setup);
        const double expected = 0.5 * 2.0 * 0.5 / kPi;
        for (const auto& p : f.pixels) {
            CHECK(p.lum_mean == doctest::Approx(expected).epsilon(1e-5));
            CHECK(p.bucket_sum[gpu::BUCKET_DIRECT] / p.count == doctest::Approx(expected).epsilon(1e-5));
        }
    }
}
