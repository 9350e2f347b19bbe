// Internal to the glTF 2.0 loader, docs/descriptor.md §8 (gltf_file.cpp: the file,
// extensions, buffers and accessors; gltf_loader.cpp: the node hierarchy,
// meshes, the camera and KHR_lights_punctual; gltf_materials.cpp:
// materials, textures, emission).
// tinygltf parses the JSON and the buffers; everything it hands over is
// validated here before use, so a hostile file gives a SceneError.
#pragma once

#include "scene/scene.hpp"
#include "scene/triangle_budget.hpp"

#include <tiny_gltf.h>

#include <glm/glm.hpp>

#include <array>
#include <cstdint>
#include <map>
#include <set>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

namespace vkmech {

// "node 3 'Lamp'": how messages name a glTF object.
inline std::string labelled(const char* kind, int index, const std::string& name) {
    std::string s = std::string(kind) + " " + std::to_string(index);
    return name.empty() ? s : s + " '" + name + "'";
}

class GltfLoader {
public:
    GltfLoader(const std::string& path, const LoadOptions& options);
    Scene load();

private:
    // ---- the file (gltf_file.cpp) ----
    void parse();
    void check_extensions();
    // Accessors: validated views of buffer data.
    struct AccessorData {
        const unsigned char* base = nullptr;  // null: no bufferView, all zeros (glTF 2.0 §3.6.2)
        size_t stride = 0;
        size_t count = 0;
        int component_type = 0;
        int components = 0;
        bool normalized = false;
    };
    AccessorData accessor(int index, int type, const std::string& what) const;
    std::vector<glm::vec3> read_vec3(int index, const std::string& what) const;
    std::vector<glm::vec2> read_vec2(int index, const std::string& what) const;
    std::vector<glm::vec4> read_vec4(int index, const std::string& what) const;
    template <int N>
    std::vector<glm::vec<N, float>> read_vec(int index, const std::string& what) const;  // VEC2, VEC3 or VEC4
    std::vector<uint32_t> read_indices(int index, const std::string& what) const;
    // The bytes of buffer view `view`, checked against its buffer.
    std::pair<const unsigned char*, size_t> view_bytes(int view, const std::string& what) const;

    // ---- structure (gltf_loader.cpp) ----
    std::vector<int> scene_roots() const;
    void walk_nodes();
    glm::dmat4 local_transform(int node) const;
    void add_mesh(int node, const glm::dmat4& world);
    void add_primitive(int node, int mesh, int primitive, const glm::dmat4& world);
    void set_camera(int node, const glm::dmat4& world);
    void note_light(int node, const glm::dmat4& world);
    void add_light_spheres();
    void framing_camera();
    void scene_bounds(glm::vec3& lo, glm::vec3& hi) const;

    // ---- materials (gltf_materials.cpp) ----
    int material(int index);  // scene material for glTF material `index` (-1: the default)
    glm::vec3 emission(int index);
    Material convert_material(const tinygltf::Material& g, const std::string& label);
    // A colour texture (base colour, emission: sRGB-decoded; `raw`: the values as stored, e.g. the
    // metallic-roughness texture) times `factor` channel by channel, its mean in `mean`; `what` names
    // it in messages. -1 where it cannot be used (another TEXCOORD set, with a warning).
    int color_texture(const tinygltf::TextureInfo& info, const glm::vec3& factor, const std::string& label,
                      glm::vec3& mean, const char* what = "baseColorTexture", bool raw = false);
    std::string material_label(int index) const;
    // KHR_texture_transform on a texture reference as Texture::to_uv (identity without it).
    glm::mat3 texture_transform(const tinygltf::TextureInfo& info, const std::string& label);

    [[noreturn]] void fail(const std::string& what) const { throw SceneError(path_, 0, what); }
    void warn(const std::string& what) { scene_.warnings.push_back(path_ + ": " + what); }
    void warn_once(const std::string& key, const std::string& what);

    std::string path_;
    LoadOptions options_;
    tinygltf::Model model_;
    Scene scene_;
    std::map<int, int> material_map_;  // glTF material (-1: default) -> Scene::materials
    // (image, premultiplied factor) -> Scene::textures
    // (image, factor, raw, uv transform rows 0 and 1) -> texture
    std::map<std::tuple<int, float, float, float, bool, std::array<float, 6>>, int> texture_map_;
    std::set<std::string> warned_;
    bool have_camera_ = false;
    size_t skipped_primitives_ = 0;
    TriangleBudget budget_;

    struct PendingLight {
        int light = -1;
        int node = -1;
        glm::vec3 position{0.0f};
    };
    std::vector<PendingLight> lights_;
};

}  // namespace vkmech
