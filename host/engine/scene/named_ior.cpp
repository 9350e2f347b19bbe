#include "scene/named_ior.hpp"

#include "scene/text_parse.hpp"

#include <string>

namespace vkmech {

namespace {

struct NamedIor {
    const char* name;
    float ior;
};

// Mitsuba's table (include/mitsuba/render/ior.h): same names and values.
constexpr NamedIor kDielectrics[] = {
    {"vacuum", 1.0f},
    {"helium", 1.000036f},
    {"hydrogen", 1.000132f},
    {"air", 1.000277f},
    {"carbon dioxide", 1.00045f},
    {"water", 1.3330f},
    {"acetone", 1.36f},
    {"ethanol", 1.361f},
    {"carbon tetrachloride", 1.461f},
    {"glycerol", 1.4729f},
    {"benzene", 1.501f},
    {"silicone oil", 1.52045f},
    {"bromine", 1.661f},
    {"water ice", 1.31f},
    {"fused quartz", 1.458f},
    {"pyrex", 1.470f},
    {"acrylic glass", 1.49f},
    {"polypropylene", 1.49f},
    {"bk7", 1.5046f},
    {"sodium chloride", 1.544f},
    {"amber", 1.55f},
    {"pet", 1.5750f},
    {"diamond", 2.419f},
    // Not in Mitsuba's table, but a common spelling in hand-written scenes.
    {"glass", 1.5f},
};

struct NamedConductor {
    const char* name;
    ComplexIor ior;
};

// Au, Ag, Al, Cu, Cr, W, Ni: Mitsuba's measured spectra (data/ior/*.spd,
// luxpop / Palik) linearly interpolated at 650, 550 and 450 nm. Fe, Pt, Ti
// are not in Mitsuba's table; they use widely quoted RGB fits of the same
// kind of data (their normal-incidence reflectance matches the measured
// ~0.53-0.56 for Fe, ~0.59-0.68 for Pt, ~0.45-0.54 for Ti).
const NamedConductor kConductors[] = {
    {"Au", {{0.1678f, 0.3504f, 1.5085f}, {3.1378f, 2.7141f, 1.8788f}}},
    {"Ag", {{0.1394f, 0.1248f, 0.1517f}, {4.1288f, 3.3396f, 2.4704f}}},
    {"Al", {{1.4748f, 0.9586f, 0.6180f}, {7.7941f, 6.6870f, 5.4694f}}},
    {"Cu", {{0.2166f, 0.9582f, 1.1658f}, {3.6377f, 2.5771f, 2.3939f}}},
    {"Cr", {{3.6375f, 3.1158f, 1.9277f}, {4.3644f, 4.4228f, 4.1675f}}},
    {"W", {{3.6925f, 3.5000f, 3.3090f}, {2.9370f, 2.7291f, 2.5258f}}},
    {"Ni", {{2.0140f, 1.7724f, 1.6288f}, {3.8079f, 3.2526f, 2.6540f}}},
    {"Ni_palik", {{2.0140f, 1.7724f, 1.6288f}, {3.8079f, 3.2526f, 2.6540f}}},
    {"Fe", {{2.9114f, 2.9497f, 2.5845f}, {3.0893f, 2.9318f, 2.7670f}}},
    {"Pt", {{2.3757f, 2.0847f, 1.8453f}, {4.2655f, 3.7153f, 3.1365f}}},
    {"Ti", {{2.7407f, 2.5418f, 2.2670f}, {3.8143f, 3.4345f, 3.0385f}}},
    {"none", {{0.0f, 0.0f, 0.0f}, {1.0f, 1.0f, 1.0f}}},
};

}  // namespace

std::optional<float> dielectric_ior(std::string_view name) {
    std::string n = text::lower(text::trim(name));
    for (const auto& d : kDielectrics)
        if (n == d.name) return d.ior;
    return std::nullopt;
}

std::optional<ComplexIor> conductor_ior(std::string_view name) {
    for (const auto& c : kConductors)
        if (name == c.name) return c.ior;
    return std::nullopt;
}

}  // namespace vkmech
