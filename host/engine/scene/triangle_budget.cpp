#include "scene/triangle_budget.hpp"

#include "scene/text_parse.hpp"

#include <cstdlib>

namespace vkmech {

size_t max_triangles(const LoadOptions& options, const std::string& path) {
    if (options.max_triangles > 0) return options.max_triangles;
    const char* env = std::getenv("VKMECH_MAX_TRIANGLES");
    if (!env || !*env) return kDefaultMaxTriangles;
    auto n = text::to_int(env);
    if (!n || *n <= 0)
        throw SceneError(path, 0, std::string("VKMECH_MAX_TRIANGLES='") + env + "' is not a positive whole number");
    return static_cast<size_t>(*n);
}

std::string triangle_limit_message(size_t limit, const std::string& what) {
    return what + " takes the scene past " + std::to_string(limit) +
           " triangles, the loader's limit; if the scene is meant to be that large, raise it with --max-triangles N "
           "or the environment variable VKMECH_MAX_TRIANGLES=N";
}

void TriangleBudget::charge(size_t n, const std::string& file, int line, const std::string& what) {
    if (n > left())
        throw SceneError(file, line, triangle_limit_message(limit_, what + " (" + std::to_string(n) + " triangles)"));
    used_ += n;
}

}  // namespace vkmech
