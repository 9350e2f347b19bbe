// Scene loading (docs/descriptor.md §8): the Mitsuba XML loader, the triangulated
// primitives and the OBJ/PLY readers. Valid fixtures pin counts, transforms,
// smoothness, areas and orientation; the malformed corpus pins that every
// fault is a SceneError naming the file, the line and the fault.
#include "io/exr.hpp"
#include "scene/mesh_io.hpp"
#include "scene/mesh_ops.hpp"
#include "scene/named_ior.hpp"
#include "scene/primitives.hpp"
#include "scene/scene.hpp"

#include <doctest/doctest.h>

#include <glm/gtc/matrix_transform.hpp>

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <sstream>
#include <string>

using namespace vkmech;
namespace fs = std::filesystem;

namespace {

constexpr double kPi = std::numbers::pi;

std::string data(const std::string& rel) { return std::string(VKMECH_TEST_DATA) + "/" + rel; }

const Mesh& mesh_named(const Scene& s, const std::string& name) {
    for (const auto& m : s.meshes)
        if (m.name == name) return m;
    FAIL("no mesh named " << name);
    return s.meshes.front();
}

bool near(const glm::vec3& a, const glm::vec3& b, float tol = 1e-5f) { return glm::length(a - b) <= tol; }

// Properties every mesh the loader hands out must have.
void check_mesh_invariants(const Mesh& m) {
    CAPTURE(m.name);
    REQUIRE(!m.indices.empty());
    if (!m.normals.empty()) REQUIRE(m.normals.size() == m.positions.size());
    if (!m.uvs.empty()) REQUIRE(m.uvs.size() == m.positions.size());
    size_t not_unit = 0, degenerate = 0, against_normals = 0;
    for (const auto& n : m.normals)
        if (!(std::abs(glm::length(n) - 1.0f) < 1e-4f)) ++not_unit;
    CHECK(not_unit == 0);
    for (const auto& t : m.indices) {
        for (int k = 0; k < 3; ++k) REQUIRE(t[k] < m.positions.size());
        glm::vec3 c = triangle_cross(m, t);
        if (!(glm::length(c) > 0.0f)) ++degenerate;
        // Winding is counter-clockwise seen from where the normals point.
        if (!m.normals.empty() && glm::dot(c, m.normals[t.x] + m.normals[t.y] + m.normals[t.z]) <= 0.0f)
            ++against_normals;
    }
    CHECK(degenerate == 0);
    CHECK(against_normals == 0);
}

// Every triangle's geometric normal is `n` (flat, planar shapes).
void check_facing(const Mesh& m, const glm::vec3& n) {
    CAPTURE(m.name);
    size_t off = 0;
    for (const auto& t : m.indices)
        if (!near(glm::normalize(triangle_cross(m, t)), n, 1e-5f)) ++off;
    CHECK(off == 0);
}

}  // namespace

// ---------------------------------------------------------------------------
// Primitives
// ---------------------------------------------------------------------------

TEST_CASE("primitives: rectangle is [-1/1]^2 at z = 0 - two CCW triangles facing +z") {
    Mesh m = make_rectangle(glm::mat4(1.0f));
    CHECK(m.kind == ShapeKind::Rectangle);
    CHECK(m.indices.size() == 2);
    CHECK(m.normals.empty());
    CHECK(m.uvs.size() == 4);
    CHECK(surface_area(m) == doctest::Approx(4.0));
    check_mesh_invariants(m);
    check_facing(m, {0, 0, 1});
    Mesh f = make_rectangle(glm::mat4(1.0f), /*flip_normals=*/true);
    CHECK(f.flip_normals);
    check_facing(f, {0, 0, -1});
}

TEST_CASE("primitives: cube has 12 outward triangles and area 24 s^2") {
    glm::mat4 s = glm::scale(glm::mat4(1.0f), glm::vec3(0.5f));
    Mesh m = make_cube(s);
    CHECK(m.indices.size() == 12);
    CHECK(surface_area(m) == doctest::Approx(6.0));
    check_mesh_invariants(m);
    // Outward: every face normal points away from the centre.
    size_t inward = 0;
    for (const auto& t : m.indices) {
        glm::vec3 centroid = (m.positions[t.x] + m.positions[t.y] + m.positions[t.z]) / 3.0f;
        if (!(glm::dot(triangle_cross(m, t), centroid) > 0.0f)) ++inward;
    }
    CHECK(inward == 0);
}

TEST_CASE("primitives: sphere is smooth - closed - CCW outward - with no pole slivers") {
    glm::vec3 c(1, 2, 3);
    float r = 0.5f;
    Mesh m = make_sphere(c, r, glm::mat4(1.0f));
    CHECK(m.kind == ShapeKind::Sphere);
    CHECK(near(m.center, c));
    CHECK(m.radius == doctest::Approx(r));
    // 64 bands x 128 segments, minus one collapsed triangle per pole quad.
    CHECK(m.indices.size() == 64 * 128 * 2 - 2 * 128);
    check_mesh_invariants(m);
    size_t off = 0;
    for (size_t i = 0; i < m.positions.size(); ++i)
        if (!near(m.normals[i], (m.positions[i] - c) / r, 1e-5f)) ++off;
    CHECK(off == 0);
    // Inscribed polyhedron: slightly below 4 pi r^2.
    double area = surface_area(m), exact = 4.0 * kPi * r * r;
    CHECK(area < exact);
    CHECK(area > exact * 0.998);

    SphereTessellation coarse{8, 16};
    Mesh low = make_sphere(glm::vec3(0.0f), 1.0f, glm::mat4(1.0f), false, coarse);
    CHECK(low.indices.size() == 8 * 16 * 2 - 2 * 16);
    check_mesh_invariants(low);
}

TEST_CASE("primitives: sphere under a similarity transform keeps (p - c) / r normals") {
    glm::mat4 t = glm::translate(glm::mat4(1.0f), glm::vec3(-2, 1, 0.5f)) *
                  glm::rotate(glm::mat4(1.0f), glm::radians(30.0f), glm::normalize(glm::vec3(1, 1, 0))) *
                  glm::scale(glm::mat4(1.0f), glm::vec3(2.0f));
    Mesh m = make_sphere(glm::vec3(0.0f), 1.0f, t);
    CHECK(near(m.center, {-2, 1, 0.5f}));
    CHECK(m.radius == doctest::Approx(2.0f));
    size_t off = 0;
    for (size_t i = 0; i < m.positions.size(); ++i)
        if (!near(m.normals[i], (m.positions[i] - m.center) / m.radius, 1e-5f)) ++off;
    CHECK(off == 0);
    check_mesh_invariants(m);
    Mesh inward = make_sphere(glm::vec3(0.0f), 1.0f, t, /*flip_normals=*/true);
    check_mesh_invariants(inward);
    CHECK(glm::dot(inward.normals[inward.positions.size() / 2],
                   inward.positions[inward.positions.size() / 2] - inward.center) < 0.0f);
}

TEST_CASE("primitives: a non-uniformly scaled sphere is an ellipsoid with exact normals - not a sphere") {
    glm::vec3 axes(0.045f, 0.033f, 0.02f);
    Mesh m = make_sphere(glm::vec3(0.0f), 1.0f, glm::scale(glm::mat4(1.0f), axes));
    CHECK(m.kind == ShapeKind::Mesh);  // must not be sampled as an analytic sphere
    CHECK(m.radius == 0.0f);
    check_mesh_invariants(m);
    // Implicit x^2/a^2 + y^2/b^2 + z^2/c^2 = 1: normal along (x/a^2, y/b^2, z/c^2).
    size_t off = 0;
    for (size_t i = 0; i < m.positions.size(); ++i) {
        glm::vec3 g = m.positions[i] / (axes * axes);
        if (!near(m.normals[i], glm::normalize(g), 1e-4f)) ++off;
    }
    CHECK(off == 0);
}

TEST_CASE("primitives: disk is the unit disk facing +z - area close to pi") {
    Mesh m = make_disk(glm::mat4(1.0f));
    CHECK(m.indices.size() == 128);
    check_mesh_invariants(m);
    check_facing(m, {0, 0, 1});
    CHECK(surface_area(m) == doctest::Approx(kPi).epsilon(1e-3));
}

TEST_CASE("primitives: cylinder is an open tube with smooth outward normals") {
    Mesh m = make_cylinder({0, 0, 0}, {0, 0, 2}, 0.3f, glm::mat4(1.0f));
    CHECK(m.indices.size() == 2 * 128);
    check_mesh_invariants(m);
    CHECK(surface_area(m) == doctest::Approx(2.0 * kPi * 0.3 * 2.0).epsilon(1e-3));
    size_t off = 0;
    for (size_t i = 0; i < m.positions.size(); ++i) {
        glm::vec3 radial(m.positions[i].x, m.positions[i].y, 0.0f);
        if (!near(m.normals[i], radial / 0.3f, 1e-5f)) ++off;
        if (m.positions[i].z < -1e-6f || m.positions[i].z > 2.0f + 1e-6f) ++off;
    }
    CHECK(off == 0);
    // An oblique axis: every vertex at distance r from the axis line.
    glm::vec3 p0(1, 0, 0), p1(1, 3, 4);
    Mesh o = make_cylinder(p0, p1, 0.5f, glm::mat4(1.0f));
    check_mesh_invariants(o);
    glm::vec3 axis = glm::normalize(p1 - p0);
    size_t off_axis = 0;
    for (const auto& p : o.positions) {
        glm::vec3 d = p - p0;
        if (std::abs(glm::length(d - glm::dot(d, axis) * axis) - 0.5f) > 1e-4f) ++off_axis;
    }
    CHECK(off_axis == 0);
}

TEST_CASE("primitives: a mirroring transform keeps the facing of the normal field") {
    glm::mat4 mirror = glm::scale(glm::mat4(1.0f), glm::vec3(-1, 1, 1));
    check_facing(make_rectangle(mirror), {0, 0, 1});
    check_mesh_invariants(make_sphere(glm::vec3(0.0f), 1.0f, mirror));
    check_mesh_invariants(make_cylinder({0, 0, 0}, {0, 0, 1}, 1.0f, mirror));
}

// ---------------------------------------------------------------------------
// Mesh files
// ---------------------------------------------------------------------------

TEST_CASE("mesh_io: OBJ with v/vt/vn - negative indices and a polygon") {
    Mesh m = load_obj(data("loader/meshes/quad.obj"));
    // Quad fan (2) + triangle (1); corners deduplicated by (v, vt, vn).
    CHECK(m.indices.size() == 3);
    CHECK(m.positions.size() == 5);
    CHECK(m.normals.size() == 5);
    CHECK(m.uvs.size() == 5);
    check_mesh_invariants(m);
    check_facing(m, {0, 0, 1});
    CHECK(surface_area(m) == doctest::Approx(1.5));
}

TEST_CASE("mesh_io: OBJ face forms v - v/vt - v//vn - v/vt/vn - partial normals are dropped") {
    Mesh m = load_obj(data("loader/meshes/forms.obj"));
    CHECK(m.indices.size() == 4 + 3);  // 4 triangles + a fan-triangulated pentagon
    CHECK(m.normals.empty());
    CHECK(m.uvs.size() == m.positions.size());
    check_mesh_invariants(m);
    check_facing(m, {0, 0, 1});
}

TEST_CASE("mesh_io: PLY ascii - binary little and big endian read the same mesh") {
    const char* files[] = {"loader/meshes/quad_ascii.ply", "loader/meshes/quad_binary_le.ply",
                           "loader/meshes/quad_binary_be.ply"};
    for (const char* f : files) {
        CAPTURE(f);
        Mesh m = load_ply(data(f));
        CHECK(m.positions.size() == 5);
        CHECK(m.indices.size() == 3);
        REQUIRE(m.normals.size() == 5);
        REQUIRE(m.uvs.size() == 5);
        CHECK(near(m.positions[4], {2, 0, 0}));
        CHECK(near(m.normals[2], {0, 0, 1}));
        CHECK(m.uvs[2] == glm::vec2(1, 1));
        CHECK(m.indices[0] == glm::uvec3(0, 1, 2));
        CHECK(m.indices[1] == glm::uvec3(0, 2, 3));
        CHECK(m.indices[2] == glm::uvec3(1, 4, 2));
        check_mesh_invariants(m);
    }
    CHECK(load_mesh_file(data("loader/meshes/quad_binary_be.ply")).indices.size() == 3);
}

TEST_CASE("mesh_io: a missing file and an unknown extension are SceneErrors naming the file") {
    CHECK_THROWS_AS(load_obj(data("loader/meshes/absent.obj")), SceneError);
    try {
        load_mesh_file(data("loader/checker2x2.png"));
        FAIL("expected a SceneError");
    } catch (const SceneError& e) {
        CHECK(std::string(e.what()).find("checker2x2.png") != std::string::npos);
        CHECK(std::string(e.what()).find("unsupported mesh format") != std::string::npos);
    }
}

// ---------------------------------------------------------------------------
// Valid Mitsuba scenes
// ---------------------------------------------------------------------------

TEST_CASE("mitsuba: every shape - bsdf family - sensor and integrator setting") {
    Scene s = load_scene(data("loader/all_shapes.xml"));
    CHECK(s.source == data("loader/all_shapes.xml"));
    CHECK(s.meshes.size() == 10);
    for (const auto& m : s.meshes) {
        check_mesh_invariants(m);
        REQUIRE(m.material >= 0);
        REQUIRE(m.material < static_cast<int>(s.materials.size()));
    }
    CHECK(s.substitutions.empty());

    SUBCASE("integrator and sensor") {
        CHECK(s.integrator.max_depth == 8);
        CHECK(s.integrator.rr_depth == 3);
        const Camera& c = s.camera;
        CHECK(c.type == CameraType::ThinLens);
        CHECK(c.fov_deg == doctest::Approx(45.0f));
        CHECK(c.fov_axis == "y");
        CHECK(c.near_clip == doctest::Approx(0.1f));
        CHECK(c.far_clip == doctest::Approx(100.0f));
        CHECK(c.aperture_radius == doctest::Approx(0.05f));
        CHECK(c.focus_distance == doctest::Approx(4.0f));
        CHECK(c.width == 64);
        CHECK(c.height == 48);
        // lookat from +z towards the origin: dir = -z, left = cross(up, dir) = -x.
        CHECK(near(glm::vec3(c.to_world[0]), {-1, 0, 0}));
        CHECK(near(glm::vec3(c.to_world[1]), {0, 1, 0}));
        CHECK(near(glm::vec3(c.to_world[2]), {0, 0, -1}));
        CHECK(near(glm::vec3(c.to_world[3]), {0, 0, 5}));
    }
    SUBCASE("translated rectangle") {
        const Mesh& m = mesh_named(s, "floor");
        CHECK(m.kind == ShapeKind::Rectangle);
        REQUIRE(m.positions.size() == 4);
        CHECK(near(m.positions[0], {0, 1, 3}));
        CHECK(near(m.positions[1], {2, 1, 3}));
        CHECK(near(m.positions[2], {2, 3, 3}));
        CHECK(near(m.positions[3], {0, 3, 3}));
        check_facing(m, {0, 0, 1});
        const Material& mat = s.materials[m.material];
        CHECK(mat.id == "white");
        CHECK(mat.type == BsdfType::Diffuse);
        CHECK(near(mat.reflectance.value, {0.8f, 0.7f, 0.6f}));
    }
    SUBCASE("cube: scale then translate, in document order") {
        const Mesh& m = mesh_named(s, "box");
        CHECK(m.indices.size() == 12);
        CHECK(surface_area(m) == doctest::Approx(6.0));
        glm::vec3 lo(1e9f), hi(-1e9f);
        for (const auto& p : m.positions) {
            lo = glm::min(lo, p);
            hi = glm::max(hi, p);
        }
        CHECK(near(lo, {2.5f, -0.5f, -0.5f}));
        CHECK(near(hi, {3.5f, 0.5f, 0.5f}));
        const Material& mat = s.materials[m.material];
        CHECK(mat.type == BsdfType::RoughPlastic);
        CHECK(mat.alpha_u == doctest::Approx(0.15f));
        CHECK(mat.nonlinear);
        CHECK(mat.int_ior == doctest::Approx(1.49f));  // Mitsuba's plastic default: polypropylene
        CHECK(near(mat.reflectance.value, glm::vec3(0.2f)));
    }
    SUBCASE("spheres: center/radius and to_world, smooth normals") {
        const Mesh& ball = mesh_named(s, "ball");
        CHECK(ball.kind == ShapeKind::Sphere);
        CHECK(near(ball.center, {1, 2, 3}));
        CHECK(ball.radius == doctest::Approx(0.5f));
        size_t off_ball = 0;
        for (size_t i = 0; i < ball.positions.size(); ++i)
            if (!near(ball.normals[i], (ball.positions[i] - ball.center) / ball.radius, 1e-5f)) ++off_ball;
        CHECK(off_ball == 0);
        CHECK(surface_area(ball) == doctest::Approx(kPi).epsilon(2e-3));
        const Material& glass = s.materials[ball.material];
        CHECK(glass.type == BsdfType::Dielectric);
        CHECK(glass.int_ior == doctest::Approx(1.5046f));
        CHECK(glass.ext_ior == doctest::Approx(1.000277f));
        CHECK(glass.is_delta_only());
        CHECK_FALSE(glass.has_diffuse());

        const Mesh& moved = mesh_named(s, "moved_ball");
        CHECK(near(moved.center, {-2, 1, 0.5f}));
        CHECK(moved.radius == doctest::Approx(2.0f));
        size_t off = 0;
        for (size_t i = 0; i < moved.positions.size(); ++i)
            if (!near(moved.normals[i], (moved.positions[i] - moved.center) / moved.radius, 1e-5f)) ++off;
        CHECK(off == 0);
        const Material& gold = s.materials[moved.material];
        CHECK(gold.id == "gold");
        CHECK(gold.type == BsdfType::RoughConductor);
        CHECK(gold.distribution == MicrofacetDistribution::GGX);
        CHECK(gold.alpha_u == doctest::Approx(0.03f));
        CHECK(gold.alpha_v == doctest::Approx(0.03f));
        // Gold: reflects red far more than blue (k_R > k_B, eta_R < eta_B).
        CHECK(gold.k.x > gold.k.z);
        CHECK(gold.eta.x < gold.eta.z);
    }
    SUBCASE("disk emitter: rotated to face -y, one emitter bound both ways") {
        const Mesh& m = mesh_named(s, "lamp");
        CHECK(m.kind == ShapeKind::Disk);
        check_facing(m, {0, -1, 0});  // rotate x by 90 degrees: +z -> -y
        CHECK(surface_area(m) == doctest::Approx(kPi * 0.0625).epsilon(1e-3));
        REQUIRE(s.emitters.size() == 1);
        CHECK(m.emitter == 0);
        CHECK(&s.meshes[s.emitters[0].mesh] == &m);
        CHECK(near(s.emitters[0].radiance, {10, 9, 8}));
        size_t off_plane = 0;
        for (const auto& p : m.positions)
            if (std::abs(p.y - 4.0f) > 1e-5f) ++off_plane;
        CHECK(off_plane == 0);
    }
    SUBCASE("cylinder from p0 to p1") {
        const Mesh& m = mesh_named(s, "ring");
        CHECK(m.kind == ShapeKind::Cylinder);
        CHECK(surface_area(m) == doctest::Approx(2.0 * kPi * 0.3 * 2.0).epsilon(1e-3));
        const Material& cu = s.materials[m.material];
        CHECK(cu.type == BsdfType::Conductor);
        CHECK(cu.is_delta_only());
        CHECK(cu.ext_ior == doctest::Approx(1.0f));
    }
    SUBCASE("obj and ply shapes, flip_normals, twosided") {
        const Mesh& obj = mesh_named(s, "quad_obj");
        CHECK(obj.kind == ShapeKind::Mesh);
        CHECK(obj.indices.size() == 3);
        check_facing(obj, {0, 0, 1});
        // Mitsuba flips OBJ texture v by default.
        CHECK(obj.uvs[0] == glm::vec2(0, 1));
        const Material& frosted = s.materials[obj.material];
        CHECK(frosted.id == "frosted");
        CHECK(frosted.twosided);
        CHECK(frosted.type == BsdfType::RoughDielectric);
        CHECK(frosted.int_ior == doctest::Approx(1.333f));
        CHECK(frosted.ext_ior == doctest::Approx(1.0f));
        CHECK(frosted.alpha_u == doctest::Approx(0.2f));
        CHECK(frosted.alpha_v == doctest::Approx(0.3f));

        const Mesh& ply = mesh_named(s, "quad_ply");
        CHECK(ply.flip_normals);
        check_facing(ply, {0, 0, -1});
        for (const auto& n : ply.normals) CHECK(near(n, {0, 0, -1}));
        CHECK(ply.uvs[2] == glm::vec2(1, 1));  // PLY uvs are kept as stored
        CHECK(s.materials[ply.material].type == BsdfType::ThinDielectric);
        CHECK(s.materials[ply.material].int_ior == doctest::Approx(1.6f));
    }
    SUBCASE("principled: eta sets specular, diffuse while not fully metallic") {
        const Material& m = s.materials[mesh_named(s, "principled_ball").material];
        CHECK(m.type == BsdfType::Principled);
        CHECK(near(m.reflectance.value, {0.9f, 0.1f, 0.1f}));
        CHECK(m.metallic == doctest::Approx(0.25f));
        CHECK(m.roughness == doctest::Approx(0.4f));
        CHECK(m.clearcoat == doctest::Approx(0.5f));
        CHECK(m.eta_principled == doctest::Approx(1.33f));
        float r = (1.33f - 1.0f) / (1.33f + 1.0f);
        CHECK(m.specular == doctest::Approx(r * r / 0.08f));
        CHECK(m.has_diffuse());
    }
    SUBCASE("no bsdf: Mitsuba's diffuse 0.5; row-major <matrix>") {
        const Mesh& m = mesh_named(s, "default_material_box");
        const Material& mat = s.materials[m.material];
        CHECK(mat.type == BsdfType::Diffuse);
        CHECK(near(mat.reflectance.value, glm::vec3(0.5f)));
        glm::vec3 lo(1e9f);
        for (const auto& p : m.positions) lo = glm::min(lo, p);
        CHECK(near(lo, {9, 19, 29}));
    }
    SUBCASE("unused materials are not in the scene") {
        for (const auto& m : s.materials) CHECK(m.id != "never_used");
        CHECK(s.materials.size() == 9);
    }
}

TEST_CASE("mitsuba: 0.6-style camelCase names - toWorld - spectra - maxDepth -1") {
    Scene s = load_mitsuba_xml(data("loader/camelcase_06.xml"));
    CHECK(s.meshes.size() == 4);
    for (const auto& m : s.meshes) check_mesh_invariants(m);
    CHECK(s.integrator.max_depth >= 1000);  // -1: unlimited
    CHECK(s.integrator.rr_depth == 7);
    CHECK(s.camera.type == CameraType::Perspective);
    CHECK(s.camera.fov_axis == "smaller");
    CHECK(s.camera.near_clip == doctest::Approx(0.5f));
    CHECK(s.camera.far_clip == doctest::Approx(50.0f));
    CHECK(s.camera.width == 32);
    CHECK(s.camera.height == 16);
    CHECK(near(glm::vec3(s.camera.to_world[2]), {0, -1, 0}));

    const Material& plastic = s.materials[s.meshes[0].material];
    CHECK(plastic.type == BsdfType::Plastic);
    CHECK(near(plastic.reflectance.value, {1, 0, 0}));  // srgb #ff0000
    CHECK(near(plastic.specular_reflectance, glm::vec3(0.5f)));
    CHECK(plastic.int_ior == doctest::Approx(1.49f));
    CHECK(plastic.ext_ior == doctest::Approx(1.0f));
    CHECK(plastic.has_diffuse());
    CHECK_FALSE(plastic.is_delta_only());
    // scale x = 2, y = 3 of [-1,1]^2: area 24.
    CHECK(surface_area(s.meshes[0]) == doctest::Approx(24.0));

    const Material& brushed = s.materials[s.meshes[1].material];
    CHECK(brushed.type == BsdfType::RoughConductor);
    CHECK(brushed.alpha_u == doctest::Approx(0.05f));
    CHECK(brushed.alpha_v == doctest::Approx(0.3f));
    CHECK(near(brushed.eta, glm::vec3(0.0f)));  // "none": a perfect mirror
    CHECK(near(brushed.k, glm::vec3(1.0f)));

    const Material& glass = s.materials[s.meshes[2].material];
    CHECK(glass.int_ior == doctest::Approx(1.5046f));
    CHECK(glass.ext_ior == doctest::Approx(1.000277f));
    // 400:0.2 ... 700:0.8 sampled at 650/550/450 nm.
    CHECK(near(glass.specular_transmittance, {0.7f, 0.5f, 0.3f}, 1e-5f));
    CHECK(s.meshes[2].flip_normals);
    for (const auto& t : s.meshes[2].indices) {  // flipped cube: inward faces
        const Mesh& m = s.meshes[2];
        glm::vec3 centroid = (m.positions[t.x] + m.positions[t.y] + m.positions[t.z]) / 3.0f;
        CHECK(glm::dot(triangle_cross(m, t), centroid) < 0.0f);
    }

    REQUIRE(s.emitters.size() == 1);
    CHECK(near(s.emitters[0].radiance, glm::vec3(5.0f)));
    CHECK(s.emitters[0].mesh == 3);
}

TEST_CASE("mitsuba: $param defaults - -D overrides - unused -D is fine") {
    Scene d = load_mitsuba_xml(data("loader/params.xml"));
    CHECK(d.meshes[0].radius == doctest::Approx(2.0f));
    CHECK(near(d.meshes[0].center, {1.5f, 0, -1.5f}));
    CHECK(d.camera.width == 40);
    CHECK(d.materials[d.meshes[0].material].int_ior == doctest::Approx(1.5046f));

    LoadOptions o;
    o.params = {{"radius", "3"}, {"res", "24"}, {"ior", "diamond"}, {"never_used", "1"}};
    Scene s = load_mitsuba_xml(data("loader/params.xml"), o);
    CHECK(s.meshes[0].radius == doctest::Approx(3.0f));
    CHECK(near(s.meshes[0].center, {1.5f, 0, -1.5f}));
    CHECK(s.camera.width == 24);
    CHECK(s.camera.height == 24);
    CHECK(s.materials[s.meshes[0].material].int_ior == doctest::Approx(2.419f));
}

TEST_CASE("mitsuba: nested includes relative to the including file - bitmap textures") {
    Scene s = load_mitsuba_xml(data("loader/include_main.xml"));
    REQUIRE(s.meshes.size() == 2);
    const Material& red = s.materials[s.meshes[0].material];
    CHECK(red.id == "included_red");
    CHECK(near(red.reflectance.value, {0.9f, 0, 0}));
    // Film default: docs/descriptor.md §1, 256 x 256; no fov_axis given: x.
    CHECK(s.camera.width == 256);
    CHECK(s.camera.height == 256);

    const Material& tex = s.materials[s.meshes[1].material];
    CHECK(tex.twosided);
    CHECK(tex.id == "included_textured");
    REQUIRE(tex.reflectance.texture == 0);
    REQUIRE(s.textures.size() == 1);
    const Texture& t = s.textures[0];
    CHECK(t.width == 2);
    CHECK(t.height == 2);
    REQUIRE(t.rgb.size() == 12);
    // Top row first: red, green; then blue, sRGB 128 -> linear 0.2158.
    CHECK(t.rgb[0] == doctest::Approx(1.0f));
    CHECK(t.rgb[1] == doctest::Approx(0.0f));
    CHECK(t.rgb[4] == doctest::Approx(1.0f));
    CHECK(t.rgb[8] == doctest::Approx(1.0f));
    CHECK(t.rgb[9] == doctest::Approx(0.21586f).epsilon(1e-3));
    CHECK(t.path.find("checker2x2.png") != std::string::npos);

    Scene raw = load_mitsuba_xml(data("loader/texture_raw.xml"));
    REQUIRE(raw.textures.size() == 1);
    CHECK(raw.textures[0].rgb[9] == doctest::Approx(128.0f / 255.0f).epsilon(1e-3));
    CHECK(raw.materials[raw.meshes[0].material].type == BsdfType::Plastic);
    CHECK(raw.materials[raw.meshes[0].material].reflectance.texture == 0);
}

TEST_CASE("mitsuba: an envmap loads as the environment, or on request as the paper's overhead panel") {
    // The map is read either way, so a missing map is an error either way.
    CHECK_THROWS_WITH_AS(load_mitsuba_xml(data("loader/envmap.xml")),
                         doctest::Contains("cannot open environment map 'sky.exr'"), SceneError);
    LoadOptions o;
    o.environment_panel = true;
    CHECK_THROWS_WITH_AS(load_mitsuba_xml(data("loader/envmap.xml"), o),
                         doctest::Contains("cannot open environment map 'sky.exr'"), SceneError);

    // A 4x2 latitude-longitude map written here: the upper row (theta = pi/4)
    // is 3, the lower row (theta = 3 pi / 4) is 1; both rows have the same
    // solid angle (sin pi/4 = sin 3pi/4), so the mean radiance is 2, and the
    // panel's radiance is 2 x scale 0.5 = 1.
    fs::path dir = fs::temp_directory_path() / ("vkmech_envmap_" + std::to_string(::getpid()));
    fs::create_directories(dir);
    std::vector<float> px = {3, 3, 3, 3, 1, 1, 1, 1};
    write_exr_layers((dir / "sky.exr").string(), 4, 2, {{"R", px}, {"G", px}, {"B", px}});
    std::ifstream in(data("loader/envmap.xml"));
    std::stringstream xml;
    xml << in.rdbuf();
    std::string text = xml.str();
    text.replace(text.find("</emitter>"), 10, "<float name=\"scale\" value=\"0.5\"/></emitter>");
    std::ofstream(dir / "envmap.xml") << text;
    Scene env = load_mitsuba_xml((dir / "envmap.xml").string());
    CHECK(env.environment.kind == EnvironmentKind::Map);
    CHECK(env.environment.scale == 0.5f);
    CHECK(env.emitters.empty());
    CHECK(env.substitutions.empty());
    Scene s = load_mitsuba_xml((dir / "envmap.xml").string(), o);
    CHECK(s.environment.kind == EnvironmentKind::None);
    REQUIRE(s.substitutions.size() == 1);
    CHECK(s.substitutions[0].find("envmap") != std::string::npos);
    REQUIRE(s.emitters.size() == 1);
    CHECK(near(s.emitters[0].radiance, glm::vec3(1.0f)));
    // The box spans y in [0, 2]; the panel hangs above it, facing down, and
    // covers its x/z extent.
    const Mesh& panel = s.meshes[s.emitters[0].mesh];
    CHECK(panel.emitter >= 0);
    check_facing(panel, {0, -1, 0});
    for (const auto& p : panel.positions) CHECK(p.y > 2.0f);
    CHECK(surface_area(panel) >= 4.0 * 6.0 - 1e-3);
    fs::remove_all(dir);
}

TEST_CASE("mitsuba: mirroring transforms - binary PLY shapes - face_normals") {
    Scene s = load_mitsuba_xml(data("loader/mirror_transform.xml"));
    for (const auto& m : s.meshes) check_mesh_invariants(m);
    // A one-sided emitter keeps facing +z (Mitsuba transforms its frame).
    check_facing(mesh_named(s, "mirrored"), {0, 0, 1});
    // A mesh with file normals keeps winding and normals in agreement.
    check_facing(mesh_named(s, "mirrored_obj"), {0, 0, 1});
    CHECK(mesh_named(s, "binary_le").positions == mesh_named(s, "binary_be").positions);
    CHECK(mesh_named(s, "forms").normals.empty());
}

TEST_CASE("mitsuba: an OBJ without normals gets Mitsuba's smooth vertex normals") {
    Scene s = load_mitsuba_xml(data("loader/mirror_transform.xml"));
    const Mesh& m = mesh_named(s, "forms_smooth");
    REQUIRE(m.normals.size() == m.positions.size());
    for (const auto& n : m.normals) CHECK(near(n, {0, 0, 1}));
    check_mesh_invariants(m);
}

TEST_CASE("scene: load_scene dispatch and the material helpers") {
    CHECK_THROWS_WITH_AS(load_scene(data("loader/scene.fbx")), doctest::Contains("unsupported scene format"),
                         SceneError);
    // .gltf goes to the glTF loader (tests/test_gltf.cpp), which says the file is absent.
    CHECK_THROWS_WITH_AS(load_scene(data("loader/scene.gltf")), doctest::Contains("cannot open scene file"),
                         SceneError);
    CHECK_THROWS_WITH_AS(load_scene(data("loader/absent.xml")), doctest::Contains("cannot open scene file"),
                         SceneError);
    CHECK(std::string(to_string(BsdfType::RoughDielectric)) == "roughdielectric");
    CHECK(std::string(to_string(ShapeKind::Cylinder)) == "cylinder");
    Material m;
    m.type = BsdfType::Principled;
    m.metallic = 1.0f;
    CHECK_FALSE(m.has_diffuse());
    m.metallic = 0.0f;
    m.spec_trans = 1.0f;
    CHECK_FALSE(m.has_diffuse());
    m.type = BsdfType::RoughConductor;
    CHECK_FALSE(m.is_delta_only());
    m.type = BsdfType::ThinDielectric;
    CHECK(m.is_delta_only());
    Scene s;
    s.meshes.resize(2);
    s.meshes[0].indices.resize(3);
    s.meshes[1].indices.resize(4);
    CHECK(s.triangle_count() == 7);
}

// ---------------------------------------------------------------------------
// The malformed corpus: every fault a SceneError with file, line and cause.
// ---------------------------------------------------------------------------

namespace {

struct Fault {
    const char* scene;     // under tests/data/malformed/
    const char* file;      // the file the error must name (basename)
    int line;              // 0: the error has no line (binary data)
    const char* fragment;  // names the fault
};

const Fault kFaults[] = {
    {"malformed_xml.xml", "malformed_xml.xml", 8, "malformed XML"},
    {"shape_without_type.xml", "shape_without_type.xml", 6, "missing the required attribute 'type'"},
    {"float_without_value.xml", "float_without_value.xml", 7, "missing the required attribute 'value'"},
    {"missing_mesh.xml", "missing_mesh.xml", 7, "cannot open mesh file 'no_such_mesh.obj'"},
    {"nan_number.xml", "nan_number.xml", 4, "non-finite number 'nan'"},
    {"inf_number.xml", "inf_number.xml", 8, "non-finite number 'inf'"},
    {"unparsable_number.xml", "unparsable_number.xml", 8, "cannot parse '1.2.3' as a number"},
    {"unknown_bsdf_ref.xml", "unknown_bsdf_ref.xml", 8, "unknown reference 'rde'"},
    {"no_sensor.xml", "no_sensor.xml", 3, "has no <sensor>"},
    {"negative_radius.xml", "negative_radius.xml", 6, "radius must be positive"},
    {"zero_film.xml", "zero_film.xml", 5, "film size must be positive"},
    {"bad_transform.xml", "bad_transform.xml", 9, "unknown transform operation <shear>"},
    {"bad_matrix.xml", "bad_matrix.xml", 8, "<matrix> needs 16 values"},
    {"lookat_parallel_up.xml", "lookat_parallel_up.xml", 6, "parallel to the viewing direction"},
    {"singular_transform.xml", "singular_transform.xml", 6, "to_world transform is singular"},
    {"unknown_distribution.xml", "unknown_distribution.xml", 8, "unknown microfacet distribution 'phong'"},
    {"missing_include.xml", "missing_include.xml", 6, "cannot open included file"},
    {"unbound_param.xml", "unbound_param.xml", 8, "unbound parameter '$roughness'"},
    {"unsupported_emitter.xml", "unsupported_emitter.xml", 6, "unsupported emitter plugin 'sunsky'"},
    {"point_light.xml", "point_light.xml", 6, "unsupported emitter plugin 'point'"},
    {"unsupported_bsdf.xml", "unsupported_bsdf.xml", 7, "unsupported bsdf plugin 'measured_polarized'"},
    {"unsupported_shape.xml", "unsupported_shape.xml", 6, "unsupported shape plugin 'bsplinecurve'"},
    {"unsupported_sensor.xml", "unsupported_sensor.xml", 3, "unsupported sensor plugin 'radiancemeter'"},
    {"unknown_conductor.xml", "unknown_conductor.xml", 7, "unknown conductor material 'Unobtainium'"},
    {"unknown_ior.xml", "unknown_ior.xml", 7, "unknown IOR name 'kryptonite'"},
    {"duplicate_id.xml", "duplicate_id.xml", 7, "duplicate id 'm'"},
    {"area_emitter_toplevel.xml", "area_emitter_toplevel.xml", 6, "outside a <shape> needs an id"},
    {"camera_scale.xml", "camera_scale.xml", 3, "must not scale the camera"},
    {"include_cycle.xml", "include_cycle.xml", 6, "include cycle"},
    {"error_in_include.xml", "bad_part.xml", 3, "'alpha_u' and 'alpha_v' go together"},
    {"bad_mesh_face.xml", "bad_face.obj", 6, "vertex index 7 out of range"},
    {"bad_ply.xml", "truncated.ply", 0, "unexpected end of binary data"},
    {"bad_texture.xml", "bad_texture.xml", 7, "cannot decode texture 'not_an_image.png'"},
    {"wrong_property_type.xml", "wrong_property_type.xml", 7, "property 'alpha' must be <float/integer>, not <rgb>"},
    {"unknown_element.xml", "unknown_element.xml", 6, "unknown element <shap>"},
    {"wrong_root.xml", "wrong_root.xml", 2, "root element must be <scene>"},
    {"bad_boolean.xml", "bad_boolean.xml", 7, "cannot parse 'yes' as a boolean"},
};

}  // namespace

TEST_CASE("mitsuba: the malformed corpus gives file:line: cause for every fault") {
    for (const Fault& f : kFaults) {
        CAPTURE(f.scene);
        std::string what;
        bool threw = false;
        try {
            load_scene(data(std::string("malformed/") + f.scene));
        } catch (const SceneError& e) {
            threw = true;
            what = e.what();
            CAPTURE(what);
            std::string file = e.file();
            CHECK(file.size() >= std::string(f.file).size());
            CHECK(file.substr(file.size() - std::string(f.file).size()) == f.file);
            CHECK(e.line() == f.line);
            std::string loc = std::string(f.file) + (f.line > 0 ? ":" + std::to_string(f.line) + ": " : ": ");
            CHECK(what.find(loc) != std::string::npos);
            CHECK(what.find(f.fragment) != std::string::npos);
        }
        CHECK_MESSAGE(threw, "expected a SceneError");
    }
    CHECK(sizeof(kFaults) / sizeof(kFaults[0]) >= 12);
}

TEST_CASE("mitsuba: the mesh error also says which shape loaded the mesh") {
    try {
        load_scene(data("malformed/bad_mesh_face.xml"));
        FAIL("expected a SceneError");
    } catch (const SceneError& e) {
        CHECK(std::string(e.what()).find("bad_mesh_face.xml:6") != std::string::npos);
    }
}

TEST_CASE("named IOR: Mitsuba's conductor names, sampled from its spectra at 650, 550 and 450 nm") {
    // Values read off Mitsuba's data/ior/*.spd (luxpop/Palik), linearly interpolated.
    const auto carbon = conductor_ior("a-C");
    REQUIRE(carbon.has_value());
    CHECK(carbon->eta.x == doctest::Approx(2.4300f));
    CHECK(carbon->eta.z == doctest::Approx(2.1848f));
    CHECK(carbon->k.y == doctest::Approx(0.8344f));
    const auto gold = conductor_ior("Au");
    REQUIRE(gold.has_value());
    CHECK(gold->eta.z == doctest::Approx(1.5085f));  // gold is blue-transparent, red-reflective
    CHECK(gold->k.x > gold->k.z);
    for (const char* name : {"Hg", "Ir", "Mo", "Rh", "TiN", "d-C", "Na_palik", "V_palik", "Cu_palik", "none"})
        CHECK_MESSAGE(conductor_ior(name).has_value(), name);
    CHECK_FALSE(conductor_ior("AlSb").has_value());  // its data stops at 590 nm
    CHECK_FALSE(conductor_ior("au").has_value());    // case-sensitive, as Mitsuba
    const std::string names = conductor_names();
    CHECK(names.find("a-C") != std::string::npos);
    CHECK(names.find("none") != std::string::npos);
}
