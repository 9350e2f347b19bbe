// The Vulkan device shared by the GPU test suite. Tests that need it call
// test_context() and return early (with a message) when there is none, so the
// suite skips cleanly on machines without Vulkan (docs/architecture.md, "Tests are specifications").
#pragma once

#include "vk/context.hpp"

namespace vkmech::testing {

// nullptr when no Vulkan device can be created. Validation layers are on
// when installed.
vk::Context* test_context();

// Destroys the shared context (tests/main.cpp, before main returns).
void release_test_context();

// True when the environment says a device must be there (VKMECH_REQUIRE_GPU=1,
// set by ci/gpu-check.sh): a missing device then fails the GPU tests instead
// of skipping them, so a GPU run cannot pass by testing nothing.
bool gpu_required();

}  // namespace vkmech::testing

#define VKMECH_REQUIRE_GPU(ctx)                                                                       \
    vkmech::vk::Context* ctx = vkmech::testing::test_context();                                       \
    if (!ctx) {                                                                                       \
        if (vkmech::testing::gpu_required()) FAIL("no Vulkan device, and VKMECH_REQUIRE_GPU is set"); \
        MESSAGE("skipped: no Vulkan device");                                                         \
        return;                                                                                       \
    }
