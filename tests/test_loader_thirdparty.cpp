// What third-party Mitsuba files need (docs/descriptor.md §8): emitters by reference,
// textures on any colour parameter, and a warning - never silence - for
// everything the loader reads but does not use. Every fixture is written here.
#include "scene/scene.hpp"

#include <doctest/doctest.h>

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

using namespace vkmech;
namespace fs = std::filesystem;

namespace {

const char* kSensor = R"(<sensor type="perspective"><float name="fov" value="40"/>
  <transform name="to_world"><lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/></transform></sensor>)";

// Writes <scene>...</scene> around `body` (after a default sensor) into a
// fresh temporary file and returns its path.
std::string write_scene(const std::string& name, const std::string& body, bool with_sensor = true) {
    fs::path dir = fs::temp_directory_path() / ("vkmech_thirdparty_" + std::to_string(::getpid()));
    fs::create_directories(dir);
    fs::path p = dir / (name + ".xml");
    std::ofstream(p) << "<scene version=\"3.0.0\">\n" << (with_sensor ? kSensor : "") << "\n" << body << "\n</scene>\n";
    return p.string();
}

bool has_warning(const Scene& s, const std::string& fragment) {
    for (const auto& w : s.warnings)
        if (w.find(fragment) != std::string::npos) return true;
    return false;
}

std::string all_warnings(const Scene& s) {
    std::string out;
    for (const auto& w : s.warnings) out += w + "\n";
    return out;
}

}  // namespace

TEST_CASE("mitsuba third-party: an area emitter declared with an id is used through <ref> (Mitsuba 3's Cornell box)") {
    std::string path = write_scene("emitter_ref", R"(
  <emitter type="area" id="light"><rgb name="radiance" value="18.4, 13.9, 6.8"/></emitter>
  <bsdf type="diffuse" id="white"/>
  <shape type="rectangle" id="lamp"><ref id="white"/><ref id="light"/></shape>
  <shape type="cube"><ref id="white"/></shape>)");
    Scene s = load_scene(path);
    REQUIRE(s.emitters.size() == 1);
    CHECK(s.emitters[0].radiance.x == doctest::Approx(18.4f));
    CHECK(s.meshes[s.emitters[0].mesh].name == "lamp");
    CHECK(s.meshes[s.emitters[0].mesh].emitter == 0);
    CHECK(s.warnings.empty());

    // Declared and never used: a warning naming it.
    Scene unused = load_scene(write_scene("emitter_unused", R"(
  <emitter type="area" id="spare"><rgb name="radiance" value="1"/></emitter>
  <shape type="cube"/>)"));
    CHECK(has_warning(unused, "emitter 'spare' is declared but no shape uses it"));

    // A reference to an emitter where a texture is expected says what it is.
    CHECK_THROWS_WITH_AS(load_scene(write_scene("emitter_as_texture", R"(
  <emitter type="area" id="light"><rgb name="radiance" value="1"/></emitter>
  <shape type="cube"><bsdf type="diffuse"><ref name="reflectance" id="light"/></bsdf></shape>)")),
                         doctest::Contains("'light' is an emitter, not a texture"), SceneError);
    CHECK_THROWS_WITH_AS(load_scene(write_scene("unknown_ref", R"(<shape type="cube"><ref id="nothing"/></shape>)")),
                         doctest::Contains("unknown reference 'nothing'"), SceneError);
}

TEST_CASE("mitsuba third-party: checkerboard and bitmap textures on any colour parameter, with to_uv") {
    std::string path = write_scene("textures", R"(
  <texture type="checkerboard" id="checks">
    <rgb name="color0" value="1, 0, 0"/><rgb name="color1" value="0, 0, 1"/>
    <transform name="to_uv"><scale x="4" y="2"/></transform>
  </texture>
  <shape type="cube"><bsdf type="roughconductor">
    <ref name="specular_reflectance" id="checks"/></bsdf></shape>
  <shape type="sphere"><bsdf type="dielectric">
    <texture type="checkerboard" name="specular_transmittance"/></bsdf></shape>
  <shape type="rectangle"><bsdf type="plastic">
    <texture type="checkerboard" name="diffuse_reflectance"><float name="uscale" value="3"/></texture></bsdf></shape>)");
    Scene s = load_scene(path);
    REQUIRE(s.materials.size() == 3);
    REQUIRE(s.textures.size() == 3);
    const Material& metal = s.materials[s.meshes[0].material];
    REQUIRE(metal.specular_reflectance_texture >= 0);
    const Texture& checks = s.textures[metal.specular_reflectance_texture];
    CHECK(checks.kind == TextureKind::Checkerboard);
    CHECK(checks.rgb == std::vector<float>{1, 0, 0, 0, 0, 1});
    CHECK(checks.to_uv[0][0] == 4.0f);  // u' = 4 u
    CHECK(checks.to_uv[1][1] == 2.0f);  // v' = 2 v
    // The constant holds the texture's mean (Mitsuba's mean()).
    CHECK(metal.specular_reflectance.x == doctest::Approx(0.5f));
    CHECK(metal.specular_reflectance.z == doctest::Approx(0.5f));

    const Material& glass = s.materials[s.meshes[1].material];
    REQUIRE(glass.specular_transmittance_texture >= 0);
    const Texture& defaults = s.textures[glass.specular_transmittance_texture];
    CHECK(defaults.rgb == std::vector<float>{0.4f, 0.4f, 0.4f, 0.2f, 0.2f, 0.2f});  // Mitsuba's defaults

    const Material& plastic = s.materials[s.meshes[2].material];
    REQUIRE(plastic.reflectance.texture >= 0);
    CHECK(s.textures[plastic.reflectance.texture].to_uv[0][0] == 3.0f);  // 0.6's uscale
    REQUIRE(s.warnings.size() == 1);                                     // only that nothing emits
    CHECK(has_warning(s, "no emitter"));

    // roughconductor's textured alpha is read at each hit (the constant holds the
    // checkerboard's mean, 0.4 / 0.2 -> 0.3); a texture on a float parameter the model
    // does not read per hit (roughplastic's alpha) is refused, or with --substitute
    // reduced to its mean.
    std::string textured_alpha = write_scene("textured_alpha", R"(
  <shape type="cube"><bsdf type="roughconductor"><texture type="checkerboard" name="alpha"/></bsdf></shape>)");
    Scene ta = load_scene(textured_alpha);
    const Material& rc = ta.materials[ta.meshes[0].material];
    CHECK(rc.alpha_u == doctest::Approx(0.3f));
    CHECK(rc.alpha_u_texture >= 0);
    CHECK(ta.substitutions.empty());
    std::string plastic_alpha = write_scene("plastic_alpha", R"(
  <shape type="cube"><bsdf type="roughplastic"><texture type="checkerboard" name="alpha"/></bsdf></shape>)");
    CHECK_THROWS_WITH_AS(load_scene(plastic_alpha), doctest::Contains("--substitute"), SceneError);
    LoadOptions sub;
    sub.substitute_unsupported = true;
    Scene pa = load_scene(plastic_alpha, sub);
    CHECK(pa.materials[pa.meshes[0].material].alpha_u == doctest::Approx(0.3f));
    CHECK(pa.materials[pa.meshes[0].material].alpha_u_texture == -1);
    CHECK(pa.substitutions.size() == 1);
}

TEST_CASE("mitsuba third-party: every element or property that is not used is a warning") {
    std::string path = write_scene("unused", R"(
  <default name="spp" value="16"/>
  <integrator type="bdpt"><integer name="max_depth" value="8"/><boolean name="hide_emitters" value="true"/></integrator>
  <sensor type="perspective">
    <float name="fov" value="40"/><float name="shutter_open" value="0"/>
    <sampler type="stratified"><integer name="sample_count" value="$spp"/></sampler>
    <film type="specfilm"><integer name="width" value="64"/><integer name="height" value="48"/>
      <string name="pixel_format" value="rgba"/><rfilter type="gaussian"/></film>
  </sensor>
  <shape type="cube"><bsdf type="diffuse"><float name="sheen" value="0.2"/></bsdf>
    <boolean name="smooth_shading" value="true"/></shape>
  <shape type="rectangle"><emitter type="area"><rgb name="radiance" value="1"/><float name="power" value="3"/></emitter></shape>)",
                                   /*with_sensor=*/false);
    LoadOptions o;
    o.params["spp"] = "32";
    o.params["roughness"] = "0.1";  // no $roughness in the scene
    Scene s = load_scene(path, o);
    INFO(all_warnings(s));
    CHECK(s.integrator.max_depth == 8);  // still read from the unknown integrator
    CHECK(s.camera.width == 64);
    CHECK(has_warning(s, "integrator 'bdpt' is not what vkmech renders"));
    CHECK(has_warning(s, "property 'hide_emitters'"));
    CHECK(has_warning(s, "property 'shutter_open'"));
    CHECK(has_warning(s, "sampler 'stratified' (sample_count 32) is not used"));
    CHECK(has_warning(s, "film 'specfilm' is read for its size only"));
    CHECK(has_warning(s, "property 'pixel_format'"));
    CHECK(has_warning(s, "reconstruction filter 'gaussian' is not used"));
    CHECK(has_warning(s, "property 'sheen'"));
    CHECK(has_warning(s, "property 'smooth_shading'"));
    CHECK(has_warning(s, "property 'power'"));
    CHECK(has_warning(s, "-D roughness=... is not used"));
    CHECK_FALSE(has_warning(s, "-D spp"));
    // Every warning names the file and the line.
    for (const auto& w : s.warnings) CHECK(w.find("unused.xml") != std::string::npos);
}

TEST_CASE(
    "mitsuba third-party: bump maps load as they are, an opaque mask with a warning, a cut-out mask needs "
    "--substitute") {
    Scene s = load_scene(write_scene("bump", R"(
  <shape type="cube"><bsdf type="bumpmap">
    <texture name="arg" type="checkerboard"/><float name="scale" value="0.1"/>
    <bsdf type="roughplastic"/></bsdf></shape>
  <shape type="sphere"><bsdf type="mask"><float name="opacity" value="1"/><bsdf type="conductor"/></bsdf></shape>)"));
    const Material& bumped = s.materials[s.meshes[0].material];
    CHECK(bumped.type == BsdfType::RoughPlastic);
    REQUIRE(bumped.bump_texture >= 0);
    CHECK(s.textures[bumped.bump_texture].kind == TextureKind::Checkerboard);
    CHECK(bumped.bump_scale == 0.1f);
    CHECK(s.materials[s.meshes[1].material].type == BsdfType::Conductor);
    CHECK_FALSE(has_warning(s, "bump map"));
    CHECK(has_warning(s, "opacity 1 changes nothing"));
    CHECK(s.substitutions.empty());

    std::string cutout = write_scene("cutout", R"(
  <shape type="cube"><bsdf type="mask"><float name="opacity" value="0.3"/><bsdf type="diffuse"/></bsdf></shape>)");
    CHECK_THROWS_WITH_AS(load_scene(cutout), doctest::Contains("unsupported bsdf plugin 'mask'"), SceneError);
    LoadOptions o;
    o.substitute_unsupported = true;
    Scene sub = load_scene(cutout, o);
    REQUIRE(sub.substitutions.size() == 1);
    CHECK(sub.substitutions[0].find("cutout.xml:") != std::string::npos);
}

TEST_CASE("mitsuba third-party: roughdiffuse loads as Oren-Nayar, without --substitute") {
    std::string path = write_scene("roughdiffuse", R"(
  <shape type="cube"><bsdf type="roughdiffuse"><rgb name="reflectance" value="0.3"/><float name="alpha" value="0.6"/></bsdf></shape>
  <shape type="sphere"><bsdf type="roughdiffuse"><boolean name="useFastApprox" value="true"/></bsdf></shape>
  <shape type="disk"><bsdf type="roughdiffuse"><float name="alpha" value="-1"/></bsdf></shape>)");
    CHECK_THROWS_WITH_AS(load_scene(path), doctest::Contains("'alpha' must be a finite number >= 0"), SceneError);
    std::string ok = write_scene("roughdiffuse_ok", R"(
  <shape type="cube"><bsdf type="roughdiffuse"><rgb name="reflectance" value="0.3"/><float name="alpha" value="0.6"/></bsdf></shape>
  <shape type="sphere"><bsdf type="roughdiffuse"><boolean name="useFastApprox" value="true"/></bsdf></shape>)");
    Scene s = load_scene(ok);
    const Material& a = s.materials[s.meshes[0].material];
    CHECK(a.type == BsdfType::RoughDiffuse);
    CHECK(a.reflectance.value.x == doctest::Approx(0.3f));
    CHECK(a.alpha_u == doctest::Approx(0.6f));
    const Material& b = s.materials[s.meshes[1].material];
    CHECK(b.type == BsdfType::RoughDiffuse);
    CHECK(b.alpha_u == doctest::Approx(0.2f));  // Mitsuba's default
    CHECK(b.lobe_flags() == gpu::LOBE_BIT_G);   // Mitsuba's flag: glossy reflection
    CHECK(s.substitutions.empty());
    CHECK(std::count_if(s.warnings.begin(), s.warnings.end(), [](const std::string& w) {
              return w.find("use_fast_approx is ignored") != std::string::npos;
          }) == 1);
}

TEST_CASE(
    "mitsuba third-party: --substitute maps point lights and phong to the model - blendbsdf and mixturebsdf need "
    "none") {
    std::string path = write_scene("outside", R"(
  <emitter type="point"><point name="position" x="0" y="2" z="0"/><rgb name="intensity" value="10"/></emitter>
  <shape type="cube"><bsdf type="phong"><float name="exponent" value="48"/></bsdf></shape>
  <shape type="sphere"><bsdf type="blendbsdf"><float name="weight" value="0.8"/>
    <bsdf type="diffuse"/><bsdf type="roughconductor"/></bsdf></shape>
  <shape type="disk"><bsdf type="mixturebsdf"><string name="weights" value="0.2, 0.7, 0.1"/>
    <bsdf type="diffuse"/><bsdf type="conductor"/><bsdf type="plastic"/></bsdf></shape>)");
    CHECK_THROWS_WITH_AS(load_scene(path), doctest::Contains("--substitute"), SceneError);
    LoadOptions o;
    o.substitute_unsupported = true;
    Scene s = load_scene(path, o);
    // phong exponent 48 -> Beckmann alpha sqrt(2 / 50) = 0.2
    const Material& phong = s.materials[s.meshes[0].material];
    CHECK(phong.type == BsdfType::RoughPlastic);
    CHECK(phong.alpha_u == doctest::Approx(0.2f));
    // blendbsdf is rendered as it is (tests/test_blend.cpp), substituted or not.
    const Material& blend = s.materials[s.meshes[1].material];
    CHECK(blend.type == BsdfType::Blend);
    CHECK(blend.blend_weight == doctest::Approx(0.8f));
    CHECK(s.materials[blend.blend_second].type == BsdfType::RoughConductor);
    // The point light: a sphere emitter of the same power, 4 pi I = 4 pi r^2 * pi L.
    REQUIRE(s.emitters.size() == 1);
    const Mesh& bulb = s.meshes[s.emitters[0].mesh];
    CHECK(bulb.center.y == doctest::Approx(2.0f));
    double r = bulb.radius;
    CHECK(r > 0.0);
    CHECK(s.emitters[0].radiance.x == doctest::Approx(10.0 / (M_PI * r * r)).epsilon(1e-4));
    // mixturebsdf 0.2, 0.7, 0.1: a chain of blends, diffuse with probability 0.2, else the conductor
    // with 0.7 / 0.8, else the plastic (tests/test_blend.cpp renders one).
    const Material& mix = s.materials[s.meshes[2].material];
    REQUIRE(mix.type == BsdfType::Blend);
    CHECK(s.materials[mix.blend_first].type == BsdfType::Diffuse);
    CHECK(mix.blend_weight == doctest::Approx(0.8f));
    const Material& rest = s.materials[mix.blend_second];
    REQUIRE(rest.type == BsdfType::Blend);
    CHECK(s.materials[rest.blend_first].type == BsdfType::Conductor);
    CHECK(s.materials[rest.blend_second].type == BsdfType::Plastic);
    CHECK(rest.blend_weight == doctest::Approx(0.125f));
    CHECK(s.substitutions.size() == 2);

    // A directional light is an emitter at infinity (docs/descriptor.md §1), with or without --substitute.
    std::string sun = write_scene("sun", R"(
  <emitter type="directional"><vector name="direction" x="0" y="-1" z="0"/><rgb name="irradiance" value="3"/></emitter>
  <shape type="cube"/>)");
    for (const Scene& d : {load_scene(sun), load_scene(sun, o)}) {
        CHECK(d.emitters.empty());
        REQUIRE(d.directional_lights.size() == 1);
        CHECK(d.directional_lights[0].direction == glm::vec3(0, -1, 0));
        CHECK(d.directional_lights[0].irradiance == glm::vec3(3.0f));
        CHECK(d.substitutions.empty());
    }
}

TEST_CASE("mitsuba third-party: <path>, <alias> and <blackbody>") {
    fs::path dir = fs::temp_directory_path() / ("vkmech_thirdparty_path_" + std::to_string(::getpid()));
    fs::create_directories(dir / "meshes");
    std::ofstream(dir / "meshes" / "tri.obj") << "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    fs::path p = dir / "scene.xml";
    std::ofstream(p) << "<scene version=\"3.0.0\">" << kSensor << R"(
  <path value="meshes"/>
  <bsdf type="diffuse" id="white"/>
  <alias id="white" as="paper"/>
  <shape type="obj"><string name="filename" value="tri.obj"/><ref id="paper"/>
    <emitter type="area"><blackbody name="radiance" temperature="6504" scale="2"/></emitter></shape>
</scene>)";
    Scene s = load_scene(p.string());
    REQUIRE(s.meshes.size() == 1);
    CHECK(s.meshes[0].positions.size() == 3);
    CHECK(s.materials[s.meshes[0].material].id == "white");
    // Unit luminance times scale 2; near-white at 6504 K.
    glm::vec3 L = s.emitters.at(0).radiance;
    CHECK(0.2126f * L.x + 0.7152f * L.y + 0.0722f * L.z == doctest::Approx(2.0f).epsilon(1e-4));
    CHECK(L.x / L.z == doctest::Approx(1.0f).epsilon(0.35));
    fs::remove_all(dir);
}
