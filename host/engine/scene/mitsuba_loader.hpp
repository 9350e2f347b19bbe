// Internal to the Mitsuba XML loader (mitsuba_xml.cpp: scene structure,
// shapes, emitters, sensor, integrator; mitsuba_bsdf.cpp: BSDFs and
// textures). docs/descriptor.md §8 lists the plugins it must understand.
#pragma once

#include "scene/scene.hpp"
#include "scene/triangle_budget.hpp"
#include "scene/xml_document.hpp"
#include "scene/xml_node.hpp"

#include <map>
#include <memory>
#include <string>
#include <vector>

namespace vkmech {

class MitsubaLoader {
public:
    MitsubaLoader(const std::string& path, const LoadOptions& options);
    Scene load();

private:
    enum class IdKind { Bsdf, Texture, Emitter, Ignored, ShapeGroup };
    static const char* to_string(IdKind k);
    struct IdEntry {
        IdKind kind = IdKind::Bsdf;
        int index = -1;
        int line = 0;
        std::string file;
    };

    // ---- structure (mitsuba_xml.cpp) ----
    // Two passes over the scene and its includes, as Mitsuba resolves
    // references after parsing: declarations first (defaults, paths,
    // top-level bsdfs, textures, emitters, aliases), then everything that
    // may refer to them (shapes, the sensor, the integrator).
    enum class Pass { Declarations, Objects };
    void scene_element(const XmlDocument& doc, int depth, Pass pass);
    void child_of_scene(const XNode& n, int depth, Pass pass);
    void include(const XNode& n, int depth, Pass pass);
    void shape(const XNode& n);
    // <shape type="shapegroup" id=...>: its shapes become Scene::groups[g]'s
    // meshes (Mesh::group), seen only through <shape type="instance">.
    void shape_group(const XNode& n);
    void instance(const XNode& n);
    // Drops the groups that no instance uses (a warning each).
    void prune_uninstanced_groups();
    void shape_bsdf_and_emitter(const XNode& n, const XProps& p, Mesh& mesh);
    void emitter_top(const XNode& n);
    void sensor(const XNode& n);
    void integrator(const XNode& n);
    void add_substituted_panels();
    void add_substituted_point_lights();
    // Bounds of the geometry so far (a unit box at the camera when empty).
    void bounds(glm::vec3& lo, glm::vec3& hi) const;
    void prune_unused();
    void warn(const XNode& n, const std::string& what);
    // One warning listing the properties of `p` that nothing read (docs/descriptor.md §8).
    void warn_unused(const XProps& p);
    // A plugin vkmech replaces by its nearest model: allowed with
    // --substitute, else an error naming file, line, plugin and the
    // replacement; then the substitution is recorded.
    void require_substitute(const XNode& n, const std::string& kind, const std::string& replacement) const;
    void record_substitution(const XNode& n, const std::string& kind, const std::string& replacement);
    // An <emitter type="area">: index into scene_.emitters. A radiance given as a texture
    // puts the texture's index into `radiance_texture` (the radiance is then 1).
    int area_emitter(const XNode& n, int mesh_index, int& radiance_texture);
    glm::vec3 area_radiance(const XNode& n, const XProps& ep, int& radiance_texture);
    // envmap / constant: Scene::environment, or with LoadOptions::environment_panel a pending panel.
    void environment(const XNode& n, const XProps& p, const std::string& type);
    // sunsky (and Mitsuba 0.x's sun and sky) under --substitute: scene/sunsky.hpp's
    // Preetham sky as the environment and its sun as a directional light.
    void sunsky(const XNode& n, const XProps& p, const std::string& type);
    // Scene::environment, or with LoadOptions::environment_panel a pending panel;
    // a second environment is an error.
    void set_environment(const XNode& n, Environment env);
    std::string resolve(const XNode& n, const std::string& filename) const;
    [[noreturn]] void unsupported(const XNode& n, const std::string& kind, const std::string& extra = {}) const;

    // ---- materials (mitsuba_bsdf.cpp) ----
    int bsdf(const XNode& n);      // <bsdf> or <ref>: index into scene_.materials
    int bsdf_ref(const XNode& n);  // <ref id=...> to a bsdf
    int texture(const XNode& n);   // <texture> or <ref>: index into scene_.textures
    // principled's textured roughness and metallic as one texture (G, B: each texel's, or
    // checkerboard colour's, luminance, or the constant), read at each hit; -1 when neither is
    // textured, or both are of different layouts. The textured ones' constants become their means.
    int principled_texture(XProps& p);
    // The parameters of a model of the material table (m.type set): one case per BsdfType.
    void model_parameters(const XProps& p, const XNode& n, Material& m);
    void conductor_parameters(const XProps& p, const XNode& n, Material& m);
    // Mitsuba's blendbsdf: a Blend material over its two nested bsdfs (Material::blend_first).
    Material blend(const XProps& p, const XNode& n);
    // Mitsuba 0.6's mixturebsdf (sum of w_i f_i): a chain of Blend materials over its components
    // and, where the weights sum to less than 1, a black one for the rest; `id` its XML id or "".
    Material mixture(const XProps& p, const XNode& n, const std::string& id);
    // A copy of texture `source` holding its luminance (summed in double) in every channel, as
    // Mitsuba 3 reads a float texture; its index, and its mean in `mean`.
    int luminance_texture(int source, float& mean);
    // How many blends deep material `index` is (0: not a blend).
    int blend_depth(int index) const;
    // Whether material `index`, or a component of it, has a normal or a bump map.
    bool shading_normal_mapped(int index) const;
    // A colour-valued BSDF parameter: a constant, or a bitmap / checkerboard
    // texture (Spectrum3::value then holds the texture's mean).
    Spectrum3 reflectance(const XProps& p, std::initializer_list<const char*> names, glm::vec3 fallback);
    glm::mat3 to_uv(const XProps& p);
    int default_material();
    void register_id(const XNode& n, IdKind kind, int index);
    const IdEntry& lookup_ref(const XNode& n);  // <ref id=...>: its entry, or an error naming what exists

    std::string path_;
    LoadOptions options_;
    XmlParams params_;
    std::vector<std::unique_ptr<XmlDocument>> docs_;  // kept alive: XNodes point into them
    std::vector<std::string> include_stack_;
    Scene scene_;
    std::map<std::string, IdEntry> ids_;
    int default_material_ = -1;
    bool have_sensor_ = false;
    bool have_integrator_ = false;
    int major_version_ = 3;  // the root <scene version="...">'s major number (0.x files keep 0.x semantics)
    int shape_count_ = 0;
    int current_group_ = -1;  // the shapegroup whose shapes are being read, or -1
    TriangleBudget budget_;
    int bsdf_count_ = 0;

    struct PendingPanel {
        std::string what;  // for Scene::substitutions
        glm::vec3 radiance{1.0f};
    };
    std::vector<PendingPanel> panels_;
    struct PendingPointLight {
        std::string what;
        glm::vec3 position{0.0f};
        glm::vec3 intensity{1.0f};  // W/sr (Mitsuba's `intensity`)
    };
    std::vector<PendingPointLight> point_lights_;
    // Area emitters declared at top level with an id (used through <ref>).
    struct DeclaredEmitter {
        glm::vec3 radiance{1.0f};
        int uses = 0;
        int texture = -1;  // a textured radiance: index into scene_.textures
    };
    std::vector<DeclaredEmitter> declared_emitters_;
    std::vector<std::string> search_paths_;               // <path value=...>, Mitsuba's file resolver
    std::map<std::string, const XmlDocument*> included_;  // "file:line" of an <include> -> its document
};

}  // namespace vkmech
