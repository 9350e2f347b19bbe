// The separation measures of experiments/separation.hpp with their segments
// traced on the device (RayCaster over the session's traversal): the GPU work
// that the separation analysis needs, handed in from the app layer.
#pragma once

#include "experiments/separation.hpp"
#include "render/session.hpp"

namespace vkmech {

SeparationMeasures measure_separation(const RenderSession& session, uint32_t points_per_object = 64, uint32_t seed = 0,
                                      float offset = 1e-3f);

}  // namespace vkmech
