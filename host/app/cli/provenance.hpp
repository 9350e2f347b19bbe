// Where a render came from (render/render_outputs.hpp Provenance): the build,
// the path tracer's code, the scene's files and parameters, the samples, the
// device and the date.
#pragma once

#include "cli/commands.hpp"
#include "render/gpu_scene.hpp"
#include "render/render_outputs.hpp"
#include "scene/scene.hpp"
#include "vk/context.hpp"

#include <string>
#include <utility>
#include <vector>

namespace vkmech {

// vkmech's version and `git describe` of the checkout it was built from.
std::string build_version();

// The absolute, canonical path (the path itself where that fails).
std::string canonical_path(const std::string& p);

// Every file other than the scene file itself that loading `scene` read
// (includes, meshes, textures), as (canonical path, SHA-256), sorted by path.
// Throws std::runtime_error when one cannot be read.
std::vector<std::pair<std::string, std::string>> scene_input_files(const Scene& scene);

// The provenance of a render of the scene file `scene_path` (loaded as `scene`
// with `defines`), of samples [0, spp) per pixel, with `trav` on `ctx`.
Provenance make_provenance(const std::string& scene_path, const Scene& scene, const std::vector<std::string>& defines,
                           const vk::Context& ctx, Traversal trav, uint32_t spp);

}  // namespace vkmech
