// Every file the scene loaders read (scene XML, includes, meshes, images,
// glTF and its buffers) goes through here: only regular files (a directory,
// a FIFO or /dev/zero would fail late, block or grow without end), and at
// most `max_bytes` of them.
#pragma once

#include <cstdint>
#include <string>

namespace vkmech {

constexpr uint64_t kMaxIncludedXmlBytes = uint64_t(64) << 20;  // a scene or included XML file
constexpr uint64_t kMaxDataFileBytes = uint64_t(16) << 30;     // a mesh, image or buffer

// The bytes of `path`. Throws SceneError(path, 0, reason) when it cannot be
// opened, is not a regular file, or is larger than `max_bytes`; the reason
// names the file as `what` ("cannot open mesh file (No such file ...)").
std::string read_regular_file(const std::string& path, const std::string& what, uint64_t max_bytes = kMaxDataFileBytes);

// The same checks without reading, for files another library reads (EXR).
void require_regular_file(const std::string& path, const std::string& what);

}  // namespace vkmech
