// Mitsuba's own binary mesh format, the `serialized` shape (Mitsuba 0.5/0.6
// exports, Mitsuba 3's material-preview scene). Meshes come back in object
// space like load_obj/load_ply (scene/mesh_io.hpp): normals and uvs when the
// file has them, v not flipped, vertex colours dropped, triangles with a
// repeated index or zero area removed.
//
// The format (little-endian throughout):
//   A file is one or more meshes, one after the other, then a dictionary.
//   Each mesh:
//     uint16  format identifier 0x041C
//     uint16  version: 3 or 4
//     then a zlib (deflate) stream holding:
//       uint32  flags: 0x0001 vertex normals, 0x0002 texture coordinates,
//               0x0008 vertex colours, 0x0010 face normals (a hint; the XML
//               face_normals property decides, as in Mitsuba 3),
//               0x1000 single precision, 0x2000 double precision
//       char[]  the mesh name, UTF-8, NUL-terminated (version 4 only)
//       uint64  vertex count, uint64 triangle count
//       positions (3 per vertex), normals (3, if flagged), uvs (2, if
//       flagged), colours (3, if flagged): float or double as flagged
//       indices: 3 per triangle, uint32 (uint64 when the vertex count
//       exceeds 0xFFFFFFFF; such meshes are refused here)
//   The dictionary, the file's last bytes: each mesh's byte offset from the
//   start of the file, uint64 in version 4 files and uint32 in version 3
//   files (the version of the first mesh), then the uint32 mesh count.
//
// Hostile input gives SceneError(path, 0, what), never a crash, a hang or a
// huge allocation: the magic, versions, shape index, offsets and counts are
// checked before anything is allocated (the counts must fit what the
// compressed bytes can expand to), inflation stops at the size the counts
// imply, indices must be below the vertex count, positions and uvs finite.
#pragma once

#include "scene/scene.hpp"

#include <cstdint>
#include <string>

namespace vkmech {

// The `shape_index`-th mesh (0-based) of a .serialized file; a mesh of more
// than `max_triangles` triangles is refused before it is read.
Mesh load_serialized(const std::string& path, int shape_index = 0, size_t max_triangles = SIZE_MAX);

}  // namespace vkmech
