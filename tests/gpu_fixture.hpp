// The Vulkan device shared by the GPU test suite. Tests that need it call
// test_context() and return early (with a message) when there is none, so the
// suite skips cleanly on machines without Vulkan (DESIGN).
#pragma once

#include "vk/context.hpp"

namespace vkmech::testing {

// nullptr when no Vulkan device can be created. Validation layers are on
// when installed.
vk::Context* test_context();

}  // namespace vkmech::testing

#define VKMECH_REQUIRE_GPU(ctx)                                      \
    vkmech::vk::Context* ctx = vkmech::testing::test_context();     \
    if (!ctx) {                                                      \
        MESSAGE("skipped: no Vulkan device");                        \
        return;                                                      \
    }
