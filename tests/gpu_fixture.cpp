#include "gpu_fixture.hpp"

#include <doctest/doctest.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>

namespace vkmech::testing {

namespace {
std::unique_ptr<vk::Context> ctx;
bool tried = false;
}  // namespace

void release_test_context() { ctx.reset(); }

vk::Context* test_context() {
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

bool gpu_required() {
    const char* v = std::getenv("VKMECH_REQUIRE_GPU");
    return v && *v && std::strcmp(v, "0") != 0;
}

}  // namespace vkmech::testing
