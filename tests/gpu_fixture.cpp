#include "gpu_fixture.hpp"

#include <doctest/doctest.h>

#include <cstdio>
#include <memory>

namespace vkmech::testing {

vk::Context* test_context() {
    static std::unique_ptr<vk::Context> ctx;
    static bool tried = false;
    if (!tried) {
        tried = true;
        try {
            vk::ContextOptions o;
            o.validation = true;
            ctx = std::make_unique<vk::Context>(o);
        } catch (const std::exception& e) {
            std::fprintf(stderr, "GPU tests skipped: %s\n", e.what());
        }
    }
    return ctx.get();
}

}  // namespace vkmech::testing
