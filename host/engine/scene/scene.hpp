// The CPU scene model: what a loader (Mitsuba XML, glTF, procedural) produces
// and what accel/ and render/ consume. All geometry is triangulated and
// stored in world space; spheres carry per-vertex shading normals fine enough
// that refraction through them is smooth (a sphere must render smooth).
#pragma once

#include "shared/types.h"

#include <glm/glm.hpp>

#include <algorithm>
#include <array>
#include <cstdint>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace vkmech {

// A loader error: names the file, the line and what is wrong. The CLI prints
// what() and exits with code 2 (bad input).
class SceneError : public std::runtime_error {
public:
    SceneError(const std::string& file, int line, const std::string& what)
        : std::runtime_error(format(file, line, what)), file_(file), line_(line), reason_(what) {}
    const std::string& file() const { return file_; }
    int line() const { return line_; }
    // What is wrong, without the "file:line: " prefix (to re-wrap it).
    const std::string& reason() const { return reason_; }

private:
    static std::string format(const std::string& file, int line, const std::string& what) {
        return line > 0 ? file + ":" + std::to_string(line) + ": " + what : file + ": " + what;
    }
    std::string file_;
    int line_;
    std::string reason_;
};

// Material models of docs/descriptor.md §2: one per row of the material table
// (shared/materials.h); values MAT_*.
enum class BsdfType : uint32_t {
#define VKM_X(code, NAME, Name, name, features, lobes, flags) Name = gpu::MAT_##NAME,
    VKM_MATERIALS(VKM_X)
#undef VKM_X
};
const char* to_string(BsdfType t);  // the Mitsuba plugin name (material table)
// The model of a Mitsuba plugin name in the material table, or nullopt.
std::optional<BsdfType> bsdf_type_of(const std::string& plugin);
// The plugin names of every model, comma-separated in table order ("diffuse, plastic, ...").
std::string bsdf_plugin_names();

enum class MicrofacetDistribution : uint32_t { Beckmann = 0, GGX = 1 };

// An RGB reflectance that is either a constant or a bitmap texture.
struct Spectrum3 {
    glm::vec3 value{0.5f};
    int texture = -1;  // index into Scene::textures, or -1 for the constant
};

enum class TextureKind : uint32_t { Bitmap = 0, Checkerboard = 1 };

struct Texture {
    TextureKind kind = TextureKind::Bitmap;
    std::string path;  // absolute path of the image file (bitmap), or a description
    int width = 0, height = 0;
    std::vector<float> rgb;  // linear RGB, row-major, top row first (checkerboard: color0, color1)
    bool nearest = false;    // Mitsuba's filter_type="nearest" (default bilinear)
    // Mitsuba's `to_uv`: uv' = to_uv * (u, v, 1), an affine 2D map (rows 0 and 1).
    glm::mat3 to_uv{1.0f};
};

struct Material {
    std::string id;  // the XML id, or a generated name
    BsdfType type = BsdfType::Diffuse;
    bool twosided = false;  // `twosided` wrapper: transparent to the lobe flags (docs/descriptor.md §2)

    // diffuse: reflectance; plastic family: diffuse_reflectance;
    // principled: base_color.
    Spectrum3 reflectance{glm::vec3(0.5f)};
    glm::vec3 specular_reflectance{1.0f};
    glm::vec3 specular_transmittance{1.0f};
    // Textures on the specular colours (index into Scene::textures, -1: the
    // constants above, which then hold the texture's mean).
    int specular_reflectance_texture = -1;
    int specular_transmittance_texture = -1;
    // Emission (glTF's emissiveTexture): where the mesh is an emitter, its radiance times this
    // texture at the point (index into Scene::textures, -1: none).
    int emission_texture = -1;
    // principled: glTF's metallicRoughnessTexture (linear; roughness in G, metallic in B, the
    // factors multiplied in), evaluated at each hit; `metallic` and `roughness` hold its means.
    int metallic_roughness_texture = -1;
    // A tangent-space normal map (glTF normalTexture, Mitsuba's normalmap): linear RGB = (n + 1) / 2,
    // +x along dp/du, +y along n x dp/du; its x and y times normal_scale.
    int normal_texture = -1;
    float normal_scale = 1.0f;
    // glTF: the normal map's bitangent flips where the uv layout is mirrored (MikkTSpace's sign,
    // per triangle); Mitsuba's normalmap keeps n x dp/du.
    bool normal_uv_handed = false;
    // Mitsuba's bumpmap: a height texture (its luminance) whose uv gradient times bump_scale
    // tilts the shading normal (Mitsuba 3's bump(): n = dp/du' x dp/dv'). A material has a
    // normal map or a bump map, not both.
    int bump_texture = -1;
    float bump_scale = 1.0f;
    // roughconductor, roughdielectric: Mitsuba's textured `alpha` (both) or `alpha_u` /
    // `alpha_v`, the texture's luminance read at each hit; alpha_u and alpha_v hold
    // the textures' mean luminances.
    int alpha_u_texture = -1;
    int alpha_v_texture = -1;
    // blendbsdf (type Blend, Mitsuba's `blendbsdf`): at each hit the material is its component
    // blend_second with probability blend_weight (blend_weight_texture's luminance at the hit,
    // where it is >= 0) and blend_first otherwise (indices into Scene::materials, both earlier
    // than the blend). No other field of a blend is read but twosided and the shading-normal
    // texture, which pass to a component without its own (shaders/pathtrace.comp blend_resolve).
    int blend_first = -1;
    int blend_second = -1;
    float blend_weight = 0.5f;
    int blend_weight_texture = -1;
    // principled: Mitsuba 3's textured spec_tint, anisotropic, sheen, sheen_tint, clearcoat,
    // clearcoat_gloss and spec_trans (kPrincipledTextured's order), each a texture holding its
    // luminance in every channel, read at each hit; the constants hold the means. -1: constant.
    static constexpr const char* kPrincipledTextured[7] = {"spec_tint", "anisotropic",     "sheen",     "sheen_tint",
                                                           "clearcoat", "clearcoat_gloss", "spec_trans"};
    std::array<int, 7> principled_param_textures{-1, -1, -1, -1, -1, -1, -1};
    // Calls f on every texture index above (-1: none), as int& (const int& on a const
    // Material): the one list of a material's textures, for whoever remaps or tests them.
    template <class F>
    void for_each_texture(F&& f) {
        each_texture(*this, [&](const char*, int& t) { f(t); });
    }
    template <class F>
    void for_each_texture(F&& f) const {
        each_texture(*this, [&](const char*, const int& t) { f(t); });
    }
    // The same with each slot's name ("reflectance", "bump", ...): f(const char* name, int texture).
    template <class F>
    void for_each_named_texture(F&& f) const {
        each_texture(*this, f);
    }
    bool has_texture() const {
        bool any = false;
        for_each_texture([&](int t) { any = any || t >= 0; });
        return any;
    }

private:
    template <class Self, class F>
    static void each_texture(Self& m, F&& f) {
        f("reflectance", m.reflectance.texture);
        f("specular_reflectance", m.specular_reflectance_texture);
        f("specular_transmittance", m.specular_transmittance_texture);
        f("emission", m.emission_texture);
        f("metallic_roughness", m.metallic_roughness_texture);
        f("normal", m.normal_texture);
        f("bump", m.bump_texture);
        f("alpha_u", m.alpha_u_texture);
        f("alpha_v", m.alpha_v_texture);
        f("blend_weight", m.blend_weight_texture);
        for (size_t i = 0; i < m.principled_param_textures.size(); ++i)
            f(kPrincipledTextured[i], m.principled_param_textures[i]);
    }

public:
    // conductor family: complex index of refraction (RGB), relative to ext_ior.
    glm::vec3 eta{0.0f};  // default "none" = perfect mirror (eta 0, k 1)
    glm::vec3 k{1.0f};

    // dielectric / plastic family: interior and exterior IOR.
    float int_ior = 1.5046f;    // bk7
    float ext_ior = 1.000277f;  // air
    bool nonlinear = false;     // plastic: Mitsuba's `nonlinear`

    // Microfacet roughness (alpha, not perceptual roughness).
    float alpha_u = 0.1f;
    float alpha_v = 0.1f;
    MicrofacetDistribution distribution = MicrofacetDistribution::Beckmann;

    // principled (Mitsuba 3 names).
    float metallic = 0.0f;
    float roughness = 0.5f;
    float specular = 0.5f;
    float spec_tint = 0.0f;
    float anisotropic = 0.0f;
    float sheen = 0.0f;
    float sheen_tint = 0.0f;
    float clearcoat = 0.0f;
    float clearcoat_gloss = 0.0f;
    float spec_trans = 0.0f;
    float eta_principled = 1.5f;

    // The lobe classes the BSDF can sample, bits gpu::LOBE_BIT_D/G/S: the
    // table of shaders/lobes.glsl, which the renderer reads too
    // (docs/descriptor.md §2).
    // A blend has none of its own (0): Scene::lobe_flags(index) joins its components'.
    uint32_t lobe_flags() const;
    bool is_delta_only() const;  // S only: conductor, dielectric, thindielectric
    bool has_diffuse() const;    // a D lobe: diffuse, plastic family, principled with diffuse
};

enum class ShapeKind : uint32_t { Mesh = 0, Rectangle, Cube, Sphere, Disk, Cylinder };
const char* to_string(ShapeKind k);

struct Mesh {
    std::string name;  // the XML id or "<plugin>#<index>"
    ShapeKind kind = ShapeKind::Mesh;
    std::vector<glm::vec3> positions;  // world space
    std::vector<glm::vec3> normals;    // world space shading normals; empty = flat
    std::vector<glm::vec2> uvs;        // empty = none; Mitsuba's convention: v = 0 is a bitmap's top row
                                       // (OBJ's v is flipped on load, as Mitsuba does)
    // Per-vertex tangents (glTF's TANGENT): xyz the world-space tangent, along which the normal
    // map's +x lies; w = +1 or -1, the bitangent being w (n x t) (glTF 2.0 §3.7.2.1), read with
    // a normal_uv_handed material (glTF's; otherwise b = n x t). Only with normals. Empty: the
    // normal map's frame comes from the uvs.
    std::vector<glm::vec4> tangents;
    std::vector<glm::uvec3> indices;
    int material = -1;  // index into Scene::materials
    int emitter = -1;   // index into Scene::emitters, or -1
    bool flip_normals = false;
    // Analytic description (kept for sampling and for separation measures).
    glm::vec3 center{0.0f};
    float radius = 0.0f;
    // A member of shape group `group` (index into Scene::groups): positions and
    // normals are then in the group's space, and the mesh is seen only through
    // the group's instances. -1: an ordinary mesh, in world space.
    int group = -1;
};

// Instancing (Mitsuba's shapegroup / instance): a group's meshes are stored
// once, and every instance places them with its own to_world. Groups hold no
// emitters (as in Mitsuba) and no instances.
struct ShapeGroup {
    std::string name;  // the XML id
};
struct Instance {
    int group = -1;            // index into Scene::groups
    glm::mat4 to_world{1.0f};  // affine, invertible
    std::string name;          // the XML id or "instance#<index>"
};

// Area emitter attached to one mesh: constant RGB radiance, one-sided (emits
// on the side of the geometric normal, turned to agree with the authored
// shading normals where the mesh has them) as in docs/descriptor.md §1.
struct AreaEmitter {
    glm::vec3 radiance{1.0f};
    int mesh = -1;
};

// Emitters at infinity (docs/descriptor.md §1, beyond the paper). An
// environment is radiance arriving from every direction: a constant, or a
// latitude-longitude map in Mitsuba 3's frame (+y up, to_world's rotation
// turning it), times `scale`. A camera ray that escapes to it is an
// emitter_direct event.
enum class EnvironmentKind : uint32_t { None = 0, Constant = 1, Map = 2 };
struct Environment {
    EnvironmentKind kind = EnvironmentKind::None;
    glm::vec3 radiance{1.0f};  // Constant: the radiance (scale applied)
    Texture map;               // Map: linear RGB, top row first (to_uv unused)
    float scale = 1.0f;        // Map: multiplies the map
    glm::mat3 to_world{1.0f};  // a rotation
    std::string what;          // where it came from ("file:line: emitter 'envmap'", "--environment FILE")
};
// A distant light: parallel rays along `direction` (the way the light
// travels, unit), delivering `irradiance` to a surface facing it (Mitsuba's
// `directional`). Sampled by NEE only: no ray can hit it.
struct DirectionalLight {
    glm::vec3 direction{0.0f, 0.0f, 1.0f};
    glm::vec3 irradiance{1.0f};
};

enum class CameraType : uint32_t { Perspective = 0, ThinLens = 1, Orthographic = 2 };

struct Camera {
    CameraType type = CameraType::Perspective;
    glm::mat4 to_world{1.0f};  // camera space: +Z forward, +Y up, Mitsuba's convention
                               // (orthographic: its scale sets the view: camera x in [-1, 1] spans the width)
    float fov_deg = 39.3077f;
    std::string fov_axis = "x";  // x, y, diagonal, smaller, larger
    float near_clip = 0.01f;
    float far_clip = 10000.0f;
    float aperture_radius = 0.0f;  // thinlens only
    float focus_distance = 0.0f;   // thinlens only
    int width = 256;               // docs/descriptor.md §1 default film
    int height = 256;

    // Resizes the film to `w` pixels wide, keeping the aspect ratio (--res).
    void set_film_width(int w) {
        double aspect = static_cast<double>(height) / width;
        width = w;
        height = std::max(1, static_cast<int>(aspect * w + 0.5));
    }
};

struct IntegratorSettings {
    int max_depth = 12;  // Mitsuba counting: segments
    int rr_depth = 5;
};

struct Scene {
    std::string source;  // file path
    std::vector<Mesh> meshes;
    std::vector<ShapeGroup> groups;
    std::vector<Instance> instances;
    std::vector<Material> materials;
    std::vector<AreaEmitter> emitters;
    std::vector<Texture> textures;
    Environment environment;
    std::vector<DirectionalLight> directional_lights;
    Camera camera;
    IntegratorSettings integrator;
    // Every further file a Mitsuba scene read (includes, meshes, textures,
    // environment maps), as the loader resolved them, in reading order, possibly
    // repeated (a sentinel record digests each, docs/descriptor.md §9.1).
    std::vector<std::string> files;
    std::vector<std::string> substitutions;  // user-requested plugin substitutions, reported
    // Everything the loader read but did not use, or approximated without
    // being asked ("file:line: what"); printed and recorded in every output.
    std::vector<std::string> warnings;

    // The triangles stored: a shape group's once, however many instances it has.
    size_t triangle_count() const;
    // Whether mesh m's own tangents (Mesh::tangents) are read: it has them and its material a
    // normal map; otherwise the renderer keeps none of them.
    bool uses_tangents(const Mesh& m) const {
        return !m.tangents.empty() && m.material >= 0 && static_cast<size_t>(m.material) < materials.size() &&
               materials[static_cast<size_t>(m.material)].normal_texture >= 0;
    }
    // The triangles the camera sees: each group's as many times as it is instanced.
    size_t instanced_triangle_count() const;
    // The lobe classes material `index` can sample (gpu::LOBE_BIT_*): its own, or for a blend
    // the union of its components' (a component of weight 0 or 1 everywhere still counts).
    uint32_t lobe_flags(int index) const;
    // Every mesh keeps the Mesh invariant (check_mesh, mesh_ops.hpp) and
    // names a material and emitter that exist; groups and instances refer to
    // each other consistently; throws SceneError at source.
    void check() const;
    // Bounding box of the world-space geometry (every ordinary mesh vertex,
    // every instance's box of its group); false (lo, hi untouched) without any.
    bool bounds(glm::vec3& lo, glm::vec3& hi) const;
    // The box of group g's vertices in the group's space (g = -1: the ordinary meshes'); false when
    // it has none.
    bool group_bounds(int g, glm::vec3& lo, glm::vec3& hi) const;
};

// The axis-aligned box of the box [lo, hi] under the affine map m (its eight corners), in place.
void transform_box(const glm::mat4& m, glm::vec3& lo, glm::vec3& hi);

// Options a loader takes from the command line.
struct LoadOptions {
    std::map<std::string, std::string> params;  // -D name=value, overrides <default>
    bool substitute_unsupported = false;        // e.g. phong -> the nearest model material
    // The paper's treatment of an environment (docs/descriptor.md §8): an overhead
    // area panel of the environment's mean radiance x scale (--environment-panel).
    bool environment_panel = false;
    // --environment FILE [--environment-scale s]: a lat-long map (identity
    // to_world) that lights the scene, replacing its own environment.
    std::string environment_file;
    float environment_scale = 1.0f;
    // Most triangles a scene may expand to (--max-triangles); 0: the
    // environment's VKMECH_MAX_TRIANGLES, else kDefaultMaxTriangles.
    size_t max_triangles = 0;
};

constexpr size_t kDefaultMaxTriangles = 50'000'000;

// Mitsuba 3 (and 0.5/0.6 camelCase) XML subset of docs/descriptor.md §8. Throws SceneError.
Scene load_mitsuba_xml(const std::string& path, const LoadOptions& options = {});

// glTF 2.0 (.gltf with external or embedded buffers, .glb), docs/descriptor.md §8. Throws
// SceneError.
Scene load_gltf(const std::string& path, const LoadOptions& options = {});

// Dispatches on the extension (.xml, .gltf, .glb), then checks every mesh
// (check_mesh). Throws SceneError, also for running out of memory.
Scene load_scene(const std::string& path, const LoadOptions& options = {});

}  // namespace vkmech
