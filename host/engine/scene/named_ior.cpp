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
    // The rest of Mitsuba's data/ior spectra, sampled the same way (Mitsuba 3's roughconductor
    // names these; the _palik and -e variants are Mitsuba 0.6's). AlSb is left out: its data
    // stops at 590 nm.
    {"a-C", {{2.4300f, 2.3569f, 2.1848f}, {0.7281f, 0.8344f, 0.8879f}}},
    {"AlAs", {{3.1146f, 3.2515f, 3.6445f}, {0.0000f, 0.0002f, 0.0016f}}},
    {"AlAs_palik", {{3.1146f, 3.2515f, 3.6445f}, {0.0000f, 0.0002f, 0.0016f}}},
    {"Be", {{3.4644f, 3.3641f, 3.0954f}, {3.2018f, 3.1729f, 3.1600f}}},
    {"Be_palik", {{3.4644f, 3.3641f, 3.0954f}, {3.2018f, 3.1729f, 3.1600f}}},
    {"CsI", {{1.7789f, 1.7945f, 1.8242f}, {0.0000f, 0.0000f, 0.0000f}}},
    {"CsI_palik", {{1.7789f, 1.7945f, 1.8242f}, {0.0000f, 0.0000f, 0.0000f}}},
    {"Cu2O", {{2.8997f, 3.0997f, 3.0602f}, {0.0999f, 0.1898f, 0.5993f}}},
    {"Cu2O_palik", {{2.8997f, 3.0997f, 3.0602f}, {0.0999f, 0.1898f, 0.5993f}}},
    {"Cu_palik", {{0.2185f, 0.9443f, 1.1658f}, {3.6367f, 2.5945f, 2.3897f}}},
    {"CuO", {{2.7207f, 2.5803f, 2.4503f}, {0.3996f, 0.5896f, 0.7697f}}},
    {"CuO_palik", {{2.7207f, 2.5803f, 2.4503f}, {0.3996f, 0.5896f, 0.7697f}}},
    {"d-C", {{2.4108f, 2.4229f, 2.4469f}, {0.0000f, 0.0000f, 0.0000f}}},
    {"d-C_palik", {{2.4108f, 2.4229f, 2.4469f}, {0.0000f, 0.0000f, 0.0000f}}},
    {"Hg", {{2.0734f, 1.5519f, 1.0607f}, {5.3388f, 4.6518f, 3.8630f}}},
    {"Hg_palik", {{2.0734f, 1.5519f, 1.0607f}, {5.3388f, 4.6518f, 3.8630f}}},
    {"HgTe", {{3.9072f, 3.3873f, 3.0033f}, {1.0769f, 1.6549f, 1.9365f}}},
    {"HgTe_palik", {{3.9072f, 3.3873f, 3.0033f}, {1.0769f, 1.6549f, 1.9365f}}},
    {"Ir", {{2.5646f, 2.2292f, 1.8276f}, {4.6715f, 4.3137f, 3.6628f}}},
    {"Ir_palik", {{2.5646f, 2.2292f, 1.8276f}, {4.6715f, 4.3137f, 3.6628f}}},
    {"K", {{0.0506f, 0.0493f, 0.0430f}, {1.7954f, 1.4438f, 1.0615f}}},
    {"K_palik", {{0.0506f, 0.0493f, 0.0430f}, {1.7954f, 1.4438f, 1.0615f}}},
    {"Li", {{0.2264f, 0.2062f, 0.2382f}, {3.0150f, 2.4742f, 1.9049f}}},
    {"Li_palik", {{0.2264f, 0.2062f, 0.2382f}, {3.0150f, 2.4742f, 1.9049f}}},
    {"MgO", {{1.7337f, 1.7405f, 1.7524f}, {0.0000f, 0.0000f, 0.0000f}}},
    {"MgO_palik", {{1.7337f, 1.7405f, 1.7524f}, {0.0000f, 0.0000f, 0.0000f}}},
    {"Mo", {{3.7354f, 3.7766f, 3.1020f}, {3.5754f, 3.5206f, 3.4596f}}},
    {"Mo_palik", {{3.7354f, 3.7766f, 3.1020f}, {3.5754f, 3.5206f, 3.4596f}}},
    {"Na_palik", {{0.0498f, 0.0586f, 0.0673f}, {2.7032f, 2.2482f, 1.8015f}}},
    {"Nb", {{2.7663f, 2.9296f, 2.6558f}, {2.8724f, 2.8704f, 2.8568f}}},
    {"Nb_palik", {{2.7663f, 2.9296f, 2.6558f}, {2.8724f, 2.8704f, 2.8568f}}},
    {"Rh", {{2.1938f, 1.9668f, 1.7507f}, {5.7406f, 5.0160f, 4.4523f}}},
    {"Rh_palik", {{2.1938f, 1.9668f, 1.7507f}, {5.7406f, 5.0160f, 4.4523f}}},
    {"Se", {{3.3538f, 3.0296f, 3.0946f}, {0.4140f, 0.6954f, 0.5694f}}},
    {"Se-e", {{4.6458f, 4.4294f, 4.5498f}, {0.4375f, 1.1958f, 1.6195f}}},
    {"Se-e_palik", {{4.6458f, 4.4294f, 4.5498f}, {0.4375f, 1.1958f, 1.6195f}}},
    {"Se_palik", {{3.3538f, 3.0296f, 3.0946f}, {0.4140f, 0.6954f, 0.5694f}}},
    {"SiC", {{2.6304f, 2.6618f, 2.7200f}, {0.0000f, 0.0000f, 0.0000f}}},
    {"SiC_palik", {{2.6304f, 2.6618f, 2.7200f}, {0.0000f, 0.0000f, 0.0000f}}},
    {"SnTe", {{3.7132f, 1.9647f, 1.5351f}, {0.0000f, 0.0000f, 0.0000f}}},
    {"SnTe_palik", {{3.7132f, 1.9647f, 1.5351f}, {0.0000f, 0.0000f, 0.0000f}}},
    {"Ta", {{1.5901f, 2.4706f, 2.8456f}, {2.2206f, 1.8376f, 2.1136f}}},
    {"Ta_palik", {{1.5901f, 2.4706f, 2.8456f}, {2.2206f, 1.8376f, 2.1136f}}},
    {"Te", {{6.0890f, 4.8135f, 3.1055f}, {2.3550f, 3.6290f, 3.6031f}}},
    {"Te-e", {{6.4855f, 4.6545f, 2.8408f}, {4.2365f, 5.2098f, 4.4377f}}},
    {"Te-e_palik", {{6.4855f, 4.6545f, 2.8408f}, {4.2365f, 5.2098f, 4.4377f}}},
    {"Te_palik", {{6.0890f, 4.8135f, 3.1055f}, {2.3550f, 3.6290f, 3.6031f}}},
    {"ThF4", {{1.5190f, 1.5210f, 1.5250f}, {0.0000f, 0.0000f, 0.0000f}}},
    {"ThF4_palik", {{1.5190f, 1.5210f, 1.5250f}, {0.0000f, 0.0000f, 0.0000f}}},
    {"TiC", {{3.1170f, 2.9936f, 2.8556f}, {2.7283f, 2.5065f, 2.4078f}}},
    {"TiC_palik", {{3.1170f, 2.9936f, 2.8556f}, {2.7283f, 2.5065f, 2.4078f}}},
    {"TiN", {{1.3928f, 1.2523f, 1.5000f}, {2.8531f, 2.1036f, 1.3111f}}},
    {"TiN_palik", {{1.3928f, 1.2523f, 1.5000f}, {2.8531f, 2.1036f, 1.3111f}}},
    {"TiO2", {{2.8599f, 2.9550f, 3.1650f}, {0.0000f, 0.0000f, 0.0000f}}},
    {"TiO2-e", {{2.5750f, 2.6500f, 2.8150f}, {0.0000f, 0.0000f, 0.0000f}}},
    {"TiO2-e_palik", {{2.5750f, 2.6500f, 2.8150f}, {0.0000f, 0.0000f, 0.0000f}}},
    {"TiO2_palik", {{2.8599f, 2.9550f, 3.1650f}, {0.0000f, 0.0000f, 0.0000f}}},
    {"V_palik", {{3.5039f, 3.6800f, 3.1004f}, {2.9854f, 3.0187f, 3.3912f}}},
    {"VC", {{3.0624f, 2.9142f, 2.8011f}, {2.5639f, 2.3409f, 2.1822f}}},
    {"VC_palik", {{3.0624f, 2.9142f, 2.8011f}, {2.5639f, 2.3409f, 2.1822f}}},
    {"VN", {{2.4054f, 2.2485f, 2.1478f}, {2.5356f, 2.1937f, 1.8244f}}},
    {"VN_palik", {{2.4054f, 2.2485f, 2.1478f}, {2.5356f, 2.1937f, 1.8244f}}},
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

std::string conductor_names() {
    std::string names;
    for (const auto& c : kConductors) names += std::string(names.empty() ? "" : ", ") + c.name;
    return names;
}

}  // namespace vkmech
