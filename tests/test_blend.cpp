// Mitsuba's blendbsdf (docs/descriptor.md §2): (1 - weight) times the first nested bsdf
// plus weight times the second, the weight a constant or a texture read at each hit. The
// path tracer resolves the blend to one component per hit (shaders/pathtrace.comp
// blend_resolve), so a weight of 0 or 1 is exactly that component, a 0/1 texture is a
// per-hit choice, and a weight in between mixes the two in expectation.
// The blend is also the oracle for principled's textured float parameters: a 0/1 checkerboard
// weight over two constant principled materials is the principled material whose parameters are
// checkerboards of the two constants, when each parameter is read at each hit.
#include "gpu_fixture.hpp"
#include "render_fixture.hpp"
#include "scene_fixtures.hpp"
#include "temp_dir.hpp"

#include "scene/scene.hpp"

#include <doctest/doctest.h>

#include <cmath>
#include <fstream>
#include <string>
#include <tuple>

using namespace vkmech;

namespace {

std::string sphere_scene(const std::string& bsdf) { return testing::sphere_on_floor_xml(bsdf); }

const std::string kRed = R"(<bsdf type="diffuse"><rgb name="reflectance" value="0.8, 0.2, 0.1"/></bsdf>)";
const std::string kMirror = R"(<bsdf type="conductor"/>)";

std::string blend(const std::string& weight, const std::string& first, const std::string& second) {
    return R"(<bsdf type="blendbsdf">)" + weight + first + second + "</bsdf>";
}

std::string write(testing::TempDir& dir, const std::string& name, const std::string& text) {
    const std::string path = dir.file(name + ".xml");
    std::ofstream(path) << text;
    return path;
}

// 24 px, 16 spp, MIS, through the generic pipeline (one compile per kernel for a whole case).
testing::RenderSetup small_generic(vkmech::vk::KernelClass kernel = vkmech::vk::KernelClass::Auto) {
    testing::RenderSetup setup;
    setup.res = 24;
    setup.spp = 16;
    setup.estimator = Estimator::Mis;
    setup.generic = true;
    setup.kernel = kernel;
    return setup;
}

// The image's mean luminance and that mean's standard error (pixel variances over their counts).
std::pair<double, double> mean_and_error(const Frame& f) {
    double sum = 0.0, var = 0.0;
    for (const PixelStats& p : f.pixels) {
        sum += p.lum_mean;
        var += p.lum_var() / p.count;
    }
    const double n = static_cast<double>(f.pixels.size());
    return {sum / n, std::sqrt(var) / n};
}

}  // namespace

TEST_CASE(
    "blendbsdf: the loader reads the components, a constant or textured weight and the wrappers, and refuses what it "
    "cannot render") {
    testing::TempDir dir("blend_loader");
    SUBCASE("a constant weight, components in document order, lobes of both") {
        const Scene s =
            load_scene(write(dir, "c", sphere_scene(blend(R"(<float name="weight" value="0.3"/>)", kRed, kMirror))));
        const Material& b = s.materials.at(static_cast<size_t>(s.meshes[1].material));
        REQUIRE(b.type == BsdfType::Blend);
        CHECK(std::string(to_string(b.type)) == "blendbsdf");
        CHECK(b.blend_weight == doctest::Approx(0.3f));
        CHECK(b.blend_weight_texture == -1);
        CHECK(s.materials.at(static_cast<size_t>(b.blend_first)).type == BsdfType::Diffuse);
        CHECK(s.materials.at(static_cast<size_t>(b.blend_second)).type == BsdfType::Conductor);
        CHECK(s.lobe_flags(s.meshes[1].material) == (gpu::LOBE_BIT_D | gpu::LOBE_BIT_S));
        CHECK(s.substitutions.empty());
        CHECK(s.warnings.empty());
    }
    SUBCASE("Mitsuba's default weight is 0.5; a texture is kept, its mean luminance beside it") {
        const Scene d = load_scene(write(dir, "d", sphere_scene(blend("", kRed, kMirror))));
        CHECK(d.materials.at(static_cast<size_t>(d.meshes[1].material)).blend_weight == doctest::Approx(0.5f));
        const Scene t = load_scene(
            write(dir, "t",
                  sphere_scene(blend(R"(<texture type="checkerboard" name="weight">)"
                                     R"(<rgb name="color0" value="0"/><rgb name="color1" value="0.6"/></texture>)",
                                     kRed, kMirror))));
        const Material& b = t.materials.at(static_cast<size_t>(t.meshes[1].material));
        REQUIRE(b.blend_weight_texture >= 0);
        CHECK(t.textures.at(static_cast<size_t>(b.blend_weight_texture)).kind == TextureKind::Checkerboard);
        CHECK(b.blend_weight == doctest::Approx(0.3f).epsilon(1e-4));
        CHECK(b.has_texture());
    }
    SUBCASE("twosided around a blend marks the blend; a normal map in a component and around the blend is refused") {
        const Scene s = load_scene(
            write(dir, "two", sphere_scene("<bsdf type=\"twosided\">" + blend("", kRed, kMirror) + "</bsdf>")));
        const Material& b = s.materials.at(static_cast<size_t>(s.meshes[1].material));
        CHECK(b.type == BsdfType::Blend);
        CHECK(b.twosided);
        const std::string map =
            R"(<texture type="checkerboard" name="normalmap"><rgb name="color0" value="0.5, 0.5, 1"/>)"
            R"(<rgb name="color1" value="0.6, 0.5, 0.9"/></texture>)";
        const std::string mapped_red = "<bsdf type=\"normalmap\">" + map + kRed + "</bsdf>";
        CHECK_NOTHROW(load_scene(write(dir, "inner", sphere_scene(blend("", mapped_red, kMirror)))));
        CHECK_NOTHROW(load_scene(write(
            dir, "outer", sphere_scene("<bsdf type=\"normalmap\">" + map + blend("", kRed, kMirror) + "</bsdf>"))));
        CHECK_THROWS_WITH_AS(load_scene(write(dir, "both",
                                              sphere_scene("<bsdf type=\"normalmap\">" + map +
                                                           blend("", mapped_red, kMirror) + "</bsdf>"))),
                             doctest::Contains("a blendbsdf: in a component"), SceneError);
    }
    SUBCASE(
        "mixturebsdf (Mitsuba 0.6): a chain of blends, a black component for weights summing below 1, rescaled above") {
        const std::string light = R"(<bsdf type="diffuse"><rgb name="reflectance" value="0.8"/></bsdf>)";
        const Scene s =
            load_scene(write(dir, "mix",
                             sphere_scene(R"(<bsdf type="mixturebsdf"><string name="weights" value="0.5, 0.3"/>)" +
                                          light + kMirror + "</bsdf>")));
        const Material& m = s.materials.at(static_cast<size_t>(s.meshes[1].material));
        REQUIRE(m.type == BsdfType::Blend);
        CHECK(m.blend_weight == doctest::Approx(0.5f));  // the first with 0.5
        const Material& rest = s.materials.at(static_cast<size_t>(m.blend_second));
        REQUIRE(rest.type == BsdfType::Blend);
        CHECK(rest.blend_weight == doctest::Approx(0.4f));  // then the mirror with 0.3 / 0.5
        const Material& black = s.materials.at(static_cast<size_t>(rest.blend_second));
        CHECK(black.type == BsdfType::Diffuse);
        CHECK(black.reflectance.value == glm::vec3(0.0f));
        CHECK(s.substitutions.empty());
        const Scene over =
            load_scene(write(dir, "over",
                             sphere_scene(R"(<bsdf type="mixturebsdf"><string name="weights" value="1, 3"/>)" + light +
                                          kMirror + "</bsdf>")));
        const Material& o = over.materials.at(static_cast<size_t>(over.meshes[1].material));
        CHECK(o.blend_weight == doctest::Approx(0.75f));
        CHECK(over.warnings.size() == 1);
        CHECK_THROWS_WITH_AS(
            load_scene(write(dir, "keep",
                             sphere_scene(R"(<bsdf type="mixturebsdf"><string name="weights" value="1, 3"/>)"
                                          R"(<boolean name="ensureEnergyConservation" value="false"/>)" +
                                          light + kMirror + "</bsdf>"))),
            doctest::Contains("must sum to at most 1"), SceneError);
    }
    SUBCASE(
        "tests/data/loader/blends.xml: nested blends, a bitmap weight, a mixture and principled textures, with no "
        "substitution") {
        const Scene s = load_scene(std::string(VKMECH_TEST_DATA) + "/loader/blends.xml");
        CHECK(s.substitutions.empty());
        CHECK(s.warnings.empty());
        const Material& outer = s.materials.at(static_cast<size_t>(s.meshes.at(0).material));
        REQUIRE(outer.type == BsdfType::Blend);
        CHECK(outer.twosided);
        REQUIRE(outer.blend_weight_texture >= 0);
        const Texture& w = s.textures.at(static_cast<size_t>(outer.blend_weight_texture));
        CHECK(w.rgb.at(0) == w.rgb.at(1));  // the luminance, in every channel
        CHECK(w.rgb.at(1) == w.rgb.at(2));
        const Material& half = s.materials.at(static_cast<size_t>(outer.blend_first));
        REQUIRE(half.type == BsdfType::Blend);
        CHECK(half.blend_weight == doctest::Approx(0.25f));
        CHECK(s.materials.at(static_cast<size_t>(outer.blend_second)).type == BsdfType::Dielectric);
        CHECK(s.lobe_flags(s.meshes.at(0).material) == (gpu::LOBE_BIT_D | gpu::LOBE_BIT_G | gpu::LOBE_BIT_S));
        const Material& mix = s.materials.at(static_cast<size_t>(s.meshes.at(1).material));
        REQUIRE(mix.type == BsdfType::Blend);
        CHECK(mix.blend_weight == doctest::Approx(0.5f));  // red with 0.5, then the mirror with 0.25 / 0.5
        const Material& rest = s.materials.at(static_cast<size_t>(mix.blend_second));
        CHECK(rest.blend_weight == doctest::Approx(0.5f));
        CHECK(s.materials.at(static_cast<size_t>(rest.blend_second)).reflectance.value == glm::vec3(0.0f));
        const Material& p = s.materials.at(static_cast<size_t>(s.meshes.at(2).material));
        REQUIRE(p.type == BsdfType::Principled);
        CHECK(p.twosided);                           // the wrapper's copy keeps the parameter textures
        CHECK(p.principled_param_textures[2] >= 0);  // sheen
        CHECK(p.principled_param_textures[4] >= 0);  // clearcoat
        CHECK(p.sheen == doctest::Approx(0.5f));     // the mean
        CHECK(p.principled_param_textures[0] == -1);
    }
    SUBCASE("refused: one component, a weight outside [0, 1], blends nested too deep") {
        CHECK_THROWS_WITH_AS(
            load_scene(write(dir, "one", sphere_scene("<bsdf type=\"blendbsdf\">" + kRed + "</bsdf>"))),
            doctest::Contains("needs exactly two nested bsdfs (it has 1)"), SceneError);
        CHECK_THROWS_WITH_AS(
            load_scene(write(dir, "w", sphere_scene(blend(R"(<float name="weight" value="1.5"/>)", kRed, kMirror)))),
            doctest::Contains("'weight' must lie in [0, 1]"), SceneError);
        std::string deep = kRed;
        for (uint32_t level = 0; level <= gpu::BLEND_MAX_DEPTH; ++level) deep = blend("", deep, kMirror);
        CHECK_THROWS_WITH_AS(load_scene(write(dir, "deep", sphere_scene(deep))),
                             doctest::Contains("blends nested more than 8 deep"), SceneError);
    }
}

// Renders on the device: in the GPU suite. Every render here goes through the generic
// pipeline (one compile for the whole case); "material table: every material renders the
// same..." compares a blend's specialized pipeline with it.
TEST_SUITE("gpu") {
    TEST_CASE(
        "blendbsdf: a weight of 0 or 1 renders exactly its component - pixels and labels - eight blends deep too") {
        VKMECH_REQUIRE_GPU(ctx);
        testing::TempDir dir("blend_ends");
        const testing::RenderSetup setup = small_generic();
        const struct {
            const char* weight;
            const std::string& component;
        } ends[] = {{"0", kRed}, {"1", kMirror}};
        for (const auto& e : ends) {
            CAPTURE(e.weight);
            const std::string w = std::string(R"(<float name="weight" value=")") + e.weight + "\"/>";
            const Frame blended = testing::render_scene(
                *ctx, write(dir, std::string("b") + e.weight, sphere_scene(blend(w, kRed, kMirror))), setup);
            const Frame alone =
                testing::render_scene(*ctx, write(dir, std::string("a") + e.weight, sphere_scene(e.component)), setup);
            CHECK(testing::pixel_values(blended) == testing::pixel_values(alone));
        }
        // Blends nested as deep as a hit resolves them (BLEND_MAX_DEPTH), weight 0 at every level:
        // the innermost first component, not a blend left unresolved (which would reflect nothing).
        std::string deep = kRed;
        for (uint32_t level = 0; level < gpu::BLEND_MAX_DEPTH; ++level)
            deep = blend(R"(<float name="weight" value="0"/>)", deep, kMirror);
        const Frame nested = testing::render_scene(*ctx, write(dir, "deep", sphere_scene(deep)), setup);
        const Frame red = testing::render_scene(*ctx, write(dir, "a0", sphere_scene(kRed)), setup);
        CHECK(testing::pixel_values(nested) == testing::pixel_values(red));
    }

    TEST_CASE(
        "blendbsdf: a textured weight is read at each hit, not averaged - a 0/1 checkerboard equals a checkerboard "
        "reflectance") {
        VKMECH_REQUIRE_GPU(ctx);
        testing::TempDir dir("blend_texture");
        const std::string blue = R"(<bsdf type="diffuse"><rgb name="reflectance" value="0.1, 0.3, 0.9"/></bsdf>)";
        const std::string checker =
            R"(<texture type="checkerboard" name="weight"><float name="color0" value="0"/>)"
            R"(<float name="color1" value="1"/><transform name="to_uv"><scale value="4"/></transform></texture>)";
        const std::string blended = write(dir, "blend", sphere_scene(blend(checker, kRed, blue)));
        const std::string painted =
            write(dir, "paint",
                  sphere_scene(R"(<bsdf type="diffuse"><texture type="checkerboard" name="reflectance">)"
                               R"(<rgb name="color0" value="0.8, 0.2, 0.1"/><rgb name="color1" value="0.1, 0.3, 0.9"/>)"
                               R"(<transform name="to_uv"><scale value="4"/></transform></texture></bsdf>)"));
        const std::string averaged =
            write(dir, "mean", sphere_scene(blend(R"(<float name="weight" value="0.5"/>)", kRed, blue)));
        for (vkmech::vk::KernelClass kernel : {vkmech::vk::KernelClass::Cpu, vkmech::vk::KernelClass::Gpu}) {
            CAPTURE(vkmech::vk::to_string(kernel));
            const testing::RenderSetup setup = small_generic(kernel);
            const Frame b = testing::render_scene(*ctx, blended, setup);
            const Frame p = testing::render_scene(*ctx, painted, setup);
            const std::vector<double> vb = testing::pixel_values(b), vp = testing::pixel_values(p);
            REQUIRE(vb.size() == vp.size());
            CHECK(testing::max_relative_difference(vb, vp) <= 1e-5);
            // The weight's mean (0.5) in its place gives another image: the test can tell.
            const std::vector<double> vm = testing::pixel_values(testing::render_scene(*ctx, averaged, setup));
            CHECK(testing::max_relative_difference(vm, vp) > 0.1);
        }
    }

    TEST_CASE(
        "blendbsdf: a constant weight mixes its components in expectation - (1 - w) f1 + w f2 - and so does a "
        "mixturebsdf") {
        VKMECH_REQUIRE_GPU(ctx);
        testing::TempDir dir("blend_mean");
        testing::RenderSetup setup = small_generic();
        setup.spp = 512;
        setup.batch = 64;
        // 0.75 x 0.8 + 0.25 x 0.2 = 0.65 (the weight is the second component's share).
        const std::string light = R"(<bsdf type="diffuse"><rgb name="reflectance" value="0.8"/></bsdf>)";
        const std::string dark = R"(<bsdf type="diffuse"><rgb name="reflectance" value="0.2"/></bsdf>)";
        // Plain doubles, not structured bindings: INFO captures them in a lambda, which clang 14 refuses.
        double mb = 0.0, eb = 0.0;
        std::tie(mb, eb) = mean_and_error(testing::render_scene(
            *ctx, write(dir, "blend", sphere_scene(blend(R"(<float name="weight" value="0.25"/>)", light, dark))),
            setup));
        double mm = 0.0, em = 0.0;
        std::tie(mm, em) = mean_and_error(testing::render_scene(
            *ctx,
            write(dir, "mixed", sphere_scene(R"(<bsdf type="diffuse"><rgb name="reflectance" value="0.65"/></bsdf>)")),
            setup));
        // The weight read the other way round (0.35): far outside the noise.
        double mr = 0.0, er = 0.0;
        std::tie(mr, er) = mean_and_error(testing::render_scene(
            *ctx,
            write(dir, "reversed",
                  sphere_scene(R"(<bsdf type="diffuse"><rgb name="reflectance" value="0.35"/></bsdf>)")),
            setup));
        // Mitsuba 0.6's mixturebsdf 0.5 x 0.8 + 0.3 x 0.2 (the rest, 0.2, absorbed) = 0.46, a chain of two
        // blends over the two components and a black one.
        double mx = 0.0, ex = 0.0;
        std::tie(mx, ex) = mean_and_error(testing::render_scene(
            *ctx,
            write(dir, "mixture",
                  sphere_scene(R"(<bsdf type="mixturebsdf"><string name="weights" value="0.5, 0.3"/>)" + light + dark +
                               "</bsdf>")),
            setup));
        double m46 = 0.0, e46 = 0.0;
        std::tie(m46, e46) = mean_and_error(testing::render_scene(
            *ctx,
            write(dir, "albedo46",
                  sphere_scene(R"(<bsdf type="diffuse"><rgb name="reflectance" value="0.46"/></bsdf>)")),
            setup));
        INFO("blend " << mb << " +- " << eb << ", mixed albedo " << mm << " +- " << em << ", reversed " << mr << " +- "
                      << er);
        INFO("mixture " << mx << " +- " << ex << ", albedo 0.46 " << m46 << " +- " << e46);
        const double combined = std::sqrt(eb * eb + em * em);
        REQUIRE(combined > 0.0);
        CHECK(std::abs(mb - mm) < 4.0 * combined);
        CHECK(std::abs(mb - mr) > 10.0 * std::sqrt(eb * eb + er * er));
        CHECK(std::abs(mx - m46) < 4.0 * std::sqrt(ex * ex + e46 * e46));
        CHECK(std::abs(mx - mm) > 10.0 * std::sqrt(ex * ex + em * em));  // not the blend's 0.65
    }

    TEST_CASE(
        "principled textures: spec_tint, anisotropic, sheen, sheen_tint, clearcoat, clearcoat_gloss and spec_trans are "
        "read at each hit") {
        VKMECH_REQUIRE_GPU(ctx);
        testing::TempDir dir("principled_textures");
        const char* names[] = {"spec_tint", "anisotropic",     "sheen",     "sheen_tint",
                               "clearcoat", "clearcoat_gloss", "spec_trans"};
        const float a[] = {0.1f, 0.0f, 0.3f, 0.9f, 0.0f, 0.2f, 0.0f};  // colour0 of each checkerboard
        const float b[] = {0.8f, 0.7f, 1.0f, 0.2f, 1.0f, 0.9f, 0.6f};  // colour1
        const std::string common =
            R"(<rgb name="base_color" value="0.7, 0.4, 0.2"/><float name="roughness" value="0.3"/>)"
            R"(<float name="metallic" value="0.1"/>)";
        const std::string to_uv = R"(<transform name="to_uv"><scale value="6"/></transform>)";
        auto checker = [&](const std::string& name, float c0, float c1) {
            return "<texture type=\"checkerboard\" name=\"" + name + "\"><float name=\"color0\" value=\"" +
                   std::to_string(c0) + "\"/><float name=\"color1\" value=\"" + std::to_string(c1) + "\"/>" + to_uv +
                   "</texture>";
        };
        auto constant = [&](const float* v) {
            std::string x = "<bsdf type=\"principled\">" + common;
            for (int k = 0; k < 7; ++k)
                x += "<float name=\"" + std::string(names[k]) + "\" value=\"" + std::to_string(v[k]) + "\"/>";
            return x + "</bsdf>";
        };
        std::string textured = "<bsdf type=\"principled\">" + common;
        for (int k = 0; k < 7; ++k) textured += checker(names[k], a[k], b[k]);
        textured += "</bsdf>";
        const std::string painted = write(dir, "textured", sphere_scene(textured));
        const std::string chosen =
            write(dir, "blend", sphere_scene(blend(checker("weight", 0.0f, 1.0f), constant(a), constant(b))));
        float mean[7];
        for (int k = 0; k < 7; ++k) mean[k] = 0.5f * (a[k] + b[k]);
        const std::string averaged = write(dir, "mean", sphere_scene(constant(mean)));
        const Scene loaded = load_scene(painted);
        CHECK(loaded.substitutions.empty());  // nothing is averaged
        for (vkmech::vk::KernelClass kernel : {vkmech::vk::KernelClass::Cpu, vkmech::vk::KernelClass::Gpu}) {
            CAPTURE(vkmech::vk::to_string(kernel));
            const testing::RenderSetup setup = small_generic(kernel);
            const std::vector<double> vt = testing::pixel_values(testing::render_scene(*ctx, painted, setup));
            const std::vector<double> vb = testing::pixel_values(testing::render_scene(*ctx, chosen, setup));
            REQUIRE(vt.size() == vb.size());
            CHECK(testing::max_relative_difference(vt, vb) <= 1e-5);
            // The parameters' means in their place give another image: the test can tell.
            const std::vector<double> vm = testing::pixel_values(testing::render_scene(*ctx, averaged, setup));
            CHECK(testing::max_relative_difference(vm, vb) > 0.05);
        }
    }
}
