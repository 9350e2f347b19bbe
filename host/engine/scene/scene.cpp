#include "scene/scene.hpp"

#include "scene/environment.hpp"
#include "scene/mesh_ops.hpp"
#include "scene/text_parse.hpp"
#include "scene/triangle_budget.hpp"

#include "lobes.glsl"

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

size_t Scene::triangle_count() const {
    size_t n = 0;
    for (const auto& m : meshes) n += m.indices.size();
    return n;
}

void Scene::check() const {
    for (const auto& m : meshes) {
        check_mesh(m, source);
        if (m.material >= static_cast<int>(materials.size()) || m.emitter >= static_cast<int>(emitters.size()))
            throw SceneError(source, 0, "mesh '" + m.name + "' names a material or emitter that does not exist");
    }
}

bool Scene::bounds(glm::vec3& lo, glm::vec3& hi) const {
    glm::vec3 l(std::numeric_limits<float>::max()), h(-std::numeric_limits<float>::max());
    for (const auto& m : meshes)
        for (const auto& p : m.positions) {
            l = glm::min(l, p);
            h = glm::max(h, p);
        }
    if (l.x > h.x) return false;
    lo = l;
    hi = h;
    return true;
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
