#include "io/invariant.hpp"

namespace vkmech {

void fail_invariant(const char* file, int line, const char* condition, const std::string& message) {
    // __FILE__ is the compiler's path; from the source tree's top folder on it reads the same
    // on every machine.
    std::string where = file;
    for (const char* root : {"/host/", "/analysis/", "/tests/", "/shaders/"})
        if (const size_t at = where.rfind(root); at != std::string::npos) {
            where = where.substr(at + 1);
            break;
        }
    throw InternalError(where + ":" + std::to_string(line) + ": " + condition + " failed: " + message);
}

}  // namespace vkmech
