// `vkmech bench traversal --dump DIR`: the benchmark's work written out so
// that another ray tracer (ci/bench_embree.cpp) can trace the very same rays
// against the very same triangles and check its closest hits against ours.
// Layout (docs/performance.md "Traversal versus Embree"); all binary files
// are little-endian, without headers:
//   <scene>.tris.bin  float32[triangles][3][3]: world-space vertices v0 v1 v2
//                     (x y z each), in the BVH's triangle order, so that a
//                     triangle's position in the file is the index vkmech reports
//   <scene>.rays.bin  float32[rays][8]: ox oy oz tmin dx dy dz tmax
//                     (gpu::GpuRay; directions unit length)
//   <scene>.hits.bin  [rays] x {float32 t, uint32 triangle}: the software
//                     BVH's closest hit; a miss is t = -1, triangle = 0xFFFFFFFF
//   <scene>.json      counts, device, seed and the measured rays/s
#pragma once

#include "render/gpu_scene.hpp"

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace vkmech {

struct DumpHit {
    float t = -1.0f;
    uint32_t triangle = 0xFFFFFFFFu;
};

struct TraversalDump {
    std::vector<float> triangles;  // 9 floats per triangle
    std::vector<gpu::GpuRay> rays;
    std::vector<DumpHit> hits;
    size_t triangle_count() const { return triangles.size() / 9; }
};

struct TraversalDumpInfo {
    std::string device;
    uint32_t seed = 0;
    double bvh_rays_per_second = 0.0;                 // the ray kernel's default schedule (RaySchedule::Auto)
    double bvh_per_invocation_rays_per_second = 0.0;  // one ray per invocation
    std::optional<double> rayquery_rays_per_second;
};

// The dump of one scene: triangles from `arrays` (BVH order), the rays and
// the hits tracerays.comp returned for them (gpu::GpuHit: x = t, w = bits of
// the triangle index).
TraversalDump make_traversal_dump(const SceneArrays& arrays, std::vector<gpu::GpuRay> rays,
                                  const std::vector<gpu::GpuHit>& hits);

// Writes <dir>/<stem>.{tris.bin,rays.bin,hits.bin,json}; creates `dir`.
// Throws std::runtime_error when a file cannot be written.
void write_traversal_dump(const std::filesystem::path& dir, const std::string& stem, const TraversalDump& dump,
                          const TraversalDumpInfo& info);

// Reads the three binary files back. Throws std::runtime_error when one is
// missing or their sizes disagree.
TraversalDump read_traversal_dump(const std::filesystem::path& dir, const std::string& stem);

}  // namespace vkmech
