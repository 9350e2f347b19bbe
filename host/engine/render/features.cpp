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
    f.dielectric = f.rough = f.plastic = f.principled = f.conductor = f.textures = false;
    for (const auto& m : scene.materials) {
        switch (m.type) {
            case BsdfType::Diffuse:
                break;
            case BsdfType::Plastic:
                f.plastic = true;
                break;
            case BsdfType::RoughPlastic:
                f.plastic = f.rough = true;
                break;
            case BsdfType::Conductor:
                f.conductor = true;
                break;
            case BsdfType::RoughConductor:
                f.conductor = f.rough = true;
                break;
            case BsdfType::Dielectric:
            case BsdfType::ThinDielectric:
                f.dielectric = true;
                break;
            case BsdfType::RoughDielectric:
                f.dielectric = f.rough = true;
                break;
            case BsdfType::Principled:
                f.principled = f.rough = true;
                break;
        }
        if (m.reflectance.texture >= 0 || m.specular_reflectance_texture >= 0 || m.specular_transmittance_texture >= 0)
            f.textures = true;
    }
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
    add(dielectric, "dielectric");
    add(rough, "rough");
    add(plastic, "plastic");
    add(principled, "principled");
    add(conductor, "conductor");
    add(textures, "textures");
    add(capture, "capture");
    add(debug_events, "debug-events");
    add(direct_glossy, "direct-glossy");
    add(counters, "counters");
    if (s.empty()) s = "diffuse-only";
    s += std::string(" estimator=") + to_string(estimator);
    if (end_vertex != EndVertex::LastNonDelta) s += std::string(" end-vertex=") + to_string(end_vertex);
    return s;
}

}  // namespace vkmech
