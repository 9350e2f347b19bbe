#include "scene/environment.hpp"

#include "scene/image_texture.hpp"

#include <cmath>
#include <filesystem>
#include <sstream>
#include <stdexcept>

namespace vkmech {

namespace {

constexpr double kPi = 3.14159265358979323846;

std::string fmt_rgb(const glm::vec3& v) {
    std::ostringstream s;
    s << "(" << v.x << ", " << v.y << ", " << v.z << ")";
    return s.str();
}

}  // namespace

glm::mat3 environment_rotation(const glm::mat3& to_world) {
    glm::mat3 r;
    for (int c = 0; c < 3; ++c) {
        float len = glm::length(to_world[c]);
        if (!(len > 0.0f) || !std::isfinite(len))
            throw std::runtime_error("its to_world has a zero or non-finite axis");
        r[c] = to_world[c] / len;
    }
    for (int a = 0; a < 3; ++a)
        for (int b = a + 1; b < 3; ++b)
            if (std::abs(glm::dot(r[a], r[b])) > 1e-3f)
                throw std::runtime_error("its to_world is not a rotation (the axes are not orthogonal)");
    if (glm::determinant(r) < 0.0f) throw std::runtime_error("its to_world mirrors (negative determinant)");
    return r;
}

Environment load_environment_map(const std::string& path, float scale, const glm::mat3& to_world) {
    if (!(scale >= 0.0f) || !std::isfinite(scale))
        throw std::runtime_error("the environment's scale must be a finite number >= 0");
    Environment env;
    env.kind = EnvironmentKind::Map;
    env.scale = scale;
    env.to_world = environment_rotation(to_world);
    try {
        env.map = load_image_texture(path, /*raw=*/true);
    } catch (const std::exception& e) {
        throw std::runtime_error("cannot read environment map '" + path + "': " + e.what());
    }
    env.map.path = path;
    if (env.map.width < 2 || env.map.height < 1)
        throw std::runtime_error("environment map '" + path + "' is smaller than 2 x 1 pixels");
    for (float v : env.map.rgb)
        if (!std::isfinite(v) || v < 0.0f)
            throw std::runtime_error("environment map '" + path + "' has negative or non-finite pixels");
    return env;
}

glm::vec3 environment_mean_radiance(const Environment& env) {
    if (env.kind == EnvironmentKind::Constant) return env.radiance;
    if (env.kind != EnvironmentKind::Map) return glm::vec3(0.0f);
    // Row y covers polar angle theta = pi (y + 0.5) / h, weighted by sin(theta).
    const Texture& t = env.map;
    glm::dvec3 sum(0.0);
    double wsum = 0.0;
    for (int y = 0; y < t.height; ++y) {
        double w = std::sin(kPi * (y + 0.5) / t.height);
        for (int x = 0; x < t.width; ++x) {
            const float* c = &t.rgb[3 * (static_cast<size_t>(y) * t.width + x)];
            sum += w * glm::dvec3(c[0], c[1], c[2]);
            wsum += w;
        }
    }
    return wsum > 0.0 ? glm::vec3(sum / wsum * static_cast<double>(env.scale)) : glm::vec3(0.0f);
}

std::string describe(const Environment& env) {
    std::ostringstream s;
    switch (env.kind) {
        case EnvironmentKind::None:
            return "";
        case EnvironmentKind::Constant:
            s << "constant radiance " << fmt_rgb(env.radiance);
            break;
        case EnvironmentKind::Map:
            s << "envmap '" << std::filesystem::path(env.map.path).filename().string() << "' " << env.map.width << "x"
              << env.map.height << ", scale " << env.scale << ", mean radiance "
              << fmt_rgb(environment_mean_radiance(env));
            break;
    }
    if (!env.what.empty()) s << " (" << env.what << ")";
    return s.str();
}

std::string describe_lights_at_infinity(const Scene& scene) {
    std::string s = describe(scene.environment);
    for (const auto& l : scene.directional_lights)
        s += (s.empty() ? "" : "; ") + std::string("directional light along ") + fmt_rgb(l.direction) +
             ", irradiance " + fmt_rgb(l.irradiance);
    return s;
}

}  // namespace vkmech
