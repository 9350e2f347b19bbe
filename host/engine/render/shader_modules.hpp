// The embedded SPIR-V modules (compiled at build time by glslangValidator).
#pragma once

#include "render/gpu_scene.hpp"

#include <span>

namespace vkmech {

std::span<const uint32_t> pathtrace_spirv(Traversal t);
std::span<const uint32_t> tracerays_spirv(Traversal t);

}  // namespace vkmech
