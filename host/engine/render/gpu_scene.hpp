// The scene flattened into GPU arrays (one vertex and one triangle list,
// materials, textures, emitters, the light-selection table), apart from
// acceleration: the software BVH traversal reorders the triangles into its
// tree's order (build_scene_bvh); ray query takes them in the scene's order.
// GpuScene uploads them with the chosen traversal's acceleration structure.
#pragma once

#include "accel/bvh.hpp"
#include "scene/scene.hpp"
#include "shared/types.h"
#include "vk/buffer.hpp"
#include "vk/pipeline.hpp"
#include "vk/rt_accel.hpp"

#include <memory>
#include <optional>
#include <string>

namespace vkmech {

enum class Traversal { Auto, RayQuery, Bvh };
const char* to_string(Traversal t);
Traversal parse_traversal(const std::string& s);  // throws std::invalid_argument

// How NEE picks an emitter (docs/descriptor.md §1): uniformly over the emitters, as Mitsuba
// does (the default), or proportionally to emitted power (luminance x area).
// Either way a point is then uniform over the chosen emitter's area.
enum class LightSelection : uint32_t { Uniform = 0, Power = 1 };
const char* to_string(LightSelection s);
LightSelection parse_light_selection(const std::string& s);  // throws std::invalid_argument

// The triangle arrays (triangles, triangle_mesh, tri_positions) and the light
// table are in one triangle order: the scene's own (mesh by mesh, as
// flatten_scene writes them) or, once build_scene_bvh has run, the software
// BVH's (bvh.order[i]: the scene's triangle at position i).
struct SceneArrays {
    std::vector<gpu::GpuVertex> vertices;
    // The file's tangents (Mesh::tangents) of the meshes that have them and a normal map, whose
    // vertices come last in `vertices`, from tangent_vertex_base: vertex i's tangent is
    // tangents[i - tangent_vertex_base]. Uploaded after the vertices, in the same buffer (the
    // shader reads vertex i's at word i + tangent_word_offset(), shared/types.h TRI_TANGENT_BIT).
    std::vector<glm::vec4> tangents;
    uint32_t tangent_vertex_base = 0;
    uint32_t tangent_word_offset() const { return static_cast<uint32_t>(2 * vertices.size()) - tangent_vertex_base; }
    std::vector<glm::uvec4> triangles;    // i0, i1, i2, material|emitter|flat
    std::vector<uint32_t> triangle_mesh;  // mesh index of each triangle
    // 3 per triangle; w: a quad's fourth vertex (build_scene_bvh), else the first vertex again.
    std::vector<glm::vec4> tri_positions;
    std::vector<gpu::GpuMaterial> materials;
    std::vector<gpu::GpuEmitter> emitters;
    std::vector<glm::vec3> emitter_mean_radiance;  // each emitter's radiance times its emission texture's mean
    std::vector<gpu::GpuLightTriangle> light_triangles;
    std::vector<glm::vec4> texels;     // every texture's linear RGB texels, then the environment map's
    std::vector<glm::uvec4> textures;  // gpu::TEX_WORDS per texture (shared/types.h)
    // The emitters at infinity (shared/types.h): the environment (map.x = ENV_NONE
    // without one; its selection probability filled in by the light table) and
    // the directional lights; the light table ends with an entry for each that emits.
    gpu::GpuEnvironment environment{};
    std::vector<gpu::GpuDirectional> directional;
    double environment_luminance = 0.0;  // the environment's mean luminance over the sphere
    bool has_infinite_lights() const { return environment.map.x != gpu::ENV_NONE || !directional.empty(); }
    // Instancing (Scene::groups, Scene::instances): each group's triangles are
    // one range [x, x + y) of the triangle arrays, in the group's space; the
    // ordinary meshes' come first, in world space. The instances' maps; info.x
    // (the group tree's root) is the GPU kernel's (build_gpu_kernel_tree).
    std::vector<glm::uvec2> group_triangles;
    std::vector<gpu::GpuInstance> instances;
    bool instanced() const { return !instances.empty(); }
    // Empty until build_scene_bvh: the software BVH and what its traversal reads.
    // An instanced scene has none: only the GPU kernel's two-level tree traces it.
    Bvh bvh;
    std::vector<gpu::GpuBvh4Node> bvh4;  // collapse_bvh4(bvh)
    float light_weight_total = 0.0f;     // sum of the light-selection weights (power: luminance x area)
    LightSelection light_selection = LightSelection::Uniform;
    glm::vec3 bbox_lo{0.0f}, bbox_hi{0.0f};
    bool has_bvh() const { return !bvh4.empty() || instanced(); }
};

// The environment array's words (BINDING_ENVIRONMENT): the GpuEnvironment, then
// each GpuDirectional.
std::vector<glm::uvec4> environment_words(const SceneArrays& a);

// Flattening alone: the arrays in the scene's own triangle order, no BVH (what
// ray query renders). Throws SceneError for scenes that cannot be rendered (no
// triangles, too many materials or emitters).
SceneArrays flatten_scene(const Scene& scene, LightSelection selection = LightSelection::Uniform);
// Acceleration for the software BVH: builds the tree over the triangles in
// the scene's order (as flatten_scene leaves them), reorders the triangle
// arrays into the tree's order and rebuilds the light table in that order.
// Throws SceneError (naming `source`) when the tree cannot be encoded
// (collapse_bvh4).
void build_scene_bvh(SceneArrays& arrays, const std::string& source);
// What a resolved traversal renders: flatten_scene, then for Traversal::Bvh
// build_scene_bvh (one light table, built once in the final order).
SceneArrays flatten_scene(const Scene& scene, Traversal traversal, LightSelection selection = LightSelection::Uniform);

class GpuScene {
public:
    // `kernel`: the device-class kernel the arrays are laid out for; Auto = the
    // context's (vk::Context::kernel). Tests compare the two on one device.
    // The software BVH traversal needs arrays with a BVH (SceneArrays::has_bvh);
    // ray query takes either order.
    GpuScene(const vk::Context& ctx, const SceneArrays& arrays, Traversal traversal,
             vk::KernelClass kernel = vk::KernelClass::Auto);
    Traversal traversal() const { return traversal_; }
    // The kernel the arrays were laid out for (the context's, vk::Context::kernel).
    vk::KernelClass kernel() const { return kernel_; }
    const RayTracingAccel* accel() const { return accel_.get(); }
    // The scene has instances: pipelines that trace it set SPEC_INSTANCES.
    bool instanced() const { return instanced_; }

    // tri_positions: SceneArrays::tri_positions, or with the GPU kernel's software
    // BVH GpuKernelTree::positions (its tree's order).
    vk::Buffer vertices, triangles, materials, emitters, light_triangles, bvh_nodes, tri_positions, texels, textures,
        environment, instances;
    // The CPU kernel reads every scene array (and the software traversal its
    // 4-wide BVH nodes and triangle positions) as uniform texel buffers of
    // RGBA32 uint texels (shaders/scene_data.glsl, trace_bvh.glsl): on lavapipe
    // a texel fetch loads a whole texel per invocation with vector loads, where
    // a storage-buffer load at a divergent address loops over the invocations
    // and bounds-checks every component (docs/performance.md). The GPU kernel
    // reads the same arrays, and the binary BVH's nodes, as storage buffers.
    // Binds this scene's traversal data (traversal_bindings(traversal())).
    void bind_traversal(vk::ComputePipeline& pipeline) const;
    // Binds every scene array and the traversal data (scene_bindings(traversal())).
    void bind_scene(vk::ComputePipeline& pipeline) const;

private:
    Traversal traversal_;
    vk::KernelClass kernel_;
    bool instanced_ = false;
    std::unique_ptr<RayTracingAccel> accel_;
    // (binding, buffer): the GPU kernel's scene arrays.
    std::vector<std::pair<uint32_t, ::vk::Buffer>> storage_;
    // (binding, view): the scene arrays; the software BVH's nodes and triangle positions.
    std::vector<std::pair<uint32_t, std::unique_ptr<::vk::raii::BufferView>>> views_, traversal_views_;
};

// The GPU kernel's software BVH (shaders/trace_bvh_gpu.glsl): a binary tree
// of its own over the scene's triangles, built with gpu_kernel_bvh_options()
// (measured on a GPU: docs/gpu.md), and the triangles' positions in that
// tree's order, 3 vec4 each, the first w holding the bits of the triangle's
// index in the scene arrays (what a hit reports). The scene arrays keep the
// order of their own tree (SceneArrays::bvh), which the CPU kernel runs.
//
// An instanced scene's tree has two levels: the top-level tree over the
// ordinary triangles and the instances' world boxes (an instance's entry:
// first w = INSTANCE_ENTRY_BIT | the instance), then each shape group's tree
// over its triangles in the group's space; `instances` are the arrays' with
// info.x set to their group's root node (one zero record in a scene without
// instances: a binding needs a buffer). Throws SceneError (naming `source`)
// where the two levels are too deep for the traversal's stack.
struct GpuKernelTree {
    std::vector<gpu::GpuBvhNode> nodes;
    std::vector<glm::vec4> positions;
    std::vector<gpu::GpuInstance> instances;
};
BvhBuildOptions gpu_kernel_bvh_options();
GpuKernelTree build_gpu_kernel_tree(const SceneArrays& arrays, const std::string& source = {});

// The descriptor bindings of a traversal's data (shaders/traversal.glsl): the
// TLAS for ray query; for the software BVH, the BVH and the triangle positions
// as uniform texel buffers (CPU kernel) or storage buffers (GPU kernel). t and
// k must be resolved (not Auto).
std::vector<vk::BindingDesc> traversal_bindings(Traversal t, vk::KernelClass k);
// The scene arrays' bindings (texel or storage buffers, by kernel) and the traversal's.
std::vector<vk::BindingDesc> scene_bindings(Traversal t, vk::KernelClass k);

// Auto: ray query on GPUs that have it; the BVH on CPU devices (faster there,
// measured) and on devices without ray query.
Traversal resolve_traversal(const vk::Context& ctx, Traversal requested);
// An instanced scene (SceneArrays::instanced) takes the GPU kernel on every
// device, whose two traversals have two levels: the software BVH's tree and
// ray query's TLAS of one BLAS per shape group (RayTracingAccel).

}  // namespace vkmech
