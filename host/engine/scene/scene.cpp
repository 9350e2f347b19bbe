#include "scene/scene.hpp"

#include "scene/environment.hpp"
#include "scene/mesh_ops.hpp"
#include "scene/text_parse.hpp"
#include "scene/triangle_budget.hpp"

#include "lobes.glsl"

#include <cmath>
#include <filesystem>
#include <limits>
#include <new>
#include <stdexcept>

namespace vkmech {

const char* to_string(BsdfType t) {
#define VKM_X(code, NAME, Name, name, features, lobes, flags) \
    if (t == BsdfType::Name) return #name;
    VKM_MATERIALS(VKM_X)
#undef VKM_X
    return "unknown";
}

std::string bsdf_plugin_names() {
    std::string names;
#define VKM_X(code, NAME, Name, name, features, lobes, flags) names += std::string(names.empty() ? "" : ", ") + #name;
    VKM_MATERIALS(VKM_X)
#undef VKM_X
    return names;
}

std::optional<BsdfType> bsdf_type_of(const std::string& plugin) {
#define VKM_X(code, NAME, Name, name, features, lobes, flags) \
    if (plugin == #name) return BsdfType::Name;
    VKM_MATERIALS(VKM_X)
#undef VKM_X
    return std::nullopt;
}

const char* to_string(ShapeKind k) {
    switch (k) {
        case ShapeKind::Mesh:
            return "mesh";
        case ShapeKind::Rectangle:
            return "rectangle";
        case ShapeKind::Cube:
            return "cube";
        case ShapeKind::Sphere:
            return "sphere";
        case ShapeKind::Disk:
            return "disk";
        case ShapeKind::Cylinder:
            return "cylinder";
    }
    return "unknown";
}

// docs/descriptor.md §2: one table for host and device (shaders/lobes.glsl).
uint32_t Material::lobe_flags() const {
    return shader::material_lobe_flags(static_cast<uint32_t>(type), metallic, spec_trans);
}

// Smooth conductor, dielectric and thindielectric: S (delta) and nothing else.
bool Material::is_delta_only() const { return lobe_flags() == gpu::LOBE_BIT_S; }

// The NEE end-vertex lobe is D iff the BSDF advertises a diffuse component.
// Principled has one while (1 - metallic)(1 - spec_trans) > 0, as Mitsuba's
// flags say; a textured base colour does not change that.
bool Material::has_diffuse() const { return (lobe_flags() & gpu::LOBE_BIT_D) != 0u; }

uint32_t Scene::lobe_flags(int index) const {
    const Material& m = materials.at(static_cast<size_t>(index));
    if (m.type != BsdfType::Blend) return m.lobe_flags();
    return lobe_flags(m.blend_first) | lobe_flags(m.blend_second);  // components come first: no cycle
}

size_t Scene::triangle_count() const {
    size_t n = 0;
    for (const auto& m : meshes) n += m.indices.size();
    return n;
}

size_t Scene::instanced_triangle_count() const {
    std::vector<size_t> per_group(groups.size(), 0);
    size_t n = 0;
    for (const auto& m : meshes) {
        if (m.group < 0)
            n += m.indices.size();
        else
            per_group.at(static_cast<size_t>(m.group)) += m.indices.size();
    }
    for (const auto& i : instances) n += per_group.at(static_cast<size_t>(i.group));
    return n;
}

void Scene::check() const {
    const int n_groups = static_cast<int>(groups.size());
    for (const auto& m : meshes) {
        check_mesh(m, source);
        if (m.material >= static_cast<int>(materials.size()) || m.emitter >= static_cast<int>(emitters.size()))
            throw SceneError(source, 0, "mesh '" + m.name + "' names a material or emitter that does not exist");
        if (m.group >= n_groups)
            throw SceneError(source, 0, "mesh '" + m.name + "' names a shape group that does not exist");
        if (m.group >= 0 && m.emitter >= 0)
            throw SceneError(source, 0,
                             "mesh '" + m.name + "' of shape group '" + groups[m.group].name +
                                 "' is an emitter; a shape group holds no emitters");
    }
    std::vector<bool> instanced(groups.size(), false);
    for (const auto& i : instances)
        if (i.group >= 0 && i.group < n_groups) instanced[static_cast<size_t>(i.group)] = true;
    for (const auto& m : meshes)
        if (m.group >= 0 && !instanced[static_cast<size_t>(m.group)])
            throw SceneError(
                source, 0,
                "shape group '" + groups[m.group].name + "' is never instanced (its meshes would not be seen)");
    for (const auto& i : instances) {
        if (i.group < 0 || i.group >= n_groups)
            throw SceneError(source, 0, "instance '" + i.name + "' names a shape group that does not exist");
        const float det = glm::determinant(glm::mat3(i.to_world));
        if (!(std::abs(det) > 0.0f) || !std::isfinite(det))
            throw SceneError(source, 0, "instance '" + i.name + "': the to_world transform is singular");
    }
}

void transform_box(const glm::mat4& m, glm::vec3& lo, glm::vec3& hi) {
    glm::vec3 l(std::numeric_limits<float>::max()), h(-std::numeric_limits<float>::max());
    for (int c = 0; c < 8; ++c) {
        const glm::vec3 corner((c & 1) ? hi.x : lo.x, (c & 2) ? hi.y : lo.y, (c & 4) ? hi.z : lo.z);
        const glm::vec3 p = glm::vec3(m * glm::vec4(corner, 1.0f));
        l = glm::min(l, p);
        h = glm::max(h, p);
    }
    lo = l;
    hi = h;
}

bool Scene::group_bounds(int g, glm::vec3& lo, glm::vec3& hi) const {
    glm::vec3 l(std::numeric_limits<float>::max()), h(-std::numeric_limits<float>::max());
    for (const auto& m : meshes)
        if (m.group == g)
            for (const auto& p : m.positions) {
                l = glm::min(l, p);
                h = glm::max(h, p);
            }
    if (l.x > h.x) return false;
    lo = l;
    hi = h;
    return true;
}

bool Scene::bounds(glm::vec3& lo, glm::vec3& hi) const {
    bool any = group_bounds(-1, lo, hi);
    for (const auto& i : instances) {
        glm::vec3 gl, gh;
        if (!group_bounds(i.group, gl, gh)) continue;
        transform_box(i.to_world, gl, gh);
        lo = any ? glm::min(lo, gl) : gl;
        hi = any ? glm::max(hi, gh) : gh;
        any = true;
    }
    return any;
}

namespace {

Scene load_by_extension(const std::string& path, const LoadOptions& options) {
    std::string ext = text::lower(std::filesystem::path(path).extension().string());
    if (ext == ".xml") return load_mitsuba_xml(path, options);
    if (ext == ".gltf" || ext == ".glb") return load_gltf(path, options);
    throw SceneError(path, 0,
                     "unsupported scene format '" + ext + "' (expected .xml (Mitsuba), .gltf or .glb (glTF 2.0))");
}

}  // namespace

Scene load_scene(const std::string& path, const LoadOptions& options) {
    Scene scene;
    try {
        scene = load_by_extension(path, options);
    } catch (const std::bad_alloc&) {
        throw SceneError(path, 0,
                         "out of memory while loading the scene (lower --max-triangles, now " +
                             std::to_string(max_triangles(options, path)) +
                             " triangles, or free memory; a corrupt count in a mesh or image?)");
    } catch (const std::length_error&) {
        throw SceneError(path, 0, "a size in the scene is too large to hold in memory (a corrupt count?)");
    }
    scene.check();
    if (!options.environment_file.empty()) {
        // --environment: the map replaces whatever environment the scene has.
        Environment env;
        try {
            env = load_environment_map(options.environment_file, options.environment_scale, glm::mat3(1.0f));
        } catch (const std::exception& e) {
            throw SceneError(options.environment_file, 0, e.what());
        }
        env.what = "--environment " + options.environment_file;
        if (scene.environment.kind != EnvironmentKind::None)
            scene.warnings.push_back(env.what + " replaces the scene's environment (" + scene.environment.what + ")");
        scene.environment = std::move(env);
        scene.files.push_back(options.environment_file);
    }
    // Loads, but would render black: say so (glTF assets often carry no light).
    for (const auto& e : scene.emitters) {
        const Mesh& m = scene.meshes.at(static_cast<size_t>(e.mesh));
        if (!(e.radiance.x > 0.0f || e.radiance.y > 0.0f || e.radiance.z > 0.0f))
            scene.warnings.push_back(path + ": the emitter on shape '" + m.name +
                                     "' has zero radiance: it emits nothing");
        else if (!(surface_area(m) > 0.0))
            scene.warnings.push_back(path + ": the emitter on shape '" + m.name +
                                     "' has zero area (degenerate triangles): it emits nothing");
    }
    if (scene.emitters.empty() && scene.environment.kind == EnvironmentKind::None && scene.directional_lights.empty())
        scene.warnings.push_back(path + ": the scene has no emitter vkmech renders, so the image will be black" +
                                 (options.substitute_unsupported
                                      ? std::string(" (--environment FILE lights it with an environment map)")
                                      : " (--environment FILE lights it with an environment map; --substitute "
                                        "turns point and spot lights into emitters)"));
    return scene;
}

}  // namespace vkmech
