// Scenes for tests: the project's scene files and tiny procedural scenes.
#pragma once

#include "scene/scene.hpp"

#include <string>
#include <vector>

namespace vkmech::testing {

// Every scenes/*.xml of the project, sorted.
std::vector<std::string> project_scene_paths();

// A unit quad [-1,1]^2 at z = 0 (normal +z), a camera above it looking down,
// no emitter.
Scene quad_scene();
// Appends an area lamp to s: a unit square centred at (x, 0, z) in the plane z, facing +z (or -z),
// of material `material`, with an emitter of radiance `radiance` (grey).
void add_square_lamp(Scene& s, const std::string& name, float x, float z, bool faces_minus_z, float radiance,
                     uint32_t material);

// Mitsuba XML: a sphere of material `bsdf` (a whole <bsdf> element) on a diffuse floor under a
// rectangle lamp, 24 x 24 pixels, max_depth 6.
std::string sphere_on_floor_xml(const std::string& bsdf);

// Triangles whose sizes and positions shrink geometrically towards the
// origin (a fractal, or a scene mixing kilometres and millimetres): triangle
// i has scale s = ratio^i and vertices c + s (0,0,0), c + s (0.1,0,0),
// c + s (0,0.1,0.05) with c = s (1, 0.3, z_slope); at most max_count of
// them, and none below scale 1e-30. Three positions per triangle. Binned SAH
// peels a few off per level, so these make the builder's deepest trees.
std::vector<glm::vec3> graded_triangles(uint32_t max_count, float ratio, float z_slope = 0.0f);

}  // namespace vkmech::testing
