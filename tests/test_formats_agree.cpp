// The same small scene written as Mitsuba XML and as glTF 2.0 renders to the
// same image within noise (docs/descriptor.md §8: the glTF mapping of rough plastic,
// emission and cameras). Both files are written by this test.
#include "gpu_fixture.hpp"
#include "render_fixture.hpp"
#include "scene/scene.hpp"

#include <doctest/doctest.h>

#include <glm/gtc/quaternion.hpp>

#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

using namespace vkmech;
namespace fs = std::filesystem;

namespace {

std::string base64(const std::vector<unsigned char>& in) {
    static const char* tbl = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::string out;
    for (size_t i = 0; i < in.size(); i += 3) {
        uint32_t v = uint32_t(in[i]) << 16;
        if (i + 1 < in.size()) v |= uint32_t(in[i + 1]) << 8;
        if (i + 2 < in.size()) v |= uint32_t(in[i + 2]);
        out += tbl[(v >> 18) & 63];
        out += tbl[(v >> 12) & 63];
        out += i + 1 < in.size() ? tbl[(v >> 6) & 63] : '=';
        out += i + 2 < in.size() ? tbl[v & 63] : '=';
    }
    return out;
}

// A rough-plastic floor (y = 0, 4 x 4, facing +y) under a 1 x 1 emitter at
// y = 2, off-centre at x = 0.8 (so a mirrored camera shows), facing down,
// seen from (0, 3, 5) with a 40 degree vertical fov.
const char* kXml = R"(<scene version="3.0.0">
  <sensor type="perspective">
    <float name="fov" value="40"/><string name="fov_axis" value="y"/>
    <transform name="to_world"><lookat origin="0, 3, 5" target="0, 0, 0" up="0, 1, 0"/></transform>
  </sensor>
  <shape type="rectangle">
    <transform name="to_world"><scale value="2"/><rotate x="1" angle="-90"/></transform>
    <bsdf type="roughplastic"><string name="distribution" value="ggx"/><float name="alpha" value="0.25"/>
      <float name="int_ior" value="1.5"/><float name="ext_ior" value="1"/>
      <rgb name="diffuse_reflectance" value="0.7, 0.6, 0.5"/></bsdf>
  </shape>
  <shape type="rectangle">
    <transform name="to_world"><scale value="0.5"/><rotate x="1" angle="90"/><translate x="0.8" y="2"/></transform>
    <bsdf type="roughplastic"><string name="distribution" value="ggx"/><float name="alpha" value="1"/>
      <float name="int_ior" value="1.5"/><float name="ext_ior" value="1"/>
      <rgb name="diffuse_reflectance" value="0"/></bsdf>
    <emitter type="area"><rgb name="radiance" value="10"/></emitter>
  </shape>
</scene>
)";

std::string gltf_json() {
    // Vertices in world space (identity mesh nodes), wound so that the
    // geometric normal is +y for the floor and -y for the emitter.
    const float pos[] = {-2,   0, 2,     2,    0, 2,     2,    0, -2,   -2,   0, -2,     // floor
                         0.3f, 2, -0.5f, 1.3f, 2, -0.5f, 1.3f, 2, 0.5f, 0.3f, 2, 0.5f};  // emitter
    const uint16_t idx[] = {0, 1, 2, 0, 2, 3, 0, 1, 2, 0, 2, 3};  // each primitive indexes its own accessor
    std::vector<unsigned char> buf(sizeof pos + sizeof idx);
    std::memcpy(buf.data(), pos, sizeof pos);
    std::memcpy(buf.data() + sizeof pos, idx, sizeof idx);
    glm::quat q = glm::quatLookAtRH(glm::normalize(glm::vec3(0, -3, -5)), glm::vec3(0, 1, 0));
    auto f = [](double v) {
        char b[32];
        std::snprintf(b, sizeof b, "%.9g", v);
        return std::string(b);
    };
    std::string s = R"({"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0,1,2]}],
"nodes":[{"mesh":0},{"mesh":1},{"camera":0,"translation":[0,3,5],"rotation":[)" +
                    f(q.x) + "," + f(q.y) + "," + f(q.z) + "," + f(q.w) + R"(]}],
"cameras":[{"type":"perspective","perspective":{"yfov":)" +
                    f(40.0 * M_PI / 180.0) +
                    R"(,"aspectRatio":1,"znear":0.01,"zfar":1000}}],
"meshes":[{"primitives":[{"attributes":{"POSITION":0},"indices":2,"material":0}]},
          {"primitives":[{"attributes":{"POSITION":1},"indices":3,"material":1}]}],
"materials":[{"pbrMetallicRoughness":{"baseColorFactor":[0.7,0.6,0.5,1],"metallicFactor":0,"roughnessFactor":0.5}},
             {"pbrMetallicRoughness":{"baseColorFactor":[0,0,0,1],"metallicFactor":0,"roughnessFactor":1},
              "emissiveFactor":[1,1,1],"extensions":{"KHR_materials_emissive_strength":{"emissiveStrength":10}}}],
"extensionsUsed":["KHR_materials_emissive_strength"],
"buffers":[{"byteLength":)" +
                    std::to_string(buf.size()) + R"(,"uri":"data:application/octet-stream;base64,)" + base64(buf) +
                    R"("}],
"bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":96},{"buffer":0,"byteOffset":96,"byteLength":24}],
"accessors":[{"bufferView":0,"byteOffset":0,"componentType":5126,"count":4,"type":"VEC3","min":[-2,0,-2],"max":[2,0,2]},
             {"bufferView":0,"byteOffset":48,"componentType":5126,"count":4,"type":"VEC3","min":[0.3,2,-0.5],"max":[1.3,2,0.5]},
             {"bufferView":1,"byteOffset":0,"componentType":5123,"count":6,"type":"SCALAR"},
             {"bufferView":1,"byteOffset":12,"componentType":5123,"count":6,"type":"SCALAR"}]}
)";
    return s;
}

struct Stats {
    double mean = 0.0, se = 0.0;
};

Stats luminance_stats(const Frame& f) {
    std::vector<float> rgb = f.rgb_mean();
    size_t n = rgb.size() / 3;
    double sum = 0.0, sum2 = 0.0;
    for (size_t i = 0; i < n; ++i) {
        double l = 0.2126 * rgb[3 * i] + 0.7152 * rgb[3 * i + 1] + 0.0722 * rgb[3 * i + 2];
        sum += l;
        sum2 += l * l;
    }
    Stats s;
    s.mean = sum / n;
    s.se = std::sqrt(std::max(0.0, sum2 / n - s.mean * s.mean) / n);
    return s;
}

}  // namespace

TEST_SUITE("gpu") {
    TEST_CASE("formats: one scene as Mitsuba XML and as glTF renders the same image within noise") {
        VKMECH_REQUIRE_GPU(ctx);
        fs::path dir = fs::temp_directory_path() / ("vkmech_formats_" + std::to_string(::getpid()));
        fs::create_directories(dir);
        std::ofstream(dir / "scene.xml") << kXml;
        std::ofstream(dir / "scene.gltf") << gltf_json();

        Scene xml = load_scene((dir / "scene.xml").string());
        Scene gl = load_scene((dir / "scene.gltf").string());
        CHECK(xml.triangle_count() == gl.triangle_count());
        REQUIRE(gl.emitters.size() == 1);
        CHECK(gl.emitters[0].radiance.x == doctest::Approx(10.0f));
        CHECK(gl.camera.fov_axis == "y");
        CHECK(gl.camera.fov_deg == doctest::Approx(40.0f).epsilon(1e-4));

        testing::RenderSetup setup;
        setup.res = 32;
        setup.spp = 256;
        setup.estimator = Estimator::Mis;
        Frame a = testing::render_scene(*ctx, (dir / "scene.xml").string(), setup);
        Frame b = testing::render_scene(*ctx, (dir / "scene.gltf").string(), setup);
        Stats sa = luminance_stats(a), sb = luminance_stats(b);
        CAPTURE(sa.mean);
        CAPTURE(sb.mean);
        CHECK(sa.mean > 0.05);
        // Same geometry, materials and sample streams: the image means agree
        // to well within their pixel-to-pixel spread's standard error.
        CHECK(std::abs(sa.mean - sb.mean) < 0.02 * sa.mean + 1e-6);
        // And pixel by pixel: the same image, not just the same mean (a
        // mirrored or shifted camera would move the bright spot).
        std::vector<float> ra = a.rgb_mean(), rb = b.rgb_mean();
        size_t close = 0, n = ra.size() / 3;
        for (size_t i = 0; i < n; ++i) {
            double la = 0.2126 * ra[3 * i] + 0.7152 * ra[3 * i + 1] + 0.0722 * ra[3 * i + 2];
            double lb = 0.2126 * rb[3 * i] + 0.7152 * rb[3 * i + 1] + 0.0722 * rb[3 * i + 2];
            if (std::abs(la - lb) <= 0.1 * std::max(la, lb) + 1e-3) ++close;
        }
        CHECK(close >= n * 95 / 100);
        fs::remove_all(dir);
    }
}
