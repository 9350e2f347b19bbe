#include "render/features.hpp"

#include <stdexcept>

namespace vkmech {

const char* to_string(Estimator e) {
    switch (e) {
        case Estimator::Nee:
            return "nee";
        case Estimator::MisRestricted:
            return "mis-restricted";
        case Estimator::Mis:
            return "mis";
    }
    return "?";
}

Estimator parse_estimator(const std::string& s) {
    if (s == "nee") return Estimator::Nee;
    if (s == "mis-restricted") return Estimator::MisRestricted;
    if (s == "mis") return Estimator::Mis;
    throw std::invalid_argument("unknown estimator '" + s + "' (expected nee, mis-restricted or mis)");
}

const char* to_string(EndVertex e) { return e == EndVertex::Literal ? "literal" : "last-nondelta"; }

EndVertex parse_end_vertex(const std::string& s) {
    if (s == "last-nondelta") return EndVertex::LastNonDelta;
    if (s == "literal") return EndVertex::Literal;
    throw std::invalid_argument("unknown end-vertex reading '" + s + "' (expected last-nondelta or literal)");
}

Features Features::generic(Estimator e, bool capture) {
    Features f;
    f.estimator = e;
    f.capture = capture;
    return f;
}

Features Features::from_scene(const Scene& scene, Estimator e, bool capture) {
    Features f;
    f.thin_lens = scene.camera.type == CameraType::ThinLens && scene.camera.aperture_radius > 0.0f;
    f.orthographic = scene.camera.type == CameraType::Orthographic;
    f.materials = 0u;
    f.textures = false;
    f.tangents = false;
    for (const auto& m : scene.materials) {
        f.materials |= gpu::material_features(static_cast<uint32_t>(m.type));
        if (m.has_texture()) f.textures = true;
    }
    for (const auto& m : scene.meshes) f.tangents = f.tangents || scene.uses_tangents(m);
    f.environment = scene.environment.kind != EnvironmentKind::None || !scene.directional_lights.empty();
    f.capture = capture;
    f.estimator = e;
    return f;
}

std::string Features::describe() const {
    std::string s;
    auto add = [&](bool on, const char* name) {
        if (on) s += std::string(s.empty() ? "" : " ") + name;
    };
    add(thin_lens, "thin-lens");
    add(orthographic, "orthographic");
#define VKM_X(NAME, name, bit, spec_id) add((materials & gpu::FEATURE_BIT_##NAME) != 0u, #name);
    VKM_MATERIAL_FEATURES(VKM_X)
#undef VKM_X
    add(textures, "textures");
    add(tangents, "tangents");
    add(environment, "environment");
    add(capture, "capture");
    add(debug_events, "debug-events");
    add(direct_glossy, "direct-glossy");
    add(counters, "counters");
    add(!taxonomy.empty(), "taxonomy");
    if (s.empty()) s = "diffuse-only";
    s += std::string(" estimator=") + to_string(estimator);
    if (end_vertex != EndVertex::LastNonDelta) s += std::string(" end-vertex=") + to_string(end_vertex);
    return s;
}

}  // namespace vkmech
