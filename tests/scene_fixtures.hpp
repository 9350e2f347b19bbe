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

}  // namespace vkmech::testing
