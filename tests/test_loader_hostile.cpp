// Hostile scene files (docs/reliability.md, "Loader"): each fixture here once crashed, hung, ate
// memory without bound or loaded as silent garbage. Every one must now be a
// SceneError naming the file, quickly. The fixtures are written by the tests.
#include "render/gpu_scene.hpp"
#include "scene/scene.hpp"
#include "scoped_env.hpp"
#include "temp_dir.hpp"

#include <doctest/doctest.h>

#include <sys/stat.h>
#include <zlib.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

using namespace vkmech;
using vkmech::testing::TempDir;

namespace {

const char* kSensor = R"(<sensor type="perspective"><float name="fov" value="40"/>
  <transform name="to_world"><lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/></transform></sensor>)";

std::string write(const TempDir& dir, const std::string& name, const std::string& bytes) {
    std::string p = dir.file(name);
    std::ofstream(p, std::ios::binary) << bytes;
    return p;
}

// <scene> with a sensor around `body`.
std::string write_scene(const TempDir& dir, const std::string& name, const std::string& body) {
    return write(dir, name, std::string("<scene version=\"3.0.0\">\n") + kSensor + "\n" + body + "\n</scene>\n");
}

std::string ply_shape(const std::string& file) {
    return "<shape type=\"ply\"><string name=\"filename\" value=\"" + file + "\"/></shape>";
}

std::string obj_shape(const std::string& file) {
    return "<shape type=\"obj\"><string name=\"filename\" value=\"" + file + "\"/></shape>";
}

std::string ply_header(const std::string& format, const std::string& elements) {
    return "ply\nformat " + format + " 1.0\n" + elements + "end_header\n";
}

template <class T>
void put(std::string& s, T v) {
    char b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));  // the test host is little-endian
    s.append(b, sizeof(T));
}

void put_be32(std::string& s, uint32_t v) {
    for (int k = 3; k >= 0; --k) s += static_cast<char>(v >> (8 * k) & 0xff);
}

void png_chunk(std::string& png, const char* type, const std::string& data) {
    put_be32(png, static_cast<uint32_t>(data.size()));
    std::string body = std::string(type) + data;
    png += body;
    put_be32(png, static_cast<uint32_t>(
                      crc32(0, reinterpret_cast<const Bytef*>(body.data()), static_cast<uInt>(body.size()))));
}

// A valid grey 8-bit PNG of w x h black pixels.
std::string black_png(uint32_t w, uint32_t h) {
    std::string png = "\x89PNG\r\n\x1a\n", ihdr, raw(static_cast<size_t>(w + 1) * h, '\0');
    put_be32(ihdr, w);
    put_be32(ihdr, h);
    ihdr += std::string("\x08\x00\x00\x00\x00", 5);  // 8 bit, grey, deflate, no filter, no interlace
    png_chunk(png, "IHDR", ihdr);
    uLongf n = compressBound(static_cast<uLong>(raw.size()));
    std::string z(n, '\0');
    compress(reinterpret_cast<Bytef*>(z.data()), &n, reinterpret_cast<const Bytef*>(raw.data()),
             static_cast<uLong>(raw.size()));
    z.resize(n);
    png_chunk(png, "IDAT", z);
    png_chunk(png, "IEND", "");
    return png;
}

using vkmech::testing::ScopedEnv;

}  // namespace

TEST_CASE("hostile: 20000 nested twosided bsdfs are refused by the nesting limit instead of overflowing the stack") {
    TempDir dir("hostile_nest");
    std::string open, close;
    for (int i = 0; i < 20000; ++i) {
        open += "<bsdf type=\"twosided\">";
        close += "</bsdf>";
    }
    std::string path = write_scene(dir, "deep.xml",
                                   "<shape type=\"cube\">\n" + open + "<bsdf type=\"diffuse\"/>" + close + "</shape>");
    CHECK_THROWS_WITH_AS(load_scene(path), doctest::Contains("nesting deeper than"), SceneError);
}

TEST_CASE("hostile: a PLY with two vertex elements is refused (normals for half the positions)") {
    TempDir dir("hostile_ply2v");
    write(dir, "two.ply",
          ply_header("ascii",
                     "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                     "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                     "property float nx\nproperty float ny\nproperty float nz\n"
                     "element face 2\nproperty list uchar int vertex_indices\n") +
              "0 0 0\n1 0 0\n0 1 0\n"
              "0 0 1 0 0 1\n1 0 1 0 0 1\n0 1 1 0 0 1\n"
              "3 0 1 2\n3 3 4 5\n");
    std::string path = write_scene(dir, "s.xml", ply_shape("two.ply"));
    CHECK_THROWS_WITH_AS(load_scene(path), doctest::Contains("second element 'vertex'"), SceneError);
}

TEST_CASE("hostile: flatten_scene refuses a mesh whose normals or uvs do not match its positions") {
    Scene s;
    Mesh m;
    m.name = "bad";
    m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 1}, {0, 1, 1}};
    m.indices = {{0, 1, 2}, {3, 4, 5}};
    m.material = 0;
    s.materials.push_back(Material{});
    s.meshes.push_back(m);
    s.meshes[0].normals = {{0, 0, 1}, {0, 0, 1}, {0, 0, 1}};
    CHECK_THROWS_WITH_AS(flatten_scene(s), doctest::Contains("3 normals for 6 positions"), SceneError);
    s.meshes[0].normals.clear();
    s.meshes[0].uvs = {{0, 0}};
    CHECK_THROWS_WITH_AS(flatten_scene(s), doctest::Contains("1 uvs for 6 positions"), SceneError);
    s.meshes[0].uvs.clear();
    s.meshes[0].indices.push_back({0, 1, 6});
    CHECK_THROWS_WITH_AS(flatten_scene(s), doctest::Contains("vertex 6"), SceneError);
}

TEST_CASE("hostile: a PLY element with no properties and a count of 1e18 is refused at once") {
    TempDir dir("hostile_plyjunk");
    write(dir, "junk.ply",
          ply_header("binary_little_endian",
                     "element junk 1000000000000000000\n"
                     "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                     "element face 1\nproperty list uchar int vertex_indices\n"));
    std::string path = write_scene(dir, "s.xml", ply_shape("junk.ply"));
    CHECK_THROWS_WITH_AS(load_scene(path), doctest::Contains("element 'junk'"), SceneError);
}

TEST_CASE("hostile: a binary PLY whose vertex count exceeds the file is refused before reading") {
    TempDir dir("hostile_plycount");
    std::string body;
    for (int i = 0; i < 9; ++i) put(body, 0.5f * static_cast<float>(i % 3));
    write(dir, "big.ply",
          ply_header("binary_little_endian",
                     "element vertex 4000000000\nproperty float x\nproperty float y\n"
                     "property float z\nelement face 1\nproperty list uchar int "
                     "vertex_indices\n") +
              body);
    std::string path = write_scene(dir, "s.xml", ply_shape("big.ply"));
    CHECK_THROWS_WITH_AS(load_scene(path), doctest::Contains("more than the"), SceneError);
}

TEST_CASE("hostile: NaN and fractional face indices from a float list are refused (binary and ascii)") {
    TempDir dir("hostile_plynan");
    std::string body;
    for (float v : {0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 0.f, 1.f, 0.f}) put(body, v);
    body += '\3';
    for (float v : {0.f, 1.f, std::numeric_limits<float>::quiet_NaN()}) put(body, v);
    const std::string elements =
        "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
        "element face 1\nproperty list uchar float vertex_indices\n";
    write(dir, "nan.ply", ply_header("binary_little_endian", elements) + body);
    CHECK_THROWS_WITH_AS(load_scene(write_scene(dir, "s.xml", ply_shape("nan.ply"))),
                         doctest::Contains("not a vertex index"), SceneError);
    write(dir, "frac.ply", ply_header("ascii", elements) + "0 0 0\n1 0 0\n0 1 0\n3 0 1.5 2\n");
    CHECK_THROWS_WITH_AS(load_scene(write_scene(dir, "s2.xml", ply_shape("frac.ply"))),
                         doctest::Contains("not a vertex index"), SceneError);
}

TEST_CASE("hostile: includes of a directory and of a FIFO are refused as not regular files") {
    TempDir dir("hostile_incl");
    std::filesystem::create_directories(dir.path / "adir");
    CHECK_THROWS_WITH_AS(load_scene(write_scene(dir, "d.xml", "<include filename=\"adir\"/>")),
                         doctest::Contains("not a regular file"), SceneError);
    REQUIRE(::mkfifo(dir.file("fifo").c_str(), 0600) == 0);
    CHECK_THROWS_WITH_AS(load_scene(write_scene(dir, "f.xml", "<include filename=\"fifo\"/>")),
                         doctest::Contains("not a regular file"), SceneError);
    CHECK_THROWS_WITH_AS(load_scene(write_scene(dir, "z.xml", "<include filename=\"/dev/zero\"/>")),
                         doctest::Contains("not a regular file"), SceneError);
}

TEST_CASE("hostile: includes that fan out exponentially stop at the include limit") {
    TempDir dir("hostile_fan");
    // Each level includes the next 8 times: 8^12 includes without a limit.
    const int levels = 12;
    for (int i = 0; i < levels; ++i) {
        std::string body;
        for (int k = 0; k < 8; ++k) body += "<include filename=\"l" + std::to_string(i + 1) + ".xml\"/>\n";
        write(dir, "l" + std::to_string(i) + ".xml", "<scene version=\"3.0.0\">\n" + body + "</scene>\n");
    }
    write(dir, "l" + std::to_string(levels) + ".xml", "<scene version=\"3.0.0\"/>\n");
    std::string path = write_scene(dir, "s.xml", "<include filename=\"l0.xml\"/>");
    CHECK_THROWS_WITH_AS(load_scene(path), doctest::Contains("includes"), SceneError);
}

TEST_CASE("hostile: spheres past the triangle budget are refused with how to raise it") {
    TempDir dir("hostile_spheres");
    std::string body = "<emitter type=\"area\" id=\"light\"><rgb name=\"radiance\" value=\"1\"/></emitter>\n";
    for (int i = 0; i < 40; ++i)
        body += "<shape type=\"sphere\"><point name=\"center\" x=\"" + std::to_string(i) +
                "\" y=\"0\" z=\"0\"/>"
                "<float name=\"radius\" value=\"0.4\"/></shape>\n";
    std::string path = write_scene(dir, "s.xml", body);
    ScopedEnv env("VKMECH_MAX_TRIANGLES", "100000");
    CHECK_THROWS_WITH_AS(load_scene(path), doctest::Contains("--max-triangles"), SceneError);
    ScopedEnv bad("VKMECH_MAX_TRIANGLES", "lots");
    CHECK_THROWS_WITH_AS(load_scene(path), doctest::Contains("VKMECH_MAX_TRIANGLES"), SceneError);
}

TEST_CASE("hostile: numbers that overflow a 32-bit float are refused with file and line") {
    TempDir dir("hostile_float");
    std::string path = write_scene(dir, "s.xml",
                                   "<shape type=\"cube\"><emitter type=\"area\">\n"
                                   "<rgb name=\"radiance\" value=\"1e39\"/></emitter></shape>");
    CHECK_THROWS_WITH_AS(load_scene(path), doctest::Contains("s.xml:5: value 1e39 overflows a 32-bit float"),
                         SceneError);
    write(dir, "big.obj", "v 0 0 0\nv 1e39 0 0\nv 0 1 0\nf 1 2 3\n");
    CHECK_THROWS_WITH_AS(load_scene(write_scene(dir, "o.xml", obj_shape("big.obj"))),
                         doctest::Contains("big.obj:2: value 1e39 overflows a 32-bit float"), SceneError);
    write(dir, "big.ply",
          ply_header("ascii",
                     "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                     "property float u\nproperty float v\n"
                     "element face 1\nproperty list uchar int vertex_indices\n") +
              "0 0 0 0 0\n1 0 0 1e39 0\n0 1 0 0 1\n3 0 1 2\n");
    CHECK_THROWS_WITH_AS(load_scene(write_scene(dir, "p.xml", ply_shape("big.ply"))),
                         doctest::Contains("overflows a 32-bit float"), SceneError);
}

TEST_CASE("hostile: a binary PLY with NaN texture coordinates is refused") {
    TempDir dir("hostile_plyuv");
    std::string body;
    const float nan = std::numeric_limits<float>::quiet_NaN();
    for (float v : {0.f, 0.f, 0.f, 0.f, 0.f, 1.f, 0.f, 0.f, nan, 0.f, 0.f, 1.f, 0.f, 0.f, 1.f}) put(body, v);
    body += '\3';
    for (int v : {0, 1, 2}) put(body, v);
    write(dir, "uv.ply",
          ply_header("binary_little_endian",
                     "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                     "property float u\nproperty float v\n"
                     "element face 1\nproperty list uchar int vertex_indices\n") +
              body);
    CHECK_THROWS_WITH_AS(load_scene(write_scene(dir, "s.xml", ply_shape("uv.ply"))),
                         doctest::Contains("texture coordinate"), SceneError);
}

TEST_CASE("hostile: glTF JSON nested 200000 deep is refused instead of overflowing the stack") {
    TempDir dir("hostile_json");
    std::string path = write(
        dir, "deep.gltf",
        "{\"asset\":{\"version\":\"2.0\"},\"extras\":" + std::string(200000, '[') + std::string(200000, ']') + "}");
    CHECK_THROWS_WITH_AS(load_scene(path), doctest::Contains("JSON nested deeper than"), SceneError);
}

TEST_CASE("hostile: an image wider than the texture limit is refused before decoding") {
    TempDir dir("hostile_png");
    write(dir, "wide.png", black_png(16385, 1));
    std::string path = write_scene(dir, "s.xml",
                                   "<shape type=\"cube\"><bsdf type=\"diffuse\"><texture type=\"bitmap\" "
                                   "name=\"reflectance\"><string name=\"filename\" value=\"wide.png\"/></texture>"
                                   "</bsdf></shape>");
    CHECK_THROWS_WITH_AS(load_scene(path), doctest::Contains("16385 x 1 pixels"), SceneError);
}

// Found by the loader fuzzer (docs/reliability.md): a GLB whose header length
// is 0 skipped the chunk checks, and the JSON-nesting scan then read the
// first chunk's claimed 1 GiB past the end of a 37-byte file.
TEST_CASE("hostile: a GLB whose header length leaves no JSON chunk is refused") {
    TempDir dir("hostile_glb");
    std::string glb("glTF", 4);
    put<uint32_t>(glb, 2);            // version
    put<uint32_t>(glb, 0);            // length: claims nothing
    put<uint32_t>(glb, 0x40000000);   // JSON chunk length: 1 GiB
    put<uint32_t>(glb, 0x4E4F534Au);  // "JSON"
    glb += "{\"scene\": 0}";
    std::string path = write(dir, "short.glb", glb);
    CHECK_THROWS_WITH_AS(load_scene(path), doctest::Contains("leaves no JSON chunk"), SceneError);
}
