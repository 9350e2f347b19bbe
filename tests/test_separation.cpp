// Separation measures between the delta-S and glossy object families (paper
// §5 Finding 1, docs/descriptor.md §5): the family rule by lobe flags, the exact
// triangle-triangle and mesh distances (analytic cases and a brute-force
// sampling check), the deterministic area sampling, and the ray-tested mutual
// visibility on synthetic sphere scenes (with an analytic reference) and on
// the project's Finding-1 scenes.
#include "gpu_fixture.hpp"

#include "bsdf.glsl"
#include "render/gpu_scene.hpp"
#include "scene/primitives.hpp"
#include "scene/scene.hpp"
#include "study/separation_gpu.hpp"

#include <doctest/doctest.h>

#include <glm/gtc/matrix_transform.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <string>
#include <vector>

using namespace vkmech;

namespace {

std::string scene_path(const std::string& name) { return std::string(VKMECH_SOURCE_DIR) + "/scenes/" + name + ".xml"; }

Material material(const std::string& id, BsdfType type, bool twosided = false) {
    Material m;
    m.id = id;
    m.type = type;
    m.twosided = twosided;
    return m;
}

// A smooth conductor sphere at c0 and a second sphere (material `second`) at
// c1, both of radius r; optionally a thin opaque diffuse wall at x = 0
// covering |y|, |z| <= wall_half; an emitting rough conductor panel far above
// (an emitter is never a family member).
struct SphereSetup {
    float r = 0.5f;
    glm::vec3 c0{-1.0f, 0.0f, 0.0f}, c1{1.0f, 0.0f, 0.0f};
    BsdfType second = BsdfType::RoughConductor;
    bool twosided_second = false;
    bool wall = false;
    float wall_half = 1.0f;
};

Scene sphere_scene(const SphereSetup& s) {
    Scene scene;
    scene.source = "<separation spheres>";
    scene.materials = {material("chrome", BsdfType::Conductor), material("second", s.second, s.twosided_second),
                       material("wall", BsdfType::Diffuse), material("lamp", BsdfType::RoughConductor)};
    Mesh a = make_sphere(s.c0, s.r, glm::mat4(1.0f));
    a.name = "delta_sphere";
    a.material = 0;
    Mesh b = make_sphere(s.c1, s.r, glm::mat4(1.0f));
    b.name = "second_sphere";
    b.material = 1;
    scene.meshes = {a, b};
    if (s.wall) {
        glm::mat4 m = glm::scale(glm::mat4(1.0f), glm::vec3(0.02f, s.wall_half, s.wall_half));
        Mesh w = make_cube(m);
        w.name = "wall";
        w.material = 2;
        scene.meshes.push_back(w);
    }
    glm::mat4 lm = glm::translate(glm::mat4(1.0f), glm::vec3(0.0f, 0.0f, 5.0f)) *
                   glm::rotate(glm::mat4(1.0f), glm::radians(180.0f), glm::vec3(1, 0, 0));
    Mesh lamp = make_rectangle(lm);
    lamp.name = "lamp";
    lamp.material = 3;
    lamp.emitter = 0;
    scene.emitters.push_back(AreaEmitter{glm::vec3(5.0f), static_cast<int>(scene.meshes.size())});
    scene.meshes.push_back(lamp);
    return scene;
}

// The outward normal of the facet of the convex mesh `m` that contains p.
glm::dvec3 facet_normal(const Mesh& m, const glm::vec3& p3) {
    glm::dvec3 p(p3), best_n(0.0);
    double best = std::numeric_limits<double>::infinity();
    for (const auto& t : m.indices) {
        glm::dvec3 a(m.positions[t.x]), b(m.positions[t.y]), c(m.positions[t.z]);
        glm::dvec3 n = glm::cross(b - a, c - a);
        double area2 = glm::length(n);
        if (!(area2 > 0.0)) continue;
        n /= area2;
        double plane = std::abs(glm::dot(p - a, n));
        if (plane >= best) continue;
        // Barycentric coordinates of p's projection: inside (with slack)?
        double u = glm::dot(glm::cross(c - b, p - b), n) / area2, v = glm::dot(glm::cross(a - c, p - c), n) / area2;
        if (u < -1e-4 || v < -1e-4 || u + v > 1.0 + 1e-4) continue;
        best = plane;
        best_n = n;
    }
    return best_n;
}

std::string fixed4(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.4f", v);
    return buf;
}

SeparationMeasures measure(vkmech::vk::Context& ctx, const Scene& scene) {
    return measure_separation(RenderSession(ctx, scene, Traversal::Bvh));
}

}  // namespace

TEST_CASE("separation: family rule by BSDF lobe flags for every material type") {
    SphereSetup s;
    Scene scene = sphere_scene(s);
    CHECK(separation_family(scene, 0) == SeparationFamily::Delta);
    CHECK(separation_family(scene, 1) == SeparationFamily::Glossy);
    CHECK(separation_family(scene, 2) == SeparationFamily::None);  // emitting rough conductor

    // Every BsdfType: a glossy lobe makes the glossy family, a delta lobe
    // without a glossy one the delta-S family, neither none; `twosided` is
    // transparent.
    struct Row {
        BsdfType type;
        SeparationFamily family;
    };
    const Row rows[] = {
        {BsdfType::Diffuse, SeparationFamily::None},           {BsdfType::Plastic, SeparationFamily::Delta},
        {BsdfType::RoughPlastic, SeparationFamily::Glossy},    {BsdfType::Conductor, SeparationFamily::Delta},
        {BsdfType::RoughConductor, SeparationFamily::Glossy},  {BsdfType::Dielectric, SeparationFamily::Delta},
        {BsdfType::RoughDielectric, SeparationFamily::Glossy}, {BsdfType::ThinDielectric, SeparationFamily::Delta},
        {BsdfType::Principled, SeparationFamily::Glossy},      {BsdfType::RoughDiffuse, SeparationFamily::Glossy}};
    CHECK(std::size(rows) + 1 == gpu::MAT_COUNT);  // a new BsdfType needs a row (Blend: below)
    for (const Row& r : rows)
        for (bool twosided : {false, true}) {
            CAPTURE(to_string(r.type));
            CAPTURE(twosided);
            scene.materials[1].type = r.type;
            scene.materials[1].twosided = twosided;
            CHECK(separation_family(scene, 1) == r.family);
        }
    // A blend is of the family its components' flags together make: a diffuse and a mirror
    // component delta-S, a mirror and a rough metal glossy.
    {
        Scene b = scene;
        const int first = static_cast<int>(b.materials.size());
        for (BsdfType t : {BsdfType::Diffuse, BsdfType::Conductor, BsdfType::RoughConductor}) {
            Material c;
            c.type = t;
            b.materials.push_back(c);
        }
        b.materials[1] = Material{};
        b.materials[1].type = BsdfType::Blend;
        for (auto [second, family] :
             {std::pair{first + 1, SeparationFamily::Delta}, std::pair{first + 2, SeparationFamily::Glossy}}) {
            b.materials[1].blend_first = second == first + 1 ? first : first + 1;
            b.materials[1].blend_second = second;
            CHECK(separation_family(b, 1) == family);
        }
    }
    // Principled is glossy with or without its diffuse lobe (its specular
    // lobe is a microfacet lobe for every parameter value).
    scene.materials[1].type = BsdfType::Principled;
    scene.materials[1].twosided = false;
    for (auto [metallic, spec_trans, roughness] : {std::tuple{0.0f, 0.0f, 0.5f}, std::tuple{1.0f, 0.0f, 0.0f},
                                                   std::tuple{0.0f, 1.0f, 0.0f}, std::tuple{0.5f, 0.5f, 1.0f}}) {
        scene.materials[1].metallic = metallic;
        scene.materials[1].spec_trans = spec_trans;
        scene.materials[1].roughness = roughness;
        CHECK(separation_family(scene, 1) == SeparationFamily::Glossy);
    }

    // The rule on the flags themselves.
    using gpu::LOBE_BIT_D, gpu::LOBE_BIT_G, gpu::LOBE_BIT_S;
    CHECK(separation_family_of(0u) == SeparationFamily::None);
    CHECK(separation_family_of(LOBE_BIT_D) == SeparationFamily::None);
    CHECK(separation_family_of(LOBE_BIT_S) == SeparationFamily::Delta);
    CHECK(separation_family_of(LOBE_BIT_S | LOBE_BIT_D) == SeparationFamily::Delta);
    CHECK(separation_family_of(LOBE_BIT_G) == SeparationFamily::Glossy);
    CHECK(separation_family_of(LOBE_BIT_G | LOBE_BIT_D) == SeparationFamily::Glossy);
    CHECK(separation_family_of(LOBE_BIT_G | LOBE_BIT_S) == SeparationFamily::Glossy);
    CHECK(separation_family_of(LOBE_BIT_G | LOBE_BIT_S | LOBE_BIT_D) == SeparationFamily::Glossy);

    // tabletop: glass, chrome and the silver mirror are delta-S; gold,
    // aluminium and frosted glass are glossy; the table, the wall, the light
    // (and tabletop_separated's partition) are in neither.
    for (std::string name : {"tabletop_mixed", "tabletop_separated"}) {
        CAPTURE(name);
        Scene tt = load_scene(scene_path(name));
        int nd = 0, ng = 0;
        for (size_t i = 0; i < tt.meshes.size(); ++i) {
            SeparationFamily f = separation_family(tt, i);
            const std::string& n = tt.meshes[i].name;
            CAPTURE(n);
            if (n == "glass_sphere" || n == "chrome_sphere" || n == "mirror_sphere")
                CHECK(f == SeparationFamily::Delta);
            else if (n == "gold_sphere" || n == "aluminium_sphere" || n == "frosted_sphere")
                CHECK(f == SeparationFamily::Glossy);
            else
                CHECK(f == SeparationFamily::None);
            nd += f == SeparationFamily::Delta;
            ng += f == SeparationFamily::Glossy;
        }
        CHECK(nd == 3);
        CHECK(ng == 3);
    }
}

TEST_CASE("separation: the tabletop partition clears every ball by 0.015 m") {
    // scenes/tabletop/generate.py builds the partition round its own copy of
    // the ball table; this catches the two drifting apart.
    Scene tt = load_scene(scene_path("tabletop_separated"));
    auto part = std::find_if(tt.meshes.begin(), tt.meshes.end(), [](const Mesh& m) { return m.name == "partition"; });
    REQUIRE(part != tt.meshes.end());
    int balls = 0;
    for (const auto& m : tt.meshes) {
        if (m.kind != ShapeKind::Sphere) continue;
        CAPTURE(m.name);
        ++balls;
        double d = mesh_distance(*part, m);
        CHECK(d >= 0.0145);
        CHECK(d <= 0.0160);
    }
    CHECK(balls == 6);
}

TEST_CASE("separation: the families follow the lobe flags the renderer uses") {
    // Host and device read one table (shaders/lobes.glsl): the packed GPU
    // material reports the same flags as the host material, and the renderer's
    // NEE lobe and delta-only test agree with the family.
    Scene scene = sphere_scene(SphereSetup{});
    for (uint32_t t = 0; t < gpu::MAT_COUNT; ++t)
        for (float metallic : {0.0f, 1.0f}) {
            // A blend has no BSDF of its own: a hit takes a component's (the family rule's case
            // above gives it its components' family).
            if (static_cast<BsdfType>(t) == BsdfType::Blend) continue;
            scene.materials[1].type = static_cast<BsdfType>(t);
            scene.materials[1].metallic = metallic;
            CAPTURE(to_string(scene.materials[1].type));
            CAPTURE(metallic);
            SceneArrays arrays = flatten_scene(scene);
            const gpu::GpuMaterial& g = arrays.materials.at(1);
            uint32_t flags = shader::bsdf_lobe_flags(g);
            CHECK(flags != 0u);
            CHECK(flags == scene.materials[1].lobe_flags());
            SeparationFamily f = separation_family(scene, 1);
            CHECK(f == separation_family_of(flags));
            CHECK(shader::bsdf_is_delta_only(g) == (flags == gpu::LOBE_BIT_S));
            if (shader::bsdf_is_delta_only(g)) CHECK(f == SeparationFamily::Delta);
            if (shader::bsdf_nee_lobe(g) == gpu::LOBE_G) CHECK(f == SeparationFamily::Glossy);
            CHECK(scene.materials[1].is_delta_only() == shader::bsdf_is_delta_only(g));
            CHECK(scene.materials[1].has_diffuse() == (shader::bsdf_nee_lobe(g) == gpu::LOBE_D));
        }
}

namespace {

Triangle3 tri(glm::dvec3 a, glm::dvec3 b, glm::dvec3 c) { return Triangle3{a, b, c}; }

Triangle3 transformed(const Triangle3& t, const glm::dmat3& r, const glm::dvec3& shift) {
    return Triangle3{r * t[0] + shift, r * t[1] + shift, r * t[2] + shift};
}

// A rotation from axis-angle (Rodrigues).
glm::dmat3 rotation(glm::dvec3 axis, double angle) {
    axis = glm::normalize(axis);
    glm::dmat3 k(0.0, axis.z, -axis.y, -axis.z, 0.0, axis.x, axis.y, -axis.x, 0.0);  // columns
    return glm::dmat3(1.0) + std::sin(angle) * k + (1.0 - std::cos(angle)) * (k * k);
}

// The vertex-triangle minimum of the former measure: each vertex as a
// point (a degenerate triangle) against the other triangle.
double vertex_triangle_min(const Triangle3& a, const Triangle3& b) {
    double d = std::numeric_limits<double>::infinity();
    for (int i = 0; i < 3; ++i) {
        d = std::min(d, triangle_distance(tri(a[i], a[i], a[i]), b));
        d = std::min(d, triangle_distance(tri(b[i], b[i], b[i]), a));
    }
    return d;
}

double max_edge(const Triangle3& t) {
    return std::max({glm::length(t[1] - t[0]), glm::length(t[2] - t[1]), glm::length(t[0] - t[2])});
}

// Every point of an n x n barycentric grid on t (vertices and edges included).
std::vector<glm::dvec3> grid_points(const Triangle3& t, int n) {
    std::vector<glm::dvec3> p;
    for (int i = 0; i <= n; ++i)
        for (int j = 0; i + j <= n; ++j)
            p.push_back(t[0] + (t[1] - t[0]) * (double(i) / n) + (t[2] - t[0]) * (double(j) / n));
    return p;
}

}  // namespace

TEST_CASE("separation: skew edges crossing at interior points give the edge-edge distance") {
    // A lies in z <= 0 with its edge e_A on z = 0, B lies in z >= d with its
    // edge e_B on z = d; the edges cross in projection at interior points, so
    // the distance is exactly d, between those points. Every vertex is far
    // from the other triangle: the vertex-triangle minimum overestimates.
    const double d = 0.25;
    Triangle3 a = tri({-1.0, 0.0, 0.0}, {1.0, 0.0, 0.0}, {0.2, -0.4, -0.9});
    Triangle3 b = tri({-0.3, -1.0, d}, {0.5, 1.2, d}, {0.1, 0.1, d + 0.7});
    CHECK(triangle_distance(a, b) == doctest::Approx(d).epsilon(1e-14));
    CHECK(triangle_distance(b, a) == triangle_distance(a, b));
    CHECK(vertex_triangle_min(a, b) > d + 0.5);
    CHECK_FALSE(triangles_intersect(a, b));
    // Invariant under rigid motions.
    for (auto [axis, angle, shift] : {std::tuple{glm::dvec3(1, 2, 3), 0.7, glm::dvec3(0.1, -4.0, 2.5)},
                                      std::tuple{glm::dvec3(-3, 1, 0.5), 2.9, glm::dvec3(100.0, 7.0, -30.0)}}) {
        glm::dmat3 r = rotation(axis, angle);
        Triangle3 ra = transformed(a, r, shift), rb = transformed(b, r, shift);
        CHECK(triangle_distance(ra, rb) == doctest::Approx(d).epsilon(1e-12));
    }
    // Perpendicular edges meeting at their midpoints when d = 0: touching.
    Triangle3 b0 = tri({-0.3, -1.0, 0.0}, {0.5, 1.2, 0.0}, {0.1, 0.1, 0.7});
    CHECK(triangle_distance(a, b0) == 0.0);
    CHECK(triangles_intersect(a, b0));

    // The same at mesh level: two cubes turned so that an edge of each is
    // the closest feature (A: 45 degrees about z, a vertical edge at
    // x = sqrt 2; B: 45 degrees about y, an edge along y at x = c - sqrt 2).
    const double c = 3.0, gap = c - 2.0 * std::sqrt(2.0);
    Mesh ca = make_cube(glm::rotate(glm::mat4(1.0f), glm::radians(45.0f), glm::vec3(0, 0, 1)));
    Mesh cb = make_cube(glm::translate(glm::mat4(1.0f), glm::vec3(float(c), 0.0f, 0.0f)) *
                        glm::rotate(glm::mat4(1.0f), glm::radians(45.0f), glm::vec3(0, 1, 0)));
    CHECK(mesh_distance(ca, cb) == doctest::Approx(gap).epsilon(1e-5));
    CHECK(mesh_distance(cb, ca) == mesh_distance(ca, cb));
}

TEST_CASE("separation: intersecting and touching triangles are at distance 0") {
    Triangle3 floor = tri({-1.0, -1.0, 0.0}, {1.0, -1.0, 0.0}, {0.0, 1.0, 0.0});
    // Piercing through the interior (no vertex near the other triangle).
    Triangle3 pierce = tri({0.0, -0.2, -1.0}, {0.1, 0.1, 1.0}, {-0.1, 0.2, 1.0});
    CHECK(triangles_intersect(floor, pierce));
    CHECK(triangle_distance(floor, pierce) == 0.0);
    CHECK(triangle_distance(pierce, floor) == 0.0);
    CHECK(vertex_triangle_min(floor, pierce) > 0.9);
    // Both cut each other's interior (neither has a vertex inside the other).
    Triangle3 cross1 = tri({-1.0, 0.0, -1.0}, {1.0, 0.0, -1.0}, {0.0, 0.0, 1.0});
    Triangle3 cross2 = tri({0.0, -1.0, 0.2}, {0.0, 1.0, 0.2}, {0.0, 0.0, -3.0});
    CHECK(triangle_distance(cross1, cross2) == 0.0);
    // A vertex exactly on the other's interior; an edge lying in the other's
    // plane and half inside it; an edge crossing the other's edge.
    CHECK(triangle_distance(floor, tri({0.0, 0.0, 0.0}, {0.0, 0.0, 1.0}, {0.5, 0.0, 1.0})) == 0.0);
    CHECK(triangle_distance(floor, tri({-1.0, 0.0, 0.0}, {0.0, 0.0, 0.0}, {0.0, 0.0, 2.0})) == 0.0);
    CHECK(triangle_distance(floor, tri({0.0, -1.0, -1.0}, {0.0, -1.0, 1.0}, {0.0, -2.0, 0.0})) == 0.0);
    // Coplanar: overlapping with only edges crossing (no vertex inside the
    // other), one inside the other, sharing only a vertex.
    Triangle3 star = tri({-1.0, 0.5, 0.0}, {1.0, 0.5, 0.0}, {0.0, -1.5, 0.0});
    CHECK(vertex_triangle_min(floor, star) > 0.1);
    CHECK(triangle_distance(floor, star) == 0.0);
    CHECK(triangle_distance(floor, tri({-0.1, -0.1, 0.0}, {0.1, -0.1, 0.0}, {0.0, 0.1, 0.0})) == 0.0);
    CHECK(triangle_distance(floor, tri({1.0, -1.0, 0.0}, {3.0, -1.0, 0.0}, {2.0, -3.0, 0.0})) == 0.0);
    // Just apart, in the same places.
    CHECK(std::abs(triangle_distance(floor, tri({0.0, 0.0, 1e-9}, {0.0, 0.0, 1.0}, {0.5, 0.0, 1.0})) - 1e-9) < 1e-20);
    CHECK_FALSE(triangles_intersect(floor, tri({0.0, 0.0, 1e-9}, {0.0, 0.0, 1.0}, {0.5, 0.0, 1.0})));
    CHECK_FALSE(triangles_intersect(floor, tri({1.0 + 1e-12, -1.0, 0.0}, {3.0, -1.0, 0.0}, {2.0, -3.0, 0.0})));
    // Rounding-hard positions (no exact binary fractions) under a rigid motion:
    // a triangle and a copy moved along its own plane still overlap.
    glm::dmat3 r = rotation({0.3, -1.7, 0.9}, 1.1);
    Triangle3 t = transformed(floor, r, {0.1, 0.2, 0.3});
    glm::dvec3 along = (t[1] - t[0]) * 0.1;
    CHECK(triangle_distance(t, Triangle3{t[0] + along, t[1] + along, t[2] + along}) <= 1e-14);
}

TEST_CASE("separation: parallel triangles in offset planes and coplanar triangles side by side") {
    // Parallel planes z = 0 and z = h, overlapping in projection: h.
    const double h = 0.3;
    Triangle3 a = tri({0.0, 0.0, 0.0}, {2.0, 0.0, 0.0}, {0.0, 2.0, 0.0});
    Triangle3 b = tri({0.5, 0.5, h}, {3.0, 0.5, h}, {0.5, 3.0, h});
    CHECK(triangle_distance(a, b) == doctest::Approx(h).epsilon(1e-14));
    // Parallel planes with the projections apart: between the parallel
    // hypotenuse edges on x + y = 2 and x + y = 2 + 2g (in-plane gap g sqrt 2,
    // the edges' extents coincide), sqrt(h^2 + 2 g^2).
    const double g = 0.4;
    Triangle3 c = tri({2.0 + g, g, h}, {g, 2.0 + g, h}, {2.0 + g, 2.0 + g, h});
    CHECK(triangle_distance(a, c) == doctest::Approx(std::sqrt(h * h + 2.0 * g * g)).epsilon(1e-14));
    // Coplanar side by side, facing parallel edges with overlapping extents.
    Triangle3 d = tri({2.0 + g, g, 0.0}, {g, 2.0 + g, 0.0}, {2.0 + g, 2.0 + g, 0.0});
    CHECK(triangle_distance(a, d) == doctest::Approx(std::sqrt(2.0) * g).epsilon(1e-14));
    // Collinear edges in one line, end to end: the gap between the ends.
    Triangle3 e = tri({2.5, 0.0, 0.0}, {4.0, 0.0, 0.0}, {3.0, -1.0, 0.0});
    CHECK(triangle_distance(a, e) == doctest::Approx(0.5).epsilon(1e-14));
    // Coplanar triangles in the plane y = 0, one above the other: parallel
    // edges h apart, with overlapping extents.
    Triangle3 f = tri({0.0, 0.0, 0.0}, {2.0, 0.0, 0.0}, {1.0, 0.0, -1.0});
    Triangle3 k = tri({0.5, 0.0, h}, {2.5, 0.0, h}, {1.5, 0.0, h + 1.0});
    CHECK(triangle_distance(f, k) == doctest::Approx(h).epsilon(1e-14));
    // Parallel edges of two triangles in different planes (offset in y too).
    Triangle3 k2 = tri({0.5, 0.1, h}, {2.5, 0.1, h}, {1.5, 0.7, h + 1.0});
    CHECK(triangle_distance(f, k2) == doctest::Approx(std::sqrt(h * h + 0.01)).epsilon(1e-14));
}

TEST_CASE("separation: degenerate triangles are their edges") {
    Triangle3 floor = tri({-1.0, -1.0, 0.0}, {1.0, -1.0, 0.0}, {0.0, 1.0, 0.0});
    // A segment (collinear vertices, middle one listed last) above the interior.
    Triangle3 seg = tri({0.0, 0.0, 1.0}, {0.0, 0.0, 3.0}, {0.0, 0.0, 2.0});
    CHECK(triangle_distance(floor, seg) == doctest::Approx(1.0).epsilon(1e-14));
    CHECK(triangle_distance(seg, floor) == triangle_distance(floor, seg));
    // The segment piercing the triangle; lying in its plane across it.
    CHECK(triangle_distance(floor, tri({0.2, 0.1, -1.0}, {0.2, 0.1, 1.0}, {0.2, 0.1, 0.5})) == 0.0);
    CHECK(triangle_distance(floor, tri({-3.0, 0.0, 0.0}, {3.0, 0.0, 0.0}, {0.0, 0.0, 0.0})) == 0.0);
    // A point: its distance to the plane, or to the nearest edge.
    CHECK(triangle_distance(floor, tri({0.1, 0.1, -0.7}, {0.1, 0.1, -0.7}, {0.1, 0.1, -0.7})) ==
          doctest::Approx(0.7).epsilon(1e-14));
    CHECK(triangle_distance(floor, tri({0.0, -2.0, 0.0}, {0.0, -2.0, 0.0}, {0.0, -2.0, 0.0})) ==
          doctest::Approx(1.0).epsilon(1e-14));
    // Two degenerate triangles: perpendicular skew segments crossing at
    // interior points, 0.5 apart; and two coincident points.
    Triangle3 s1 = tri({-1.0, 0.0, 0.0}, {1.0, 0.0, 0.0}, {0.0, 0.0, 0.0});
    Triangle3 s2 = tri({0.3, -1.0, 0.5}, {0.3, 1.0, 0.5}, {0.3, 1.0, 0.5});
    CHECK(triangle_distance(s1, s2) == doctest::Approx(0.5).epsilon(1e-14));
    Triangle3 p = tri({0.25, 0.5, 2.0}, {0.25, 0.5, 2.0}, {0.25, 0.5, 2.0});
    CHECK(triangle_distance(p, p) == 0.0);
    CHECK(std::isfinite(triangle_distance(s1, p)));
    // A mesh of zero-area triangles has a finite distance too.
    Mesh flat;
    flat.positions = {{0.0f, 0.0f, 2.0f}, {1.0f, 0.0f, 2.0f}, {2.0f, 0.0f, 2.0f}};
    flat.indices = {{0, 1, 2}};
    Mesh cube = make_cube(glm::mat4(1.0f));
    CHECK(mesh_distance(flat, cube) == doctest::Approx(1.0).epsilon(1e-6));
}

TEST_CASE("separation: triangle distance agrees with dense point sampling of both triangles") {
    // Random triangle pairs (some intersecting, some with edges closest, some
    // degenerate or coplanar): the minimum over every pair of grid points is
    // never below the exact distance and exceeds it by at most the grid's
    // resolution (any point of a triangle is within max edge / n of a grid
    // point).
    std::mt19937_64 rng(20240612);
    auto u = [&]() { return static_cast<double>(rng() >> 11) * 0x1p-52 - 1.0; };  // [-1, 1), portable
    auto rnd = [&]() {
        double x = u(), y = u();
        return glm::dvec3(x, y, u());
    };
    const int n = 80;
    int zero = 0, edge_closest = 0;
    for (int k = 0; k < 40; ++k) {
        CAPTURE(k);
        Triangle3 a = {rnd(), rnd(), rnd()};
        glm::dvec3 shift = rnd() * 1.2;
        Triangle3 b = {rnd() * 0.7 + shift, rnd() * 0.7 + shift, rnd() * 0.7 + shift};
        if (k % 10 == 7) b[2] = 0.3 * b[0] + 0.7 * b[1];  // (nearly) degenerate
        if (k % 10 == 8) {                                // coplanar with a, moved in its plane
            glm::dvec3 along = (a[1] - a[0]) * (0.5 * u()) + (a[2] - a[0]) * (0.5 * u());
            b = {a[0] + along, a[1] + along * 0.5 + (a[2] - a[1]) * 0.3, a[2] + along};
        }
        double exact = triangle_distance(a, b);
        CHECK(triangle_distance(b, a) == exact);
        std::vector<glm::dvec3> pa = grid_points(a, n), pb = grid_points(b, n);
        double sampled2 = std::numeric_limits<double>::infinity();
        for (const auto& p : pa)
            for (const auto& q : pb) {
                glm::dvec3 d = p - q;
                sampled2 = std::min(sampled2, glm::dot(d, d));
            }
        double sampled = std::sqrt(sampled2);
        double tol = (max_edge(a) + max_edge(b)) / n;
        CAPTURE(exact);
        CAPTURE(sampled);
        CHECK(sampled >= exact - 1e-12);
        CHECK(sampled <= exact + tol);
        if (triangles_intersect(a, b))
            CHECK(exact == 0.0);
        else if (k % 10 != 8)
            CHECK(exact > 0.0);  // (nearly coplanar pairs may touch within rounding)
        zero += exact == 0.0;
        edge_closest += vertex_triangle_min(a, b) > exact + 1e-9;
    }
    MESSAGE("random pairs: " << zero << " intersecting, " << edge_closest
                             << " closer than any vertex-triangle distance");
    CHECK(zero >= 4);
    CHECK(edge_closest >= 8);
}

TEST_CASE("separation: surface samples are deterministic - on the surface - and uniform by area") {
    Mesh s = make_sphere(glm::vec3(1, 2, 3), 0.7f, glm::mat4(1.0f));
    auto p1 = sample_surface_points(s, 4, 256, 0);
    auto p2 = sample_surface_points(s, 4, 256, 0);
    auto p3 = sample_surface_points(s, 5, 256, 0);
    auto p4 = sample_surface_points(s, 4, 256, 1);
    REQUIRE(p1.size() == 256);
    CHECK(p1 == p2);
    CHECK(p1 != p3);
    CHECK(p1 != p4);
    for (const auto& p : p1) CHECK(glm::length(p - glm::vec3(1, 2, 3)) == doctest::Approx(0.7).epsilon(1e-3));
    // A box 4 x 1 x 1: its two 4 x 1 faces at +-y get 4/18 of the area each.
    Mesh box = make_cube(glm::scale(glm::mat4(1.0f), glm::vec3(2.0f, 0.5f, 0.5f)));
    auto pts = sample_surface_points(box, 0, 20000, 0);
    int plus_y = 0;
    for (const auto& p : pts) plus_y += p.y > 0.4999f;
    CHECK(std::abs(plus_y / 20000.0 - 4.0 / 18.0) < 0.01);  // binomial sd 0.003
    Mesh empty;
    CHECK(sample_surface_points(empty, 0, 8, 0).empty());
}

TEST_SUITE("gpu") {
    TEST_CASE("separation: two spheres - distance d - 2r and visibility matching an exact convex reference") {
        VKMECH_REQUIRE_GPU(ctx);
        SphereSetup s;  // r 0.5, centres 2 apart
        Scene scene = sphere_scene(s);
        SeparationMeasures m = measure(*ctx, scene);
        REQUIRE(m.defined());
        CHECK(m.delta_objects == 1);
        CHECK(m.glossy_objects == 1);  // the emitting rough conductor panel does not count
        CHECK(std::abs(m.min_distance - (2.0 - 2.0 * 0.5)) <= 0.01 * (2.0 - 2.0 * 0.5));
        CHECK(m.segments == 64u * 64u);
        CHECK(m.mutual_visibility > 0.0);
        CHECK(m.mutual_visibility < 1.0);

        // Exact reference for two disjoint convex meshes: a segment from a
        // on A to b on B passes through neither iff it leaves A's facet at a
        // and B's facet at b on their outer sides (the lamp is far away).
        auto pa = sample_surface_points(scene.meshes[0], 0, 64, 0);
        auto pb = sample_surface_points(scene.meshes[1], 1, 64, 0);
        std::vector<glm::dvec3> na, nb;
        for (const auto& a : pa) na.push_back(facet_normal(scene.meshes[0], a));
        for (const auto& b : pb) nb.push_back(facet_normal(scene.meshes[1], b));
        uint64_t vis = 0;
        for (size_t i = 0; i < pa.size(); ++i)
            for (size_t j = 0; j < pb.size(); ++j) {
                glm::dvec3 d = glm::dvec3(pb[j]) - glm::dvec3(pa[i]);
                vis += glm::dot(d, na[i]) > 0.0 && glm::dot(d, nb[j]) < 0.0;
            }
        double ref = vis / 4096.0;
        MESSAGE("two spheres: min distance " << m.min_distance << ", visibility " << m.mutual_visibility
                                             << " (facet-normal reference " << ref << ")");
        CHECK(std::abs(m.mutual_visibility - ref) <= 8.0 / 4096.0);  // grazing segments may round either way

        // Deterministic.
        SeparationMeasures again = measure(*ctx, scene);
        CHECK(again.mutual_visibility == m.mutual_visibility);
        CHECK(again.min_distance == m.min_distance);

        // A twosided rough dielectric is glossy too, and the measures do not
        // depend on which of the two rough models it is.
        s.second = BsdfType::RoughDielectric;
        s.twosided_second = true;
        SeparationMeasures rd = measure(*ctx, sphere_scene(s));
        CHECK(rd.glossy_objects == 1);
        CHECK(rd.mutual_visibility == m.mutual_visibility);
        CHECK(ctx->validation_messages() == 0);
    }

    TEST_CASE("separation: an opaque wall between the spheres blocks every segment") {
        VKMECH_REQUIRE_GPU(ctx);
        SphereSetup s;
        s.wall = true;
        SeparationMeasures m = measure(*ctx, sphere_scene(s));
        REQUIRE(m.defined());
        CHECK(std::abs(m.min_distance - 1.0) <= 0.01);  // the wall is in neither family
        CHECK(m.segments == 64u * 64u);
        CHECK(m.visible == 0u);
        CHECK(m.mutual_visibility == 0.0);

        // A wall too small to cover the spheres lets some sight lines past.
        s.wall_half = 0.2f;
        SeparationMeasures part = measure(*ctx, sphere_scene(s));
        CHECK(part.mutual_visibility > 0.0);
    }

    TEST_CASE("separation: no glossy object leaves the measures undefined") {
        VKMECH_REQUIRE_GPU(ctx);
        SphereSetup s;
        s.second = BsdfType::Plastic;  // smooth plastic: delta-S, no glossy lobe
        SeparationMeasures m = measure(*ctx, sphere_scene(s));
        CHECK(m.delta_objects == 2);
        CHECK(m.glossy_objects == 0);
        CHECK_FALSE(m.defined());
        CHECK(std::isnan(m.min_distance));
        CHECK(std::isnan(m.mutual_visibility));
        CHECK(m.segments == 0u);
    }

    TEST_CASE("separation: project scenes - the partition of tabletop_separated blocks every sight line") {
        VKMECH_REQUIRE_GPU(ctx);
        for (std::string name : {"tabletop_mixed", "tabletop_separated", "snooker", "kitchen_counter"}) {
            CAPTURE(name);
            Scene scene = load_scene(scene_path(name));
            SeparationMeasures m = measure_separation(RenderSession(*ctx, scene, Traversal::Bvh));
            MESSAGE(name << ": delta-S objects " << m.delta_objects << ", glossy objects " << m.glossy_objects
                         << ", min distance " << m.min_distance << " m, mutual visibility " << m.mutual_visibility
                         << " (" << m.visible << " of " << m.segments << " segments)");
            REQUIRE(m.defined());
            CHECK(m.segments == 64ull * 64ull * m.delta_objects * m.glossy_objects);
            CHECK(std::isfinite(m.min_distance));
            CHECK(m.min_distance >= 0.0);
            if (ctx->ray_query_enabled()) {
                // The other traversal sees the same sight lines (up to grazing
                // segments rounding differently).
                SeparationMeasures q = measure_separation(RenderSession(*ctx, scene, Traversal::RayQuery));
                CHECK(q.segments == m.segments);
                CHECK(q.min_distance == m.min_distance);
                CHECK(std::abs(q.mutual_visibility - m.mutual_visibility) <= 1e-3);
            }
            const std::string& n = name;
            if (n == "tabletop_separated") CHECK(m.mutual_visibility == 0.0);
            if (n == "tabletop_mixed") CHECK(m.mutual_visibility > 0.0);
            if (n.rfind("tabletop", 0) == 0) {
                // Every family member is a sphere: the analytic gap (the
                // scene's declared 0.05 m) within 1%.
                double gap = std::numeric_limits<double>::infinity();
                for (size_t i = 0; i < scene.meshes.size(); ++i)
                    for (size_t j = 0; j < scene.meshes.size(); ++j)
                        if (separation_family(scene, i) == SeparationFamily::Delta &&
                            separation_family(scene, j) == SeparationFamily::Glossy) {
                            const Mesh &a = scene.meshes[i], &b = scene.meshes[j];
                            REQUIRE(a.radius > 0.0f);
                            REQUIRE(b.radius > 0.0f);
                            gap = std::min(
                                gap, glm::length(glm::dvec3(a.center) - glm::dvec3(b.center)) - a.radius - b.radius);
                        }
                CAPTURE(gap);
                CHECK(std::abs(m.min_distance - gap) <= 0.01 * gap);
                CHECK(std::abs(gap - 0.05) <= 1e-6);
            }
        }
        CHECK(ctx->validation_messages() == 0);
    }

    // The measurement behind docs/scenes.md "tabletop pair: design record":
    // both scenes at the default sampling (64 points per object, seed 0) and
    // at a larger one (256 points per object, seeds 0 and 1).
    TEST_CASE("separation: tabletop pair design record - mixed has sight lines and the partition blocks all") {
        VKMECH_REQUIRE_GPU(ctx);
        struct Sampling {
            uint32_t points, seed;
        };
        for (std::string name : {"tabletop_mixed", "tabletop_separated"}) {
            CAPTURE(name);
            Scene scene = load_scene(scene_path(name));
            RenderSession session(*ctx, scene, Traversal::Bvh);
            for (Sampling s : {Sampling{64, 0}, Sampling{256, 0}, Sampling{256, 1}}) {
                CAPTURE(s.points);
                CAPTURE(s.seed);
                SeparationMeasures m = measure_separation(session, s.points, s.seed);
                MESSAGE(name << ", " << s.points << " points per object, seed " << s.seed << ": delta-S objects "
                             << m.delta_objects << ", glossy objects " << m.glossy_objects << ", min distance "
                             << fixed4(m.min_distance) << " m, mutual visibility " << fixed4(m.mutual_visibility)
                             << " (" << m.visible << " of " << m.segments << " segments)");
                REQUIRE(m.defined());
                CHECK(m.delta_objects == 3);
                CHECK(m.glossy_objects == 3);
                CHECK(m.segments == uint64_t(s.points) * s.points * 9u);
                if (name == "tabletop_mixed")
                    CHECK(m.mutual_visibility > 0.0);
                else
                    CHECK(m.visible == 0u);
            }
        }
        CHECK(ctx->validation_messages() == 0);
    }
}
