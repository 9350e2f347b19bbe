// Sets an environment variable for one scope (the tests' switches such as
// VKMECH_GPU_TALLY, VKMECH_MEMORY_LIMIT); the destructor unsets it however
// the scope ends.
#pragma once

#include <cstdlib>
#include <string>

namespace vkmech::testing {

struct ScopedEnv {
    std::string name;
    ScopedEnv(const std::string& n, const std::string& value) : name(n) { ::setenv(n.c_str(), value.c_str(), 1); }
    ~ScopedEnv() { ::unsetenv(name.c_str()); }
    ScopedEnv(const ScopedEnv&) = delete;
    ScopedEnv& operator=(const ScopedEnv&) = delete;
};

}  // namespace vkmech::testing
