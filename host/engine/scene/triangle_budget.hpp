// The scene's triangle budget (LoadOptions::max_triangles, --max-triangles,
// VKMECH_MAX_TRIANGLES): loaders charge every shape before or while they
// build it, so a small file cannot expand to billions of triangles (20,000
// spheres in 1.3 MB are 330 M triangles and 5.5 GB).
#pragma once

#include "scene/scene.hpp"

#include <cstddef>
#include <string>

namespace vkmech {

// The limit `options` ask for: max_triangles, else VKMECH_MAX_TRIANGLES,
// else kDefaultMaxTriangles. A malformed variable is a SceneError at `path`.
size_t max_triangles(const LoadOptions& options, const std::string& path);

// "... more than N triangles ...; raise the limit with ...": the message of
// every loader that stops at the limit.
std::string triangle_limit_message(size_t limit, const std::string& what);

class TriangleBudget {
public:
    explicit TriangleBudget(size_t limit) : limit_(limit) {}
    size_t left() const { return limit_ - used_; }
    // Adds `n` triangles of `what`; past the limit, SceneError(file, line).
    void charge(size_t n, const std::string& file, int line, const std::string& what);

private:
    size_t limit_;
    size_t used_ = 0;
};

}  // namespace vkmech
