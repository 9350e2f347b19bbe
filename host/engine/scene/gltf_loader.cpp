// glTF 2.0 scenes, docs/descriptor.md §8: the node hierarchy, meshes, the camera and
// KHR_lights_punctual. The file and accessors are in gltf_file.cpp,
// materials in gltf_materials.cpp.
#include "scene/gltf_loader.hpp"

#include "scene/mesh_ops.hpp"
#include "scene/primitives.hpp"

#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <sstream>

namespace vkmech {

namespace {

std::string fmt_vec(const glm::vec3& v) {
    std::ostringstream s;
    s << v.x << " " << v.y << " " << v.z;
    return s.str();
}

}  // namespace

GltfLoader::GltfLoader(const std::string& path, const LoadOptions& options)
    : path_(path), options_(options), budget_(max_triangles(options, path)) {}

void GltfLoader::warn_once(const std::string& key, const std::string& what) {
    if (warned_.insert(key).second) warn(what);
}

Scene GltfLoader::load() {
    scene_.source = path_;
    parse();
    check_extensions();
    walk_nodes();
    if (scene_.meshes.empty())
        fail(skipped_primitives_ > 0 ? "nothing to render: every primitive uses a mode other than TRIANGLES (" +
                                           std::to_string(skipped_primitives_) + " skipped)"
                                     : "nothing to render: the scene has no mesh");
    add_light_spheres();
    if (!have_camera_) framing_camera();
    return std::move(scene_);
}

// ---- the node hierarchy ----

std::vector<int> GltfLoader::scene_roots() const {
    if (!model_.scenes.empty()) {
        int s = model_.defaultScene;
        if (s < -1 || s >= static_cast<int>(model_.scenes.size()))
            fail("the default scene " + std::to_string(s) + " does not exist (the file has " +
                 std::to_string(model_.scenes.size()) + " scenes)");
        return model_.scenes[s < 0 ? 0 : s].nodes;
    }
    // No scenes: every node that is nobody's child is a root.
    std::vector<char> is_child(model_.nodes.size(), 0);
    for (const auto& n : model_.nodes)
        for (int c : n.children)
            if (c >= 0 && static_cast<size_t>(c) < is_child.size()) is_child[c] = 1;
    std::vector<int> roots;
    for (size_t i = 0; i < model_.nodes.size(); ++i)
        if (!is_child[i]) roots.push_back(static_cast<int>(i));
    return roots;
}

glm::dmat4 GltfLoader::local_transform(int index) const {
    const auto& n = model_.nodes[index];
    std::string label = labelled("node", index, n.name);
    glm::dmat4 m(1.0);
    if (!n.matrix.empty()) {
        if (n.matrix.size() != 16) fail(label + ": 'matrix' needs 16 numbers, got " + std::to_string(n.matrix.size()));
        for (int c = 0; c < 4; ++c)
            for (int r = 0; r < 4; ++r) m[c][r] = n.matrix[4 * c + r];  // column-major (glTF 2.0 §3.5.3)
    } else {
        auto check = [&](const std::vector<double>& v, size_t size, const char* what) {
            if (!v.empty() && v.size() != size)
                fail(label + ": '" + what + "' needs " + std::to_string(size) + " numbers, got " +
                     std::to_string(v.size()));
        };
        check(n.translation, 3, "translation");
        check(n.rotation, 4, "rotation");
        check(n.scale, 3, "scale");
        glm::dvec3 t(0.0), s(1.0);
        glm::dquat q(1.0, 0.0, 0.0, 0.0);
        if (!n.translation.empty()) t = {n.translation[0], n.translation[1], n.translation[2]};
        if (!n.scale.empty()) s = {n.scale[0], n.scale[1], n.scale[2]};
        if (!n.rotation.empty()) {
            q = glm::dquat(n.rotation[3], n.rotation[0], n.rotation[1], n.rotation[2]);  // glTF order: x, y, z, w
            double len = glm::length(q);
            if (!(len > 0.0) || !std::isfinite(len)) fail(label + ": the rotation quaternion is zero or not finite");
            q = q / len;
        }
        // T * R * S (glTF 2.0 §3.5.3).
        m = glm::translate(glm::dmat4(1.0), t) * glm::mat4_cast(q) * glm::scale(glm::dmat4(1.0), s);
    }
    for (int c = 0; c < 4; ++c)
        for (int r = 0; r < 4; ++r)
            if (!std::isfinite(m[c][r])) fail(label + ": the transform is not finite");
    return m;
}

void GltfLoader::walk_nodes() {
    struct Item {
        int node;
        glm::dmat4 parent;
    };
    std::vector<Item> stack;
    std::vector<int> roots = scene_roots();
    for (auto it = roots.rbegin(); it != roots.rend(); ++it) stack.push_back({*it, glm::dmat4(1.0)});
    std::vector<char> seen(model_.nodes.size(), 0);
    // Depth-first, children in order: "the first camera" is the first one
    // reached in this order.
    while (!stack.empty()) {
        Item item = stack.back();
        stack.pop_back();
        int n = item.node;
        if (n < 0 || static_cast<size_t>(n) >= model_.nodes.size())
            fail("the scene refers to node " + std::to_string(n) + ", which does not exist (the file has " +
                 std::to_string(model_.nodes.size()) + ")");
        const auto& node = model_.nodes[n];
        // glTF 2.0 §3.5.1: nodes form disjoint strict trees. A cycle or a
        // shared child would otherwise loop or instance twice.
        if (seen[n]) fail(labelled("node", n, node.name) + " is reached twice: the node hierarchy must be a tree");
        seen[n] = 1;
        glm::dmat4 world = item.parent * local_transform(n);
        if (node.camera >= 0) {
            if (!have_camera_)
                set_camera(n, world);
            else
                warn_once("cameras", "only the first camera in the node hierarchy is used");
        }
        if (node.mesh >= 0) add_mesh(n, world);
        if (node.skin >= 0 || !model_.skins.empty())
            warn_once("skins", "skins are ignored: skinned meshes are placed by their node transforms");
        if (node.extensions.count("KHR_lights_punctual")) note_light(n, world);
        for (auto it = node.children.rbegin(); it != node.children.rend(); ++it) stack.push_back({*it, world});
    }
}

// ---- meshes ----

void GltfLoader::add_mesh(int n, const glm::dmat4& world) {
    const auto& node = model_.nodes[n];
    if (static_cast<size_t>(node.mesh) >= model_.meshes.size())
        fail(labelled("node", n, node.name) + " refers to mesh " + std::to_string(node.mesh) +
             ", which does not exist (the file has " + std::to_string(model_.meshes.size()) + ")");
    double det = glm::determinant(glm::dmat3(world));
    if (!(std::abs(det) > 0.0))
        fail(labelled("node", n, node.name) + " places " + labelled("mesh", node.mesh, model_.meshes[node.mesh].name) +
             " with a singular transform");
    for (size_t p = 0; p < model_.meshes[node.mesh].primitives.size(); ++p)
        add_primitive(n, node.mesh, static_cast<int>(p), world);
}

void GltfLoader::add_primitive(int n, int mi, int pi, const glm::dmat4& world) {
    const auto& node = model_.nodes[n];
    const auto& gm = model_.meshes[mi];
    const auto& prim = gm.primitives[pi];
    std::string label = labelled("mesh", mi, gm.name) + " primitive " + std::to_string(pi) + " (on " +
                        labelled("node", n, node.name) + ")";
    if (prim.mode != TINYGLTF_MODE_TRIANGLES) {
        warn(label + " has mode " + std::to_string(prim.mode) +
             ", not TRIANGLES (4): skipped (docs/descriptor.md §8: triangles only)");
        ++skipped_primitives_;
        return;
    }
    auto attr = [&](const char* name) {
        auto it = prim.attributes.find(name);
        return it == prim.attributes.end() ? -1 : it->second;
    };
    int pos = attr("POSITION");
    if (pos < 0) fail(label + " has no POSITION attribute");

    Mesh m;
    m.positions = read_vec3(pos, label + " POSITION");
    for (size_t i = 0; i < m.positions.size(); ++i) {
        const glm::vec3& p = m.positions[i];
        if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
            fail(label + ": vertex " + std::to_string(i) + " has a non-finite position");
    }
    size_t nv = m.positions.size();
    if (int a = attr("NORMAL"); a >= 0) {
        m.normals = read_vec3(a, label + " NORMAL");
        if (m.normals.size() != nv)
            fail(label + ": NORMAL has " + std::to_string(m.normals.size()) + " elements, POSITION " +
                 std::to_string(nv));
    }
    if (int a = attr("TEXCOORD_0"); a >= 0) {
        // glTF's uv (0, 0) is the image's top-left corner, as in vkmech
        // (Mesh::uvs), so no flip.
        m.uvs = read_vec2(a, label + " TEXCOORD_0");
        if (m.uvs.size() != nv)
            fail(label + ": TEXCOORD_0 has " + std::to_string(m.uvs.size()) + " elements, POSITION " +
                 std::to_string(nv));
    }
    if (int a = attr("TANGENT"); a >= 0) {
        // glTF 2.0 §3.7.2.1: without normals, flat normals and the tangents ignored.
        if (m.normals.empty()) {
            warn(label + " has TANGENT but no NORMAL: its tangents are ignored (glTF 2.0 §3.7.2.1: flat normals)");
        } else {
            m.tangents = read_vec4(a, label + " TANGENT");
            if (m.tangents.size() != nv)
                fail(label + ": TANGENT has " + std::to_string(m.tangents.size()) + " elements, POSITION " +
                     std::to_string(nv));
            for (size_t i = 0; i < nv; ++i) {
                glm::vec4& t = m.tangents[i];
                if (!std::isfinite(t.x) || !std::isfinite(t.y) || !std::isfinite(t.z) || !std::isfinite(t.w))
                    fail(label + ": vertex " + std::to_string(i) + " has a non-finite TANGENT");
                t.w = t.w < 0.0f ? -1.0f : 1.0f;  // the handedness: a sign (exported as +-1)
            }
        }
    }
    if (attr("COLOR_0") >= 0) warn_once("color0", "vertex colours (COLOR_0) are ignored");
    if (attr("JOINTS_0") >= 0 || attr("WEIGHTS_0") >= 0)
        warn_once("skins", "skins are ignored: skinned meshes are placed by their node transforms");
    if (!prim.targets.empty()) warn_once("morph", "morph targets are ignored: meshes keep their base geometry");

    std::vector<uint32_t> idx;
    if (prim.indices >= 0) {
        idx = read_indices(prim.indices, label + " indices");
    } else {
        idx.resize(nv);
        for (size_t i = 0; i < nv; ++i) idx[i] = static_cast<uint32_t>(i);
    }
    if (idx.size() % 3 != 0)
        fail(label + ": " + std::to_string(idx.size()) + " indices is not a whole number of triangles");
    budget_.charge(idx.size() / 3, path_, 0, label);  // each instance of a mesh counts
    for (size_t i = 0; i < idx.size(); ++i)
        if (idx[i] >= nv)
            fail(label + ": index " + std::to_string(idx[i]) + " (at " + std::to_string(i) + ") is out of range (" +
                 std::to_string(nv) + " vertices)");
    m.indices.reserve(idx.size() / 3);
    for (size_t i = 0; i < idx.size(); i += 3) m.indices.emplace_back(idx[i], idx[i + 1], idx[i + 2]);
    if (m.indices.empty()) fail(label + " has no triangles");

    // World space (Mesh: positions are world-space). glTF 2.0 §3.7.4: a
    // transform with a negative determinant flips the winding, so front faces
    // stay front faces: keep_facing reverses the triangles with it.
    transform_mesh(m, glm::mat4(world), /*keep_facing=*/true);
    repair_normals(m);
    size_t dropped = remove_degenerate_triangles(m);
    if (m.indices.empty()) fail(label + ": every triangle is degenerate (zero area)");
    if (dropped > 0) warn(label + ": " + std::to_string(dropped) + " degenerate triangle(s) dropped");

    std::string mesh_name = gm.name.empty() ? "mesh#" + std::to_string(mi) : gm.name;
    if (gm.primitives.size() > 1) mesh_name += ".primitive" + std::to_string(pi);
    m.name = mesh_name + "@" + (node.name.empty() ? "node#" + std::to_string(n) : node.name);
    m.kind = ShapeKind::Mesh;
    m.center = glm::vec3(world[3]);
    if (prim.material >= static_cast<int>(model_.materials.size()))
        fail(label + " refers to material " + std::to_string(prim.material) + ", which does not exist (the file has " +
             std::to_string(model_.materials.size()) + ")");
    m.material = material(prim.material);
    glm::vec3 radiance = emission(prim.material);
    if (radiance.x > 0.0f || radiance.y > 0.0f || radiance.z > 0.0f) {
        // docs/descriptor.md §1: area emitters are one-sided along the geometric normal;
        // glTF emits from the front (counter-clockwise) face, which is the
        // same side after keep_facing above.
        m.emitter = static_cast<int>(scene_.emitters.size());
        scene_.emitters.push_back({radiance, static_cast<int>(scene_.meshes.size())});
    }
    scene_.meshes.push_back(std::move(m));
}

// ---- camera ----

void GltfLoader::set_camera(int n, const glm::dmat4& world) {
    const auto& node = model_.nodes[n];
    if (static_cast<size_t>(node.camera) >= model_.cameras.size())
        fail(labelled("node", n, node.name) + " refers to camera " + std::to_string(node.camera) +
             ", which does not exist (the file has " + std::to_string(model_.cameras.size()) + ")");
    const auto& c = model_.cameras[node.camera];
    std::string label = labelled("camera", node.camera, c.name);
    if (c.type == "orthographic")
        fail(label + " is orthographic; only perspective cameras are supported (docs/descriptor.md §8)");
    if (c.type != "perspective") fail(label + " has unknown type '" + c.type + "' (expected perspective)");
    const auto& p = c.perspective;
    if (!(p.yfov > 0.0 && p.yfov < std::numbers::pi)) fail(label + ": yfov must be in (0, pi) radians");
    if (!(p.znear > 0.0)) fail(label + ": znear must be positive");
    if (p.zfar != 0.0 && !(p.zfar > p.znear)) fail(label + ": zfar must be greater than znear");
    if (p.aspectRatio < 0.0 || !std::isfinite(p.aspectRatio)) fail(label + ": aspectRatio must be positive");

    Camera cam;
    cam.type = CameraType::Perspective;
    cam.fov_deg = static_cast<float>(glm::degrees(p.yfov));
    cam.fov_axis = "y";
    cam.near_clip = static_cast<float>(p.znear);
    // zfar absent: glTF's infinite projection; vkmech's default far plane.
    cam.far_clip = p.zfar > 0.0 ? static_cast<float>(p.zfar) : std::max(10000.0f, 2.0f * cam.near_clip);
    cam.height = 256;  // docs/descriptor.md §1's default film height
    cam.width = 256;
    if (p.aspectRatio > 0.0) {
        double w = std::round(256.0 * p.aspectRatio);
        if (!(w >= 1.0 && w <= 32768.0))
            fail(label + ": aspectRatio " + std::to_string(p.aspectRatio) + " is implausible");
        cam.width = static_cast<int>(w);
    }

    // glTF cameras look down -Z with +Y up and +X to the right; vkmech's
    // (Mitsuba's) look down +Z with +Y up and +X to the left. The same frame
    // turned half-way round Y: left = -x, up = y, forward = -z, which is a
    // rotation (no mirror). Orthonormalised: to_world carries no scale.
    glm::dvec3 x(world[0]), y(world[1]), z(world[2]);
    glm::dvec3 dir = -z;
    double dl = glm::length(dir);
    if (!(dl > 0.0)) fail(labelled("node", n, node.name) + ": the camera transform is singular");
    dir /= dl;
    glm::dvec3 up = y - glm::dot(y, dir) * dir;
    double ul = glm::length(up);
    if (!(ul > 1e-9 * glm::length(y))) fail(labelled("node", n, node.name) + ": the camera transform is singular");
    up /= ul;
    glm::dvec3 left = glm::cross(up, dir);
    glm::dmat3 lin(world);
    if (!(std::abs(glm::length(x) - 1.0) < 1e-3 && std::abs(glm::length(y) - 1.0) < 1e-3 &&
          std::abs(glm::length(z) - 1.0) < 1e-3 && std::abs(glm::determinant(lin) - 1.0) < 1e-3))
        warn(label +
             ": its node transform scales, shears or mirrors (glTF 2.0 §3.10.2 forbids it); the camera "
             "uses the orthonormalised frame");
    cam.to_world = glm::mat4(1.0f);
    cam.to_world[0] = glm::vec4(glm::vec3(left), 0.0f);
    cam.to_world[1] = glm::vec4(glm::vec3(up), 0.0f);
    cam.to_world[2] = glm::vec4(glm::vec3(dir), 0.0f);
    cam.to_world[3] = glm::vec4(glm::vec3(world[3]), 1.0f);
    scene_.camera = cam;
    have_camera_ = true;
}

void GltfLoader::scene_bounds(glm::vec3& lo, glm::vec3& hi) const {
    lo = glm::vec3(std::numeric_limits<float>::max());
    hi = glm::vec3(-std::numeric_limits<float>::max());
    scene_.bounds(lo, hi);  // unchanged (empty) when there is no geometry
}

// docs/descriptor.md §8: with no camera, one that frames the scene's bounds: from +Z
// (glTF's usual viewing direction), 45 degrees vertically, far enough that
// the bounding sphere fits the square film.
void GltfLoader::framing_camera() {
    glm::vec3 lo, hi;
    scene_bounds(lo, hi);
    glm::dvec3 c = 0.5 * (glm::dvec3(lo) + glm::dvec3(hi));
    double r = std::max(0.5 * glm::length(glm::dvec3(hi) - glm::dvec3(lo)), 1e-6);
    constexpr double kFovDeg = 45.0;
    double d = r / std::sin(glm::radians(0.5 * kFovDeg));
    Camera cam;
    cam.fov_deg = static_cast<float>(kFovDeg);
    cam.fov_axis = "y";
    cam.to_world = glm::mat4(1.0f);
    cam.to_world[0] = glm::vec4(-1.0f, 0.0f, 0.0f, 0.0f);  // left = -X: +X is to the right, as in glTF
    cam.to_world[1] = glm::vec4(0.0f, 1.0f, 0.0f, 0.0f);
    cam.to_world[2] = glm::vec4(0.0f, 0.0f, -1.0f, 0.0f);
    cam.to_world[3] = glm::vec4(glm::vec3(c + glm::dvec3(0.0, 0.0, d)), 1.0f);
    cam.near_clip = static_cast<float>(0.5 * (d - r));
    cam.far_clip = static_cast<float>(2.0 * (d + r));
    scene_.camera = cam;
    std::ostringstream s;
    s << "the scene has no camera: a perspective camera (45 degrees vertical field of view) at "
      << fmt_vec(glm::vec3(cam.to_world[3])) << " looks at the centre of the scene's bounds along -Z";
    warn(s.str());
}

// ---- KHR_lights_punctual ----

void GltfLoader::note_light(int n, const glm::dmat4& world) {
    const auto& node = model_.nodes[n];
    const tinygltf::Value& v = node.extensions.at("KHR_lights_punctual");
    std::string where = labelled("node", n, node.name);
    if (!v.IsObject() || !v.Has("light") || !v.Get("light").IsNumber())
        fail(where + ": malformed KHR_lights_punctual (expected {\"light\": index})");
    double li = v.Get("light").GetNumberAsDouble();
    if (!(li >= 0.0 && li < static_cast<double>(model_.lights.size())) || li != std::floor(li))
        fail(where + " refers to light " + std::to_string(li) + ", which does not exist (the file has " +
             std::to_string(model_.lights.size()) + ")");
    int index = static_cast<int>(li);
    const auto& light = model_.lights[index];
    std::string label =
        "KHR_lights_punctual " + labelled("light", index, light.name) + " (" + light.type + ", on " + where + ")";
    if (light.type != "point" && light.type != "spot" && light.type != "directional")
        fail(label + ": unknown light type (expected point, spot or directional)");
    // docs/descriptor.md §1: area emitters and emitters at infinity are in the model.
    if (light.type != "directional" && !options_.substitute_unsupported)
        fail(label +
             ": point and spot lights are outside vkmech's model (docs/descriptor.md §1: area emitters and lights at "
             "infinity); pass --substitute to replace them by small spherical emitters of the same power");
    if (!(light.intensity >= 0.0) || !std::isfinite(light.intensity))
        fail(label + ": the intensity must be a non-negative number");
    if (!light.color.empty()) {
        if (light.color.size() != 3) fail(label + ": 'color' needs 3 numbers");
        for (double c : light.color)
            if (!(c >= 0.0) || !std::isfinite(c)) fail(label + ": 'color' must be non-negative");
    }
    if (light.type == "directional") {
        // Along the node's -Z; its intensity (lux) is taken as the irradiance, colour times
        // intensity, as point lights take theirs as W/sr.
        glm::dvec3 dir = glm::dmat3(world) * glm::dvec3(0.0, 0.0, -1.0);
        if (!(glm::length(dir) > 0.0) || !std::isfinite(glm::length(dir)))
            fail(label + ": the node's transform has no direction (a zero or non-finite scale)");
        glm::vec3 color =
            light.color.empty() ? glm::vec3(1.0f) : glm::vec3(light.color[0], light.color[1], light.color[2]);
        scene_.directional_lights.push_back(
            {glm::vec3(glm::normalize(dir)), color * static_cast<float>(light.intensity)});
        return;
    }
    lights_.push_back({index, n, glm::vec3(world[3])});
}

void GltfLoader::add_light_spheres() {
    if (lights_.empty()) return;
    glm::vec3 lo, hi;
    scene_bounds(lo, hi);
    float diag = glm::length(hi - lo);
    float radius = 1e-2f * (diag > 0.0f ? diag : 1.0f);
    // A black diffuse: the sphere stands in for a light, which reflects nothing.
    Material black;
    black.id = "gltf-light-substitute";
    black.type = BsdfType::Diffuse;
    black.reflectance = Spectrum3{glm::vec3(0.0f), -1};
    int material = static_cast<int>(scene_.materials.size());
    scene_.materials.push_back(black);
    for (const auto& pl : lights_) {
        const auto& light = model_.lights[pl.light];
        glm::vec3 color =
            light.color.empty() ? glm::vec3(1.0f) : glm::vec3(light.color[0], light.color[1], light.color[2]);
        Mesh s = make_sphere(pl.position, radius, glm::mat4(1.0f), false, SphereTessellation{16, 32});
        budget_.charge(s.indices.size(), path_, 0, "the sphere standing in for light " + std::to_string(pl.light));
        // Equal power: a point light of intensity I (W/sr in vkmech's units)
        // emits 4 pi I; a sphere of area A with uniform one-sided radiance L
        // emits pi L A. So L = 4 I / A, which is I / (pi r^2) for an exact
        // sphere; the tessellated area is used so the power matches exactly.
        double area = surface_area(s);
        glm::vec3 radiance = color * static_cast<float>(4.0 * light.intensity / area);
        std::string name = labelled("light", pl.light, light.name);
        s.name = "gltf-light#" + std::to_string(pl.light) + (light.name.empty() ? "" : "-" + light.name);
        s.material = material;
        s.emitter = static_cast<int>(scene_.emitters.size());
        scene_.emitters.push_back({radiance, static_cast<int>(scene_.meshes.size())});
        scene_.meshes.push_back(std::move(s));
        if (light.type == "spot")
            warn("KHR_lights_punctual " + name +
                 ": a spot light becomes a sphere emitting in every direction "
                 "(its cone is ignored)");
        std::ostringstream sub;
        sub << path_ << ": KHR_lights_punctual " << name << " (" << light.type << ", intensity " << light.intensity
            << ") replaced by a sphere emitter of the same power (radius " << radius << ", centre "
            << fmt_vec(pl.position) << ", radiance " << fmt_vec(radiance) << ")";
        scene_.substitutions.push_back(sub.str());
    }
}

Scene load_gltf(const std::string& path, const LoadOptions& options) { return GltfLoader(path, options).load(); }

}  // namespace vkmech
