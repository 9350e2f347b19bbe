// Mitsuba's `sunsky` (and Mitsuba 0.x's `sun` and `sky`) under --substitute
// (docs/descriptor.md §8, "sunsky"). Mitsuba renders the Hosek-Wilkie sky and
// sun from measured datasets that no Debian package ships, so vkmech
// substitutes documented analytic models in the same physical units:
// - the sky: Preetham, Shirley and Smits (1999), "A Practical Analytic Model
//   for Daylight": the Perez distribution in xyY, zenith luminance in kcd/m²,
//   baked into a lat-long environment map (zero below the horizon);
// - the sun: a directional light whose irradiance is the solar radiance outside
//   the atmosphere (the same paper's table, at 650 / 550 / 450 nm for R, G, B)
//   times the sun's solid angle and the Rayleigh and aerosol (Angstrom)
//   transmittances along the relative air mass.
// Mitsuba's sunsky radiance is spectral, W m^-2 sr^-1 nm^-1; an RGB value v
// there has luminance 683 lm/W x 106.857 nm (the integral of CIE y-bar) x v
// cd/m², which converts Preetham's luminance. The sun's position follows the
// PSA algorithm (Blanco-Muriel et al. 2001) from Mitsuba's location and time
// parameters, or `sun_direction`.
#pragma once

#include "scene/scene.hpp"

#include <glm/glm.hpp>
#include <string>

namespace vkmech {

// The sun's zenith angle and azimuth (radians) as the PSA algorithm gives them
// for a local date, time (hours, minutes, seconds; `timezone` hours east of
// UTC) and place (degrees, east and north positive).
struct SolarAngles {
    double zenith = 0.0;
    double azimuth = 0.0;  // from the algorithm's own origin, in [0, 2 pi)
};
struct SunTime {
    int year = 2010, month = 7, day = 10;
    double hour = 15.0, minute = 0.0, second = 0.0;
    double latitude = 35.6894, longitude = 139.6917, timezone = 9.0;  // Mitsuba's defaults: Tokyo
};
SolarAngles solar_angles(const SunTime& t);

// The unit direction towards the sun in the emitter's local frame, as each
// Mitsuba places it: Mitsuba 3 is z-up, the azimuth turned by pi (so the noon
// sun of the northern hemisphere lies towards +x); Mitsuba 0.x is y-up, its
// own spherical mapping (the noon sun towards +z).
glm::dvec3 sun_direction_local(const SolarAngles& a, bool mitsuba3);

// Preetham's sky: linear sRGB radiance in Mitsuba's sunsky units towards a
// direction at zenith angle theta and angle gamma from the sun, the sun at
// zenith angle theta_sun (clamped to the horizon), for turbidity T (clamped to
// [2, 10], where the model is defined). Zero below the horizon.
glm::dvec3 preetham_sky_rgb(double theta, double gamma, double theta_sun, double turbidity);

// The sun's irradiance on a surface facing it (R, G, B at 650, 550, 450 nm), in
// Mitsuba's units (W m^-2 nm^-1): solar radiance x the solid angle of a disc
// 0.5338 degrees across x the transmittance at the relative air mass of zenith
// angle theta_sun. Zero below the horizon. (Mitsuba's `sun_aperture` resizes the
// disc at constant power, so it does not enter.)
glm::dvec3 sun_irradiance_rgb(double theta_sun, double turbidity);

// Luminance of linear sRGB (Rec. 709 Y).
double rgb_luminance(const glm::dvec3& c);
// cd/m² per unit of Mitsuba's spectral radiance: 683 x 106.857.
constexpr double kNitsPerMitsubaUnit = 683.0 * 106.856895;

// What a sunsky element describes, in the scene's world frame.
struct SunskySpec {
    double turbidity = 3.0;
    glm::dvec3 sun_world{0.0, 0.0, 1.0};  // unit, towards the sun
    glm::mat3 rotation{1.0f};             // emitter to world (a rotation)
    bool mitsuba3 = true;                 // the local frame's up axis: z (3.x) or y (0.x)
    double sun_scale = 1.0, sky_scale = 1.0;
    bool want_sun = true, want_sky = true;  // Mitsuba 0.x `sun` / `sky` give one each
};
// The sky baked into a lat-long map (width x width/2) in the world frame,
// radiance x sky_scale; the map's `path` reads "preetham-sky".
Environment bake_preetham_sky(const SunskySpec& s, int width = 512);
// The sun as a directional light (travelling away from the sun).
DirectionalLight sun_light(const SunskySpec& s);

}  // namespace vkmech
