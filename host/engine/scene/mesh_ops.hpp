// Geometry operations on a triangulated Mesh shared by the primitives and
// the mesh-file shapes: object-to-world transform, orientation flips,
// vertex normals, degenerate-triangle removal and area.
#pragma once

#include "scene/scene.hpp"

#include <glm/glm.hpp>

#include <string>

namespace vkmech {

// Inverse transpose of the linear part: how normals transform.
glm::mat3 normal_matrix(const glm::mat4& to_world);

// True when the linear part of `m` is a rotation times a uniform scale
// (possibly mirrored), within a relative tolerance: spheres need it.
bool is_similarity(const glm::mat4& m, float rel_tol = 1e-4f);

// Unnormalised geometric normal cross(p1 - p0, p2 - p0) of triangle t.
glm::vec3 triangle_cross(const Mesh& m, const glm::uvec3& t);

// Positions by the matrix, normals by its inverse transpose (renormalised), tangents by the
// matrix (renormalised; a mirroring matrix turns their handedness w).
// With `keep_facing`, a mirroring transform (det < 0) also reverses the
// winding, so the geometric normal keeps agreeing with the transformed
// normal field (analytic primitives and meshes with normals); without it
// the winding is kept as is (Mitsuba for meshes whose normals are derived
// from the world-space winding).
void transform_mesh(Mesh& m, const glm::mat4& to_world, bool keep_facing);

// Reverses every triangle's winding, negates the normals and the tangents' handedness.
void flip_orientation(Mesh& m);

// Angle-weighted vertex normals from the winding (Mitsuba recomputes these
// for mesh files without normals unless face_normals is set).
void compute_vertex_normals(Mesh& m);

// Replaces missing (zero or non-finite) normals by angle-weighted ones and
// normalises the rest.
void repair_normals(Mesh& m);

// Drops triangles with a repeated index or zero area; returns how many.
size_t remove_degenerate_triangles(Mesh& m);

double surface_area(const Mesh& m);

// The Mesh invariant every loader must deliver and flatten_scene relies on:
// normals, uvs and tangents empty or one per position (tangents only with normals), indices
// below the position count, positions, uvs and tangents finite, handedness +-1. Throws SceneError(file, 0, ...) naming
// the mesh otherwise.
void check_mesh(const Mesh& m, const std::string& file);

}  // namespace vkmech
