// The test runner. The shared Vulkan context of the GPU suites is released
// before main returns: destroying it during static destruction, after the
// driver's own teardown has begun, crashed the NVIDIA driver at exit.
#define DOCTEST_CONFIG_IMPLEMENT
#include <doctest/doctest.h>

#include "gpu_fixture.hpp"

int main(int argc, char** argv) {
    doctest::Context context(argc, argv);
    int rc = context.run();
    vkmech::testing::release_test_context();
    return rc;
}
