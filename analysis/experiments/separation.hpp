// Object-space separation between the delta-S and the glossy object families
// (paper §5 Finding 1, tab:sign-reversal; docs/descriptor.md §5 "Separation measures"):
// the minimum surface-to-surface distance and the mutual visibility fraction.
//
// Objects and families (the paper: "family assignment by BSDF flags (delta
// reflection/transmission vs glossy)", with docs/descriptor.md §2's material-to-lobe map):
// - An object is one Mesh of Scene::meshes that is not an emitter
//   (Mesh::emitter < 0), has a material (Mesh::material >= 0) and has a
//   positive surface area.
// - delta-S family: the material is delta-only (Material::is_delta_only():
//   conductor, dielectric, thindielectric; lobe S).
// - glossy family: roughconductor or roughdielectric (lobe G).
// - Everything else (diffuse, plastic, roughplastic, principled) belongs to
//   neither family: those BSDFs advertise a diffuse component (lobe D under
//   NEE). A `twosided` wrapper is transparent: the wrapped type decides.
//
// Minimum distance: for every (delta, glossy) object pair, the exact
// point-to-triangle distance (double precision) from every vertex of one
// object to every triangle of the other, in both directions; the minimum
// over all pairs. The edge-edge closest points of two meshes are thereby
// approximated by the vertex-triangle minimum, which overestimates the true
// distance by at most about the edge length -- negligible for the finely
// tessellated analytic shapes of the project's scenes (a default sphere has
// 16k triangles). Pairs whose bounding boxes are farther apart than the
// current minimum are skipped, and each object's triangles are searched
// through a per-object BVH, so the result is exact but cheap.
//
// Mutual visibility: `points_per_object` points are sampled uniformly by
// area on each object, deterministically (a counter-based hash of (seed,
// mesh index, point index, dimension): the lowbias32 hash of
// shaders/rng.glsl). For every (delta, glossy) object pair every point pair
// (a, b) is one segment, tested with an any-hit ray against the full scene
// (a SegmentVisibility function: the app layer passes one that traces them on
// the device, study/separation_gpu.hpp): origin a + offset * dir, direction
// dir = (b - a) / |b - a|, tmin 0, tmax |b - a| - 2 * offset. The segment is
// visible iff nothing is hit. The sampled points lie on the objects' own
// surfaces, so a segment passing through either object itself is occluded.
// A segment no longer than 2 * offset (touching objects) counts as visible
// without a ray. mutual_visibility = visible segments / tested segments,
// pooled over all pairs.
#pragma once

#include "scene/scene.hpp"
#include "shared/types.h"

#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <vector>

namespace vkmech {

struct SeparationMeasures {
    int delta_objects = 0, glossy_objects = 0;  // family sizes
    // Scene units (metres in the project's scenes): minimum surface-to-surface
    // distance between any delta-S object and any glossy object; NaN when
    // undefined.
    double min_distance = std::numeric_limits<double>::quiet_NaN();
    // Share of unoccluded segments between sampled surface points, over all
    // (delta, glossy) object pairs; NaN when undefined or no segment was tested.
    double mutual_visibility = std::numeric_limits<double>::quiet_NaN();
    uint64_t segments = 0;  // segments tested
    uint64_t visible = 0;   // of which unoccluded

    bool defined() const { return delta_objects > 0 && glossy_objects > 0; }
};

enum class SeparationFamily { None, Delta, Glossy };

// The family of one mesh under the rule above.
SeparationFamily separation_family(const Scene& scene, size_t mesh_index);

// For each ray (origin, tmin in .w = 0; direction, tmax in .w): 1 when nothing
// is hit on [tmin, tmax], 0 otherwise; one answer per ray, in order.
using SegmentVisibility = std::function<std::vector<uint8_t>(const std::vector<gpu::GpuRay>&)>;

SeparationMeasures measure_separation(const Scene& scene, const SegmentVisibility& unoccluded,
                                      uint32_t points_per_object = 64, uint32_t seed = 0, float offset = 1e-3f);

// CPU parts, exposed for tests.
// `count` points uniformly distributed by area on the mesh, a pure function
// of (seed, mesh_index, point index); empty when the mesh has no area.
std::vector<glm::vec3> sample_surface_points(const Mesh& mesh, uint32_t mesh_index, uint32_t count, uint32_t seed);
// Minimum vertex-to-triangle distance between two meshes, both directions;
// +inf when either has no triangle.
double mesh_distance(const Mesh& a, const Mesh& b);

}  // namespace vkmech
