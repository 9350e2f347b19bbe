#include "scene/sunsky.hpp"

#include <algorithm>
#include <cmath>

namespace vkmech {

namespace {

constexpr double kPi = 3.14159265358979323846;

double deg(double rad) { return rad * 180.0 / kPi; }
double rad(double deg) { return deg * kPi / 180.0; }

// The Julian day number of a Gregorian date (Fliegel and Van Flandern), with
// C's truncating division, as the PSA paper states it.
long julian_day_number(long y, long m, long d) {
    long a = (m - 14) / 12;
    return (1461 * (y + 4800 + a)) / 4 + (367 * (m - 2 - 12 * a)) / 12 - (3 * ((y + 4900 + a) / 100)) / 4 + d - 32075;
}

double wrap_two_pi(double a) {
    a = std::fmod(a, 2.0 * kPi);
    return a < 0.0 ? a + 2.0 * kPi : a;
}

// Perez et al.'s all-weather distribution, relative to its value at the zenith.
struct Perez {
    double a, b, c, d, e;
    double operator()(double cos_theta, double gamma) const {
        double ct = std::max(cos_theta, 1e-4);
        double cg = std::cos(gamma);
        return (1.0 + a * std::exp(b / ct)) * (1.0 + c * std::exp(d * gamma) + e * cg * cg);
    }
};

// Preetham et al. 1999, table 2 (Y, x, y), linear in the turbidity.
Perez perez_Y(double t) {
    return {0.1787 * t - 1.4630, -0.3554 * t + 0.4275, -0.0227 * t + 5.3251, 0.1206 * t - 2.5771, -0.0670 * t + 0.3703};
}
Perez perez_x(double t) {
    return {-0.0193 * t - 0.2592, -0.0665 * t + 0.0008, -0.0004 * t + 0.2125, -0.0641 * t - 0.8989,
            -0.0033 * t + 0.0452};
}
Perez perez_y(double t) {
    return {-0.0167 * t - 0.2608, -0.0950 * t + 0.0092, -0.0079 * t + 0.2102, -0.0441 * t - 1.6537,
            -0.0109 * t + 0.0529};
}

// The zenith chromaticity: [T^2 T 1] M [ts^3 ts^2 ts 1]^T (the paper's appendix).
double zenith_chromaticity(const double m[3][4], double t, double ts) {
    const double tv[3] = {t * t, t, 1.0};
    const double sv[4] = {ts * ts * ts, ts * ts, ts, 1.0};
    double r = 0.0;
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 4; ++j) r += tv[i] * m[i][j] * sv[j];
    return r;
}

glm::dvec3 xyY_to_srgb(double x, double y, double Y) {
    if (!(y > 0.0) || !(Y > 0.0)) return glm::dvec3(0.0);
    double X = x * Y / y;
    double Z = (1.0 - x - y) * Y / y;
    glm::dvec3 c(3.2404542 * X - 1.5371385 * Y - 0.4985314 * Z, -0.9692660 * X + 1.8760108 * Y + 0.0415560 * Z,
                 0.0556434 * X - 0.2040259 * Y + 1.0572252 * Z);
    return glm::max(c, glm::dvec3(0.0));
}

// Solar radiance outside the atmosphere, W m^-2 sr^-1 nm^-1 (Preetham et al. 1999's
// table, 10 nm steps) at the three wavelengths vkmech's RGB stands for.
constexpr double kSunRadiance650 = 22339.8, kSunRadiance550 = 25503.8, kSunRadiance450 = 29658.3;
constexpr double kSunAperture = 0.5338;  // degrees: Mitsuba's normal sun

glm::dvec3 up_axis(bool mitsuba3) { return mitsuba3 ? glm::dvec3(0, 0, 1) : glm::dvec3(0, 1, 0); }

}  // namespace

SolarAngles solar_angles(const SunTime& t) {
    // Blanco-Muriel, Alarcón-Padilla, López-Moratalla and Lara-Coira (2001), "Computing the
    // solar vector", Solar Energy 70(5): days from J2000.0, ecliptic, celestial, then local
    // coordinates with the parallax correction.
    const double hours_ut = t.hour - t.timezone + (t.minute + t.second / 60.0) / 60.0;
    const double jd = static_cast<double>(julian_day_number(t.year, t.month, t.day)) - 0.5 + hours_ut / 24.0;
    const double n = jd - 2451545.0;

    const double omega = 2.1429 - 0.0010394594 * n;
    const double mean_longitude = 4.8950630 + 0.017202791698 * n;
    const double mean_anomaly = 6.2400600 + 0.0172019699 * n;
    const double ecl_longitude = mean_longitude + 0.03341607 * std::sin(mean_anomaly) +
                                 0.00034894 * std::sin(2.0 * mean_anomaly) - 0.0001134 - 0.0000203 * std::sin(omega);
    const double obliquity = 0.4090928 - 6.2140e-9 * n + 0.0000396 * std::cos(omega);

    const double sl = std::sin(ecl_longitude);
    const double right_ascension = wrap_two_pi(std::atan2(std::cos(obliquity) * sl, std::cos(ecl_longitude)));
    const double declination = std::asin(std::sin(obliquity) * sl);

    const double gmst_hours = 6.6974243242 + 0.0657098283 * n + hours_ut;
    const double lmst = rad(gmst_hours * 15.0 + t.longitude);
    const double lat = rad(t.latitude);
    const double hour_angle = lmst - right_ascension;

    SolarAngles a;
    a.zenith = std::acos(
        std::clamp(std::cos(lat) * std::cos(hour_angle) * std::cos(declination) + std::sin(declination) * std::sin(lat),
                   -1.0, 1.0));
    a.azimuth = wrap_two_pi(std::atan2(-std::sin(hour_angle),
                                       std::tan(declination) * std::cos(lat) - std::sin(lat) * std::cos(hour_angle)));
    constexpr double kEarthRadiusKm = 6371.01, kAstronomicalUnitKm = 149597890.0;
    a.zenith += kEarthRadiusKm / kAstronomicalUnitKm * std::sin(a.zenith);
    return a;
}

glm::dvec3 sun_direction_local(const SolarAngles& a, bool mitsuba3) {
    const double st = std::sin(a.zenith), ct = std::cos(a.zenith);
    if (mitsuba3) {
        // Mitsuba 3 turns the azimuth by pi and maps (theta, phi) to (sin t cos p, sin t sin p, cos t).
        const double phi = a.azimuth - kPi;
        return {st * std::cos(phi), st * std::sin(phi), ct};
    }
    // Mitsuba 0.x: (sin p sin t, cos t, -cos p sin t).
    return {std::sin(a.azimuth) * st, ct, -std::cos(a.azimuth) * st};
}

double rgb_luminance(const glm::dvec3& c) { return 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z; }

glm::dvec3 preetham_sky_rgb(double theta, double gamma, double theta_sun, double turbidity) {
    const double cos_theta = std::cos(theta);
    if (cos_theta < 0.0) return glm::dvec3(0.0);
    const double t = std::clamp(turbidity, 2.0, 10.0);
    const double ts = std::clamp(theta_sun, 0.0, kPi / 2.0);

    const double chi = (4.0 / 9.0 - t / 120.0) * (kPi - 2.0 * ts);
    const double zenith_Y = (4.0453 * t - 4.9710) * std::tan(chi) - 0.2155 * t + 2.4192;  // kcd/m²
    static const double mx[3][4] = {{0.00166, -0.00375, 0.00209, 0.0},
                                    {-0.02903, 0.06377, -0.03202, 0.00394},
                                    {0.11693, -0.21196, 0.06052, 0.25886}};
    static const double my[3][4] = {{0.00275, -0.00610, 0.00317, 0.0},
                                    {-0.04214, 0.08970, -0.04153, 0.00516},
                                    {0.15346, -0.26756, 0.06670, 0.26688}};
    const double zenith_x = zenith_chromaticity(mx, t, ts);
    const double zenith_y = zenith_chromaticity(my, t, ts);

    const Perez pY = perez_Y(t), px = perez_x(t), py = perez_y(t);
    const double Y = zenith_Y * pY(cos_theta, gamma) / pY(1.0, ts);
    const double x = zenith_x * px(cos_theta, gamma) / px(1.0, ts);
    const double y = zenith_y * py(cos_theta, gamma) / py(1.0, ts);
    return xyY_to_srgb(x, y, std::max(Y, 0.0) * 1000.0 / kNitsPerMitsubaUnit);
}

glm::dvec3 sun_irradiance_rgb(double theta_sun, double turbidity) {
    if (!(theta_sun < kPi / 2.0)) return glm::dvec3(0.0);
    const double t = std::clamp(turbidity, 2.0, 10.0);
    // Relative optical air mass (Kasten 1966, as in Preetham et al.'s appendix).
    const double air_mass = 1.0 / (std::cos(theta_sun) + 0.15 * std::pow(93.885 - deg(theta_sun), -1.253));
    const double beta = 0.04608 * t - 0.04586;  // Angstrom's turbidity coefficient, alpha = 1.3
    const double solid_angle = 2.0 * kPi * (1.0 - std::cos(rad(kSunAperture) / 2.0));
    auto at = [&](double radiance, double lambda_um) {
        double rayleigh = std::exp(-0.008735 * std::pow(lambda_um, -4.08) * air_mass);
        double aerosol = std::exp(-beta * std::pow(lambda_um, -1.3) * air_mass);
        return radiance * solid_angle * rayleigh * aerosol;
    };
    return {at(kSunRadiance650, 0.65), at(kSunRadiance550, 0.55), at(kSunRadiance450, 0.45)};
}

Environment bake_preetham_sky(const SunskySpec& s, int width) {
    const int w = std::max(width, 8), h = w / 2;
    const glm::dmat3 rot(s.rotation);
    const glm::dmat3 to_local = glm::transpose(rot);
    const glm::dvec3 up = up_axis(s.mitsuba3);
    const glm::dvec3 sun_local = glm::normalize(to_local * s.sun_world);
    const double theta_sun = std::acos(std::clamp(glm::dot(sun_local, up), -1.0, 1.0));

    Environment env;
    env.kind = EnvironmentKind::Map;
    env.scale = static_cast<float>(s.sky_scale);
    env.to_world = glm::mat3(1.0f);  // baked in world directions
    env.map.path = "preetham-sky";
    env.map.width = w;
    env.map.height = h;
    env.map.rgb.assign(static_cast<size_t>(w) * h * 3, 0.0f);
    for (int yi = 0; yi < h; ++yi) {
        const double theta = kPi * (yi + 0.5) / h;
        for (int xi = 0; xi < w; ++xi) {
            const double phi = 2.0 * kPi * (xi + 0.5) / w;
            // The map's own frame (shaders/environment.glsl): (sin t sin p, cos t, -sin t cos p).
            const glm::dvec3 world(std::sin(theta) * std::sin(phi), std::cos(theta), -std::sin(theta) * std::cos(phi));
            const glm::dvec3 local = to_local * world;
            const double view_theta = std::acos(std::clamp(glm::dot(local, up), -1.0, 1.0));
            const double gamma = std::acos(std::clamp(glm::dot(local, sun_local), -1.0, 1.0));
            const glm::dvec3 c = preetham_sky_rgb(view_theta, gamma, theta_sun, s.turbidity);
            float* px = &env.map.rgb[3 * (static_cast<size_t>(yi) * w + xi)];
            for (int k = 0; k < 3; ++k) px[k] = static_cast<float>(c[k]);
        }
    }
    return env;
}

DirectionalLight sun_light(const SunskySpec& s) {
    const glm::dmat3 to_local = glm::transpose(glm::dmat3(s.rotation));
    const glm::dvec3 sun_local = glm::normalize(to_local * s.sun_world);
    const double theta_sun = std::acos(std::clamp(glm::dot(sun_local, up_axis(s.mitsuba3)), -1.0, 1.0));
    DirectionalLight l;
    l.direction = glm::vec3(-glm::normalize(s.sun_world));
    l.irradiance = glm::vec3(sun_irradiance_rgb(theta_sun, s.turbidity) * s.sun_scale);
    return l;
}

}  // namespace vkmech
