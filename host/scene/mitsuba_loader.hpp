// Internal to the Mitsuba XML loader (mitsuba_xml.cpp: scene structure,
// shapes, emitters, sensor, integrator; mitsuba_bsdf.cpp: BSDFs and
// textures). SPEC §8 lists the plugins it must understand.
#pragma once

#include "scene/scene.hpp"
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
    // ---- structure (mitsuba_xml.cpp) ----
    void scene_element(const XmlDocument& doc, int depth);
    void child_of_scene(const XNode& n, int depth);
    void include(const XNode& n, int depth);
    void shape(const XNode& n);
    void shape_bsdf_and_emitter(const XNode& n, const XProps& p, Mesh& mesh);
    void emitter_top(const XNode& n);
    void sensor(const XNode& n);
    void integrator(const XNode& n);
    void add_substituted_panels();
    void prune_unused();
    std::string resolve(const XNode& n, const std::string& filename) const;
    [[noreturn]] void unsupported(const XNode& n, const std::string& kind, const std::string& extra = {}) const;

    // ---- materials (mitsuba_bsdf.cpp) ----
    int bsdf(const XNode& n);            // <bsdf> or <ref>: index into scene_.materials
    int bsdf_ref(const XNode& n);        // <ref id=...> to a bsdf
    int texture(const XNode& n);         // <texture> or <ref>: index into scene_.textures
    Spectrum3 reflectance(const XProps& p, std::initializer_list<const char*> names, glm::vec3 fallback);
    int default_material();
    void register_id(const XNode& n, bool is_bsdf, int index);

    struct IdEntry {
        bool is_bsdf = true;
        int index = -1;
        int line = 0;
        std::string file;
    };

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
    int shape_count_ = 0;
    int bsdf_count_ = 0;

    struct PendingPanel {
        std::string what;  // for Scene::substitutions
        glm::vec3 radiance{1.0f};
    };
    std::vector<PendingPanel> panels_;
};

}  // namespace vkmech
