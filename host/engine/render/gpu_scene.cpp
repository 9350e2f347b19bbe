#include "render/gpu_scene.hpp"
#include "io/invariant.hpp"

#include "bsdf.glsl"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <optional>
#include <stdexcept>

namespace vkmech {

const char* to_string(Traversal t) {
    switch (t) {
        case Traversal::Auto:
            return "auto";
        case Traversal::RayQuery:
            return "rayquery";
        case Traversal::Bvh:
            return "bvh";
    }
    return "?";
}

Traversal parse_traversal(const std::string& s) {
    if (s == "auto") return Traversal::Auto;
    if (s == "rayquery") return Traversal::RayQuery;
    if (s == "bvh") return Traversal::Bvh;
    throw std::invalid_argument("unknown traversal '" + s + "' (expected auto, rayquery or bvh)");
}

Traversal resolve_traversal(const vk::Context& ctx, Traversal requested) {
    if (requested == Traversal::RayQuery && !ctx.ray_query_enabled())
        throw vk::VulkanError("--traversal rayquery: device '" + ctx.info().name + "' has no VK_KHR_ray_query");
    if (requested == Traversal::Auto) {
        // Measured (`vkmech bench traversal`, README): on lavapipe the software
        // BVH traces 1.6-2.5x faster than lavapipe's own ray query, so CPU
        // devices get the BVH; GPUs get ray query where they have it.
        if (ctx.info().type == "cpu") return Traversal::Bvh;
        return ctx.ray_query_enabled() ? Traversal::RayQuery : Traversal::Bvh;
    }
    return requested;
}

namespace {

float luminance(const glm::vec3& c) {
    return static_cast<float>(gpu::LUM_R) * c.r + static_cast<float>(gpu::LUM_G) * c.g +
           static_cast<float>(gpu::LUM_B) * c.b;
}

glm::vec3 texture_mean(const Texture& t) {
    glm::dvec3 sum(0.0);
    for (size_t i = 0; i + 2 < t.rgb.size(); i += 3) sum += glm::dvec3(t.rgb[i], t.rgb[i + 1], t.rgb[i + 2]);
    return glm::vec3(sum / std::max<double>(1.0, static_cast<double>(t.rgb.size() / 3)));
}

uint32_t texture_slot(int texture) {
    if (texture < 0) return 0u;
    if (texture + 1 > static_cast<int>(gpu::MAT_TEX_MASK))
        throw SceneError("", 0, "more than " + std::to_string(gpu::MAT_TEX_MASK - 1) + " textures");
    return static_cast<uint32_t>(texture + 1);
}

gpu::GpuMaterial pack_material(const Material& m, const std::vector<Texture>& textures) {
    gpu::GpuMaterial g{};
    const uint32_t emission = texture_slot(m.emission_texture);
    if (emission > gpu::MAT_EMISSION_TEX_MASK)
        throw SceneError("", 0, "more than " + std::to_string(gpu::MAT_EMISSION_TEX_MASK - 1) + " textures");
    g.header = glm::uvec4(
        static_cast<uint32_t>(m.type),
        (m.twosided ? 1u : 0u) | emission << gpu::MAT_EMISSION_TEX_SHIFT |
            texture_slot(m.specular_transmittance_texture) << gpu::MAT_TEX_SHIFT,
        texture_slot(m.reflectance.texture) | texture_slot(m.specular_reflectance_texture) << gpu::MAT_TEX_SHIFT,
        static_cast<uint32_t>(m.distribution) | texture_slot(m.metallic_roughness_texture) << gpu::MAT_TEX_SHIFT);
    VKM_ASSERT(m.metallic_roughness_texture < 0 || m.type == BsdfType::Principled,
               "only principled reads a metallic-roughness texture (header.w is the others' distribution)");
    // A texture's mean stands in where a single value is needed (plastic
    // sampling weights, Fresnel tints), as Mitsuba takes the texture mean.
    glm::vec3 refl =
        m.reflectance.texture >= 0 ? texture_mean(textures.at(m.reflectance.texture)) : m.reflectance.value;
    glm::vec3 spec = m.specular_reflectance_texture >= 0 ? texture_mean(textures.at(m.specular_reflectance_texture))
                                                         : m.specular_reflectance;
    glm::vec3 trans = m.specular_transmittance_texture >= 0
                          ? texture_mean(textures.at(m.specular_transmittance_texture))
                          : m.specular_transmittance;
    g.reflectance = glm::vec4(refl, m.alpha_u);
    g.specular_reflectance = glm::vec4(spec, m.alpha_v);
    g.specular_transmittance = glm::vec4(trans, m.int_ior);
    g.eta = glm::vec4(m.eta, m.ext_ior);
    g.k = glm::vec4(m.k, m.nonlinear ? 1.0f : 0.0f);
    g.model0 = glm::vec4(m.metallic, m.roughness, m.specular, m.spec_tint);
    g.model1 = glm::vec4(m.anisotropic, m.sheen, m.sheen_tint, m.clearcoat);
    g.model2 = glm::vec4(m.clearcoat_gloss, m.spec_trans, m.eta_principled, 0.0f);
    VKM_ASSERT(m.normal_texture < 0 || m.bump_texture < 0, "material '" + m.id + "' has a normal and a bump map");
    g.frame_tex = glm::uvec4(texture_slot(m.normal_texture) | texture_slot(m.bump_texture) << gpu::MAT_TEX_SHIFT,
                             std::bit_cast<uint32_t>(m.bump_texture >= 0 ? m.bump_scale : m.normal_scale),
                             texture_slot(m.alpha_u_texture) | texture_slot(m.alpha_v_texture) << gpu::MAT_TEX_SHIFT,
                             m.normal_uv_handed ? 1u : 0u);
    // principled: its textured float parameters besides metallic and roughness (shared/types.h).
    const auto& pt = m.principled_param_textures;
    VKM_ASSERT(m.type == BsdfType::Principled || std::all_of(pt.begin(), pt.end(), [](int t) { return t < 0; }),
               "only principled reads parameter textures");
    g.param_tex = glm::uvec4(texture_slot(pt[0]) | texture_slot(pt[1]) << gpu::MAT_TEX_SHIFT,
                             texture_slot(pt[2]) | texture_slot(pt[3]) << gpu::MAT_TEX_SHIFT,
                             texture_slot(pt[4]) | texture_slot(pt[5]) << gpu::MAT_TEX_SHIFT, texture_slot(pt[6]));
    // roughplastic: precomputed coat transmittance table in the unused fields.
    if (m.type == BsdfType::RoughPlastic) g = shader::roughplastic_prepare(g);
    // blendbsdf: its components, its weight and the weight's texture (shared/types.h MAT_BLEND).
    if (m.type == BsdfType::Blend) {
        VKM_ASSERT(m.blend_first >= 0 && m.blend_second >= 0 && m.blend_first <= int(gpu::TRI_MATERIAL_MASK) &&
                       m.blend_second <= int(gpu::TRI_MATERIAL_MASK),
                   "blend '" + m.id + "' has no components, or ones past the material limit");
        g.header.z = texture_slot(m.blend_weight_texture);
        g.header.w = static_cast<uint32_t>(m.blend_first) | static_cast<uint32_t>(m.blend_second) << 16;
        g.reflectance = glm::vec4(m.blend_weight, 0.0f, 0.0f, 0.0f);
    }
    return g;
}

}  // namespace

const char* to_string(LightSelection s) { return s == LightSelection::Power ? "power" : "uniform"; }

LightSelection parse_light_selection(const std::string& s) {
    if (s == "uniform") return LightSelection::Uniform;
    if (s == "power") return LightSelection::Power;
    throw std::invalid_argument("unknown light selection '" + s + "' (expected uniform or power)");
}

namespace {

// The environment map's texels after the textures' (shared/types.h
// GpuEnvironment): rgb the radiance, w the cdf of the pixel's row; then one
// texel per row whose x is the marginal cdf. A pixel's sampling weight is the
// largest luminance of its 3 x 3 neighbourhood (wrapping in x, clamped in y),
// which bounds the bilinear radiance inside it (shaders/environment.glsl), times
// sin(theta) at its centre. The sums run in double.
void flatten_environment_map(const Environment& env, SceneArrays& a) {
    const Texture& t = env.map;
    const int w = t.width, h = t.height;
    auto lum = [&](int x, int y) {
        x = (x % w + w) % w;
        y = std::clamp(y, 0, h - 1);
        const float* c = &t.rgb[3 * (static_cast<size_t>(y) * w + x)];
        return static_cast<double>(luminance(glm::vec3(c[0], c[1], c[2])));
    };
    const uint32_t first = static_cast<uint32_t>(a.texels.size());
    std::vector<double> weight(static_cast<size_t>(w) * h), row_sum(h, 0.0);
    double total = 0.0, lum_sum = 0.0, sin_sum = 0.0;
    for (int y = 0; y < h; ++y) {
        const double sin_t = std::sin(3.14159265358979323846 * (y + 0.5) / h);
        for (int x = 0; x < w; ++x) {
            double m = 0.0;
            for (int dy = -1; dy <= 1; ++dy)
                for (int dx = -1; dx <= 1; ++dx) m = std::max(m, lum(x + dx, y + dy));
            weight[static_cast<size_t>(y) * w + x] = m * sin_t;
            row_sum[y] += m * sin_t;
            lum_sum += lum(x, y) * sin_t;
            sin_sum += sin_t;
        }
        total += row_sum[y];
    }
    for (int y = 0; y < h; ++y) {
        double acc = 0.0;
        for (int x = 0; x < w; ++x) {
            const size_t i = static_cast<size_t>(y) * w + x;
            acc += weight[i];
            // A row that cannot be chosen still gets an increasing cdf.
            float cdf = row_sum[y] > 0.0 ? static_cast<float>(acc / row_sum[y]) : static_cast<float>((x + 1.0) / w);
            if (x == w - 1) cdf = 1.0f;
            a.texels.push_back(glm::vec4(t.rgb[3 * i], t.rgb[3 * i + 1], t.rgb[3 * i + 2], cdf));
        }
    }
    double acc = 0.0;
    for (int y = 0; y < h; ++y) {
        acc += row_sum[y];
        float cdf = total > 0.0 ? static_cast<float>(acc / total) : static_cast<float>((y + 1.0) / h);
        a.texels.push_back(glm::vec4(y == h - 1 ? 1.0f : cdf, 0.0f, 0.0f, 0.0f));
    }
    a.environment.radiance = glm::vec4(glm::vec3(env.scale), 0.0f);
    a.environment.map = glm::uvec4(gpu::ENV_MAP, first, static_cast<uint32_t>(w), static_cast<uint32_t>(h));
    a.environment_luminance = total > 0.0 && sin_sum > 0.0 ? lum_sum / sin_sum * env.scale : 0.0;
}

void flatten_environment(const Scene& scene, SceneArrays& a) {
    const Environment& env = scene.environment;
    if (env.kind == EnvironmentKind::Constant) {
        a.environment.radiance = glm::vec4(env.radiance, 0.0f);
        a.environment.map = glm::uvec4(gpu::ENV_CONSTANT, 0u, 0u, 0u);
        a.environment_luminance = luminance(env.radiance);
    } else if (env.kind == EnvironmentKind::Map) {
        flatten_environment_map(env, a);
    }
    // Rows of the rotation (glm: to_world[column][row]).
    glm::vec4* rows[] = {&a.environment.to_world0, &a.environment.to_world1, &a.environment.to_world2};
    for (int r = 0; r < 3; ++r) *rows[r] = glm::vec4(env.to_world[0][r], env.to_world[1][r], env.to_world[2][r], 0.0f);
    for (const auto& l : scene.directional_lights)
        a.directional.push_back({glm::vec4(glm::normalize(l.direction), 0.0f), glm::vec4(l.irradiance, 0.0f)});
}

// Geometry, materials and textures in the scene's own triangle order (mesh by
// mesh), and the emitters' radiance and mesh; no light table yet.
SceneArrays flatten_unlit(const Scene& scene, LightSelection selection) {
    SceneArrays a;
    if (scene.triangle_count() == 0) throw SceneError(scene.source, 0, "the scene has no geometry to render");
    scene.check();  // the arrays below index normals, uvs and positions by the mesh's indices
    if (scene.materials.size() > gpu::TRI_MATERIAL_MASK) throw SceneError(scene.source, 0, "too many materials");
    if (scene.emitters.size() >= gpu::TRI_EMITTER_MASK) throw SceneError(scene.source, 0, "too many emitters");

    // The file's tangents are kept where a normal map reads them; those meshes' vertices go
    // after every other's (SceneArrays::tangents), each mesh's contiguous.
    auto keeps_tangents = [&](const Mesh& mesh) { return scene.uses_tangents(mesh); };
    size_t vertex_count = 0, plain_count = 0;
    for (const Mesh& mesh : scene.meshes) {
        vertex_count += mesh.positions.size();
        if (!keeps_tangents(mesh)) plain_count += mesh.positions.size();
    }
    if (vertex_count >= (size_t{1} << 30)) throw SceneError(scene.source, 0, "too many vertices");
    a.vertices.resize(vertex_count);
    a.tangents.resize(vertex_count - plain_count);
    a.tangent_vertex_base = static_cast<uint32_t>(plain_count);
    uint32_t next_plain = 0, next_tangent = a.tangent_vertex_base;
    // The ordinary meshes' triangles first, then each shape group's, a group's contiguous.
    auto add_mesh = [&](size_t mi) {
        const Mesh& mesh = scene.meshes[mi];
        const bool tangents = keeps_tangents(mesh);
        uint32_t& next = tangents ? next_tangent : next_plain;
        const uint32_t base = next;
        next += static_cast<uint32_t>(mesh.positions.size());
        bool flat = mesh.normals.empty();
        for (size_t v = 0; v < mesh.positions.size(); ++v) {
            glm::vec2 uv = mesh.uvs.empty() ? glm::vec2(0.0f) : mesh.uvs[v];
            glm::vec3 n = flat ? glm::vec3(0.0f) : mesh.normals[v];
            a.vertices[base + v] = gpu::GpuVertex{glm::vec4(mesh.positions[v], uv.x), glm::vec4(n, uv.y)};
            if (tangents) a.tangents[base - a.tangent_vertex_base + v] = mesh.tangents[v];
        }
        uint32_t material = mesh.material < 0 ? 0u : static_cast<uint32_t>(mesh.material);
        uint32_t w = material | (static_cast<uint32_t>(mesh.emitter + 1) << gpu::TRI_EMITTER_SHIFT) |
                     (flat ? gpu::TRI_FLAT_BIT : 0u) | (tangents ? gpu::TRI_TANGENT_BIT : 0u);
        for (const auto& t : mesh.indices) {
            a.triangles.push_back(glm::uvec4(base + t.x, base + t.y, base + t.z, w));
            a.triangle_mesh.push_back(static_cast<uint32_t>(mi));
            // w: the first vertex again, the software BVH's "no quad" (build_scene_bvh).
            const glm::vec3 first = mesh.positions[t[0]];
            for (int k = 0; k < 3; ++k) a.tri_positions.push_back(glm::vec4(mesh.positions[t[k]], first[k]));
        }
    };
    for (size_t mi = 0; mi < scene.meshes.size(); ++mi)
        if (scene.meshes[mi].group < 0) add_mesh(mi);
    for (size_t g = 0; g < scene.groups.size(); ++g) {
        const uint32_t first = static_cast<uint32_t>(a.triangles.size());
        for (size_t mi = 0; mi < scene.meshes.size(); ++mi)
            if (scene.meshes[mi].group == static_cast<int>(g)) add_mesh(mi);
        a.group_triangles.push_back(glm::uvec2(first, static_cast<uint32_t>(a.triangles.size()) - first));
    }
    VKM_ASSERT(next_plain == a.tangent_vertex_base && next_tangent == vertex_count,
               "flatten_unlit: every mesh's vertices are placed once");
    for (const auto& inst : scene.instances) {
        if (a.group_triangles[static_cast<size_t>(inst.group)].y == 0) continue;  // an empty group: nothing to trace
        const glm::mat4 to_local = glm::inverse(inst.to_world);
        gpu::GpuInstance g{};
        for (int r = 0; r < 3; ++r) {  // rows (glm: m[column][row])
            g.to_local[r] = glm::vec4(to_local[0][r], to_local[1][r], to_local[2][r], to_local[3][r]);
            g.to_world[r] =
                glm::vec4(inst.to_world[0][r], inst.to_world[1][r], inst.to_world[2][r], inst.to_world[3][r]);
        }
        g.info =
            glm::uvec4(0u, static_cast<uint32_t>(inst.group), a.group_triangles[static_cast<size_t>(inst.group)].x, 0u);
        a.instances.push_back(g);
    }
    if (a.instances.size() >= gpu::INSTANCE_ENTRY_BIT - 1u)
        throw SceneError(scene.source, 0, "too many instances (" + std::to_string(a.instances.size()) + ")");
    if (scene.materials.empty()) {
        Material m;
        a.materials.push_back(pack_material(m, scene.textures));
    }
    for (const auto& m : scene.materials) a.materials.push_back(pack_material(m, scene.textures));

    for (const auto& t : scene.textures) {
        uint32_t kind = (t.kind == TextureKind::Checkerboard ? gpu::TEX_CHECKERBOARD : gpu::TEX_BITMAP) |
                        (t.nearest ? gpu::TEX_NEAREST_BIT : 0u);
        a.textures.push_back(glm::uvec4(static_cast<uint32_t>(a.texels.size()), t.width, t.height, kind));
        for (int r = 0; r < 2; ++r)  // rows of the affine uv transform (glm: to_uv[column][row])
            a.textures.push_back(glm::uvec4(std::bit_cast<uint32_t>(t.to_uv[0][r]),
                                            std::bit_cast<uint32_t>(t.to_uv[1][r]),
                                            std::bit_cast<uint32_t>(t.to_uv[2][r]), 0u));
        for (size_t i = 0; i + 2 < t.rgb.size(); i += 3)
            a.texels.push_back(glm::vec4(t.rgb[i], t.rgb[i + 1], t.rgb[i + 2], 1.0f));
    }

    flatten_environment(scene, a);

    glm::vec3 lo(std::numeric_limits<float>::max()), hi(-std::numeric_limits<float>::max());
    if (a.instances.empty() && scene.groups.empty()) {
        for (const auto& p : a.tri_positions) {
            lo = glm::min(lo, glm::vec3(p));
            hi = glm::max(hi, glm::vec3(p));
        }
    } else {
        scene.bounds(lo, hi);
    }
    a.bbox_lo = lo;
    a.bbox_hi = hi;

    // The light table (build_light_table) reads each emitter's radiance and
    // mesh from here; it fills in the area, the range and the pdf.
    a.emitters.resize(scene.emitters.size());
    a.emitter_mean_radiance.resize(scene.emitters.size());
    a.light_selection = selection;
    for (size_t e = 0; e < scene.emitters.size(); ++e) {
        a.emitters[e].radiance = glm::vec4(scene.emitters[e].radiance, 0.0f);
        // An emission texture scales the radiance point by point: its mean weighs the emitter.
        const Mesh& mesh = scene.meshes.at(static_cast<size_t>(scene.emitters[e].mesh));
        const int tex =
            mesh.material >= 0 ? scene.materials.at(static_cast<size_t>(mesh.material)).emission_texture : -1;
        a.emitter_mean_radiance[e] =
            tex >= 0 ? scene.emitters[e].radiance * texture_mean(scene.textures.at(tex)) : scene.emitters[e].radiance;
        a.emitters[e].info = glm::uvec4(static_cast<uint32_t>(scene.emitters[e].mesh), 0u, 0u, 0u);
    }
    return a;
}

// Light table: every emissive triangle with its selection weight
// (docs/descriptor.md §1), in the arrays' triangle order. Uniform: 1 /
// (emitters x the emitter's area) per unit area; power: luminance(L) x area.
// Each emitter records its area pdf (info.w) for the MIS weight of
// BSDF-sampled hits. The sums run in triangle order, so the table (and the
// image) follows the order the arrays are in.
void build_light_table(SceneArrays& a) {
    const size_t n = a.triangles.size();
    const size_t emitter_count = a.emitters.size();
    const LightSelection selection = a.light_selection;
    a.light_triangles.clear();
    std::vector<std::vector<uint32_t>> per_emitter(emitter_count);
    for (uint32_t i = 0; i < n; ++i) {
        uint32_t e = (a.triangles[i].w >> gpu::TRI_EMITTER_SHIFT) & gpu::TRI_EMITTER_MASK;
        if (e > 0) per_emitter[e - 1].push_back(i);
    }
    auto tri_area = [&](uint32_t t) {
        glm::dvec3 p0(glm::vec3(a.tri_positions[3 * t])), p1(glm::vec3(a.tri_positions[3 * t + 1])),
            p2(glm::vec3(a.tri_positions[3 * t + 2]));
        return 0.5 * glm::length(glm::cross(p1 - p0, p2 - p0));
    };
    auto radiance = [&](size_t e) { return a.emitter_mean_radiance[e]; };
    std::vector<double> emitter_area(emitter_count, 0.0);
    uint32_t lit_emitters = 0;
    for (size_t e = 0; e < emitter_count; ++e) {
        for (uint32_t t : per_emitter[e]) emitter_area[e] += std::max(tri_area(t), 0.0);
        if (emitter_area[e] > 0.0 && luminance(radiance(e)) > 0.0) ++lit_emitters;
    }
    // The emitters at infinity that emit: the environment (index 0), then directional light i (1 + i).
    // Power selection weighs them by the power they deliver to the scene's bounding sphere of
    // radius r, divided by pi as the area emitters' luminance x area is: r^2 x the integral of
    // the environment's luminance over the sphere; r^2 x the directional light's irradiance.
    const double r2 = 0.25 * glm::dot(glm::dvec3(a.bbox_hi - a.bbox_lo), glm::dvec3(a.bbox_hi - a.bbox_lo));
    std::vector<std::pair<uint32_t, double>> infinite;  // (index, power weight)
    if (a.environment.map.x != gpu::ENV_NONE && a.environment_luminance > 0.0)
        infinite.push_back({0u, r2 * 4.0 * 3.14159265358979323846 * a.environment_luminance});
    for (size_t i = 0; i < a.directional.size(); ++i)
        if (double lum = luminance(glm::vec3(a.directional[i].irradiance)); lum > 0.0)
            infinite.push_back({static_cast<uint32_t>(1 + i), r2 * lum});
    const uint32_t selectable = lit_emitters + static_cast<uint32_t>(infinite.size());
    double total = 0.0;
    std::vector<double> weights;
    std::vector<double> emitter_weight(emitter_count, 0.0);
    for (size_t e = 0; e < emitter_count; ++e) {
        double lum = luminance(radiance(e));
        uint32_t first = static_cast<uint32_t>(a.light_triangles.size());
        if (emitter_area[e] > 0.0 && lum > 0.0) {
            for (uint32_t t : per_emitter[e]) {
                double area = tri_area(t);
                if (!(area > 0.0)) continue;
                gpu::GpuLightTriangle lt{};
                lt.info = glm::uvec4(t, static_cast<uint32_t>(e), 0u, 0u);
                lt.cdf = glm::vec4(0.0f, static_cast<float>(area), 0.0f, 0.0f);
                a.light_triangles.push_back(lt);
                double w = selection == LightSelection::Power ? lum * area : area / emitter_area[e] / selectable;
                weights.push_back(w);
                total += w;
                emitter_weight[e] += w;
            }
        }
        a.emitters[e].radiance.w = static_cast<float>(emitter_area[e]);
        a.emitters[e].info =
            glm::uvec4(a.emitters[e].info.x, first, static_cast<uint32_t>(a.light_triangles.size()) - first, 0u);
    }
    const size_t area_entries = a.light_triangles.size();
    for (const auto& [index, power] : infinite) {
        gpu::GpuLightTriangle lt{};
        lt.info = glm::uvec4(gpu::LIGHT_INFINITE, index, 0u, 0u);
        a.light_triangles.push_back(lt);
        double w = selection == LightSelection::Power ? power : 1.0 / selectable;
        weights.push_back(w);
        total += w;
    }
    for (size_t e = 0; e < emitter_count; ++e) {
        double pdf_area = total > 0.0 && emitter_area[e] > 0.0 ? emitter_weight[e] / total / emitter_area[e] : 0.0;
        a.emitters[e].info.w = std::bit_cast<uint32_t>(static_cast<float>(pdf_area));
    }
    double acc = 0.0;
    for (size_t i = 0; i < a.light_triangles.size(); ++i) {
        acc += weights[i];
        a.light_triangles[i].cdf.x = static_cast<float>(acc / total);
        // pdf per unit area of choosing this triangle then a uniform point on it; an emitter at
        // infinity's selection probability.
        a.light_triangles[i].cdf.z =
            static_cast<float>(i < area_entries ? weights[i] / total / a.light_triangles[i].cdf.y : weights[i] / total);
    }
    a.environment.radiance.w = 0.0f;
    for (auto& d : a.directional) d.direction.w = 0.0f;
    for (size_t i = area_entries; i < a.light_triangles.size(); ++i) {
        const uint32_t index = a.light_triangles[i].info.y;
        (index == 0 ? a.environment.radiance.w : a.directional[index - 1].direction.w) = a.light_triangles[i].cdf.z;
    }
    if (!a.light_triangles.empty()) a.light_triangles.back().cdf.x = 1.0f;
    a.light_weight_total = static_cast<float>(total);
}

// build_scene_bvh without the light table.
void order_by_bvh(SceneArrays& a, const std::string& source) {
    VKM_ASSERT(a.bvh4.empty(), "build_scene_bvh: the scene arrays already have a BVH");
    const size_t n = a.triangles.size();
    std::vector<glm::vec3> pos3(3 * n);
    for (size_t i = 0; i < 3 * n; ++i) pos3[i] = glm::vec3(a.tri_positions[i]);
    Bvh bvh = build_bvh(pos3);
    std::vector<gpu::GpuBvh4Node> bvh4;
    try {
        bvh4 = collapse_bvh4(bvh);
    } catch (const std::length_error& e) {
        throw SceneError(source, 0, std::string("the scene is too large for the software BVH: ") + e.what());
    }
    const std::vector<glm::uvec4> tris = std::move(a.triangles);
    const std::vector<uint32_t> tri_mesh = std::move(a.triangle_mesh);
    a.triangles.resize(n);
    a.triangle_mesh.resize(n);
    a.tri_positions.resize(3 * n);
    for (size_t i = 0; i < n; ++i) {
        uint32_t src = bvh.order[i];
        a.triangles[i] = tris[src];
        a.triangle_mesh[i] = tri_mesh[src];
        // The w components of the three texels: the fourth vertex d of the
        // quad this triangle starts (Bvh::quad_next: the next one is (a, c, d)),
        // else its own first vertex, so the traversal tests (a, c, d) as well
        // exactly where the bits differ.
        const glm::vec3 d = bvh.quad_next[i] ? pos3[3 * size_t{bvh.order[i + 1]} + 2] : pos3[3 * src];
        for (int k = 0; k < 3; ++k) a.tri_positions[3 * i + k] = glm::vec4(pos3[3 * src + k], d[k]);
    }
    a.bvh = std::move(bvh);
    a.bvh4 = std::move(bvh4);
}

}  // namespace

SceneArrays flatten_scene(const Scene& scene, LightSelection selection) {
    SceneArrays a = flatten_unlit(scene, selection);
    build_light_table(a);
    return a;
}

void build_scene_bvh(SceneArrays& a, const std::string& source) {
    if (!a.instanced()) order_by_bvh(a, source);
    build_light_table(a);
}

SceneArrays flatten_scene(const Scene& scene, Traversal traversal, LightSelection selection) {
    VKM_ASSERT(traversal != Traversal::Auto, "flatten_scene: the traversal is not resolved");
    SceneArrays a = flatten_unlit(scene, selection);
    // An instanced scene keeps the scene's order: only the GPU kernel's two-level tree traces it.
    if (traversal == Traversal::Bvh && !a.instanced()) order_by_bvh(a, scene.source);
    build_light_table(a);
    return a;
}

std::vector<vk::BindingDesc> traversal_bindings(Traversal t, vk::KernelClass k) {
    using DT = ::vk::DescriptorType;
    VKM_ASSERT(k != vk::KernelClass::Auto, "traversal_bindings: the kernel is not resolved");
    if (t == Traversal::RayQuery) {
        if (k == vk::KernelClass::Gpu)  // the instances (shaders/instances.glsl)
            return {{gpu::BINDING_TLAS, DT::eAccelerationStructureKHR}, {gpu::BINDING_INSTANCES, DT::eStorageBuffer}};
        return {{gpu::BINDING_TLAS, DT::eAccelerationStructureKHR}};
    }
    const DT type = k == vk::KernelClass::Gpu ? DT::eStorageBuffer : DT::eUniformTexelBuffer;
    VKM_ASSERT(t == Traversal::Bvh, "traversal_bindings: the traversal is not resolved");
    if (k == vk::KernelClass::Gpu)
        return {{gpu::BINDING_BVH_NODES, type}, {gpu::BINDING_BVH_TRIS, type}, {gpu::BINDING_INSTANCES, type}};
    return {{gpu::BINDING_BVH_NODES, type}, {gpu::BINDING_BVH_TRIS, type}};
}

void GpuScene::bind_traversal(vk::ComputePipeline& pipeline) const {
    if (traversal_ == Traversal::RayQuery) {
        pipeline.bind_acceleration_structure(gpu::BINDING_TLAS, accel_->tlas());
        if (kernel_ == vk::KernelClass::Gpu) pipeline.bind_buffer(gpu::BINDING_INSTANCES, instances.handle());
    } else if (kernel_ == vk::KernelClass::Gpu) {
        pipeline.bind_buffer(gpu::BINDING_BVH_NODES, bvh_nodes.handle());
        pipeline.bind_buffer(gpu::BINDING_BVH_TRIS, tri_positions.handle());
        pipeline.bind_buffer(gpu::BINDING_INSTANCES, instances.handle());
    } else {
        for (const auto& [binding, view] : traversal_views_) pipeline.bind_texel_buffer(binding, **view);
    }
}

namespace {

// A view of `texels` RGBA32 uint texels of b (shaders read it as a utextureBuffer).
std::unique_ptr<::vk::raii::BufferView> texel_view(const vk::Context& ctx, const vk::Buffer& b, size_t texels,
                                                   const char* what) {
    const uint32_t limit = ctx.physical().getProperties().limits.maxTexelBufferElements;
    if (texels > limit) {
        std::string msg = "the scene needs ";
        msg += std::to_string(texels);
        msg += " texels of ";
        msg += what;
        msg += ", more than this device's limit of ";
        msg += std::to_string(limit);
        msg += " (maxTexelBufferElements); make the scene smaller (fewer triangles, smaller textures)";
        throw SceneError("", 0, msg);
    }
    return std::make_unique<::vk::raii::BufferView>(
        ctx.device(), ::vk::BufferViewCreateInfo{.buffer = b.handle(),
                                                 .format = ::vk::Format::eR32G32B32A32Uint,
                                                 .offset = 0,
                                                 .range = std::max<size_t>(texels, 1) * 16});
}

template <class T>
size_t texels_of(const std::vector<T>& v) {
    static_assert(sizeof(T) % 16 == 0);
    return v.size() * (sizeof(T) / 16);
}

}  // namespace

std::vector<glm::uvec4> environment_words(const SceneArrays& a) {
    std::vector<glm::uvec4> words(gpu::ENV_WORDS + 2 * a.directional.size());
    std::memcpy(words.data(), &a.environment, sizeof a.environment);
    if (!a.directional.empty())
        std::memcpy(words.data() + gpu::ENV_WORDS, a.directional.data(),
                    a.directional.size() * sizeof(gpu::GpuDirectional));
    return words;
}

std::vector<vk::BindingDesc> scene_bindings(Traversal t, vk::KernelClass k) {
    using DT = ::vk::DescriptorType;
    const DT type = k == vk::KernelClass::Gpu ? DT::eStorageBuffer : DT::eUniformTexelBuffer;
    std::vector<vk::BindingDesc> b = {{gpu::BINDING_VERTICES, type},  {gpu::BINDING_TRIANGLES, type},
                                      {gpu::BINDING_MATERIALS, type}, {gpu::BINDING_LIGHT_TRIS, type},
                                      {gpu::BINDING_EMITTERS, type},  {gpu::BINDING_TEXELS, type},
                                      {gpu::BINDING_TEXTURES, type},  {gpu::BINDING_ENVIRONMENT, type}};
    for (const auto& x : traversal_bindings(t, k)) b.push_back(x);
    return b;
}

void GpuScene::bind_scene(vk::ComputePipeline& pipeline) const {
    if (kernel_ == vk::KernelClass::Gpu) {
        for (const auto& [binding, buffer] : storage_) pipeline.bind_buffer(binding, buffer);
    } else {
        for (const auto& [binding, view] : views_) pipeline.bind_texel_buffer(binding, **view);
    }
    bind_traversal(pipeline);
}

// Measured on an H200 (docs/gpu.md, 2026-11-26): leaves of at most 2, 32 bins
// and a node visit costing one triangle test (the CPU tree's options) against
// 3631bde's leaves of 4, 16 bins and free node visits: faster on 6 of the 9
// bench scenes (ring_caustic +14%, kitchen_counter +8%), slower on
// glass_caustic (-8%). Kept a separate tree so a GPU can be tuned alone.
BvhBuildOptions gpu_kernel_bvh_options() {
    BvhBuildOptions o;
    o.max_leaf_size = 2;
    o.bins = 32;
    o.traversal_cost = 1.0f;
    return o;
}

namespace {

// A tree over `pos3` (3 points per primitive) appended to t: its nodes'
// links moved past the nodes and entries already there; entry i's first w
// the bits of ids[order[i]]. Returns the tree's depth.
uint32_t append_gpu_tree(GpuKernelTree& t, const std::vector<glm::vec3>& pos3, const std::vector<uint32_t>& ids) {
    Bvh tree = build_bvh(pos3, gpu_kernel_bvh_options());
    const uint32_t node_base = static_cast<uint32_t>(t.nodes.size());
    const uint32_t entry_base = static_cast<uint32_t>(t.positions.size() / 3);
    for (gpu::GpuBvhNode n : tree.nodes) {
        const uint32_t offset = std::bit_cast<uint32_t>(n.bmin.w);
        const uint32_t count = std::bit_cast<uint32_t>(n.bmax.w);
        n.bmin.w = std::bit_cast<float>(offset + (count > 0 ? entry_base : node_base));
        t.nodes.push_back(n);
    }
    for (size_t i = 0; i < tree.order.size(); ++i) {
        const uint32_t src = tree.order[i];
        for (int k = 0; k < 3; ++k) t.positions.push_back(glm::vec4(pos3[3 * size_t{src} + k], 0.0f));
        t.positions[3 * (entry_base + i)].w = std::bit_cast<float>(ids[src]);
    }
    return bvh_stats(tree).max_depth;
}

}  // namespace

GpuKernelTree build_gpu_kernel_tree(const SceneArrays& a, const std::string& source) {
    GpuKernelTree t;
    const size_t n = a.tri_positions.size() / 3;
    // Top level: the ordinary meshes' triangles and, for each instance, its
    // world box as a degenerate "triangle" (lo, hi, centre), whose entry is
    // INSTANCE_ENTRY_BIT | the instance.
    const size_t world = a.group_triangles.empty() ? n : a.group_triangles.front().x;
    std::vector<glm::vec3> pos3;
    std::vector<uint32_t> ids;
    pos3.reserve(3 * (world + a.instances.size()));
    for (size_t i = 0; i < world; ++i) {
        for (int k = 0; k < 3; ++k) pos3.push_back(glm::vec3(a.tri_positions[3 * i + k]));
        ids.push_back(static_cast<uint32_t>(i));
    }
    // Each group's box in its space.
    std::vector<glm::vec3> glo(a.group_triangles.size(), glm::vec3(std::numeric_limits<float>::max()));
    std::vector<glm::vec3> ghi(a.group_triangles.size(), glm::vec3(-std::numeric_limits<float>::max()));
    for (size_t g = 0; g < a.group_triangles.size(); ++g)
        for (size_t i = 3 * size_t{a.group_triangles[g].x};
             i < 3 * size_t{a.group_triangles[g].x + a.group_triangles[g].y}; ++i) {
            glo[g] = glm::min(glo[g], glm::vec3(a.tri_positions[i]));
            ghi[g] = glm::max(ghi[g], glm::vec3(a.tri_positions[i]));
        }
    for (size_t j = 0; j < a.instances.size(); ++j) {
        const gpu::GpuInstance& in = a.instances[j];
        const size_t g = in.info.y;
        glm::mat4 to_world(1.0f);
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 4; ++c) to_world[c][r] = in.to_world[r][c];
        glm::vec3 lo = glo[g], hi = ghi[g];
        transform_box(to_world, lo, hi);
        pos3.push_back(lo);
        pos3.push_back(hi);
        pos3.push_back(0.5f * (lo + hi));
        ids.push_back(gpu::INSTANCE_ENTRY_BIT | static_cast<uint32_t>(j));
    }
    const uint32_t top_depth = append_gpu_tree(t, pos3, ids);
    // Each group's tree, in the group's space; its instances descend from its root.
    t.instances = a.instances;
    uint32_t group_depth = 0;
    for (size_t g = 0; g < a.group_triangles.size(); ++g) {
        const glm::uvec2 r = a.group_triangles[g];
        if (r.y == 0) continue;
        pos3.clear();
        ids.clear();
        for (uint32_t i = r.x; i < r.x + r.y; ++i) {
            for (int k = 0; k < 3; ++k) pos3.push_back(glm::vec3(a.tri_positions[3 * size_t{i} + k]));
            ids.push_back(i);
        }
        const uint32_t root = static_cast<uint32_t>(t.nodes.size());
        group_depth = std::max(group_depth, append_gpu_tree(t, pos3, ids));
        for (auto& in : t.instances)
            if (in.info.y == g) in.info.x = root;
    }
    // The traversal's stack (shaders/trace_bvh_gpu.glsl, BVH_STACK_SIZE 64): a
    // top-level path, a leaf's instance entries (at most 4), the return marker,
    // a group's path.
    if (!a.instances.empty() && top_depth + 4 + 1 + group_depth > 64)
        throw SceneError(source, 0,
                         "the instanced scene's trees are too deep for the GPU kernel's traversal stack (top level " +
                             std::to_string(top_depth) + ", deepest shape group " + std::to_string(group_depth) +
                             " levels; at most 59 together)");
    if (t.nodes.size() >= gpu::INSTANCE_ENTRY_BIT)
        throw SceneError(source, 0, "the scene is too large for the GPU kernel's software BVH");
    if (t.instances.empty()) t.instances.resize(1);  // a binding needs a buffer
    return t;
}

namespace {

// The GPU kernel reads each array as a storage buffer: refused, as a texel
// buffer's count is, where the device cannot address it.
void check_storage_range(const vk::Context& ctx, const vk::Buffer& b, const char* what) {
    const uint64_t limit = ctx.info().max_storage_buffer_range;
    if (limit > 0 && b.size() > limit)
        throw SceneError("", 0,
                         std::string("the scene needs ") + vk::byte_size_text(b.size()) + " of " + what +
                             ", more than this device's limit of " + vk::byte_size_text(limit) +
                             " (maxStorageBufferRange); make the scene smaller (fewer triangles, smaller textures)");
}

}  // namespace

GpuScene::GpuScene(const vk::Context& ctx, const SceneArrays& a, Traversal traversal, vk::KernelClass kernel)
    : traversal_(resolve_traversal(ctx, traversal)),
      // Instances: only the GPU kernel's traversals have two levels (on any device).
      kernel_(a.instanced()                     ? vk::KernelClass::Gpu
              : kernel == vk::KernelClass::Auto ? ctx.kernel()
                                                : kernel),
      instanced_(a.instanced()) {
    VKM_ASSERT(
        traversal_ != Traversal::Bvh || a.has_bvh(),
        "GpuScene: the software BVH traverses scene arrays without a BVH (flatten_scene(scene, Traversal::Bvh))");
    using BU = ::vk::BufferUsageFlagBits;
    const bool gpu_kernel = kernel_ == vk::KernelClass::Gpu;
    const ::vk::BufferUsageFlags usage =
        gpu_kernel ? ::vk::BufferUsageFlags(BU::eStorageBuffer) : ::vk::BufferUsageFlags(BU::eUniformTexelBuffer);
    // The vertices, then the file's tangents where a mesh keeps them (SceneArrays::tangents).
    std::vector<glm::vec4> vertex_words;
    if (!a.tangents.empty()) {
        vertex_words.resize(2 * a.vertices.size() + a.tangents.size());
        std::memcpy(vertex_words.data(), a.vertices.data(), a.vertices.size() * sizeof(gpu::GpuVertex));
        std::copy(a.tangents.begin(), a.tangents.end(), vertex_words.begin() + 2 * a.vertices.size());
    }
    vertices = a.tangents.empty() ? vk::Buffer::from_vector(ctx, a.vertices, usage)
                                  : vk::Buffer::from_vector(ctx, vertex_words, usage);
    triangles = vk::Buffer::from_vector(ctx, a.triangles, usage);
    materials = vk::Buffer::from_vector(ctx, a.materials, usage);
    emitters = vk::Buffer::from_vector(ctx, a.emitters, usage);
    light_triangles = vk::Buffer::from_vector(ctx, a.light_triangles, usage);
    texels = vk::Buffer::from_vector(ctx, a.texels, usage);
    textures = vk::Buffer::from_vector(ctx, a.textures, usage);
    const std::vector<glm::uvec4> env_words = environment_words(a);
    environment = vk::Buffer::from_vector(ctx, env_words, usage);
    ::vk::BufferUsageFlags pos_usage = usage;
    if (traversal_ == Traversal::RayQuery)
        pos_usage =
            pos_usage | BU::eStorageBuffer | BU::eAccelerationStructureBuildInputReadOnlyKHR | BU::eShaderDeviceAddress;
    // The GPU kernel's software BVH reads the positions in its own tree's order
    // (shaders/trace_bvh_gpu.glsl); everything else in the scene arrays' order.
    std::optional<GpuKernelTree> gpu_tree;
    if (gpu_kernel && traversal_ == Traversal::Bvh) gpu_tree = build_gpu_kernel_tree(a, "");
    tri_positions = vk::Buffer::from_vector(ctx, gpu_tree ? gpu_tree->positions : a.tri_positions, pos_usage);
    if (gpu_kernel) {
        const std::pair<uint32_t, const vk::Buffer*> arrays[] = {
            {gpu::BINDING_VERTICES, &vertices},   {gpu::BINDING_TRIANGLES, &triangles},
            {gpu::BINDING_MATERIALS, &materials}, {gpu::BINDING_LIGHT_TRIS, &light_triangles},
            {gpu::BINDING_EMITTERS, &emitters},   {gpu::BINDING_TEXELS, &texels},
            {gpu::BINDING_TEXTURES, &textures},   {gpu::BINDING_ENVIRONMENT, &environment}};
        const char* what[] = {"vertices", "triangles",      "materials",       "emissive triangles",
                              "emitters", "texture texels", "texture records", "lights at infinity"};
        for (size_t i = 0; i < std::size(arrays); ++i) {
            check_storage_range(ctx, *arrays[i].second, what[i]);
            storage_.emplace_back(arrays[i].first, arrays[i].second->handle());
        }
    } else {
        views_.emplace_back(gpu::BINDING_VERTICES,
                            texel_view(ctx, vertices, texels_of(a.vertices) + a.tangents.size(), "vertices"));
        views_.emplace_back(gpu::BINDING_TRIANGLES, texel_view(ctx, triangles, texels_of(a.triangles), "triangles"));
        views_.emplace_back(gpu::BINDING_MATERIALS, texel_view(ctx, materials, texels_of(a.materials), "materials"));
        views_.emplace_back(gpu::BINDING_LIGHT_TRIS,
                            texel_view(ctx, light_triangles, texels_of(a.light_triangles), "emissive triangles"));
        views_.emplace_back(gpu::BINDING_EMITTERS, texel_view(ctx, emitters, texels_of(a.emitters), "emitters"));
        views_.emplace_back(gpu::BINDING_TEXELS, texel_view(ctx, texels, texels_of(a.texels), "texture texels"));
        views_.emplace_back(gpu::BINDING_TEXTURES, texel_view(ctx, textures, texels_of(a.textures), "texture records"));
        views_.emplace_back(gpu::BINDING_ENVIRONMENT,
                            texel_view(ctx, environment, texels_of(env_words), "lights at infinity"));
    }
    // The GPU kernel's instances (shaders/instances.glsl): as flattened under ray query, with their
    // group trees' roots under the software BVH.
    const bool ray_query = traversal_ == Traversal::RayQuery;
    const std::vector<gpu::GpuInstance>* gpu_instances =
        ray_query ? (gpu_kernel ? &a.instances : nullptr) : (gpu_tree ? &gpu_tree->instances : nullptr);
    if (gpu_instances) {
        instances = vk::Buffer::from_vector(ctx, *gpu_instances, usage);
        check_storage_range(ctx, instances, "instances");
    }
    if (ray_query) {
        accel_ = std::make_unique<RayTracingAccel>(ctx, tri_positions, static_cast<uint32_t>(a.triangles.size()),
                                                   a.group_triangles, a.instances);
    } else if (gpu_tree) {
        bvh_nodes = vk::Buffer::from_vector(ctx, gpu_tree->nodes, usage);
        check_storage_range(ctx, bvh_nodes, "BVH nodes");
        check_storage_range(ctx, tri_positions, "triangle positions");
    } else {
        bvh_nodes = vk::Buffer::from_vector(ctx, a.bvh4, usage);
        traversal_views_.emplace_back(gpu::BINDING_BVH_NODES,
                                      texel_view(ctx, bvh_nodes, texels_of(a.bvh4), "BVH nodes"));
        traversal_views_.emplace_back(gpu::BINDING_BVH_TRIS,
                                      texel_view(ctx, tri_positions, texels_of(a.tri_positions), "triangle positions"));
    }
}

}  // namespace vkmech
