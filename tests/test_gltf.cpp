// glTF 2.0 loading (docs/descriptor.md §8, glTF part). Every fixture is written here, by
// hand: the JSON as text and the buffers byte by byte (base64 and the GLB
// container too), so the tests are a reference independent of tinygltf.
#include "cli_run.hpp"
#include "gpu_fixture.hpp"
#include "render/gpu_scene.hpp"
#include "render_fixture.hpp"
#include "scene/mesh_ops.hpp"
#include "scene/scene.hpp"
#include "temp_dir.hpp"

#include <doctest/doctest.h>

// stb's implementations are in Debian's libstb (linked by vkmech_core).
#include <stb/stb_image_write.h>

#include <glm/glm.hpp>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <string>
#include <vector>

#include <unistd.h>

using namespace vkmech;
namespace fs = std::filesystem;

namespace {

constexpr float kPi = std::numbers::pi_v<float>;

struct TempDir : vkmech::testing::TempDir {
    explicit TempDir(const std::string& tag) : vkmech::testing::TempDir("gltf_" + tag) {}
};

std::string join(const std::vector<std::string>& items) {
    std::string s;
    for (size_t i = 0; i < items.size(); ++i) s += (i ? "," : "") + items[i];
    return s;
}

std::string num(double v) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.9g", v);
    return buf;
}

std::string base64(const std::vector<unsigned char>& in) {
    static const char* tbl = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::string out;
    size_t i = 0;
    for (; i + 2 < in.size(); i += 3) {
        uint32_t v = (in[i] << 16) | (in[i + 1] << 8) | in[i + 2];
        for (int k = 3; k >= 0; --k) out += tbl[(v >> (6 * k)) & 63];
    }
    if (i + 1 == in.size()) {
        uint32_t v = in[i] << 16;
        out += tbl[(v >> 18) & 63];
        out += tbl[(v >> 12) & 63];
        out += "==";
    } else if (i + 2 == in.size()) {
        uint32_t v = (in[i] << 16) | (in[i + 1] << 8);
        out += tbl[(v >> 18) & 63];
        out += tbl[(v >> 12) & 63];
        out += tbl[(v >> 6) & 63];
        out += '=';
    }
    return out;
}

void write_bytes(const std::string& path, const std::vector<unsigned char>& b) {
    std::ofstream out(path, std::ios::binary);
    out.write(reinterpret_cast<const char*>(b.data()), static_cast<std::streamsize>(b.size()));
}

void write_text(const std::string& path, const std::string& s) { std::ofstream(path) << s; }

void put_u32(std::vector<unsigned char>& b, uint32_t v) {
    for (int k = 0; k < 4; ++k) b.push_back(static_cast<unsigned char>(v >> (8 * k)));
}

// A glTF document assembled by hand: one binary buffer, JSON arrays as text.
struct Gltf {
    std::vector<unsigned char> bin;
    std::vector<std::string> views, accessors, meshes, nodes, materials, cameras, textures, images, samplers, lights;
    std::vector<int> scene_nodes;
    std::vector<std::string> used, required;
    std::string extra;  // more top-level members, with a leading comma

    int view(const void* data, size_t n) {
        while (bin.size() % 4) bin.push_back(0);
        size_t off = bin.size();
        const auto* p = static_cast<const unsigned char*>(data);
        bin.insert(bin.end(), p, p + n);
        views.push_back("{\"buffer\":0,\"byteOffset\":" + std::to_string(off) + ",\"byteLength\":" + std::to_string(n) +
                        "}");
        return static_cast<int>(views.size()) - 1;
    }
    int accessor(int view, int component, size_t count, const char* type) {
        accessors.push_back("{\"bufferView\":" + std::to_string(view) +
                            ",\"componentType\":" + std::to_string(component) + ",\"count\":" + std::to_string(count) +
                            ",\"type\":\"" + type + "\"}");
        return static_cast<int>(accessors.size()) - 1;
    }
    int vec3s(const std::vector<glm::vec3>& v) {
        return accessor(view(v.data(), v.size() * 12), 5126, v.size(), "VEC3");
    }
    int vec2s(const std::vector<glm::vec2>& v) {
        return accessor(view(v.data(), v.size() * 8), 5126, v.size(), "VEC2");
    }
    int indices(const std::vector<uint32_t>& v) {
        return accessor(view(v.data(), v.size() * 4), 5125, v.size(), "SCALAR");
    }
    int indices16(const std::vector<uint16_t>& v) {
        return accessor(view(v.data(), v.size() * 2), 5123, v.size(), "SCALAR");
    }
    int add(std::vector<std::string>& list, const std::string& json) {
        list.push_back(json);
        return static_cast<int>(list.size()) - 1;
    }
    // A node at the scene root.
    int root(const std::string& json) {
        int n = add(nodes, json);
        scene_nodes.push_back(n);
        return n;
    }

    std::string json(const std::string& buffer_uri) const {
        auto arr = [](const char* name, const std::vector<std::string>& items) {
            return items.empty() ? std::string() : ",\"" + std::string(name) + "\":[" + join(items) + "]";
        };
        auto strs = [](const std::vector<std::string>& v) {
            std::vector<std::string> q;
            for (const auto& s : v) q.push_back("\"" + s + "\"");
            return q;
        };
        std::vector<std::string> sn;
        for (int n : scene_nodes) sn.push_back(std::to_string(n));
        std::string buffer = "{\"byteLength\":" + std::to_string(bin.size()) +
                             (buffer_uri.empty() ? "" : ",\"uri\":\"" + buffer_uri + "\"") + "}";
        std::string s = "{\"asset\":{\"version\":\"2.0\",\"generator\":\"vkmech tests\"}";
        s += ",\"scene\":0,\"scenes\":[{\"nodes\":[" + join(sn) + "]}]";
        s += arr("nodes", nodes) + arr("meshes", meshes) + arr("materials", materials) + arr("cameras", cameras);
        s += arr("textures", textures) + arr("images", images) + arr("samplers", samplers);
        s += arr("accessors", accessors) + arr("bufferViews", views);
        if (!bin.empty()) s += ",\"buffers\":[" + buffer + "]";
        s += arr("extensionsUsed", strs(used)) + arr("extensionsRequired", strs(required));
        if (!lights.empty()) s += ",\"extensions\":{\"KHR_lights_punctual\":{\"lights\":[" + join(lights) + "]}}";
        return s + extra + "}";
    }

    // .gltf + external .bin
    std::string write_external(const TempDir& dir, const std::string& name) const {
        write_bytes(dir.file(name + ".bin"), bin);
        std::string path = dir.file(name + ".gltf");
        write_text(path, json(name + ".bin"));
        return path;
    }
    // .gltf with the buffer as a base64 data URI
    std::string write_embedded(const TempDir& dir, const std::string& name) const {
        std::string path = dir.file(name + ".gltf");
        write_text(path, json("data:application/octet-stream;base64," + base64(bin)));
        return path;
    }
    // .glb: 12-byte header, JSON chunk (space-padded), BIN chunk (zero-padded)
    std::vector<unsigned char> glb() const {
        std::string j = json("");
        while (j.size() % 4) j += ' ';
        std::vector<unsigned char> b = bin;
        while (b.size() % 4) b.push_back(0);
        std::vector<unsigned char> out = {'g', 'l', 'T', 'F'};
        put_u32(out, 2);
        put_u32(out, static_cast<uint32_t>(12 + 8 + j.size() + (b.empty() ? 0 : 8 + b.size())));
        put_u32(out, static_cast<uint32_t>(j.size()));
        put_u32(out, 0x4E4F534Au);
        out.insert(out.end(), j.begin(), j.end());
        if (!b.empty()) {
            put_u32(out, static_cast<uint32_t>(b.size()));
            put_u32(out, 0x004E4942u);
            out.insert(out.end(), b.begin(), b.end());
        }
        return out;
    }
    std::string write_glb(const TempDir& dir, const std::string& name) const {
        std::string path = dir.file(name + ".glb");
        write_bytes(path, glb());
        return path;
    }
};

// The unit quad [0,1]^2 at z = 0, counter-clockwise seen from +z.
const std::vector<glm::vec3> kQuad = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
const std::vector<uint32_t> kQuadIdx = {0, 1, 2, 0, 2, 3};

// A quad mesh (optionally with a material); returns the mesh index.
int quad_mesh(Gltf& g, int material = -1, bool normals = false) {
    int pos = g.vec3s(kQuad);
    int idx = g.indices(kQuadIdx);
    std::string attrs = "\"POSITION\":" + std::to_string(pos);
    if (normals) attrs += ",\"NORMAL\":" + std::to_string(g.vec3s(std::vector<glm::vec3>(4, {0, 0, 1})));
    return g.add(g.meshes, "{\"primitives\":[{\"attributes\":{" + attrs + "},\"indices\":" + std::to_string(idx) +
                               (material >= 0 ? ",\"material\":" + std::to_string(material) : "") + "}]}");
}

bool near(const glm::vec3& a, const glm::vec3& b, float tol = 1e-5f) { return glm::length(a - b) <= tol; }

bool has_warning(const Scene& s, const std::string& fragment) {
    for (const auto& w : s.warnings)
        if (w.find(fragment) != std::string::npos) return true;
    return false;
}

// A SceneError naming the file (no line: glTF is JSON plus binary) and the fault.
void expect_error(const std::string& path, const std::string& fragment, const LoadOptions& options = {}) {
    CAPTURE(path);
    CAPTURE(fragment);
    REQUIRE_THROWS_AS(load_scene(path, options), SceneError);
    try {
        load_scene(path, options);
    } catch (const SceneError& e) {
        std::string what = e.what();
        CAPTURE(what);
        CHECK(e.line() == 0);
        CHECK(what.find(fs::path(path).filename().string()) != std::string::npos);
        CHECK(what.find(fragment) != std::string::npos);
    }
}

float srgb_to_linear(float c) { return c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f); }

// A w x h RGB PNG of the 8-bit texels px (row-major, top row first).
std::vector<unsigned char> png_rgb(int w, int h, const std::vector<unsigned char>& px) {
    std::vector<unsigned char> out;
    auto sink = [](void* ctx, void* data, int size) {
        auto* v = static_cast<std::vector<unsigned char>*>(ctx);
        v->insert(v->end(), static_cast<unsigned char*>(data), static_cast<unsigned char*>(data) + size);
    };
    REQUIRE(stbi_write_png_to_func(sink, &out, w, h, 3, px.data(), 3 * w) != 0);
    return out;
}

std::vector<unsigned char> png_2x2() {
    // Top row: red, mid green; bottom row: blue, white.
    return png_rgb(2, 2, {255, 0, 0, 0, 128, 0, 0, 0, 255, 255, 255, 255});
}

// A quad with TEXCOORD_0 from (0, 0) to (1, 1), its material made of `material` (JSON), whose
// textures can use texture 0: png_2x2() as a data URI.
void textured_quad(Gltf& g, const std::string& material) {
    g.images.push_back("{\"uri\":\"data:image/png;base64," + base64(png_2x2()) + "\"}");
    g.textures.push_back("{\"source\":0}");
    int mat = g.add(g.materials, material);
    int pos = g.vec3s(kQuad);
    int uv = g.vec2s({{0, 0}, {1, 0}, {1, 1}, {0, 1}});
    int idx = g.indices16({0, 1, 2, 0, 2, 3});
    int mesh = g.add(g.meshes, "{\"primitives\":[{\"attributes\":{\"POSITION\":" + std::to_string(pos) +
                                   ",\"TEXCOORD_0\":" + std::to_string(uv) + "},\"indices\":" + std::to_string(idx) +
                                   ",\"material\":" + std::to_string(mat) + "}]}");
    g.root("{\"mesh\":" + std::to_string(mesh) + "}");
}

}  // namespace

TEST_CASE("gltf: external bin - embedded data URI and glb load the same triangles") {
    TempDir dir("formats");
    Gltf g;
    int mesh = quad_mesh(g);
    g.root("{\"mesh\":" + std::to_string(mesh) + ",\"translation\":[0.5,0,-2]}");
    std::vector<std::string> paths = {g.write_external(dir, "ext"), g.write_embedded(dir, "emb"),
                                      g.write_glb(dir, "bin")};
    std::vector<Scene> scenes;
    for (const auto& p : paths) scenes.push_back(load_scene(p));
    for (size_t i = 0; i < scenes.size(); ++i) {
        const Scene& s = scenes[i];
        CAPTURE(paths[i]);
        CHECK(s.source == paths[i]);
        REQUIRE(s.meshes.size() == 1);
        CHECK(s.triangle_count() == 2);
        CHECK(s.integrator.max_depth == 12);
        CHECK(s.integrator.rr_depth == 5);
        const Mesh& m = s.meshes[0];
        REQUIRE(m.positions.size() == 4);
        for (size_t v = 0; v < 4; ++v) CHECK(near(m.positions[v], kQuad[v] + glm::vec3(0.5f, 0.0f, -2.0f)));
        CHECK(m.indices == scenes[0].meshes[0].indices);
        for (const auto& t : m.indices) CHECK(triangle_cross(m, t).z > 0.0f);  // CCW front face kept
        CHECK(m.normals.empty());                                              // no NORMAL: flat, as glTF asks
        CHECK(has_warning(s, "no camera"));
        CHECK(has_warning(s, "no emitter"));  // a lightless file would render black
        CHECK(s.warnings.size() == 2);        // nothing else to say about a plain file
    }
    // The extension is matched without regard to case.
    fs::copy_file(paths[0], dir.file("UPPER.GLTF"));
    CHECK(load_scene(dir.file("UPPER.GLTF")).triangle_count() == 2);
}

TEST_CASE("gltf: node transforms - TRS child under a matrix parent - mirrors keep faces outwards") {
    TempDir dir("nodes");
    SUBCASE("world positions are parent matrix * T * R * S") {
        Gltf g;
        int pos = g.vec3s({{1, 0, 0}, {0, 1, 0}, {0, 0, 1}});
        int mesh = g.add(g.meshes, "{\"primitives\":[{\"attributes\":{\"POSITION\":" + std::to_string(pos) + "}}]}");
        // Child: scale (1,2,1), then 90 degrees about +Z, then translate (0,0,1).
        float h = std::sqrt(0.5f);
        int child = g.add(g.nodes, "{\"mesh\":" + std::to_string(mesh) + ",\"translation\":[0,0,1],\"rotation\":[0,0," +
                                       num(h) + "," + num(h) + "],\"scale\":[1,2,1]}");
        // Parent: uniform scale 2 then translate (1,2,3), column-major.
        g.root("{\"children\":[" + std::to_string(child) + "],\"matrix\":[2,0,0,0, 0,2,0,0, 0,0,2,0, 1,2,3,1]}");
        Scene s = load_scene(g.write_external(dir, "trs"));
        REQUIRE(s.meshes.size() == 1);
        const Mesh& m = s.meshes[0];
        // (1,0,0): S -> (1,0,0), R -> (0,1,0), T -> (0,1,1), parent -> (1,4,5).
        CHECK(near(m.positions[0], {1, 4, 5}, 1e-5f));
        // (0,1,0): S -> (0,2,0), R -> (-2,0,0), T -> (-2,0,1), parent -> (-3,2,5).
        CHECK(near(m.positions[1], {-3, 2, 5}, 1e-5f));
        // (0,0,1): -> (0,0,2) -> parent (1,2,7).
        CHECK(near(m.positions[2], {1, 2, 7}, 1e-5f));
    }
    SUBCASE("a mirroring scale keeps a closed mesh's faces outwards and normals along them") {
        // A tetrahedron wound counter-clockwise seen from outside.
        std::vector<glm::vec3> p = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
        std::vector<uint32_t> idx = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};
        for (const char* scale : {"[1,1,1]", "[-1,1,1]", "[1,-2,1]", "[-1,-1,-1]"}) {
            CAPTURE(scale);
            Gltf g;
            int pa = g.vec3s(p), ia = g.indices(idx);
            int mesh = g.add(g.meshes, "{\"primitives\":[{\"attributes\":{\"POSITION\":" + std::to_string(pa) +
                                           "},\"indices\":" + std::to_string(ia) + "}]}");
            g.root("{\"mesh\":" + std::to_string(mesh) + ",\"scale\":" + scale + "}");
            // The quad with normals under the same mirror: normals follow the faces.
            int quad = quad_mesh(g, -1, /*normals=*/true);
            g.root("{\"mesh\":" + std::to_string(quad) + ",\"scale\":" + scale + "}");
            Scene s = load_scene(g.write_glb(dir, "mirror"));
            REQUIRE(s.meshes.size() == 2);
            const Mesh& m = s.meshes[0];
            glm::vec3 c(0.0f);
            for (const auto& q : m.positions) c += q / 4.0f;
            for (const auto& t : m.indices) {
                glm::vec3 fc = (m.positions[t.x] + m.positions[t.y] + m.positions[t.z]) / 3.0f;
                CHECK(glm::dot(triangle_cross(m, t), fc - c) > 0.0f);
            }
            const Mesh& q = s.meshes[1];
            REQUIRE(q.normals.size() == 4);
            for (const auto& t : q.indices) CHECK(glm::dot(triangle_cross(q, t), q.normals[t.x]) > 0.0f);
        }
    }
}

TEST_CASE("gltf: the first camera - forward is glTF -Z - up +Y - not mirrored - yfov and aspect") {
    TempDir dir("camera");
    Gltf g;
    int mesh = quad_mesh(g);
    g.root("{\"mesh\":" + std::to_string(mesh) + "}");
    g.cameras.push_back(
        "{\"type\":\"perspective\",\"name\":\"cam\",\"perspective\":{\"yfov\":0.5,\"aspectRatio\":1.5,\"znear\":0.1,"
        "\"zfar\":100}}");
    g.cameras.push_back("{\"type\":\"perspective\",\"perspective\":{\"yfov\":1.0,\"znear\":0.1}}");
    // 90 degrees about +Y at (1,2,3): glTF's -Z turns to -X, +X to -Z.
    float h = std::sqrt(0.5f);
    int cam = g.add(g.nodes, "{\"camera\":0,\"translation\":[1,2,3],\"rotation\":[0," + num(h) + ",0," + num(h) + "]}");
    g.root("{\"children\":[" + std::to_string(cam) + "]}");
    g.root("{\"camera\":1}");  // reached later: ignored
    Scene s = load_scene(g.write_external(dir, "cam"));
    const Camera& c = s.camera;
    CHECK(c.type == CameraType::Perspective);
    CHECK(near(glm::vec3(c.to_world[2]), {-1, 0, 0}));  // forward = glTF -Z in world space
    CHECK(near(glm::vec3(c.to_world[1]), {0, 1, 0}));   // up = glTF +Y
    CHECK(near(glm::vec3(c.to_world[0]), {0, 0, 1}));   // Mitsuba's +X is the image's left = -(glTF +X)
    CHECK(near(glm::vec3(c.to_world[3]), {1, 2, 3}));
    CHECK(glm::determinant(glm::mat3(c.to_world)) == doctest::Approx(1.0f));  // a rotation: no mirror, no scale
    // A point to the glTF camera's right lands in the right half of the image:
    // camera-space x < 0 is u > 0.5 (shaders/camera.glsl).
    glm::vec3 right_point = glm::vec3(1, 2, 3) + 5.0f * glm::vec3(-1, 0, 0) + glm::vec3(0, 0, -1);
    glm::vec3 local = glm::vec3(glm::inverse(c.to_world) * glm::vec4(right_point, 1.0f));
    CHECK(local.z > 0.0f);
    CHECK(local.x < 0.0f);
    CHECK(c.fov_axis == "y");
    CHECK(c.fov_deg == doctest::Approx(0.5 * 180.0 / std::numbers::pi));
    CHECK(c.width == 384);
    CHECK(c.height == 256);
    CHECK(c.near_clip == doctest::Approx(0.1f));
    CHECK(c.far_clip == doctest::Approx(100.0f));
    CHECK_FALSE(has_warning(s, "no camera"));
    CHECK(has_warning(s, "only the first camera"));

    SUBCASE("no aspect ratio: 256 x 256") {
        Gltf g2;
        int m2 = quad_mesh(g2);
        g2.root("{\"mesh\":" + std::to_string(m2) + "}");
        g2.cameras.push_back("{\"type\":\"perspective\",\"perspective\":{\"yfov\":0.8,\"znear\":0.01}}");
        g2.root("{\"camera\":0,\"translation\":[0,0,5]}");
        Scene s2 = load_scene(g2.write_glb(dir, "square"));
        CHECK(s2.camera.width == 256);
        CHECK(s2.camera.height == 256);
        CHECK(near(glm::vec3(s2.camera.to_world[2]), {0, 0, -1}));
        CHECK(near(glm::vec3(s2.camera.to_world[0]), {-1, 0, 0}));
    }
    SUBCASE("orthographic cameras are refused") {
        Gltf g3;
        int m3 = quad_mesh(g3);
        g3.root("{\"mesh\":" + std::to_string(m3) + "}");
        g3.cameras.push_back(
            "{\"type\":\"orthographic\",\"orthographic\":{\"xmag\":1,\"ymag\":1,\"znear\":0.1,\"zfar\":10}}");
        g3.root("{\"camera\":0}");
        expect_error(g3.write_external(dir, "ortho"), "orthographic");
    }
}

TEST_CASE("gltf: no camera - a camera framing the scene's bounds and a warning") {
    TempDir dir("framing");
    Gltf g;
    int mesh = quad_mesh(g);
    g.root("{\"mesh\":" + std::to_string(mesh) + ",\"translation\":[3,-1,2],\"scale\":[4,2,1]}");
    Scene s = load_scene(g.write_external(dir, "frame"));
    CHECK(has_warning(s, "no camera"));
    const Camera& c = s.camera;
    CHECK(c.fov_axis == "y");
    CHECK(c.fov_deg == doctest::Approx(45.0f));
    CHECK(near(glm::vec3(c.to_world[2]), {0, 0, -1}));
    CHECK(near(glm::vec3(c.to_world[1]), {0, 1, 0}));
    CHECK(glm::determinant(glm::mat3(c.to_world)) == doctest::Approx(1.0f));
    // Looks at the centre; every corner of the bounds is in view and in the clip range.
    glm::vec3 centre(5, 0, 2);
    glm::vec3 eye(c.to_world[3]);
    CHECK(near(glm::normalize(centre - eye), {0, 0, -1}));
    glm::mat4 to_cam = glm::inverse(c.to_world);
    float t = std::tan(glm::radians(22.5f));
    for (float x : {3.0f, 7.0f})
        for (float y : {-1.0f, 1.0f}) {
            glm::vec3 l = glm::vec3(to_cam * glm::vec4(x, y, 2.0f, 1.0f));
            CHECK(l.z > c.near_clip);
            CHECK(l.z < c.far_clip);
            CHECK(std::abs(l.x / l.z) <= t);
            CHECK(std::abs(l.y / l.z) <= t);
        }
}

TEST_CASE("gltf: metallic-roughness materials map to the model's families") {
    TempDir dir("materials");
    Gltf g;
    auto mat = [&](const std::string& pbr, const std::string& more = "") {
        return g.add(g.materials, "{\"name\":\"m" + std::to_string(g.materials.size()) +
                                      "\",\"pbrMetallicRoughness\":{" + pbr + "}" + more + "}");
    };
    int rough_plastic = mat("\"baseColorFactor\":[0.8,0.2,0.1,1],\"metallicFactor\":0,\"roughnessFactor\":0.5");
    int plastic = mat("\"metallicFactor\":0,\"roughnessFactor\":0");
    int rough_conductor = mat("\"baseColorFactor\":[0.9,0.6,0.3,1],\"metallicFactor\":1,\"roughnessFactor\":0.3");
    int conductor = mat("\"metallicFactor\":1,\"roughnessFactor\":0");
    int rough_dielectric = mat("\"metallicFactor\":0,\"roughnessFactor\":0.2",
                               ",\"extensions\":{\"KHR_materials_transmission\":{\"transmissionFactor\":1},"
                               "\"KHR_materials_ior\":{\"ior\":1.33}}");
    int dielectric = mat("\"metallicFactor\":0,\"roughnessFactor\":0",
                         ",\"extensions\":{\"KHR_materials_transmission\":{\"transmissionFactor\":1}}");
    int clearcoat = mat("\"baseColorFactor\":[0.1,0.2,0.7,1],\"metallicFactor\":0.2,\"roughnessFactor\":0.4",
                        ",\"extensions\":{\"KHR_materials_clearcoat\":{\"clearcoatFactor\":0.7,"
                        "\"clearcoatRoughnessFactor\":0.2}}");
    int two_sided = mat("\"metallicFactor\":0,\"roughnessFactor\":1", ",\"doubleSided\":true");
    int half_metal = mat("\"metallicFactor\":0.3,\"roughnessFactor\":0.5");
    int see_through = mat("\"baseColorFactor\":[1,1,1,0.5],\"metallicFactor\":0", ",\"alphaMode\":\"BLEND\"");
    g.used = {"KHR_materials_transmission", "KHR_materials_ior", "KHR_materials_clearcoat"};
    int pos = g.vec3s(kQuad);
    int idx = g.indices(kQuadIdx);
    std::vector<std::string> prims;
    for (int m = 0; m < static_cast<int>(g.materials.size()); ++m)
        prims.push_back("{\"attributes\":{\"POSITION\":" + std::to_string(pos) +
                        "},\"indices\":" + std::to_string(idx) + ",\"material\":" + std::to_string(m) + "}");
    prims.push_back("{\"attributes\":{\"POSITION\":" + std::to_string(pos) + "},\"indices\":" + std::to_string(idx) +
                    "}");
    int mesh = g.add(g.meshes, "{\"name\":\"all\",\"primitives\":[" + join(prims) + "]}");
    g.root("{\"mesh\":" + std::to_string(mesh) + "}");
    Scene s = load_scene(g.write_external(dir, "mats"));
    REQUIRE(s.meshes.size() == g.materials.size() + 1);
    auto of = [&](int prim) -> const Material& { return s.materials.at(s.meshes.at(prim).material); };

    const Material& rp = of(rough_plastic);
    CHECK(rp.type == BsdfType::RoughPlastic);
    CHECK(near(rp.reflectance.value, {0.8f, 0.2f, 0.1f}));
    CHECK(rp.reflectance.texture == -1);
    CHECK(rp.distribution == MicrofacetDistribution::GGX);
    CHECK(rp.alpha_u == doctest::Approx(0.25f));  // alpha = roughness^2
    CHECK(rp.alpha_v == doctest::Approx(0.25f));
    CHECK(rp.int_ior == doctest::Approx(1.5f));
    CHECK(rp.ext_ior == doctest::Approx(1.0f));
    CHECK_FALSE(rp.twosided);
    CHECK(rp.id == "m0");

    CHECK(of(plastic).type == BsdfType::Plastic);
    CHECK(near(of(plastic).reflectance.value, {1, 1, 1}));

    const Material& rc = of(rough_conductor);
    CHECK(rc.type == BsdfType::RoughConductor);
    CHECK(rc.alpha_u == doctest::Approx(0.09f));
    CHECK(near(rc.eta, {0, 0, 0}));
    CHECK(near(rc.k, {1, 1, 1}));
    CHECK(near(rc.specular_reflectance, {0.9f, 0.6f, 0.3f}));
    CHECK(of(conductor).type == BsdfType::Conductor);

    const Material& rd = of(rough_dielectric);
    CHECK(rd.type == BsdfType::RoughDielectric);
    CHECK(rd.int_ior == doctest::Approx(1.33f));
    CHECK(rd.ext_ior == doctest::Approx(1.0f));
    CHECK(rd.alpha_u == doctest::Approx(0.04f));
    const Material& d = of(dielectric);
    CHECK(d.type == BsdfType::Dielectric);
    CHECK(d.int_ior == doctest::Approx(1.5f));

    const Material& cc = of(clearcoat);
    CHECK(cc.type == BsdfType::Principled);
    CHECK(near(cc.reflectance.value, {0.1f, 0.2f, 0.7f}));
    CHECK(cc.metallic == doctest::Approx(0.2f));
    CHECK(cc.roughness == doctest::Approx(0.4f));
    CHECK(cc.clearcoat == doctest::Approx(0.7f));
    CHECK(cc.clearcoat_gloss == doctest::Approx(0.8f));

    CHECK(of(two_sided).twosided);
    CHECK(of(two_sided).type == BsdfType::RoughPlastic);
    CHECK(of(two_sided).alpha_u == doctest::Approx(1.0f));
    CHECK(of(half_metal).type == BsdfType::RoughPlastic);
    CHECK(has_warning(s, "material 8 'm8': metallicFactor 0.3"));
    CHECK(has_warning(s, "material 9 'm9': alpha"));

    // No material: glTF's default (white, metallic 1, roughness 1).
    const Material& def = of(static_cast<int>(g.materials.size()));
    CHECK(def.type == BsdfType::RoughConductor);
    CHECK(def.alpha_u == doctest::Approx(1.0f));
    CHECK(near(def.specular_reflectance, {1, 1, 1}));
    CHECK(s.materials.size() == g.materials.size() + 1);
    CHECK(s.emitters.empty());
    (void)see_through;
}

TEST_CASE("gltf: emissive materials with emissive_strength are front-side area emitters") {
    TempDir dir("emissive");
    Gltf g;
    int lamp = g.add(g.materials,
                     "{\"name\":\"lamp\",\"emissiveFactor\":[1,0.5,0.25],"
                     "\"extensions\":{\"KHR_materials_emissive_strength\":{\"emissiveStrength\":4}}}");
    int plain = g.add(g.materials, "{\"name\":\"glow\",\"emissiveFactor\":[0.2,0.2,0.2],\"doubleSided\":true}");
    g.used = {"KHR_materials_emissive_strength"};
    int a = quad_mesh(g, lamp), b = quad_mesh(g, plain), c = quad_mesh(g);
    g.root("{\"mesh\":" + std::to_string(a) + "}");
    g.root("{\"mesh\":" + std::to_string(b) + ",\"translation\":[0,0,1]}");
    g.root("{\"mesh\":" + std::to_string(c) + ",\"translation\":[0,0,2]}");
    Scene s = load_scene(g.write_glb(dir, "emit"));
    REQUIRE(s.meshes.size() == 3);
    REQUIRE(s.emitters.size() == 2);
    const Mesh& m = s.meshes[0];
    REQUIRE(m.emitter == 0);
    CHECK(s.emitters[0].mesh == 0);
    CHECK(near(s.emitters[0].radiance, {4.0f, 2.0f, 1.0f}));
    // The front (counter-clockwise) face emits: the geometric normal is +z.
    for (const auto& t : m.indices) CHECK(triangle_cross(m, t).z > 0.0f);
    CHECK(s.meshes[1].emitter == 1);
    CHECK(near(s.emitters[1].radiance, {0.2f, 0.2f, 0.2f}));
    CHECK(has_warning(s, "doubleSided"));
    CHECK(s.meshes[2].emitter == -1);
}

TEST_CASE("gltf: KHR_materials_unlit is refused with the reason, and --substitute renders it lit and says so") {
    TempDir dir("unlit");
    Gltf g;
    int m = g.add(g.materials,
                  "{\"name\":\"sign\",\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.9,0.1,0.1,1],"
                  "\"metallicFactor\":0,\"roughnessFactor\":1},\"extensions\":{\"KHR_materials_unlit\":{}}}");
    g.used = {"KHR_materials_unlit"};
    g.root("{\"mesh\":" + std::to_string(quad_mesh(g, m)) + "}");
    std::string path = g.write_external(dir, "unlit");

    expect_error(path, "material 0 'sign': KHR_materials_unlit");
    expect_error(path, "--substitute");

    LoadOptions sub;
    sub.substitute_unsupported = true;
    Scene s = load_scene(path, sub);
    REQUIRE(s.substitutions.size() == 1);
    CHECK(s.substitutions[0].find("KHR_materials_unlit ignored") != std::string::npos);
    CHECK(s.substitutions[0].find("'sign'") != std::string::npos);
    CHECK_FALSE(has_warning(s, "KHR_materials_unlit"));  // said once, as a substitution
    const Material& mat = s.materials.at(s.meshes.at(0).material);
    CHECK(mat.emission_texture < 0);
    CHECK(s.emitters.empty());  // lit, not a light
    CHECK(near(mat.reflectance.value, {0.9f, 0.1f, 0.1f}));
}

TEST_CASE("gltf: KHR_lights_punctual is an error unless substituted by spheres of equal power") {
    TempDir dir("lights");
    Gltf g;
    int mesh = quad_mesh(g);
    g.root("{\"mesh\":" + std::to_string(mesh) + ",\"scale\":[3,4,1]}");  // bounds diagonal 5
    g.lights.push_back("{\"name\":\"bulb\",\"type\":\"point\",\"intensity\":10,\"color\":[1,0.5,0.25]}");
    g.lights.push_back("{\"name\":\"cone\",\"type\":\"spot\",\"intensity\":2,\"spot\":{\"outerConeAngle\":0.5}}");
    g.used = {"KHR_lights_punctual"};
    g.root("{\"translation\":[1,1,2],\"extensions\":{\"KHR_lights_punctual\":{\"light\":0}}}");
    g.root("{\"translation\":[2,1,2],\"extensions\":{\"KHR_lights_punctual\":{\"light\":1}}}");
    std::string path = g.write_external(dir, "lights");

    expect_error(path, "light 0 'bulb' (point");
    try {
        load_scene(path);
    } catch (const SceneError& e) {
        CHECK(std::string(e.what()).find("--substitute") != std::string::npos);
    }

    LoadOptions sub;
    sub.substitute_unsupported = true;
    Scene s = load_scene(path, sub);
    REQUIRE(s.meshes.size() == 3);
    REQUIRE(s.emitters.size() == 2);
    REQUIRE(s.substitutions.size() == 2);
    CHECK(s.substitutions[0].find("bulb") != std::string::npos);
    CHECK(s.substitutions[1].find("cone") != std::string::npos);
    CHECK(has_warning(s, "cone is ignored"));
    const Mesh& sphere = s.meshes[1];
    CHECK(sphere.kind == ShapeKind::Sphere);
    CHECK(sphere.radius == doctest::Approx(0.05f));  // 1e-2 of the bounds' diagonal
    CHECK(near(sphere.center, {1, 1, 2}));
    REQUIRE(sphere.emitter >= 0);
    const AreaEmitter& e = s.emitters[sphere.emitter];
    CHECK(e.mesh == 1);
    // Power: pi L A (a uniform one-sided emitter) equals 4 pi I colour.
    double area = surface_area(sphere);
    CHECK(kPi * e.radiance.x * area == doctest::Approx(4.0 * kPi * 10.0).epsilon(1e-4));
    CHECK(kPi * e.radiance.y * area == doctest::Approx(4.0 * kPi * 5.0).epsilon(1e-4));
    CHECK(kPi * e.radiance.z * area == doctest::Approx(4.0 * kPi * 2.5).epsilon(1e-4));
    // About I / (pi r^2) for the tessellated sphere.
    CHECK(e.radiance.x == doctest::Approx(10.0f / (kPi * 0.05f * 0.05f)).epsilon(0.02));
    const AreaEmitter& spot = s.emitters[s.meshes[2].emitter];
    CHECK(kPi * spot.radiance.x * surface_area(s.meshes[2]) == doctest::Approx(4.0 * kPi * 2.0).epsilon(1e-4));

    SUBCASE("a directional light is a light at infinity along its node's -Z, with or without --substitute") {
        Gltf d;
        int m = quad_mesh(d);
        d.root("{\"mesh\":" + std::to_string(m) + "}");
        d.lights.push_back("{\"name\":\"sun\",\"type\":\"directional\",\"intensity\":3,\"color\":[1,0.5,1]}");
        // Turned 90 degrees about +x (quaternion x = sin 45, w = cos 45): -Z becomes +Y.
        d.root("{\"rotation\":[0.70710678,0,0,0.70710678],\"extensions\":{\"KHR_lights_punctual\":{\"light\":0}}}");
        std::string sun = d.write_external(dir, "sun");
        for (const Scene& ds : {load_scene(sun), load_scene(sun, sub)}) {
            REQUIRE(ds.directional_lights.size() == 1);
            CHECK(near(ds.directional_lights[0].direction, {0, 1, 0}));
            CHECK(near(ds.directional_lights[0].irradiance, {3, 1.5f, 3}));
            CHECK(ds.emitters.empty());
            CHECK(ds.substitutions.empty());
        }
    }
}

TEST_CASE("gltf: an emissiveTexture scales the emitter's radiance (emissiveFactor x strength) point by point") {
    TempDir dir("emissive");
    Gltf g;
    g.used = {"KHR_materials_emissive_strength"};
    textured_quad(g,
                  "{\"name\":\"glow\",\"emissiveFactor\":[1,0.5,1],\"emissiveTexture\":{\"index\":0},"
                  "\"extensions\":{\"KHR_materials_emissive_strength\":{\"emissiveStrength\":4}}}");
    Scene s = load_scene(g.write_external(dir, "glow"));
    REQUIRE(s.emitters.size() == 1);
    CHECK(near(s.emitters[0].radiance, {4, 2, 4}));
    const Material& m = s.materials[s.meshes[0].material];
    REQUIRE(m.emission_texture >= 0);
    const Texture& t = s.textures[m.emission_texture];
    CHECK(t.rgb[0] == doctest::Approx(1.0f));  // sRGB-decoded, the factor not baked in
    CHECK(t.rgb[4] == doctest::Approx(srgb_to_linear(128.0f / 255.0f)).epsilon(1e-3));
    CHECK_FALSE(has_warning(s, "emissiveTexture"));
}

TEST_CASE("gltf: a metallicRoughnessTexture makes a principled material whose metallic and roughness vary per point") {
    TempDir dir("mr");
    Gltf g;
    textured_quad(g,
                  "{\"name\":\"mr\",\"pbrMetallicRoughness\":{\"metallicFactor\":0.5,"
                  "\"roughnessFactor\":0.25,\"metallicRoughnessTexture\":{\"index\":0}}}");
    Scene s = load_scene(g.write_external(dir, "mr"));
    const Material& m = s.materials[s.meshes[0].material];
    CHECK(m.type == BsdfType::Principled);
    REQUIRE(m.metallic_roughness_texture >= 0);
    const Texture& t = s.textures[m.metallic_roughness_texture];
    // Linear data (not sRGB-decoded), G times roughnessFactor, B times metallicFactor. Texels: red,
    // mid green (128); blue, white.
    CHECK(t.rgb[1] == 0.0f);
    CHECK(t.rgb[4] == doctest::Approx(0.25f * 128.0f / 255.0f).epsilon(1e-4));
    CHECK(t.rgb[8] == doctest::Approx(0.5f));
    CHECK(t.rgb[10] == doctest::Approx(0.25f));
    // The constants are the texture's means.
    CHECK(m.roughness == doctest::Approx(0.25f * (128.0f / 255.0f + 1.0f) / 4.0f).epsilon(1e-4));
    CHECK(m.metallic == doctest::Approx(0.5f * 2.0f / 4.0f).epsilon(1e-4));
    CHECK_FALSE(has_warning(s, "metallicRoughnessTexture"));
}

TEST_CASE("gltf: KHR_texture_transform becomes the texture's uv transform, T R S as the extension's GLSL") {
    TempDir dir("uvxform");
    Gltf g;
    g.used = {"KHR_texture_transform"};
    textured_quad(g,
                  "{\"pbrMetallicRoughness\":{\"metallicFactor\":0,\"baseColorTexture\":{\"index\":0,"
                  "\"extensions\":{\"KHR_texture_transform\":{\"offset\":[0.5,0.25],"
                  "\"rotation\":1.5707963268,\"scale\":[2,3]}}}}}");
    Scene s = load_scene(g.write_external(dir, "uvxform"));
    REQUIRE(s.textures.size() == 1);
    // Rotation 90 degrees (c = 0, s = 1): u' = -3 v + 0.5, v' = 2 u + 0.25.
    const glm::mat3& m = s.textures[0].to_uv;
    auto at = [&](float u, float v) { return glm::vec2(m * glm::vec3(u, v, 1.0f)); };
    CHECK(glm::length(at(0, 0) - glm::vec2(0.5f, 0.25f)) < 1e-6f);
    CHECK(glm::length(at(1, 0) - glm::vec2(0.5f, 2.25f)) < 1e-6f);
    CHECK(glm::length(at(0, 1) - glm::vec2(-2.5f, 0.25f)) < 1e-6f);
    CHECK_FALSE(has_warning(s, "KHR_texture_transform"));
}

TEST_CASE("gltf: base-colour textures from a data URI and a glb bufferView are decoded sRGB to linear") {
    TempDir dir("texture");
    std::vector<unsigned char> png = png_2x2();
    auto build = [&](Gltf& g, bool in_buffer, const std::string& factor, double metallic) {
        if (in_buffer) {
            int v = g.view(png.data(), png.size());
            g.images.push_back("{\"bufferView\":" + std::to_string(v) + ",\"mimeType\":\"image/png\"}");
        } else {
            g.images.push_back("{\"uri\":\"data:image/png;base64," + base64(png) + "\"}");
        }
        g.samplers.push_back("{\"magFilter\":9728}");
        g.textures.push_back("{\"source\":0,\"sampler\":0}");
        int mat = g.add(g.materials, "{\"name\":\"tex\",\"pbrMetallicRoughness\":{\"baseColorFactor\":" + factor +
                                         ",\"metallicFactor\":" + num(metallic) +
                                         ",\"baseColorTexture\":{\"index\":0}},\"normalTexture\":{\"index\":0}}");
        int pos = g.vec3s(kQuad);
        int uv = g.vec2s({{0, 0}, {1, 0}, {1, 1}, {0, 1}});
        int idx = g.indices16({0, 1, 2, 0, 2, 3});
        int mesh =
            g.add(g.meshes, "{\"primitives\":[{\"attributes\":{\"POSITION\":" + std::to_string(pos) +
                                ",\"TEXCOORD_0\":" + std::to_string(uv) + "},\"indices\":" + std::to_string(idx) +
                                ",\"material\":" + std::to_string(mat) + "}]}");
        g.root("{\"mesh\":" + std::to_string(mesh) + "}");
    };
    const float g128 = srgb_to_linear(128.0f / 255.0f);
    SUBCASE("data URI, white factor: plastic with the texture") {
        Gltf g;
        build(g, false, "[1,1,1,1]", 0.0);
        Scene s = load_scene(g.write_external(dir, "uri"));
        REQUIRE(s.textures.size() == 2);  // the base colour (sRGB-decoded) and the normal map (linear)
        const Texture& t = s.textures[0];
        CHECK(t.width == 2);
        CHECK(t.height == 2);
        CHECK(t.nearest);
        REQUIRE(t.rgb.size() == 12);
        // Row-major, top row first: red, green; blue, white.
        CHECK(t.rgb[0] == doctest::Approx(1.0f));
        CHECK(t.rgb[1] == doctest::Approx(0.0f));
        CHECK(t.rgb[4] == doctest::Approx(g128).epsilon(1e-3));
        CHECK(t.rgb[8] == doctest::Approx(1.0f));
        CHECK(t.rgb[9] == doctest::Approx(1.0f));
        const Material& m = s.materials[s.meshes[0].material];
        CHECK(m.type == BsdfType::RoughPlastic);
        CHECK(m.reflectance.texture == 0);
        CHECK(m.reflectance.value.x == doctest::Approx(0.5f));
        CHECK(m.reflectance.value.y == doctest::Approx((g128 + 1.0f) / 4.0f).epsilon(1e-3));
        REQUIRE(s.meshes[0].uvs.size() == 4);
        CHECK(s.meshes[0].uvs[2] == glm::vec2(1, 1));  // no v flip
        // The same image as the normal map: read again as linear data (a texture of its own).
        REQUIRE(m.normal_texture >= 0);
        CHECK(m.normal_texture != m.reflectance.texture);
        CHECK(s.textures[m.normal_texture].rgb[4] == doctest::Approx(128.0f / 255.0f));
        CHECK(m.normal_scale == 1.0f);
        CHECK(m.normal_uv_handed);  // glTF: the bitangent follows the uv layout (MikkTSpace's sign)
    }
    SUBCASE("glb bufferView, tinted factor, metallic: the conductor's specular texture") {
        Gltf g;
        build(g, true, "[0.5,1,1,1]", 1.0);
        Scene s = load_scene(g.write_glb(dir, "view"));
        REQUIRE(s.textures.size() == 2);  // the base colour and the normal map
        const Texture& t = s.textures[0];
        CHECK(t.rgb[0] == doctest::Approx(0.5f));  // factor premultiplied
        CHECK(t.rgb[9] == doctest::Approx(0.5f));
        const Material& m = s.materials[s.meshes[0].material];
        CHECK(m.type == BsdfType::RoughConductor);
        CHECK(m.specular_reflectance_texture == 0);
        CHECK(m.specular_reflectance.x == doctest::Approx(0.25f));
        CHECK(m.reflectance.texture == -1);
    }
}

TEST_CASE("gltf: what is read but not used is a warning - not an error") {
    TempDir dir("ignored");
    Gltf g;
    int pos = g.vec3s(kQuad);
    int idx = g.indices(kQuadIdx);
    int color = g.accessor(g.view(kQuad.data(), 48), 5126, 4, "VEC3");
    g.images.push_back("{\"uri\":\"data:image/png;base64," + base64(png_2x2()) + "\"}");
    g.textures.push_back("{\"source\":0}");
    int mat = g.add(g.materials,
                    "{\"name\":\"shiny\",\"pbrMetallicRoughness\":{\"metallicFactor\":0,\"baseColorTexture\":{"
                    "\"index\":0,\"extensions\":{\"KHR_texture_transform\":{\"scale\":[2,2]}}},"
                    "\"metallicRoughnessTexture\":{\"index\":0}},\"occlusionTexture\":{\"index\":0},"
                    "\"emissiveTexture\":{\"index\":0},\"extensions\":{\"KHR_materials_sheen\":{}}}");
    std::string tri = "\"attributes\":{\"POSITION\":" + std::to_string(pos) + ",\"COLOR_0\":" + std::to_string(color) +
                      "},\"indices\":" + std::to_string(idx);
    int mesh =
        g.add(g.meshes, "{\"primitives\":[{" + tri + ",\"material\":" + std::to_string(mat) +
                            ",\"targets\":[{\"POSITION\":" + std::to_string(color) + "}]},{" + tri + ",\"mode\":0}]}");
    g.root("{\"mesh\":" + std::to_string(mesh) + ",\"skin\":0}");
    g.used = {"KHR_texture_transform", "KHR_materials_sheen", "EXT_mesh_gpu_instancing"};
    g.extra =
        ",\"skins\":[{\"joints\":[0]}],\"animations\":[{\"channels\":[{\"sampler\":0,\"target\":{"
        "\"node\":0,\"path\":\"translation\"}}],\"samplers\":[{\"input\":0,\"output\":0}]}]";
    std::string path = g.write_external(dir, "ignored");
    Scene s = load_scene(path);
    CHECK(s.meshes.size() == 1);  // the POINTS primitive is skipped
    for (const char* w :
         {"mode 0, not TRIANGLES", "animation(s) ignored", "skins are ignored", "morph targets", "COLOR_0",
          "occlusionTexture is ignored", "emissiveTexture is ignored: emissiveFactor is 0",
          "KHR_materials_sheen is not supported", "EXT_mesh_gpu_instancing is not supported", "no camera"}) {
        CAPTURE(w);
        CHECK(has_warning(s, w));
    }
    for (const auto& w : s.warnings) CHECK(w.rfind(path + ": ", 0) == 0);  // "file: what"
}

TEST_CASE("gltf: interleaved views - normalized uv - byte indices - 32-bit indices stay exact") {
    TempDir dir("accessors");
    Gltf g;
    // POSITION and NORMAL interleaved in one view (byteStride 24).
    std::vector<float> inter;
    for (const auto& p : kQuad) inter.insert(inter.end(), {p.x, p.y, p.z, 0.0f, 0.0f, 2.0f});
    g.view(inter.data(), inter.size() * 4);
    g.views.back().insert(g.views.back().size() - 1, ",\"byteStride\":24");
    g.accessors.push_back("{\"bufferView\":0,\"componentType\":5126,\"count\":4,\"type\":\"VEC3\"}");
    g.accessors.push_back("{\"bufferView\":0,\"byteOffset\":12,\"componentType\":5126,\"count\":4,\"type\":\"VEC3\"}");
    const uint16_t uv[] = {0, 0, 65535, 0, 65535, 32768, 0, 65535};
    int uv_view = g.view(uv, sizeof uv);
    g.accessors.push_back("{\"bufferView\":" + std::to_string(uv_view) +
                          ",\"componentType\":5123,\"normalized\":true,\"count\":4,\"type\":\"VEC2\"}");
    const uint8_t idx[] = {0, 1, 2, 0, 2, 3};
    int idx_view = g.view(idx, sizeof idx);
    g.accessors.push_back("{\"bufferView\":" + std::to_string(idx_view) +
                          ",\"componentType\":5121,\"count\":6,\"type\":\"SCALAR\"}");
    int mesh = g.add(g.meshes,
                     "{\"primitives\":[{\"attributes\":{\"POSITION\":0,\"NORMAL\":1,\"TEXCOORD_0\":2},"
                     "\"indices\":3}]}");
    g.root("{\"mesh\":" + std::to_string(mesh) + "}");
    Scene s = load_scene(g.write_glb(dir, "inter"));
    REQUIRE(s.meshes.size() == 1);
    const Mesh& m = s.meshes[0];
    for (size_t v = 0; v < 4; ++v) CHECK(near(m.positions[v], kQuad[v]));
    for (const auto& n : m.normals) CHECK(near(n, {0, 0, 1}));  // renormalised
    REQUIRE(m.uvs.size() == 4);
    CHECK(m.uvs[1].x == doctest::Approx(1.0f));
    CHECK(m.uvs[2].y == doctest::Approx(32768.0f / 65535.0f));
    CHECK(m.indices.size() == 2);
    CHECK(m.indices[1] == glm::uvec3(0, 2, 3));

    // 16777217 is not a float: a float round trip would report 16777216.
    Gltf big;
    int pos = big.vec3s(kQuad);
    int bi = big.indices({0, 1, 16777217});
    int bm = big.add(big.meshes, "{\"primitives\":[{\"attributes\":{\"POSITION\":" + std::to_string(pos) +
                                     "},\"indices\":" + std::to_string(bi) + "}]}");
    big.root("{\"mesh\":" + std::to_string(bm) + "}");
    expect_error(big.write_external(dir, "big"), "index 16777217 (at 2)");
}

TEST_CASE("gltf: hostile files are SceneErrors naming the file - never a crash") {
    TempDir dir("hostile");
    auto valid = [] {
        Gltf g;
        int mesh = quad_mesh(g);
        g.root("{\"mesh\":" + std::to_string(mesh) + "}");
        return g;
    };
    SUBCASE("truncated glb") {
        std::vector<unsigned char> b = valid().glb();
        for (size_t keep : {b.size() - 7, b.size() / 2, size_t(30), size_t(10), size_t(0)}) {
            CAPTURE(keep);
            std::vector<unsigned char> cut(b.begin(), b.begin() + static_cast<std::ptrdiff_t>(keep));
            write_bytes(dir.file("cut.glb"), cut);
            expect_error(dir.file("cut.glb"), keep >= 20 ? "truncated" : "");
        }
    }
    SUBCASE("a glb whose BIN chunk claims more than the file") {
        std::vector<unsigned char> b = valid().glb();
        uint32_t json_len;
        std::memcpy(&json_len, b.data() + 12, 4);
        size_t at = 20 + json_len;
        uint32_t huge = 0x7ffffff0u;
        std::memcpy(b.data() + at, &huge, 4);
        write_bytes(dir.file("chunk.glb"), b);
        expect_error(dir.file("chunk.glb"), "runs past the end");
    }
    SUBCASE("an index out of range") {
        Gltf g;
        int pos = g.vec3s(kQuad);
        int idx = g.indices({0, 1, 7});
        int mesh = g.add(g.meshes, "{\"primitives\":[{\"attributes\":{\"POSITION\":" + std::to_string(pos) +
                                       "},\"indices\":" + std::to_string(idx) + "}]}");
        g.root("{\"mesh\":" + std::to_string(mesh) + "}");
        expect_error(g.write_external(dir, "index"), "index 7 (at 2) is out of range (4 vertices)");
    }
    SUBCASE("an accessor past the end of its bufferView") {
        Gltf g = valid();
        g.accessors[0] = "{\"bufferView\":0,\"componentType\":5126,\"count\":5,\"type\":\"VEC3\"}";
        expect_error(g.write_embedded(dir, "accessor"), "runs past the end of its bufferView");
        g.accessors[0] = "{\"bufferView\":0,\"byteOffset\":4,\"componentType\":5126,\"count\":4,\"type\":\"VEC3\"}";
        expect_error(g.write_embedded(dir, "offset"), "runs past the end of its bufferView");
    }
    SUBCASE("a bufferView past the end of its buffer") {
        Gltf g = valid();
        g.views[0] = "{\"buffer\":0,\"byteOffset\":40,\"byteLength\":48}";
        expect_error(g.write_glb(dir, "view"), "runs past the end of buffer 0");
    }
    SUBCASE("a missing external .bin") {
        Gltf g = valid();
        write_text(dir.file("nobin.gltf"), g.json("absent.bin"));
        expect_error(dir.file("nobin.gltf"), "absent.bin");
    }
    SUBCASE("a missing external image") {
        Gltf g = valid();
        g.images.push_back("{\"uri\":\"missing.png\"}");
        g.textures.push_back("{\"source\":0}");
        g.materials.push_back("{\"pbrMetallicRoughness\":{\"baseColorTexture\":{\"index\":0}}}");
        g.meshes[0] = "{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"indices\":1,\"material\":0}]}";
        expect_error(g.write_external(dir, "noimage"), "cannot read image 0 'missing.png'");
        write_text(dir.file("missing.png"), "not a png");
        expect_error(g.write_external(dir, "badimage"), "cannot decode image 0");
    }
    SUBCASE("only non-triangle primitives") {
        Gltf g;
        int pos = g.vec3s(kQuad);
        int mesh = g.add(g.meshes,
                         "{\"primitives\":[{\"attributes\":{\"POSITION\":" + std::to_string(pos) + "},\"mode\":1}]}");
        g.root("{\"mesh\":" + std::to_string(mesh) + "}");
        expect_error(g.write_external(dir, "lines"), "mode other than TRIANGLES");
    }
    SUBCASE("garbage JSON") {
        write_text(dir.file("garbage.gltf"), "{ \"asset\": { \"version\": \"2.0\" }, nodes: [ ");
        expect_error(dir.file("garbage.gltf"), "cannot load the glTF file");
        write_text(dir.file("empty.gltf"), "");
        expect_error(dir.file("empty.gltf"), "cannot load the glTF file");
        write_text(dir.file("text.glb"), "{}");
        expect_error(dir.file("text.glb"), "magic");
    }
    SUBCASE("a missing file") { expect_error(dir.file("absent.gltf"), "cannot open scene file"); }
    SUBCASE("a required extension vkmech lacks") {
        Gltf g = valid();
        g.used = g.required = {"KHR_draco_mesh_compression"};
        expect_error(g.write_external(dir, "draco"), "KHR_draco_mesh_compression");
    }
    SUBCASE("a sparse accessor") {
        Gltf g = valid();
        g.accessors[0] =
            "{\"bufferView\":0,\"componentType\":5126,\"count\":4,\"type\":\"VEC3\",\"sparse\":{"
            "\"count\":1,\"indices\":{\"bufferView\":1,\"componentType\":5125},\"values\":{\"bufferView\":0}}}";
        expect_error(g.write_external(dir, "sparse"), "sparse accessors are not supported");
    }
    SUBCASE("a node cycle") {
        Gltf g = valid();
        g.nodes[0] = "{\"mesh\":0,\"children\":[1]}";
        g.nodes.push_back("{\"children\":[0]}");
        expect_error(g.write_external(dir, "cycle"), "reached twice");
    }
    SUBCASE("a non-finite position") {
        Gltf g;
        std::vector<glm::vec3> p = kQuad;
        p[2].y = std::nanf("");
        int pos = g.vec3s(p);
        int mesh =
            g.add(g.meshes,
                  "{\"name\":\"bad\",\"primitives\":[{\"attributes\":{\"POSITION\":" + std::to_string(pos) + "}}]}");
        g.root("{\"mesh\":" + std::to_string(mesh) + "}");
        expect_error(g.write_external(dir, "nan"), "mesh 0 'bad' primitive 0");
    }
    SUBCASE("only degenerate triangles") {
        Gltf g;
        int pos = g.vec3s({{0, 0, 0}, {1, 1, 1}, {2, 2, 2}});
        int mesh =
            g.add(g.meshes,
                  "{\"name\":\"flat\",\"primitives\":[{\"attributes\":{\"POSITION\":" + std::to_string(pos) + "}}]}");
        g.root("{\"mesh\":" + std::to_string(mesh) + "}");
        expect_error(g.write_external(dir, "degenerate"), "every triangle is degenerate");
    }
    SUBCASE("out-of-range references") {
        Gltf g = valid();
        g.nodes[0] = "{\"mesh\":3}";
        expect_error(g.write_external(dir, "badmesh"), "refers to mesh 3");
        g = valid();
        g.meshes[0] = "{\"primitives\":[{\"attributes\":{\"POSITION\":9}}]}";
        expect_error(g.write_external(dir, "badacc"), "refers to accessor 9");
        g = valid();
        g.meshes[0] = "{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"indices\":1,\"material\":2}]}";
        expect_error(g.write_external(dir, "badmat"), "refers to material 2");
        g = valid();
        g.scene_nodes = {5};
        expect_error(g.write_external(dir, "badnode"), "refers to node 5");
    }
}

TEST_CASE("gltf: load_scene names the three formats for an unknown extension") {
    CHECK_THROWS_WITH_AS(load_scene("scene.fbx"), doctest::Contains(".xml (Mitsuba), .gltf or .glb"), SceneError);
}

// ---- TANGENT (glTF 2.0 §3.7.2.1): the normal map's frame from the file ----

namespace {

// One texel, (r, g, b) in 0..255, as a PNG.
std::vector<unsigned char> png_1x1(const glm::ivec3& rgb) {
    return png_rgb(
        1, 1,
        {static_cast<unsigned char>(rgb.x), static_cast<unsigned char>(rgb.y), static_cast<unsigned char>(rgb.z)});
}

// The 2 x 2 quad at z = 0 facing -z (counter-clockwise seen from -z), NORMAL -z, its uvs not
// mirrored seen from -z: u grows along world -x, v along -y (glTF's v runs down the image), so
// MikkTSpace's tangent is -x with w = +1 (bitangent n x t = +y). Its material has the normal
// map `texel` (1 x 1 PNG, linear); TANGENT as given (none when empty); `node` the node's
// extra JSON (a transform). Returns the file.
std::string normal_mapped_quad(const TempDir& dir, const std::string& name, const glm::ivec3& texel,
                               const std::vector<glm::vec4>& tangents, bool normals = true,
                               const std::string& node = "") {
    Gltf g;
    g.images.push_back("{\"uri\":\"data:image/png;base64," + base64(png_1x1(texel)) + "\"}");
    g.textures.push_back("{\"source\":0}");
    int mat = g.add(g.materials, "{\"normalTexture\":{\"index\":0}}");
    std::string attrs = "\"POSITION\":" + std::to_string(g.vec3s({{1, 1, 0}, {1, -1, 0}, {-1, -1, 0}, {-1, 1, 0}}));
    attrs += ",\"TEXCOORD_0\":" + std::to_string(g.vec2s({{0, 0}, {0, 1}, {1, 1}, {1, 0}}));
    if (normals) attrs += ",\"NORMAL\":" + std::to_string(g.vec3s(std::vector<glm::vec3>(4, {0, 0, -1})));
    if (!tangents.empty())
        attrs += ",\"TANGENT\":" + std::to_string(g.accessor(g.view(tangents.data(), tangents.size() * 16), 5126,
                                                             tangents.size(), "VEC4"));
    int idx = g.indices({0, 1, 2, 0, 2, 3});
    int mesh = g.add(g.meshes, "{\"primitives\":[{\"attributes\":{" + attrs + "},\"indices\":" + std::to_string(idx) +
                                   ",\"material\":" + std::to_string(mat) + "}]}");
    g.root("{\"mesh\":" + std::to_string(mesh) + node + "}");
    return g.write_embedded(dir, name);
}

}  // namespace

TEST_CASE("gltf: TANGENT is read where there are normals - moved by the node - mirrored handedness flips") {
    TempDir dir("tangent");
    const glm::ivec3 flat(128, 128, 255);
    const std::vector<glm::vec4> t = {{0, 1, 0, 1}, {0, 1, 0, 1}, {0, 1, 0, -1}, {0, 0.5f, 0, 1}};
    {
        Scene s = load_scene(normal_mapped_quad(dir, "plain", flat, t));
        REQUIRE(s.meshes.size() == 1);
        REQUIRE(s.meshes[0].tangents.size() == 4);
        CHECK(s.meshes[0].tangents[0] == glm::vec4(0, 1, 0, 1));
        CHECK(s.meshes[0].tangents[2] == glm::vec4(0, 1, 0, -1));
        CHECK(s.meshes[0].tangents[3] == glm::vec4(0, 1, 0, 1));  // normalised
    }
    {
        // Turned 90 degrees about z: the tangent +y goes to -x. Mirrored in x: +y stays, the
        // handedness turns (the bitangent w (n x t) must stay the mirror image of the old one).
        Scene r =
            load_scene(normal_mapped_quad(dir, "turned", flat, t, true, ",\"rotation\":[0,0,0.70710678,0.70710678]"));
        REQUIRE(r.meshes[0].tangents.size() == 4);
        CHECK(near(glm::vec3(r.meshes[0].tangents[0]), {-1, 0, 0}));
        CHECK(r.meshes[0].tangents[0].w == 1.0f);
        Scene m = load_scene(normal_mapped_quad(dir, "mirrored", flat, t, true, ",\"scale\":[-1,1,1]"));
        REQUIRE(m.meshes[0].tangents.size() == 4);
        CHECK(near(glm::vec3(m.meshes[0].tangents[0]), {0, 1, 0}));
        CHECK(m.meshes[0].tangents[0].w == -1.0f);
        CHECK(m.meshes[0].tangents[2].w == 1.0f);
        // The mirrored frame is the mirror image: n' x t' times w' is the mirrored bitangent.
        const glm::vec3 b_old = t[0].w * glm::cross(glm::vec3(0, 0, -1), glm::vec3(t[0]));
        const glm::vec3 b_new =
            m.meshes[0].tangents[0].w * glm::cross(m.meshes[0].normals[0], glm::vec3(m.meshes[0].tangents[0]));
        CHECK(near(b_new, {-b_old.x, b_old.y, b_old.z}));
    }
    {
        // Without NORMAL: flat normals and the tangents ignored (§3.7.2.1), with a warning.
        Scene s = load_scene(normal_mapped_quad(dir, "no_normals", flat, t, false));
        CHECK(s.meshes[0].tangents.empty());
        CHECK(has_warning(s, "TANGENT but no NORMAL"));
    }
    {
        // A count that disagrees with POSITION is an error; non-finite ones too.
        std::vector<glm::vec4> three(t.begin(), t.begin() + 3);
        expect_error(normal_mapped_quad(dir, "short", flat, three), "TANGENT has 3 elements");
        std::vector<glm::vec4> nan = t;
        nan[1].x = std::nanf("");
        expect_error(normal_mapped_quad(dir, "nan", flat, nan), "non-finite TANGENT");
    }
}

TEST_CASE("gltf: vkmech check says which normal maps read the file's TANGENT and which the uv frame") {
    TempDir dir("tangent_check");
    const std::vector<glm::vec4> t(4, glm::vec4(0, 1, 0, 1));
    const auto with = vkmech::testing::run_cli("check --scene " + normal_mapped_quad(dir, "with", {128, 128, 255}, t));
    CHECK(with.code == 0);
    CHECK(
        with.output.find("normal maps: 1 shape; tangents from the file's TANGENT on 1, from the uv derivatives on 0") !=
        std::string::npos);
    const auto uv = vkmech::testing::run_cli("check --scene " + normal_mapped_quad(dir, "uv", {128, 128, 255}, {}));
    CHECK(uv.code == 0);
    CHECK(uv.output.find("normal maps: 1 shape; tangents from the file's TANGENT on 0, from the uv derivatives on 1") !=
          std::string::npos);
    // A scene without a normal map has no such line.
    const auto plain = vkmech::testing::run_cli("check --scene cubes_dof");
    CHECK(plain.code == 0);
    CHECK(plain.output.find("normal maps:") == std::string::npos);
}

TEST_CASE("gltf: the file's tangents reach the device only for meshes with a normal map") {
    TempDir dir("tangent_arrays");
    const std::vector<glm::vec4> t(4, glm::vec4(0, 1, 0, 1));
    Scene with = load_scene(normal_mapped_quad(dir, "with", {128, 128, 255}, t));
    Scene without = load_scene(normal_mapped_quad(dir, "without", {128, 128, 255}, {}));
    // A second, plain mesh before the tangent one: its vertices stay first.
    for (Scene* s : {&with, &without}) {
        Mesh plain = s->meshes[0];
        plain.tangents.clear();
        plain.material = -1;
        s->meshes.insert(s->meshes.begin(), plain);
    }
    const SceneArrays a = flatten_scene(with), b = flatten_scene(without);
    REQUIRE(a.tangents.size() == 4);
    CHECK(a.tangent_vertex_base == 4);
    CHECK(a.tangents[0] == glm::vec4(0, 1, 0, 1));
    CHECK(a.vertices.size() == b.vertices.size());
    CHECK(b.tangents.empty());
    for (size_t i = 0; i < a.triangles.size(); ++i) {
        CAPTURE(i);
        const bool second = a.triangle_mesh[i] == 1;
        CHECK(((a.triangles[i].w & gpu::TRI_TANGENT_BIT) != 0) == second);
        CHECK((b.triangles[i].w & gpu::TRI_TANGENT_BIT) == 0);
        for (int k = 0; k < 3; ++k)
            if (second) CHECK(a.triangles[i][k] >= a.tangent_vertex_base);
    }
    // Without a normal map the file's tangents are not kept.
    with.materials[with.meshes[1].material].normal_texture = -1;
    CHECK(flatten_scene(with).tangents.empty());
}

TEST_SUITE("gpu") {
    TEST_CASE("gltf: a normal map on the file's TANGENT turns with it - without TANGENT the uv frame") {
        VKMECH_REQUIRE_GPU(ctx);
        TempDir dir("tangent_render");
        // The map's tangent-space normal, as the PNG holds it (8 bits, linear: c / 255 x 2 - 1).
        const glm::ivec3 texel(166, 179, 238);
        const glm::vec3 n = glm::vec3(texel) / 255.0f * 2.0f - 1.0f;
        // The quad seen from z = -3 along +z, diffuse 0.5, lit by one directional light of
        // irradiance 2 and nothing else: a pixel is 0.5 / pi x 2 x cos(mapped normal, light).
        const glm::vec3 light = glm::normalize(glm::vec3(0.5f, -0.3f, 0.8f));
        auto render = [&](const std::string& name, const std::vector<glm::vec4>& tangents) {
            Scene s = load_scene(normal_mapped_quad(dir, name, texel, tangents));
            REQUIRE(s.materials.size() == 1);
            Material& m = s.materials[0];
            REQUIRE(m.normal_texture >= 0);
            m.type = BsdfType::Diffuse;
            m.reflectance = Spectrum3{glm::vec3(0.5f)};
            s.camera = Camera{};
            s.camera.to_world[3] = glm::vec4(0, 0, -3, 1);
            s.camera.fov_deg = 30.0f;
            s.camera.width = s.camera.height = 8;
            s.directional_lights.push_back({light, glm::vec3(2.0f)});
            testing::RenderSetup setup;
            setup.res = 8;
            setup.spp = 4;
            return testing::render_scene(*ctx, s, setup);
        };
        // glTF 2.0: the normal is t n.x + b n.y + n n.z with b = w (n x t), t the file's tangent
        // (made orthogonal to n); without TANGENT MikkTSpace's, here t = -x, w = +1.
        const glm::vec3 ng(0, 0, -1);
        auto expected = [&](const glm::vec3& t, float w) {
            const glm::vec3 b = w * glm::cross(ng, t);
            const glm::vec3 mapped = glm::normalize(t * n.x + b * n.y + ng * n.z);
            return 0.5 * 2.0 * glm::dot(mapped, -light) / 3.14159265358979;
        };
        const double uv_frame = expected({-1, 0, 0}, 1.0f);
        struct Case {
            const char* what;
            std::vector<glm::vec4> tangents;
            double value;
        };
        const std::vector<Case> cases = {
            {"no TANGENT", {}, uv_frame},
            {"TANGENT equal to the uv frame's", std::vector<glm::vec4>(4, {-1, 0, 0, 1}), uv_frame},
            {"TANGENT turned 90 degrees", std::vector<glm::vec4>(4, {0, 1, 0, 1}), expected({0, 1, 0}, 1.0f)},
            {"TANGENT with handedness -1", std::vector<glm::vec4>(4, {-1, 0, 0, -1}), expected({-1, 0, 0}, -1.0f)},
            {"TANGENT off the plane (made orthogonal to n)", std::vector<glm::vec4>(4, {0, 0.8f, 0.6f, 1}),
             expected({0, 1, 0}, 1.0f)}};
        CHECK(std::abs(cases[2].value - uv_frame) > 0.05);  // each differs visibly from the uv frame
        CHECK(std::abs(cases[3].value - uv_frame) > 0.05);
        for (const Case& c : cases) {
            const std::string what = c.what;
            CAPTURE(what);
            Frame f = render(std::string("q") + std::to_string(&c - cases.data()), c.tangents);
            for (const PixelStats& p : f.pixels) CHECK(p.lum_mean == doctest::Approx(c.value).epsilon(1e-4));
        }
    }
}
