// The project's scenes match their descriptions in docs/descriptor.md §7 (shapes, materials,
// emitters), and the sweep parameters do what they say.
#include "scene_fixtures.hpp"

#include "scene/scene.hpp"

#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <set>

using namespace vkmech;

namespace {

std::string scene_path(const std::string& name) { return std::string(VKMECH_SOURCE_DIR) + "/scenes/" + name + ".xml"; }

int count_kind(const Scene& s, ShapeKind k) {
    return static_cast<int>(
        std::count_if(s.meshes.begin(), s.meshes.end(), [&](const Mesh& m) { return m.kind == k; }));
}

const Material& material_of(const Scene& s, const Mesh& m) { return s.materials.at(m.material); }

std::vector<const Mesh*> meshes_of_kind(const Scene& s, ShapeKind k) {
    std::vector<const Mesh*> out;
    for (const auto& m : s.meshes)
        if (m.kind == k) out.push_back(&m);
    return out;
}

bool has_type(const Scene& s, BsdfType t) {
    return std::any_of(s.materials.begin(), s.materials.end(), [&](const Material& m) { return m.type == t; });
}

double mesh_area(const Mesh& m) {
    double a = 0.0;
    for (const auto& t : m.indices)
        a += 0.5 * glm::length(glm::cross(m.positions[t.y] - m.positions[t.x], m.positions[t.z] - m.positions[t.x]));
    return a;
}

double emitted_power(const Scene& s) {
    double p = 0.0;
    for (const auto& e : s.emitters) {
        double lum = 0.2126 * e.radiance.r + 0.7152 * e.radiance.g + 0.0722 * e.radiance.b;
        p += lum * mesh_area(s.meshes.at(e.mesh));
    }
    return p;
}

}  // namespace

TEST_CASE("scenes: every scene file loads - has a camera - geometry and a light") {
    auto paths = testing::project_scene_paths();
    CHECK(paths.size() >= 9);
    for (const auto& p : paths) {
        CAPTURE(p);
        Scene s = load_scene(p);
        CHECK(s.triangle_count() > 0);
        CHECK(!s.emitters.empty());
        CHECK(s.camera.width == 256);  // docs/descriptor.md §1 default film
        CHECK(s.camera.height == 256);
        CHECK(s.integrator.max_depth == 12);
        CHECK(s.integrator.rr_depth == 5);
        for (const auto& m : s.meshes) CHECK(m.material >= 0);
    }
}

TEST_CASE("scenes: cubes_dof is Lambertian cubes under a thin-lens camera") {
    Scene s = load_scene(scene_path("cubes_dof"));
    CHECK(count_kind(s, ShapeKind::Cube) == 3);
    for (const auto& m : s.materials) CHECK(m.type == BsdfType::Diffuse);
    CHECK(s.camera.type == CameraType::ThinLens);
    CHECK(s.camera.aperture_radius > 0.0f);
    CHECK(s.camera.focus_distance > 0.0f);
}

TEST_CASE("scenes: glass_caustic has one smooth glass sphere in a diffuse box") {
    Scene s = load_scene(scene_path("glass_caustic"));
    auto spheres = meshes_of_kind(s, ShapeKind::Sphere);
    REQUIRE(spheres.size() == 1);
    CHECK(material_of(s, *spheres[0]).type == BsdfType::Dielectric);
    CHECK(material_of(s, *spheres[0]).int_ior == doctest::Approx(1.5).epsilon(0.05));
    for (const auto& m : s.meshes)
        if (m.kind != ShapeKind::Sphere) CHECK(material_of(s, m).type == BsdfType::Diffuse);
    CHECK(s.emitters.size() == 1);
}

TEST_CASE("scenes: snooker has six balls of the docs/descriptor.md §7 materials") {
    Scene s = load_scene(scene_path("snooker"));
    auto balls = meshes_of_kind(s, ShapeKind::Sphere);
    REQUIRE(balls.size() == 6);
    std::multiset<BsdfType> types;
    int polished = 0;
    for (const Mesh* b : balls) {
        const Material& m = material_of(s, *b);
        types.insert(m.type);
        if (m.type == BsdfType::RoughConductor && m.alpha_u > 0.015f && m.alpha_u < 0.05f) polished++;
    }
    CHECK(types.count(BsdfType::RoughPlastic) == 1);    // matte plastic
    CHECK(types.count(BsdfType::RoughConductor) == 3);  // gold, silver, copper
    CHECK(polished == 3);                               // roughness ~0.03
    CHECK(types.count(BsdfType::Conductor) == 1);       // chrome
    CHECK(types.count(BsdfType::Dielectric) == 1);      // glass
}

namespace {

// The tabletop families (docs/descriptor.md §7): delta-S = smooth conductor
// or dielectric, glossy = rough conductor or dielectric. Both family rules
// (by BSDF type, by BSDF flags) agree on these; plastics would not.
bool tabletop_delta(BsdfType t) { return t == BsdfType::Conductor || t == BsdfType::Dielectric; }
bool tabletop_glossy(BsdfType t) { return t == BsdfType::RoughConductor || t == BsdfType::RoughDielectric; }

bool same_material(const Material& a, const Material& b) {
    return a.type == b.type && a.twosided == b.twosided && a.reflectance.value == b.reflectance.value &&
           a.reflectance.texture == b.reflectance.texture && a.specular_reflectance == b.specular_reflectance &&
           a.specular_transmittance == b.specular_transmittance && a.eta == b.eta && a.k == b.k &&
           a.int_ior == b.int_ior && a.ext_ior == b.ext_ior && a.alpha_u == b.alpha_u && a.alpha_v == b.alpha_v &&
           a.distribution == b.distribution;
}

// Plan view (x, y): twice the signed area of triangle uvw (> 0: counter-clockwise).
float orient(glm::vec2 u, glm::vec2 v, glm::vec2 w) { return (v.x - u.x) * (w.y - u.y) - (v.y - u.y) * (w.x - u.x); }

// Plan view: does point p lie strictly inside triangle abc?
bool inside_triangle(glm::vec2 p, glm::vec2 a, glm::vec2 b, glm::vec2 c) {
    float d1 = orient(a, b, p), d2 = orient(b, c, p), d3 = orient(c, a, p);
    return (d1 > 0 && d2 > 0 && d3 > 0) || (d1 < 0 && d2 < 0 && d3 < 0);
}

// Plan view: do segments ab and cd cross at an interior point?
bool segments_cross(glm::vec2 a, glm::vec2 b, glm::vec2 c, glm::vec2 d) {
    return orient(a, b, c) * orient(a, b, d) < 0 && orient(c, d, a) * orient(c, d, b) < 0;
}

// Plan view: the convex hulls of two point sets intersect (so no vertical
// plane separates them) -- a point of one inside a triangle of the other, or
// an edge of one crossing an edge of the other.
bool hulls_overlap(const std::vector<glm::vec2>& p, const std::vector<glm::vec2>& q) {
    for (int pass = 0; pass < 2; ++pass) {
        const auto& a = pass ? q : p;
        const auto& b = pass ? p : q;
        for (size_t i = 0; i < b.size(); ++i)
            for (size_t j = i + 1; j < b.size(); ++j)
                for (size_t k = j + 1; k < b.size(); ++k)
                    for (const auto& x : a)
                        if (inside_triangle(x, b[i], b[j], b[k])) return true;
    }
    for (size_t i = 0; i < p.size(); ++i)
        for (size_t j = i + 1; j < p.size(); ++j)
            for (size_t k = 0; k < q.size(); ++k)
                for (size_t l = k + 1; l < q.size(); ++l)
                    if (segments_cross(p[i], p[j], q[k], q[l])) return true;
    return false;
}

}  // namespace

TEST_CASE("scenes: tabletop_separated is tabletop_mixed plus one opaque partition") {
    Scene mixed = load_scene(scene_path("tabletop_mixed"));
    Scene sep = load_scene(scene_path("tabletop_separated"));
    REQUIRE(sep.meshes.size() == mixed.meshes.size() + 1);
    // Every mesh of the mixed scene is in the separated one, unchanged, with
    // the same material and emitter.
    for (const auto& m : mixed.meshes) {
        CAPTURE(m.name);
        auto it = std::find_if(sep.meshes.begin(), sep.meshes.end(), [&](const Mesh& o) { return o.name == m.name; });
        REQUIRE(it != sep.meshes.end());
        CHECK(it->positions == m.positions);
        CHECK(it->indices == m.indices);
        CHECK(it->center == m.center);
        CHECK(it->radius == m.radius);
        CHECK(same_material(material_of(sep, *it), material_of(mixed, m)));
        CHECK((it->emitter >= 0) == (m.emitter >= 0));
        if (m.emitter >= 0 && it->emitter >= 0)
            CHECK(sep.emitters.at(it->emitter).radiance == mixed.emitters.at(m.emitter).radiance);
    }
    // Same camera, lights and integrator.
    CHECK(sep.camera.to_world == mixed.camera.to_world);
    CHECK(sep.camera.fov_deg == mixed.camera.fov_deg);
    CHECK(sep.emitters.size() == mixed.emitters.size());
    CHECK(sep.integrator.max_depth == mixed.integrator.max_depth);
    CHECK(sep.integrator.rr_depth == mixed.integrator.rr_depth);
    // The extra mesh is the partition: opaque (diffuse), not an emitter.
    int extra = 0;
    for (const auto& m : sep.meshes) {
        bool in_mixed =
            std::any_of(mixed.meshes.begin(), mixed.meshes.end(), [&](const Mesh& o) { return o.name == m.name; });
        if (in_mixed) continue;
        ++extra;
        CHECK(m.name == "partition");
        CHECK(material_of(sep, m).type == BsdfType::Diffuse);
        CHECK(m.emitter < 0);
    }
    CHECK(extra == 1);
}

TEST_CASE("scenes: tabletop_mixed interleaves the delta-S and glossy balls") {
    Scene s = load_scene(scene_path("tabletop_mixed"));
    std::vector<glm::vec2> delta, glossy;
    for (const auto& m : s.meshes) {
        BsdfType t = material_of(s, m).type;
        // Unambiguous families: no plastic, whose family depends on the rule.
        CHECK(t != BsdfType::Plastic);
        CHECK(t != BsdfType::RoughPlastic);
        if (!tabletop_delta(t) && !tabletop_glossy(t)) continue;
        CAPTURE(m.name);
        REQUIRE(m.kind == ShapeKind::Sphere);
        CHECK(m.center.z == doctest::Approx(m.radius));  // resting on the table
        (tabletop_delta(t) ? delta : glossy).push_back({m.center.x, m.center.y});
    }
    CHECK(delta.size() == 3);
    CHECK(glossy.size() == 3);
    // Not two groups on two sides: no vertical plane separates the families.
    CHECK(hulls_overlap(delta, glossy));
    // (The check can fail: two groups on two sides of x = 0, as the old design had.)
    CHECK_FALSE(
        hulls_overlap({{-0.2f, 0.0f}, {-0.3f, -0.25f}, {-0.1f, 0.3f}}, {{0.2f, 0.1f}, {0.35f, -0.2f}, {0.1f, -0.3f}}));
    CHECK(hulls_overlap({{-0.3f, 0.0f}, {0.04f, -0.35f}, {0.04f, 0.35f}}, {{-0.04f, 0.0f}}));
    // Each ball has a ball of the other family within 0.06 m (surface to
    // surface): close proximity.
    auto balls = meshes_of_kind(s, ShapeKind::Sphere);
    for (const Mesh* a : balls) {
        CAPTURE(a->name);
        bool da = tabletop_delta(material_of(s, *a).type);
        double nearest = 1e9;
        for (const Mesh* b : balls)
            if (tabletop_delta(material_of(s, *b).type) != da)
                nearest = std::min(nearest, double(glm::length(a->center - b->center) - a->radius - b->radius));
        CHECK(nearest > 0.0);
        CHECK(nearest <= 0.06);
    }
}

TEST_CASE("scenes: ring_caustic has two polished metal rings (open cylinders) and a small light") {
    Scene s = load_scene(scene_path("ring_caustic"));
    auto rings = meshes_of_kind(s, ShapeKind::Cylinder);
    REQUIRE(rings.size() == 2);
    for (const Mesh* r : rings) CHECK(material_of(s, *r).type == BsdfType::Conductor);
    REQUIRE(s.emitters.size() == 1);
    double light_area = mesh_area(s.meshes.at(s.emitters[0].mesh));
    double ring_area = mesh_area(*rings[0]);
    CHECK(light_area < 0.05 * ring_area);  // small and bright
}

TEST_CASE("scenes: kitchen_counter spans the docs/descriptor.md §7 materials with two lights") {
    Scene s = load_scene(scene_path("kitchen_counter"));
    CHECK(s.emitters.size() == 2);
    CHECK(s.meshes.size() >= 15);
    CHECK(has_type(s, BsdfType::Diffuse));
    CHECK(has_type(s, BsdfType::RoughPlastic));
    CHECK(has_type(s, BsdfType::Dielectric));       // smooth glass
    CHECK(has_type(s, BsdfType::RoughDielectric));  // frosted tumbler
    std::set<float> conductor_alphas;
    for (const auto& m : s.materials)
        if (m.type == BsdfType::RoughConductor) conductor_alphas.insert(m.alpha_u);
    CHECK(conductor_alphas.size() >= 3);  // brushed and polished at several roughnesses
}

TEST_CASE("scenes: the roughness sweep sets the sphere's alpha from -D alpha") {
    for (float alpha : {0.01f, 0.02f, 0.03f, 0.042f, 0.06f, 0.10f, 0.18f, 0.30f}) {
        CAPTURE(alpha);
        LoadOptions o;
        o.params["alpha"] = std::to_string(alpha);
        Scene s = load_scene(scene_path("sweep_roughness"), o);
        auto spheres = meshes_of_kind(s, ShapeKind::Sphere);
        REQUIRE(spheres.size() == 1);
        const Material& m = material_of(s, *spheres[0]);
        CHECK(m.type == BsdfType::RoughConductor);
        CHECK(m.alpha_u == doctest::Approx(alpha));
        CHECK(m.alpha_v == doctest::Approx(alpha));  // isotropic
    }
}

TEST_CASE("scenes: the light-count sweep keeps the emitted power constant for 1..16 lights") {
    LoadOptions o;
    o.params["lights"] = "1";
    double p1 = emitted_power(load_scene(scene_path("sweep_lights"), o));
    CHECK(p1 > 0.0);
    for (int n = 1; n <= 16; ++n) {
        CAPTURE(n);
        o.params["lights"] = std::to_string(n);
        Scene s = load_scene(scene_path("sweep_lights"), o);
        CHECK(s.emitters.size() == static_cast<size_t>(n));
        CHECK(emitted_power(s) == doctest::Approx(p1).epsilon(1e-3));
        auto spheres = meshes_of_kind(s, ShapeKind::Sphere);
        REQUIRE(spheres.size() == 1);
        CHECK(material_of(s, *spheres[0]).alpha_u == doctest::Approx(0.03f));
    }
}
