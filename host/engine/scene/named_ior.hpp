// Named optical constants accepted by Mitsuba's dielectric and conductor
// plugins (`int_ior="bk7"`, `material="Au"`), reduced to RGB.
#pragma once

#include <glm/glm.hpp>

#include <optional>
#include <string>
#include <string_view>

namespace vkmech {

// Mitsuba's dielectric IOR table (vacuum, air, water, bk7, diamond, ...),
// plus "glass" (1.5). Case-insensitive; nullopt when unknown.
std::optional<float> dielectric_ior(std::string_view name);

struct ComplexIor {
    glm::vec3 eta;
    glm::vec3 k;
};

// Conductor presets as RGB complex IOR sampled at R = 650 nm, G = 550 nm,
// B = 450 nm. "none" is Mitsuba's perfect mirror (eta 0, k 1). Element
// names are case-sensitive as in Mitsuba ("Au", "Ag", ...); nullopt when
// unknown.
std::optional<ComplexIor> conductor_ior(std::string_view name);
// Every name conductor_ior accepts, comma-separated (for error messages).
std::string conductor_names();

}  // namespace vkmech
