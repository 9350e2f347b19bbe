// Object-space separation between the delta-S and the glossy object families
// (paper §5 Finding 1, tab:sign-reversal; docs/descriptor.md §5 "Separation measures"):
// the minimum surface-to-surface distance and the mutual visibility fraction.
//
// Objects and families (the paper: "family assignment by BSDF flags (delta
// reflection/transmission vs glossy)"):
// - An object is one Mesh of Scene::meshes that is not an emitter
//   (Mesh::emitter < 0), has a material (Mesh::material >= 0) and has a
//   positive surface area.
// - Its family is a function of its material's lobe flags
//   (Material::lobe_flags(): the set of lobe classes D / G / S the BSDF can
//   sample, from shaders/lobes.glsl, the same table that gives the renderer
//   its NEE lobe and delta-only test; docs/descriptor.md §2):
//   * glossy family: the BSDF can sample a glossy lobe (G), whatever else it
//     has: roughconductor, roughdielectric, roughplastic (microfacet coat),
//     principled (its GGX specular lobe is always there, alpha >= 0.001, and
//     never a delta; with or without its diffuse lobe);
//   * delta-S family: the BSDF has a delta reflection or transmission lobe
//     (S) and no glossy lobe: conductor, dielectric, thindielectric, and
//     smooth plastic (its coat is a mirror reflection, sampled as a delta lobe
//     beside the diffuse base);
//   * neither: no G and no S lobe (diffuse).
//   A `twosided` wrapper is transparent: the wrapped type decides.
//   separation_family_of(flags) is the rule; separation_family(scene, mesh)
//   applies it to one mesh.
//
// Minimum distance: the exact minimum distance between the surfaces of any
// delta-S object and any glossy object, in double precision. Between two
// triangles it is 0 when they intersect (closed triangles, decided with exact
// orientation predicates: a double evaluation with a rounding bound and an
// exact floating-point-expansion fallback), otherwise the minimum of the 6
// vertex-triangle and the 9 edge-edge (segment-segment) distances. Degenerate
// (zero-area) triangles are their edges; parallel edges are handled through
// the endpoint cases. Coplanar contact is decided exactly too; only two
// degenerate triangles touching each other are left to the distance
// formulas, which then return a distance of the order of rounding. Between
// two objects the minimum is found by a simultaneous descent of the two
// objects' BVHs, nearer node pairs first, skipping node and triangle pairs
// whose bounding boxes are at least the current minimum apart; object pairs
// are visited in order of bounding-box distance and skipped on the same rule.
// The result is exact (up to rounding) and cheap.
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

#include <array>
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

// The family rule above, from a set of lobe flags (gpu::LOBE_BIT_D/G/S).
SeparationFamily separation_family_of(uint32_t lobe_flags);
// The family of one mesh (None for emitters, meshes without a material and
// meshes without area).
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

using Triangle3 = std::array<glm::dvec3, 3>;
// Whether two closed triangles share a point (exact predicates). Two
// degenerate triangles are never reported as intersecting (their distance
// decides).
bool triangles_intersect(const Triangle3& a, const Triangle3& b);
// The exact distance between two closed triangles (0 when they intersect);
// symmetric, also for degenerate triangles.
double triangle_distance(const Triangle3& a, const Triangle3& b);
// The exact minimum surface-to-surface distance between two meshes; +inf
// when either has no triangle.
double mesh_distance(const Mesh& a, const Mesh& b);

}  // namespace vkmech
