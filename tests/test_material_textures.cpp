// Textures on material parameters other than colours, on the device. An
// emission texture (glTF's emissiveTexture): the emitter's radiance times the
// texture, texel by texel, whether the light is seen by the camera, hit by a
// BSDF-sampled ray or sampled by NEE. A metallic-roughness texture (glTF's):
// principled's metallic and roughness read at each hit, not averaged; likewise
// Mitsuba's textured alpha on roughconductor and roughdielectric.
#include "cli_run.hpp"
#include "gpu_fixture.hpp"
#include "render_fixture.hpp"
#include "scene_fixtures.hpp"
#include "temp_dir.hpp"

#include "io/exr.hpp"

#include "render/gpu_scene.hpp"
#include "scene/primitives.hpp"

#include <doctest/doctest.h>

#include <glm/gtc/matrix_transform.hpp>

#include <bit>
#include <cmath>
#include <fstream>

using namespace vkmech;

namespace {

// A 2 x 2 texture, nearest lookup: red, green / blue, white (top row first).
Texture checker_2x2() {
    Texture t;
    t.width = t.height = 2;
    t.nearest = true;
    t.rgb = {1, 0, 0, 0, 1, 0, 0, 0, 1, 1, 1, 1};
    return t;
}

// The quad scene's camera (at z = -3 looking along +z) facing a 2 x 2 emissive
// quad at z = 0 whose front faces the camera, radiance (2, 3, 4) times the
// texture; uv (0, 0) at world (-1, 1).
Scene emissive_quad() {
    Scene s = testing::quad_scene();
    s.textures.push_back(checker_2x2());
    Material glow;
    glow.id = "glow";
    glow.reflectance.value = glm::vec3(0.0f);
    glow.emission_texture = 0;
    s.materials.push_back(glow);
    Mesh& q = s.meshes[0];
    q.positions = {{-1, -1, 0}, {-1, 1, 0}, {1, 1, 0}, {1, -1, 0}};  // normal -z, towards the camera
    q.uvs = {{0, 1}, {0, 0}, {1, 0}, {1, 1}};
    q.material = 1;
    q.emitter = 0;
    s.emitters.push_back({glm::vec3(2, 3, 4), 0});
    return s;
}

// The quad scene's camera facing its quad (30 degree view), lit by a directional light at
// about 50 degrees and a dim constant environment.
Scene lit_quad() {
    Scene s = testing::quad_scene();
    s.camera.fov_deg = 30.0f;
    s.directional_lights.push_back({glm::normalize(glm::vec3(0.6f, -0.5f, 0.62f)), glm::vec3(3.0f)});
    s.environment.kind = EnvironmentKind::Constant;
    s.environment.radiance = glm::vec3(0.1f);
    return s;
}

// Gives s a 2 x 1 texture (nearest lookup; rgb of texel 0, then texel 1) as texture 0 and its
// quad the uvs that put texel 0 on x < 0 and texel 1 on x > 0.
void two_texel_quad(Scene& s, std::vector<float> rgb) {
    Texture t;
    t.width = 2;
    t.height = 1;
    t.nearest = true;
    t.rgb = std::move(rgb);
    s.textures.push_back(t);
    Mesh& q = s.meshes[0];
    q.positions = {{-1, -1, 0}, {-1, 1, 0}, {1, 1, 0}, {1, -1, 0}};
    q.uvs = {{0, 1}, {0, 0}, {1, 0}, {1, 1}};
}

// The quad scene's 2 x 2 quad split at x = 0 into two meshes: the left half (x < 0, image
// right) with material 0 and the right half with material 1 (the reference a texture whose
// two texels cover those halves must match).
void split_quad(Scene& s, const Material& left, const Material& right) {
    s.materials = {left, right};
    s.meshes[0].positions = {{-1, -1, 0}, {-1, 1, 0}, {0, 1, 0}, {0, -1, 0}};
    Mesh r = s.meshes[0];
    r.positions = {{0, -1, 0}, {0, 1, 0}, {1, 1, 0}, {1, -1, 0}};
    r.material = 1;
    s.meshes.push_back(r);
}

// A diffuse quad (albedo 0.5) facing the camera (normal -z) whose uvs are not mirrored as seen
// from its front: u grows to the image right (world -x), v downwards; so dp/du = (-2, 0, 0),
// dp/dv = (0, -2, 0) and n x dp/du = +y. Lit by one directional light (irradiance 2), nothing
// else, so each pixel is albedo / pi x 2 x cos: exact up to float rounding.
const glm::vec3 kFacingQuadLight = glm::normalize(glm::vec3(0.5f, -0.3f, 0.8f));
Scene facing_quad() {
    Scene s = testing::quad_scene();
    s.camera.fov_deg = 30.0f;
    Mesh& q = s.meshes[0];
    q.positions = {{1, 1, 0}, {1, -1, 0}, {-1, -1, 0}, {-1, 1, 0}};
    q.uvs = {{0, 0}, {0, 1}, {1, 1}, {1, 0}};
    s.materials[0].reflectance.value = glm::vec3(0.5f);
    s.directional_lights.push_back({kFacingQuadLight, glm::vec3(2.0f)});
    return s;
}
// What facing_quad renders where the shading normal is n.
double facing_quad_radiance(const glm::vec3& n) {
    return 0.5 * 2.0 * glm::dot(n, -kFacingQuadLight) / 3.14159265358979;
}

// A 16 x 16 render, 64 spp, MIS: the size half_means reads.
Frame render_halves(vkmech::vk::Context& ctx, const Scene& s) {
    testing::RenderSetup setup;
    setup.res = 16;
    setup.spp = 64;
    setup.estimator = Estimator::Mis;
    return testing::render_scene(ctx, s, setup);
}

// Mean luminance of two 16 x 16 renders over the inside of one image half (0: left, 1:
// right), and the variance of the difference of those means.
struct HalfMeans {
    double a = 0.0, b = 0.0, var = 0.0;
};
HalfMeans half_means(const Frame& fa, const Frame& fb, int half) {
    HalfMeans h;
    int n = 0;
    for (int y = 2; y < 14; ++y)
        for (int x = half * 8 + 1; x < half * 8 + 7; ++x) {
            const size_t i = static_cast<size_t>(y) * 16 + x;
            const PixelStats &a = fa.pixels[i], &b = fb.pixels[i];
            h.a += a.lum_mean;
            h.b += b.lum_mean;
            h.var += a.lum_var() / a.count + b.lum_var() / b.count;
            ++n;
        }
    h.a /= n;
    h.b /= n;
    h.var /= static_cast<double>(n) * n;
    return h;
}

}  // namespace

TEST_CASE("emission texture: power selection weighs an emitter by its radiance times the texture's mean") {
    Scene s = emissive_quad();
    Mesh panel = make_rectangle(glm::translate(glm::mat4(1.0f), {0, 0, -2}));
    panel.material = 0;
    panel.emitter = 1;
    s.emitters.push_back({glm::vec3(1.0f), static_cast<int>(s.meshes.size())});
    s.meshes.push_back(panel);
    SceneArrays a = flatten_scene(s, LightSelection::Power);
    // Texture mean (0.5, 0.5, 0.5) x (2, 3, 4): luminance 0.5 x (2 R + 3 G + 4 B weights); area 4 each.
    double lum_textured = 0.5 * (0.2126 * 2 + 0.7152 * 3 + 0.0722 * 4), lum_panel = 1.0;
    double p0 = lum_textured / (lum_textured + lum_panel);
    CHECK(std::bit_cast<float>(a.emitters[0].info.w) == doctest::Approx(p0 / 4.0).epsilon(1e-5));
}

TEST_CASE("emission texture: a Mitsuba area emitter's radiance texture becomes its shape's own emission texture") {
    testing::TempDir dir("emitter_texture");
    std::vector<float> px = {1, 2, 3, 4};
    write_exr_layers(dir.file("glow.exr"), 2, 2, {{"R", px}, {"G", px}, {"B", px}});
    std::ofstream(dir.file("s.xml")) << R"(<scene version="3.0.0"><sensor type="perspective"/>
  <bsdf type="diffuse" id="grey"/>
  <shape type="rectangle"><ref id="grey"/>
    <emitter type="area"><texture type="bitmap" name="radiance"><string name="filename" value="glow.exr"/></texture></emitter>
  </shape>
  <shape type="cube"><ref id="grey"/></shape>
</scene>)";
    Scene s = load_scene(dir.file("s.xml"));
    REQUIRE(s.emitters.size() == 1);
    CHECK(s.emitters[0].radiance == glm::vec3(1.0f));
    const Mesh& panel = s.meshes[s.emitters[0].mesh];
    const Material& m = s.materials[panel.material];
    REQUIRE(m.emission_texture >= 0);
    CHECK(s.textures[m.emission_texture].rgb[3 * 3] == 4.0f);
    // The cube keeps the shared material, without the texture.
    CHECK(s.materials[s.meshes[1].material].emission_texture == -1);
    CHECK(s.warnings.empty());

    // Declared at top level with an id and used through <ref>, as Mitsuba's docs scenes do.
    std::ofstream(dir.file("d.xml")) << R"(<scene version="3.0.0"><sensor type="perspective"/>
  <emitter type="area" id="sky"><texture type="checkerboard" name="radiance"><rgb name="color0" value="2"/></texture></emitter>
  <shape type="rectangle"><ref id="sky"/></shape>
</scene>)";
    Scene d = load_scene(dir.file("d.xml"));
    REQUIRE(d.emitters.size() == 1);
    const Material& dm = d.materials[d.meshes[0].material];
    REQUIRE(dm.emission_texture >= 0);
    CHECK(d.textures[dm.emission_texture].kind == TextureKind::Checkerboard);
    CHECK(d.textures[dm.emission_texture].rgb[0] == 2.0f);
}

TEST_CASE("normal map: Mitsuba's normalmap and bumpmap wrappers give their nested bsdf the map, one per material") {
    testing::TempDir dir("normalmap");
    std::vector<float> x = {0.5f}, z = {1.0f};
    write_exr_layers(dir.file("n.exr"), 1, 1, {{"R", x}, {"G", x}, {"B", z}});
    std::ofstream(dir.file("s.xml")) << R"(<scene version="3.0.0"><sensor type="perspective"/>
  <shape type="rectangle"><bsdf type="normalmap">
    <texture name="normalmap" type="bitmap"><string name="filename" value="n.exr"/><boolean name="raw" value="true"/></texture>
    <bsdf type="roughconductor"/></bsdf></shape>
  <shape type="cube"><bsdf type="bumpmap"><texture type="bitmap"><string name="filename" value="n.exr"/></texture>
    <bsdf type="diffuse"/></bsdf></shape>
</scene>)";
    Scene s = load_scene(dir.file("s.xml"));
    const Material& m = s.materials[s.meshes[0].material];
    CHECK(m.type == BsdfType::RoughConductor);
    REQUIRE(m.normal_texture >= 0);
    CHECK_FALSE(m.normal_uv_handed);  // Mitsuba: b = n x dp/du whatever the uv layout
    CHECK(s.textures[m.normal_texture].rgb[2] == 1.0f);
    const Material& b = s.materials[s.meshes[1].material];
    CHECK(b.normal_texture == -1);
    CHECK(b.bump_texture >= 0);  // the unnamed nested texture (0.6 style)
    CHECK(b.bump_scale == 1.0f);
    for (const auto& w : s.warnings) {
        CHECK(w.find("bump") == std::string::npos);
        CHECK(w.find("normal map") == std::string::npos);
    }
    // Packed for the device: the normal map's slot low in frame_tex.x, the bump map's high.
    const SceneArrays a = flatten_scene(s);
    CHECK(a.materials[s.meshes[0].material].frame_tex.x == static_cast<uint32_t>(m.normal_texture + 1));
    CHECK(a.materials[s.meshes[1].material].frame_tex.x == static_cast<uint32_t>(b.bump_texture + 1) << 16);
    // `vkmech check` names every texture slot of every material.
    const testing::CliRun check = testing::run_cli("check --scene " + dir.file("s.xml"));
    CHECK(check.code == 0);
    CHECK(check.output.find(" normal=" + dir.file("n.exr")) != std::string::npos);
    CHECK(check.output.find(" bump=" + dir.file("n.exr")) != std::string::npos);

    // Both around one bsdf: refused (one shading-normal texture per material).
    std::ofstream(dir.file("both.xml")) << R"(<scene version="3.0.0"><sensor type="perspective"/>
  <shape type="cube"><bsdf type="bumpmap"><texture type="bitmap"><string name="filename" value="n.exr"/></texture>
    <bsdf type="normalmap"><texture name="normalmap" type="bitmap"><string name="filename" value="n.exr"/></texture>
      <bsdf type="diffuse"/></bsdf></bsdf></shape>
</scene>)";
    CHECK_THROWS_WITH_AS(load_scene(dir.file("both.xml")), doctest::Contains("one shading-normal texture per material"),
                         SceneError);
}

TEST_CASE(
    "roughness texture: Mitsuba's textured alpha loads on roughconductor and roughdielectric, its mean as the "
    "constant") {
    testing::TempDir dir("alphatex");
    // 2 x 1 texels, linear (EXR): luminance 0.1 and 0.5.
    std::vector<float> v = {0.1f, 0.5f};
    write_exr_layers(dir.file("a.exr"), 2, 1, {{"R", v}, {"G", v}, {"B", v}});
    std::ofstream(dir.file("s.xml")) << R"(<scene version="3.0.0"><sensor type="perspective"/>
  <texture type="bitmap" id="rough"><string name="filename" value="a.exr"/></texture>
  <shape type="rectangle"><bsdf type="roughconductor"><ref name="alpha" id="rough"/></bsdf></shape>
  <shape type="cube"><bsdf type="roughdielectric"><float name="alpha_u" value="0.2"/>
    <texture name="alpha_v" type="bitmap"><string name="filename" value="a.exr"/></texture></bsdf></shape>
  <shape type="sphere"><bsdf type="roughplastic"><ref name="alpha" id="rough"/></bsdf></shape>
</scene>)";
    // roughplastic's alpha is a plain float in Mitsuba 3 (its tables are precomputed): a
    // texture there still needs --substitute.
    CHECK_THROWS_WITH_AS(load_scene(dir.file("s.xml")), doctest::Contains("--substitute"), SceneError);
    LoadOptions sub;
    sub.substitute_unsupported = true;
    Scene s = load_scene(dir.file("s.xml"), sub);
    const Material& c = s.materials[s.meshes[0].material];
    CHECK(c.type == BsdfType::RoughConductor);
    REQUIRE(c.alpha_u_texture >= 0);
    CHECK(c.alpha_v_texture == c.alpha_u_texture);
    CHECK(c.alpha_u == doctest::Approx(0.3f).epsilon(1e-4));  // the mean luminance
    CHECK(c.alpha_v == doctest::Approx(0.3f).epsilon(1e-4));
    const Material& d = s.materials[s.meshes[1].material];
    CHECK(d.type == BsdfType::RoughDielectric);
    CHECK(d.alpha_u_texture == -1);
    CHECK(d.alpha_u == doctest::Approx(0.2f));
    REQUIRE(d.alpha_v_texture >= 0);
    CHECK(d.alpha_v == doctest::Approx(0.3f).epsilon(1e-4));
    const Material& p = s.materials[s.meshes[2].material];
    CHECK(p.alpha_u_texture == -1);
    // Only roughplastic's alpha is a substitution.
    int alpha_subs = 0;
    for (const auto& line : s.substitutions) alpha_subs += line.find("float parameter 'alpha") != std::string::npos;
    CHECK(alpha_subs == 1);
    // Packed for the device: alpha_u's slot in the low half of frame_tex.z, alpha_v's in the high.
    const SceneArrays a = flatten_scene(s);
    const gpu::GpuMaterial& gc = a.materials[s.meshes[0].material];
    CHECK((gc.frame_tex.z & 0xFFFFu) == static_cast<uint32_t>(c.alpha_u_texture + 1));
    CHECK((gc.frame_tex.z >> 16) == static_cast<uint32_t>(c.alpha_v_texture + 1));
}

TEST_CASE(
    "metallic-roughness texture: Mitsuba's principled reads a bitmap roughness and metallic at each hit, "
    "through the glTF layout") {
    testing::TempDir dir("principledtex");
    // 2 x 1 linear texels: luminance 0.1 and 0.5 (r), 1 and 0 (m).
    std::vector<float> r = {0.1f, 0.5f}, m = {1.0f, 0.0f};
    write_exr_layers(dir.file("r.exr"), 2, 1, {{"R", r}, {"G", r}, {"B", r}});
    write_exr_layers(dir.file("m.exr"), 2, 1, {{"R", m}, {"G", m}, {"B", m}});
    std::ofstream(dir.file("s.xml")) << R"(<scene version="3.0.0"><sensor type="perspective"/>
  <shape type="rectangle"><bsdf type="principled"><float name="metallic" value="0.25"/>
    <texture name="roughness" type="bitmap"><string name="filename" value="r.exr"/></texture></bsdf></shape>
  <shape type="cube"><bsdf type="principled">
    <texture name="roughness" type="bitmap"><string name="filename" value="r.exr"/></texture>
    <texture name="metallic" type="bitmap"><string name="filename" value="m.exr"/></texture></bsdf></shape>
  <shape type="sphere"><bsdf type="principled">
    <texture name="metallic" type="checkerboard"><float name="color0" value="0.7"/><float name="color1" value="0.1"/>
    </texture></bsdf></shape>
  <shape type="disk"><bsdf type="principled">
    <texture name="metallic" type="checkerboard"/>
    <texture name="roughness" type="bitmap"><string name="filename" value="r.exr"/></texture></bsdf></shape>
</scene>)";
    // A checkerboard and a bitmap (two layouts) keep their means (--substitute).
    CHECK_THROWS_WITH_AS(load_scene(dir.file("s.xml")), doctest::Contains("--substitute"), SceneError);
    LoadOptions sub;
    sub.substitute_unsupported = true;
    const Scene s = load_scene(dir.file("s.xml"), sub);
    auto texel = [&](const Material& mat, int i, int channel) {
        return s.textures.at(static_cast<size_t>(mat.metallic_roughness_texture)).rgb.at(3 * i + channel);
    };
    const Material& a = s.materials[s.meshes[0].material];
    REQUIRE(a.metallic_roughness_texture >= 0);
    CHECK(texel(a, 0, 1) == doctest::Approx(0.1f));  // G: roughness, texel by texel
    CHECK(texel(a, 1, 1) == doctest::Approx(0.5f));
    CHECK(texel(a, 0, 2) == doctest::Approx(0.25f));  // B: the constant metallic
    CHECK(texel(a, 1, 2) == doctest::Approx(0.25f));
    CHECK(a.roughness == doctest::Approx(0.3f));  // the constants: the means
    CHECK(a.metallic == doctest::Approx(0.25f));
    const Material& b = s.materials[s.meshes[1].material];
    REQUIRE(b.metallic_roughness_texture >= 0);
    CHECK(texel(b, 0, 1) == doctest::Approx(0.1f));
    CHECK(texel(b, 0, 2) == doctest::Approx(1.0f));
    CHECK(texel(b, 1, 2) == doctest::Approx(0.0f));
    CHECK(b.metallic == doctest::Approx(0.5f));
    // A checkerboard's two colours are combined like two texels.
    const Material& c = s.materials[s.meshes[2].material];
    REQUIRE(c.metallic_roughness_texture >= 0);
    CHECK(s.textures[c.metallic_roughness_texture].kind == TextureKind::Checkerboard);
    CHECK(texel(c, 0, 2) == doctest::Approx(0.7f));
    CHECK(texel(c, 1, 2) == doctest::Approx(0.1f));
    CHECK(texel(c, 0, 1) == doctest::Approx(0.5f));  // Mitsuba's default roughness
    const Material& d = s.materials[s.meshes[3].material];
    CHECK(d.metallic_roughness_texture == -1);
    int subs = 0;
    for (const auto& line : s.substitutions) subs += line.find("float parameter") != std::string::npos;
    CHECK(subs == 2);  // the disk's two
    const SceneArrays arrays = flatten_scene(s);
    CHECK((arrays.materials[s.meshes[1].material].header.w >> gpu::MAT_TEX_SHIFT) ==
          static_cast<uint32_t>(b.metallic_roughness_texture + 1));
}

TEST_SUITE("gpu") {
    TEST_CASE("emission texture: seen by the camera, each texel's quarter of the quad shows radiance x texel") {
        VKMECH_REQUIRE_GPU(ctx);
        Scene s = emissive_quad();
        s.camera.fov_deg = 30.0f;  // the quad fills the view: tan 15 deg x 3 = 0.8 < 1
        testing::RenderSetup setup;
        setup.res = 8;
        setup.spp = 4;
        Frame f = testing::render_scene(*ctx, s, setup);
        // Image quadrants (row-major, top row first) against the texels. The camera looks along +z
        // with +y up, so image left is world +x (Mitsuba's camera): texel (0, 0) at world (-1, 1)
        // lands top right.
        auto px = [&](int x, int y) {
            const PixelStats& p = f.pixels[static_cast<size_t>(y) * f.width + x];
            return glm::vec3(p.rgb_sum[0], p.rgb_sum[1], p.rgb_sum[2]) / static_cast<float>(p.count);
        };
        auto near = [](glm::vec3 a, glm::vec3 b) { return glm::length(a - b) < 1e-4f; };
        CHECK(near(px(6, 1), {2, 0, 0}));  // red
        CHECK(near(px(1, 1), {0, 3, 0}));  // green
        CHECK(near(px(6, 6), {0, 0, 4}));  // blue
        CHECK(near(px(1, 6), {2, 3, 4}));  // white
    }

    TEST_CASE("emission texture: NEE and MIS agree on a floor lit by a textured emitter") {
        VKMECH_REQUIRE_GPU(ctx);
        Scene s = emissive_quad();
        // The emitter above a diffuse floor, facing down; the camera looks at the floor.
        s.meshes[0].positions = {{-1, 1, -1}, {1, 1, -1}, {1, 1, 1}, {-1, 1, 1}};  // normal -y
        Mesh floor =
            make_rectangle(glm::scale(glm::rotate(glm::mat4(1.0f), -1.5707963f, glm::vec3(1, 0, 0)), glm::vec3(3.0f)));
        floor.material = 0;
        s.meshes.push_back(floor);
        s.camera.to_world = glm::mat4(1.0f);
        s.camera.to_world[3] = glm::vec4(0, 0.5f, -4, 1);
        double mean[2] = {}, var[2] = {};
        int i = 0;
        for (Estimator est : {Estimator::Nee, Estimator::Mis}) {
            testing::RenderSetup setup;
            setup.res = 16;
            setup.spp = 256;
            setup.batch = 128;
            setup.estimator = est;
            Frame f = testing::render_scene(*ctx, s, setup);
            for (const auto& p : f.pixels) {
                mean[i] += p.lum_mean / f.pixels.size();
                var[i] += p.lum_var() / p.count / (double(f.pixels.size()) * f.pixels.size());
            }
            ++i;
        }
        CAPTURE(mean[0]);
        CAPTURE(mean[1]);
        CHECK(mean[0] > 0.01);
        CHECK(std::abs(mean[0] - mean[1]) < 4.0 * std::sqrt(var[0] + var[1]));
    }

    TEST_CASE("metallic-roughness texture: each texel's half renders as the constant material of that texel") {
        VKMECH_REQUIRE_GPU(ctx);
        // A principled quad facing the camera, lit by a directional light at 50 degrees and a dim
        // constant environment; its texture: metallic 1, roughness 0.3 for u < 1/2 (world x < 0),
        // metallic 0, roughness 0.8 for u > 1/2.
        auto principled = [](float metallic, float roughness) {
            Material m;
            m.type = BsdfType::Principled;
            m.reflectance.value = glm::vec3(0.8f, 0.6f, 0.3f);
            m.metallic = metallic;
            m.roughness = roughness;
            return m;
        };
        Scene tex = lit_quad();
        two_texel_quad(tex, {0.0f, 0.3f, 1.0f, 0.0f, 0.8f, 0.0f});
        tex.materials[0] = principled(0.5f, 0.55f);  // the texture's means, as the loader sets them
        tex.materials[0].metallic_roughness_texture = 0;
        Scene ref = lit_quad();
        split_quad(ref, principled(1.0f, 0.3f), principled(0.0f, 0.8f));
        Frame ft = render_halves(*ctx, tex);
        Frame fr = render_halves(*ctx, ref);
        // Image left is world +x (texel 1); compare each half's mean luminance.
        for (int half = 0; half < 2; ++half) {
            const HalfMeans h = half_means(ft, fr, half);
            CAPTURE(half);
            CAPTURE(h.a);
            CAPTURE(h.b);
            CHECK(std::abs(h.a - h.b) < 4.0 * std::sqrt(h.var) + 1e-5);
        }
    }

    TEST_CASE("roughness texture: each texel's half of a roughconductor renders as the constant alpha of that texel") {
        VKMECH_REQUIRE_GPU(ctx);
        // A rough gold-tinted conductor quad facing the camera, lit by a directional light at
        // about 50 degrees and a dim constant environment; alpha 0.08 for u < 1/2 (world x < 0)
        // and 0.6 for u > 1/2: the narrow lobe's highlight and the wide one's differ by far more
        // than the noise.
        auto conductor = [](float alpha) {
            Material m;
            m.type = BsdfType::RoughConductor;
            m.distribution = MicrofacetDistribution::GGX;
            m.eta = glm::vec3(0.0f);
            m.k = glm::vec3(1.0f);
            m.specular_reflectance = glm::vec3(0.9f, 0.7f, 0.4f);
            m.alpha_u = m.alpha_v = alpha;
            return m;
        };
        Scene tex = lit_quad();
        two_texel_quad(tex, {0.08f, 0.08f, 0.08f, 0.6f, 0.6f, 0.6f});
        tex.materials[0] = conductor(0.34f);  // the texture's mean, as the loader sets it
        tex.materials[0].alpha_u_texture = tex.materials[0].alpha_v_texture = 0;
        Scene ref = lit_quad();
        split_quad(ref, conductor(0.08f), conductor(0.6f));
        Scene flat = lit_quad();  // the mean alpha everywhere: what the texture must not render as
        flat.materials[0] = conductor(0.34f);
        Frame ft = render_halves(*ctx, tex);
        Frame fr = render_halves(*ctx, ref);
        Frame ff = render_halves(*ctx, flat);
        // Image left is world +x (texel 1); compare each half's mean luminance.
        for (int half = 0; half < 2; ++half) {
            const HalfMeans h = half_means(ft, fr, half), flat_h = half_means(ft, ff, half);
            CAPTURE(half);
            CAPTURE(h.a);
            CAPTURE(h.b);
            CAPTURE(flat_h.b);
            CHECK(std::abs(h.a - h.b) < 4.0 * std::sqrt(h.var) + 1e-5);
            CHECK(std::abs(flat_h.a - flat_h.b) > 8.0 * std::sqrt(flat_h.var));  // not the mean alpha
        }
    }

    TEST_CASE("bump map: a constant height renders the plain plane, a ramp tilts the normal as Mitsuba's bump() says") {
        VKMECH_REQUIRE_GPU(ctx);
        // Heights 0, 1/4, 1/2, 3/4 across u (4 x 1 texels, bilinear): between the first and the
        // last texel centre (u in [1/8, 7/8], image columns 1..6 of 8) dh/du = 1/4 x 4 = 1, and
        // dh/dv = 0. Times scale s: dp/du' = (-2, 0, 0) + n s = (-2, 0, -s), dp/dv' = (0, -2, 0),
        // so the normal is (s, 0, -2) / sqrt(s^2 + 4) on the camera's side.
        auto bumped = [](std::vector<float> heights, float scale) {
            Scene s = facing_quad();
            Texture t;
            t.width = static_cast<int>(heights.size());
            t.height = 1;
            for (float h : heights) t.rgb.insert(t.rgb.end(), {h, h, h});
            s.textures.push_back(t);
            s.materials[0].bump_texture = 0;
            s.materials[0].bump_scale = scale;
            return s;
        };
        testing::RenderSetup setup;
        setup.res = 8;
        setup.spp = 4;
        Frame flat = testing::render_scene(*ctx, bumped({0.7f}, 3.0f), setup);
        Frame ramp = testing::render_scene(*ctx, bumped({0.0f, 0.25f, 0.5f, 0.75f}, 0.5f), setup);
        Frame steep = testing::render_scene(*ctx, bumped({0.0f, 0.25f, 0.5f, 0.75f}, -2.0f), setup);
        const double plain = facing_quad_radiance(glm::vec3(0, 0, -1));
        const double tilted = facing_quad_radiance(glm::normalize(glm::vec3(0.5f, 0.0f, -2.0f)));
        const double tilted_back = facing_quad_radiance(glm::normalize(glm::vec3(-2.0f, 0.0f, -2.0f)));
        CHECK(std::abs(tilted - plain) > 0.03);  // the tilts show
        CHECK(std::abs(tilted_back - plain) > 0.03);
        for (int y = 0; y < 8; ++y)
            for (int x = 1; x < 7; ++x) {
                CAPTURE(x);
                CAPTURE(y);
                const size_t i = static_cast<size_t>(y) * 8 + x;
                CHECK(flat.pixels[i].lum_mean == doctest::Approx(plain).epsilon(1e-5));
                CHECK(ramp.pixels[i].lum_mean == doctest::Approx(tilted).epsilon(1e-4));
                CHECK(steep.pixels[i].lum_mean == doctest::Approx(tilted_back).epsilon(1e-4));
            }
    }

    TEST_CASE("normal map: on a mirrored uv layout glTF's bitangent follows the layout, Mitsuba's stays n x t") {
        VKMECH_REQUIRE_GPU(ctx);
        // facing_quad with u mirrored (u grows to world +x): t = +x; ns x t = -y, while dp/dv
        // is -y, so a glTF map (uv_handed, MikkTSpace's sign) turns b to +y, against dp/dv, as on
        // the unmirrored quad; Mitsuba's normalmap keeps b = ns x t = -y.
        const glm::vec3 n = glm::normalize(glm::vec3(0.3f, 0.4f, 0.866f));
        auto mirrored = [&](bool uv_handed) {
            Scene s = facing_quad();
            s.meshes[0].uvs = {{1, 0}, {1, 1}, {0, 1}, {0, 0}};
            Texture t;
            t.width = t.height = 1;
            const glm::vec3 texel = 0.5f * (n + 1.0f);
            t.rgb = {texel.x, texel.y, texel.z};
            s.textures.push_back(t);
            s.materials[0].normal_texture = 0;
            s.materials[0].normal_uv_handed = uv_handed;
            return s;
        };
        testing::RenderSetup setup;
        setup.res = 8;
        setup.spp = 4;
        Frame gltf = testing::render_scene(*ctx, mirrored(true), setup);
        Frame mitsuba = testing::render_scene(*ctx, mirrored(false), setup);
        const glm::vec3 t(1, 0, 0), ns(0, 0, -1);
        const double expected_gltf =
            facing_quad_radiance(glm::normalize(t * n.x + glm::vec3(0, 1, 0) * n.y + ns * n.z));
        const double expected_mitsuba =
            facing_quad_radiance(glm::normalize(t * n.x + glm::vec3(0, -1, 0) * n.y + ns * n.z));
        CHECK(std::abs(expected_gltf - expected_mitsuba) > 0.05);  // the two conventions differ visibly
        for (size_t i = 0; i < gltf.pixels.size(); ++i) {
            CHECK(gltf.pixels[i].lum_mean == doctest::Approx(expected_gltf).epsilon(1e-4));
            CHECK(mitsuba.pixels[i].lum_mean == doctest::Approx(expected_mitsuba).epsilon(1e-4));
        }
    }

    TEST_CASE("normal map: a flat map renders the plain plane, a tilted one lights it as its normal says") {
        VKMECH_REQUIRE_GPU(ctx);
        auto quad = [](const glm::vec3& texel) {
            Scene s = facing_quad();
            if (texel.z > 0.0f) {
                Texture t;
                t.width = t.height = 1;
                t.rgb = {texel.x, texel.y, texel.z};
                s.textures.push_back(t);
                s.materials[0].normal_texture = 0;
            }
            return s;
        };
        testing::RenderSetup setup;
        setup.res = 8;
        setup.spp = 4;
        Frame plain = testing::render_scene(*ctx, quad(glm::vec3(0.0f)), setup);
        Frame flat = testing::render_scene(*ctx, quad(glm::vec3(0.5f, 0.5f, 1.0f)), setup);
        const glm::vec3 n = glm::normalize(glm::vec3(0.3f, 0.4f, 0.866f));
        Frame tilted = testing::render_scene(*ctx, quad(0.5f * (n + 1.0f)), setup);
        // Tangent frame: t = -x, b = +y, the normal -z.
        const glm::vec3 mapped =
            glm::normalize(glm::vec3(-1, 0, 0) * n.x + glm::vec3(0, 1, 0) * n.y + glm::vec3(0, 0, -1) * n.z);
        const double expected_plain = facing_quad_radiance(glm::vec3(0, 0, -1));
        const double expected_tilted = facing_quad_radiance(mapped);
        CHECK(std::abs(expected_tilted - expected_plain) > 0.05);  // the tilt shows
        for (size_t i = 0; i < plain.pixels.size(); ++i) {
            CHECK(plain.pixels[i].lum_mean == doctest::Approx(expected_plain).epsilon(1e-5));
            CHECK(flat.pixels[i].lum_mean == doctest::Approx(plain.pixels[i].lum_mean).epsilon(1e-5));
            CHECK(tilted.pixels[i].lum_mean == doctest::Approx(expected_tilted).epsilon(1e-4));
        }
    }
}
