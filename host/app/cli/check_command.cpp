// `vkmech check --scene FILE`.
#include "cli/commands.hpp"

#include "render/features.hpp"
#include "render/gpu_scene.hpp"
#include "scene/environment.hpp"
#include "scene/scene.hpp"

#include <cstdio>
#include <map>
#include <string>
#include <utility>

namespace vkmech {

namespace {

// docs/descriptor.md §2's lobe classes a material can sample (Scene::lobe_flags, the
// renderer's table; a blend's are its components'): D diffuse, G glossy, S delta.
std::string lobe_classes(const Scene& scene, int index) {
    uint32_t f = scene.lobe_flags(index);
    std::string s;
    for (auto [bit, name] :
         {std::pair{gpu::LOBE_BIT_D, "D"}, std::pair{gpu::LOBE_BIT_G, "G"}, std::pair{gpu::LOBE_BIT_S, "S"}})
        if (f & bit) s += s.empty() ? name : std::string("+") + name;
    return s.empty() ? "?" : s;
}

}  // namespace

// `vkmech check --scene FILE`: loads without rendering and says what the
// renderer will see, so a user can trust (or fix) a third-party scene.
int cmd_check(const CommonOptions& o) {
    Scene scene = load_for_cli(o, /*report=*/false);
    SceneArrays arrays = flatten_scene(scene);
    Features f = Features::from_scene(scene, Estimator::Mis);
    std::printf("scene: %s\n", resolve_scene_path(o.scene).c_str());
    size_t tris = scene.triangle_count();
    std::map<std::string, int> kinds;
    for (const auto& m : scene.meshes) kinds[to_string(m.kind)]++;
    std::printf("shapes: %zu (", scene.meshes.size());
    bool first = true;
    for (const auto& [k, n] : kinds) std::printf("%s%d %s", first ? "" : ", ", n, k.c_str()), first = false;
    std::printf("), %zu triangles\n", tris);
    if (!scene.instances.empty())
        std::printf("instancing: %zu shape groups, %zu instances; %zu triangles stored, %zu seen\n",
                    scene.groups.size(), scene.instances.size(), tris, scene.instanced_triangle_count());
    std::printf("bounds: (%g, %g, %g) .. (%g, %g, %g)\n", arrays.bbox_lo.x, arrays.bbox_lo.y, arrays.bbox_lo.z,
                arrays.bbox_hi.x, arrays.bbox_hi.y, arrays.bbox_hi.z);
    std::printf("materials: %zu\n", scene.materials.size());
    for (size_t i = 0; i < scene.materials.size(); ++i) {
        const Material& m = scene.materials[i];
        int users = 0;
        for (const auto& mesh : scene.meshes) users += mesh.material == static_cast<int>(i);
        std::string tex;
        m.for_each_named_texture([&](const char* slot, int t) {
            if (t >= 0) tex += std::string(" ") + slot + "=" + scene.textures[t].path;
        });
        int in_blends = 0;
        for (const Material& b : scene.materials)
            in_blends += b.type == BsdfType::Blend &&
                         (b.blend_first == static_cast<int>(i)) + (b.blend_second == static_cast<int>(i)) > 0;
        std::string blend =
            in_blends == 0 ? "" : ", in " + std::to_string(in_blends) + " blend" + (in_blends == 1 ? "" : "s");
        if (m.type == BsdfType::Blend) {
            const std::string& first = scene.materials.at(static_cast<size_t>(m.blend_first)).id;
            const std::string& second = scene.materials.at(static_cast<size_t>(m.blend_second)).id;
            char w[32];
            std::snprintf(w, sizeof w, "%g", m.blend_weight);
            blend += ", " + first + " or " + second + " (weight " +
                     (m.blend_weight_texture >= 0 ? std::string("textured") : std::string(w)) + ")";
        }
        std::printf("  %-24s %-16s lobes %-5s %d shape%s%s%s%s\n", m.id.c_str(), to_string(m.type),
                    lobe_classes(scene, static_cast<int>(i)).c_str(), users, users == 1 ? "" : "s",
                    m.twosided ? ", twosided" : "", blend.c_str(), tex.c_str());
    }
    // Normal maps and the frame they are read in (glTF TANGENT, else the uv derivatives).
    size_t mapped = 0, file_frame = 0, no_uv = 0;
    for (const auto& mesh : scene.meshes) {
        if (mesh.material < 0 || scene.materials[static_cast<size_t>(mesh.material)].normal_texture < 0) continue;
        ++mapped;
        file_frame += scene.uses_tangents(mesh);
        no_uv += !scene.uses_tangents(mesh) && mesh.uvs.empty();
    }
    if (mapped > 0) {
        std::string without;
        if (no_uv > 0) {
            without = ", ";
            without += std::to_string(no_uv);
            without += " without uvs";
        }
        std::printf(
            "normal maps: %zu shape%s; tangents from the file's TANGENT on %zu, from the uv derivatives on "
            "%zu%s\n",
            mapped, mapped == 1 ? "" : "s", file_frame, mapped - file_frame - no_uv, without.c_str());
    }
    std::printf("emitters: %zu\n", scene.emitters.size());
    for (const auto& e : scene.emitters) {
        const auto& ge = arrays.emitters[&e - scene.emitters.data()];
        std::printf("  %-24s radiance (%g, %g, %g), area %g\n", scene.meshes[e.mesh].name.c_str(), e.radiance.x,
                    e.radiance.y, e.radiance.z, ge.radiance.w);
    }
    std::printf("lights at infinity: %s\n",
                scene.environment.kind == EnvironmentKind::None && scene.directional_lights.empty() ? "none" : "");
    if (scene.environment.kind != EnvironmentKind::None)
        std::printf("  environment: %s\n", describe(scene.environment).c_str());
    for (const auto& l : scene.directional_lights)
        std::printf("  directional: along (%g, %g, %g), irradiance (%g, %g, %g)\n", l.direction.x, l.direction.y,
                    l.direction.z, l.irradiance.x, l.irradiance.y, l.irradiance.z);
    if (scene.emitters.empty() && !arrays.has_infinite_lights())
        std::printf("  (no light at all: the image will be black)\n");
    const Camera& c = scene.camera;
    glm::vec3 pos(c.to_world[3]), fwd(c.to_world[2]);
    std::printf("camera: %s, %d x %d, fov %g deg (%s), at (%g, %g, %g) looking along (%g, %g, %g)%s\n",
                c.type == CameraType::ThinLens       ? "thinlens"
                : c.type == CameraType::Orthographic ? "orthographic"
                                                     : "perspective",
                c.width, c.height, c.type == CameraType::Orthographic ? 0.0f : c.fov_deg, c.fov_axis.c_str(), pos.x,
                pos.y, pos.z, fwd.x, fwd.y, fwd.z,
                c.type == CameraType::ThinLens ? (", aperture " + std::to_string(c.aperture_radius)).c_str() : "");
    std::printf("integrator: max_depth %d, rr_depth %d\n", scene.integrator.max_depth, scene.integrator.rr_depth);
    std::printf("features: %s\n", f.describe().c_str());
    std::printf("substitutions: %zu\n", scene.substitutions.size());
    for (const auto& s : scene.substitutions) std::printf("  %s\n", s.c_str());
    std::printf("warnings: %zu\n", scene.warnings.size());
    for (const auto& w : scene.warnings) std::printf("  %s\n", w.c_str());
    return 0;
}

// `vkmech check`.
void register_check(CLI::App& app, CliCommands& commands) {
    auto o = std::make_shared<CommonOptions>();
    auto* check = app.add_subcommand(
        "check",
        "Load a scene without rendering: shapes, materials and their lobes, emitters, camera, the features the "
        "renderer specializes on, and every warning and substitution");
    add_common_options(check, *o);

    commands.push_back({check, [o](const std::vector<std::string>&) { return cmd_check(*o); }});
}

}  // namespace vkmech
