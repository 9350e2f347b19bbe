// Emitters at infinity in the scene model (scene.hpp Environment,
// DirectionalLight): loading a latitude-longitude map, its mean, and the one
// line that describes an environment in the outputs.
#pragma once

#include "scene/scene.hpp"

#include <glm/glm.hpp>
#include <string>

namespace vkmech {

// A lat-long environment map from an image file (OpenEXR, Radiance HDR, or
// any format load_image_texture reads, taken as linear). Throws
// std::runtime_error naming the file and what is wrong (unreadable, fewer
// than 2 x 1 pixels, a negative or non-finite pixel, no light at all).
Environment load_environment_map(const std::string& path, float scale, const glm::mat3& to_world);

// to_world's rotation: the matrix with its columns normalized. Throws
// std::runtime_error when the columns are not orthogonal (a shear or a
// mirror cannot turn an environment).
glm::mat3 environment_rotation(const glm::mat3& to_world);

// The mean radiance over the sphere (solid-angle weighted; scale applied).
glm::vec3 environment_mean_radiance(const Environment& env);

// "envmap 'sky.exr' 2048x1024, scale 1, mean radiance (0.8, 0.9, 1.1)" and
// the like; "" for none.
std::string describe(const Environment& env);
// The environment (describe) and the directional lights, "; "-separated: what
// the outputs record; "" for none.
std::string describe_lights_at_infinity(const Scene& scene);

}  // namespace vkmech
