// Mitsuba `serialized` meshes (scene/serialized_io.hpp): the tests write
// their own files with zlib (versions 3 and 4, single and double precision,
// with and without normals and uvs, two meshes in one file), load them back,
// load one through a scene XML, and check that hostile files are SceneErrors
// naming the file.
#include "scene/scene.hpp"
#include "scene/serialized_io.hpp"
#include "temp_dir.hpp"

#include <doctest/doctest.h>

#include <zlib.h>

#include <unistd.h>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

namespace fs = std::filesystem;
using namespace vkmech;

namespace {

struct TempDir : vkmech::testing::TempDir {
    explicit TempDir(const std::string& tag) : vkmech::testing::TempDir("serialized_" + tag) {}
};

// What a test writes: doubles, so the double-precision files hold values a
// float cannot (positions are compared after rounding to float).
struct TestMesh {
    std::string name = "testmesh";
    std::vector<double> positions, normals, uvs, colors;  // flat: 3, 3, 2, 3 per vertex
    std::vector<uint32_t> indices;                        // 3 per triangle
    uint64_t vertex_count() const { return positions.size() / 3; }
};

// A unit quad in z = 0 with unit +z normals and uvs, and a tilted third
// vertex row so that positions are not all simple.
TestMesh quad(double dz = 0.0) {
    TestMesh m;
    m.positions = {0, 0, dz, 1, 0, dz, 1, 1, dz, 0, 1, dz, 0.5, 1.7, dz + 0.25};
    m.normals = {0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1};
    m.uvs = {0, 0, 1, 0, 1, 1, 0, 1, 0.5, 0.125};
    m.colors = {1, 0, 0, 0, 1, 0, 0, 0, 1, 1, 1, 1, 0.5, 0.5, 0.5};
    m.indices = {0, 1, 2, 0, 2, 3, 3, 2, 4};
    return m;
}

template <class T>
void put(std::string& s, T v) {
    char b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));  // the test host is little-endian (x86-64, arm64)
    s.append(b, sizeof(T));
}

struct Options {
    int version = 4;
    bool dbl = false;
    bool normals = true, uvs = true, colors = false;
    uint64_t vertex_count_override = 0;  // 0: the real count
    bool no_precision_flag = false;      // Tungsten-written files: flags 0x103, single precision
};

// The uncompressed body of one mesh.
std::string mesh_body(const TestMesh& m, const Options& o) {
    std::string s;
    uint32_t flags = (o.no_precision_flag ? 0x100u
                      : o.dbl             ? 0x2000u
                                          : 0x1000u) |
                     (o.normals ? 0x1u : 0u) | (o.uvs ? 0x2u : 0u) | (o.colors ? 0x8u : 0u);
    put(s, flags);
    if (o.version == 4) s += m.name + '\0';
    put<uint64_t>(s, o.vertex_count_override ? o.vertex_count_override : m.vertex_count());
    put<uint64_t>(s, m.indices.size() / 3);
    auto reals = [&](const std::vector<double>& v) {
        for (double x : v) {
            if (o.dbl)
                put<double>(s, x);
            else
                put<float>(s, static_cast<float>(x));
        }
    };
    reals(m.positions);
    if (o.normals) reals(m.normals);
    if (o.uvs) reals(m.uvs);
    if (o.colors) reals(m.colors);
    for (uint32_t i : m.indices) put<uint32_t>(s, i);
    return s;
}

std::string zlib_compress(const std::string& in) {
    uLongf size = compressBound(static_cast<uLong>(in.size()));
    std::string out(size, '\0');
    REQUIRE(compress(reinterpret_cast<Bytef*>(out.data()), &size, reinterpret_cast<const Bytef*>(in.data()),
                     static_cast<uLong>(in.size())) == Z_OK);
    out.resize(size);
    return out;
}

// Meshes one after the other, then the offset dictionary and the count.
std::string serialized_file(const std::vector<std::string>& bodies, int version) {
    std::string file;
    std::vector<uint64_t> offsets;
    for (const auto& b : bodies) {
        offsets.push_back(file.size());
        put<uint16_t>(file, 0x041C);
        put<uint16_t>(file, static_cast<uint16_t>(version));
        file += zlib_compress(b);
    }
    for (uint64_t o : offsets) {
        if (version == 4)
            put<uint64_t>(file, o);
        else
            put<uint32_t>(file, static_cast<uint32_t>(o));
    }
    put<uint32_t>(file, static_cast<uint32_t>(bodies.size()));
    return file;
}

std::string write(const TempDir& dir, const std::string& name, const std::string& bytes) {
    std::string p = (dir.path / name).string();
    std::ofstream(p, std::ios::binary).write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    return p;
}

void check_equal(const Mesh& got, const TestMesh& want, const Options& o) {
    REQUIRE(got.positions.size() == want.vertex_count());
    for (size_t i = 0; i < got.positions.size(); ++i)
        for (int c = 0; c < 3; ++c) CHECK(got.positions[i][c] == static_cast<float>(want.positions[3 * i + c]));
    if (o.normals) {
        REQUIRE(got.normals.size() == want.vertex_count());
        for (size_t i = 0; i < got.normals.size(); ++i)
            for (int c = 0; c < 3; ++c) CHECK(got.normals[i][c] == static_cast<float>(want.normals[3 * i + c]));
    } else {
        CHECK(got.normals.empty());
    }
    if (o.uvs) {
        REQUIRE(got.uvs.size() == want.vertex_count());
        for (size_t i = 0; i < got.uvs.size(); ++i)  // v as stored: Mitsuba does not flip serialized uvs
            for (int c = 0; c < 2; ++c) CHECK(got.uvs[i][c] == static_cast<float>(want.uvs[2 * i + c]));
    } else {
        CHECK(got.uvs.empty());
    }
    REQUIRE(got.indices.size() * 3 == want.indices.size());
    for (size_t t = 0; t < got.indices.size(); ++t)
        for (int c = 0; c < 3; ++c) CHECK(got.indices[t][c] == want.indices[3 * t + c]);
}

// load_serialized must throw a SceneError naming the file and saying `what`.
void check_refused(const std::string& path, int index, const std::string& what) {
    CAPTURE(path);
    try {
        load_serialized(path, index);
        FAIL("no SceneError for " << what);
    } catch (const SceneError& e) {
        const std::string msg = e.what();
        CAPTURE(msg);
        CHECK(e.file() == path);
        CHECK(msg.find(path) != std::string::npos);
        CHECK(msg.find(what) != std::string::npos);
    }
}

}  // namespace

TEST_CASE("serialized: versions 3 and 4, single and double precision, with and without normals and uvs") {
    TempDir dir("formats");
    const TestMesh m = quad(0.1);  // 0.1 is not exact in float: the double files round it on load
    for (int version : {3, 4})
        for (bool dbl : {false, true})
            for (int attrs = 0; attrs < 4; ++attrs) {
                Options o;
                o.version = version;
                o.dbl = dbl;
                o.normals = attrs & 1;
                o.uvs = attrs & 2;
                CAPTURE(version);
                CAPTURE(dbl);
                CAPTURE(attrs);
                std::string p = write(dir, "m.serialized", serialized_file({mesh_body(m, o)}, version));
                Mesh got = load_serialized(p, 0);
                check_equal(got, m, o);
                if (version == 4) CHECK(got.name == m.name);
            }
}

TEST_CASE("serialized: a file naming no precision (as Tungsten writes them, flags 0x103) is single precision") {
    TempDir dir("noprecision");
    const TestMesh m = quad(0.1);
    Options o;
    o.version = 3;
    o.no_precision_flag = true;
    std::string p = write(dir, "m.serialized", serialized_file({mesh_body(m, o)}, 3));
    check_equal(load_serialized(p, 0), m, o);
}

TEST_CASE("serialized: two meshes in one file, vertex colours skipped, shape_index picks the mesh") {
    TempDir dir("two");
    TestMesh a = quad(0.0), b = quad(2.0);
    b.indices = {4, 3, 2};
    Options oa, ob;
    oa.colors = true;  // colours in the first mesh: read past, not returned
    ob.normals = false;
    for (int version : {3, 4}) {
        CAPTURE(version);
        oa.version = ob.version = version;
        std::string p = write(dir, "two.serialized", serialized_file({mesh_body(a, oa), mesh_body(b, ob)}, version));
        check_equal(load_serialized(p, 0), a, oa);
        check_equal(load_serialized(p, 1), b, ob);
        check_refused(p, 2, "shape_index 2 is out of range: the file holds 2 meshes");
        check_refused(p, -1, "shape_index -1 is out of range");
    }
}

TEST_CASE("serialized: a scene XML with serialized shapes loads through load_scene") {
    TempDir dir("scene");
    TestMesh a = quad(0.0), b = quad(2.0);
    Options o;
    write(dir, "meshes.serialized", serialized_file({mesh_body(a, o), mesh_body(b, o)}, 4));
    std::ofstream(dir.path / "scene.xml") << R"(<scene version="3.0.0">
    <sensor type="perspective">
        <float name="fov" value="45"/>
        <transform name="to_world"><lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="32"/><integer name="height" value="32"/></film>
    </sensor>
    <shape type="serialized" id="first">
        <string name="filename" value="meshes.serialized"/>
        <transform name="to_world"><translate x="1" y="0" z="0"/></transform>
        <emitter type="area"><rgb name="radiance" value="1, 1, 1"/></emitter>
    </shape>
    <shape type="serialized" id="second">
        <string name="filename" value="meshes.serialized"/>
        <integer name="shape_index" value="1"/>
        <boolean name="face_normals" value="true"/>
        <boolean name="flip_normals" value="true"/>
    </shape>
</scene>
)";
    Scene s = load_scene((dir.path / "scene.xml").string());
    REQUIRE(s.meshes.size() == 2);
    const Mesh& first = s.meshes[0];
    CHECK(first.name == "first");
    REQUIRE(first.positions.size() == 5);
    CHECK(first.positions[1] == glm::vec3(2, 0, 0));  // (1, 0, 0) moved by to_world
    REQUIRE(first.normals.size() == 5);
    CHECK(first.normals[0] == glm::vec3(0, 0, 1));
    CHECK(first.uvs[3] == glm::vec2(0, 1));  // not flipped
    CHECK(first.emitter >= 0);
    const Mesh& second = s.meshes[1];
    CHECK(second.name == "second");
    CHECK(second.positions[0] == glm::vec3(0, 0, 2));
    CHECK(second.normals.empty());  // face_normals drops them
    CHECK(second.flip_normals);
    CHECK(second.indices[0] == glm::uvec3(0, 2, 1));  // flip_normals reverses the winding

    // Errors from the mesh file keep its name and say which shape asked for it.
    std::ofstream(dir.path / "bad.xml") << R"(<scene version="3.0.0">
    <shape type="serialized"><string name="filename" value="meshes.serialized"/><integer name="shape_index" value="5"/></shape>
</scene>
)";
    CHECK_THROWS_WITH_AS(load_scene((dir.path / "bad.xml").string()), doctest::Contains("meshes.serialized"),
                         SceneError);
}

TEST_CASE("serialized: hostile files are SceneErrors naming the file") {
    TempDir dir("hostile");
    const TestMesh m = quad();
    const Options o;
    const std::string good = serialized_file({mesh_body(m, o)}, 4);

    std::string bad_magic = good;
    bad_magic[0] = 'P';
    check_refused(write(dir, "magic.serialized", bad_magic), 0, "not a Mitsuba serialized mesh");

    std::string bad_version = good;
    bad_version[2] = 7;
    check_refused(write(dir, "version.serialized", bad_version), 0, "version 7");

    // The zlib stream cut short (the dictionary rewritten to still match).
    {
        std::string body = zlib_compress(mesh_body(m, o));
        std::string cut;
        put<uint16_t>(cut, 0x041C);
        put<uint16_t>(cut, 4);
        cut += body.substr(0, body.size() / 2);
        put<uint64_t>(cut, 0);
        put<uint32_t>(cut, 1);
        check_refused(write(dir, "truncated.serialized", cut), 0, "truncated compressed data");
    }
    // Garbage instead of a zlib stream.
    {
        std::string junk;
        put<uint16_t>(junk, 0x041C);
        put<uint16_t>(junk, 4);
        junk += std::string(64, '\x5a');
        put<uint64_t>(junk, 0);
        put<uint32_t>(junk, 1);
        check_refused(write(dir, "junk.serialized", junk), 0, "corrupt compressed data");
    }
    // A file cut anywhere: always a SceneError, never a crash.
    for (size_t n = 0; n < good.size(); n += 3) {
        CAPTURE(n);
        std::string p = write(dir, "cut.serialized", good.substr(0, n));
        CHECK_THROWS_AS(load_serialized(p, 0), SceneError);
    }

    check_refused(write(dir, "range.serialized", good), 1, "shape_index 1 is out of range: the file holds 1 mesh");

    TestMesh past = m;
    past.indices[4] = 5;  // 5 vertices: 0..4
    check_refused(write(dir, "index.serialized", serialized_file({mesh_body(past, o)}, 4)), 0,
                  "uses vertex 5, past the 5 vertices");

    Options huge = o;
    huge.vertex_count_override = uint64_t(1) << 40;
    check_refused(write(dir, "huge.serialized", serialized_file({mesh_body(m, huge)}, 4)), 0, "1099511627776 vertices");
    // A count that fits 32 bits but not the compressed bytes: refused before allocating.
    huge.vertex_count_override = 3'000'000'000ull;
    check_refused(write(dir, "big.serialized", serialized_file({mesh_body(m, huge)}, 4)), 0, "a corrupt count?");

    TestMesh nan = m;
    nan.positions[4] = std::nan("");
    check_refused(write(dir, "nan.serialized", serialized_file({mesh_body(nan, o)}, 4)), 0, "not finite");

    // A dictionary offset pointing outside the mesh data.
    std::string off = good;
    const uint64_t bogus = uint64_t(1) << 62;
    std::memcpy(off.data() + off.size() - 12, &bogus, 8);
    check_refused(write(dir, "offset.serialized", off), 0, "outside the file's mesh data");
    // A mesh count claiming more entries than the file has bytes.
    std::string count = good;
    const uint32_t many = 0xFFFFFFFFu;
    std::memcpy(count.data() + count.size() - 4, &many, 4);
    check_refused(write(dir, "count.serialized", count), 0, "more than the file can hold");

    check_refused((dir.path / "absent.serialized").string(), 0, "cannot open mesh file");
}
