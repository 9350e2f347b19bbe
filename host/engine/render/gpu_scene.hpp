// The scene flattened into GPU arrays (one vertex and one triangle list in
// BVH order, materials, emitters, the light-selection table) and
// uploaded with the chosen traversal's acceleration structure.
#pragma once

#include "accel/bvh.hpp"
#include "accel/rt_accel.hpp"
#include "scene/scene.hpp"
#include "shared/types.h"
#include "vk/buffer.hpp"

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

struct SceneArrays {
    std::vector<gpu::GpuVertex> vertices;
    std::vector<glm::uvec4> triangles;     // i0, i1, i2, material|emitter|flat (BVH order)
    std::vector<uint32_t> triangle_mesh;   // mesh index of each triangle (BVH order)
    std::vector<glm::vec4> tri_positions;  // 3 per triangle (BVH order)
    std::vector<gpu::GpuMaterial> materials;
    std::vector<gpu::GpuEmitter> emitters;
    std::vector<gpu::GpuLightTriangle> light_triangles;
    std::vector<glm::vec4> texels;        // every texture's linear RGB texels
    std::vector<glm::uvec4> textures;     // gpu::TEX_WORDS per texture (shared/types.h)
    Bvh bvh;
    float light_weight_total = 0.0f;  // sum of the light-selection weights (power: luminance x area)
    LightSelection light_selection = LightSelection::Uniform;
    glm::vec3 bbox_lo{0.0f}, bbox_hi{0.0f};
};

// Throws SceneError for scenes that cannot be rendered (no triangles).
SceneArrays flatten_scene(const Scene& scene, LightSelection selection = LightSelection::Uniform);

class GpuScene {
public:
    GpuScene(const vk::Context& ctx, const SceneArrays& arrays, Traversal traversal);
    Traversal traversal() const { return traversal_; }
    const RayTracingAccel* accel() const { return accel_.get(); }

    vk::Buffer vertices, triangles, materials, emitters, light_triangles, bvh_nodes, tri_positions, texels, textures;

private:
    Traversal traversal_;
    std::unique_ptr<RayTracingAccel> accel_;
};

// Auto: ray query on GPUs that have it; the BVH on CPU devices (faster there,
// measured) and on devices without ray query.
Traversal resolve_traversal(const vk::Context& ctx, Traversal requested);

}  // namespace vkmech
