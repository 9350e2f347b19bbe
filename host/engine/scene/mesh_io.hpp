// Triangle-mesh files for the `obj` and `ply` shapes (docs/descriptor.md §8). Meshes come
// back in object space, exactly as stored: normals and uvs only when the
// file has them for every vertex; polygons fan-triangulated; triangles with
// a repeated index or zero area dropped. Errors are SceneError naming the
// mesh file and, where it has one, the line; also a mesh of more than
// `max_triangles` triangles (the scene's budget left, triangle_budget.hpp).
#pragma once

#include "scene/scene.hpp"

#include <cstdint>
#include <string>

namespace vkmech {

// Wavefront OBJ: v / vt / vn, faces in any index form (v, v/vt, v//vn,
// v/vt/vn), negative (relative) indices. Groups, objects, smoothing groups
// and materials are ignored. Corners are deduplicated by their
// (v, vt, vn) triple, as Mitsuba does. uv is returned as stored (OBJ's
// v = 0 at the bottom); Mitsuba's flip_tex_coords is the caller's business.
Mesh load_obj(const std::string& path, size_t max_triangles = SIZE_MAX);

// PLY, ascii or binary (little or big endian). Vertex x, y, z; optional
// nx, ny, nz and u, v (or s, t, texture_u/texture_v, texture_s/texture_t);
// face list `vertex_indices` or `vertex_index` with any integer list types.
Mesh load_ply(const std::string& path, size_t max_triangles = SIZE_MAX);

// By extension (.obj, .ply; case-insensitive).
Mesh load_mesh_file(const std::string& path, size_t max_triangles = SIZE_MAX);

// A mesh file's bytes (a regular file, file_read.hpp); SceneError(path, 0,
// "cannot open mesh file (...)").
std::string read_whole_file(const std::string& path);

}  // namespace vkmech
