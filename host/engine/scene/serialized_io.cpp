// Reader of Mitsuba's `serialized` meshes; the format is in serialized_io.hpp.
#include "scene/serialized_io.hpp"

#include "scene/mesh_io.hpp"

#include "scene/mesh_ops.hpp"
#include "scene/triangle_budget.hpp"

#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <sstream>

namespace vkmech {

namespace {

constexpr uint16_t kFormatId = 0x041C;
constexpr uint32_t kHasNormals = 0x0001, kHasUvs = 0x0002, kHasColors = 0x0008;
constexpr uint32_t kSinglePrecision = 0x1000, kDoublePrecision = 0x2000;
// Deflate expands at most about 1032:1; counts implying more than this from
// the compressed bytes at hand cannot be real and are refused before any
// allocation.
constexpr uint64_t kMaxInflateRatio = 1032;
constexpr size_t kMaxNameBytes = 1 << 16;

uint64_t read_le(const std::string& data, uint64_t at, int bytes) {
    uint64_t v = 0;
    for (int k = bytes - 1; k >= 0; --k) v = v << 8 | static_cast<uint8_t>(data[at + k]);
    return v;
}

// Inflates one mesh's zlib stream on demand, exactly as many bytes as asked.
class Inflater {
public:
    Inflater(const std::string& path, const char* in, size_t size) : path_(path) {
        zs_.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(in));
        zs_.avail_in = static_cast<uInt>(std::min<size_t>(size, std::numeric_limits<uInt>::max()));
        rest_in_ = size - zs_.avail_in;
        if (inflateInit(&zs_) != Z_OK) throw SceneError(path_, 0, "zlib cannot start inflating (out of memory?)");
    }
    ~Inflater() { inflateEnd(&zs_); }
    Inflater(const Inflater&) = delete;
    Inflater& operator=(const Inflater&) = delete;

    void read(void* out, size_t n, const char* what) {
        auto* p = static_cast<Bytef*>(out);
        while (n > 0) {
            const uInt chunk = static_cast<uInt>(std::min<size_t>(n, 1u << 30));
            zs_.next_out = p;
            zs_.avail_out = chunk;
            while (zs_.avail_out > 0) {
                if (zs_.avail_in == 0 && rest_in_ > 0) {
                    zs_.avail_in = static_cast<uInt>(std::min<size_t>(rest_in_, std::numeric_limits<uInt>::max()));
                    rest_in_ -= zs_.avail_in;
                }
                const int r = inflate(&zs_, Z_NO_FLUSH);
                if (r == Z_STREAM_END && zs_.avail_out > 0)
                    fail(std::string("the compressed data ends before the ") + what);
                if (r == Z_DATA_ERROR || r == Z_NEED_DICT)
                    fail(std::string("corrupt compressed data in the ") + what +
                         " (zlib: " + (zs_.msg ? zs_.msg : "invalid data") + ")");
                if (r == Z_MEM_ERROR) fail("zlib ran out of memory");
                if (r == Z_BUF_ERROR && zs_.avail_in == 0 && rest_in_ == 0)
                    fail(std::string("truncated compressed data: it stops inside the ") + what);
                if (r != Z_OK && r != Z_BUF_ERROR && r != Z_STREAM_END)
                    fail("zlib failed with code " + std::to_string(r));
            }
            p += chunk;
            n -= chunk;
        }
    }

    template <class T>
    T value(const char* what) {
        uint8_t b[sizeof(T)];
        read(b, sizeof b, what);
        uint64_t v = 0;
        for (int k = static_cast<int>(sizeof(T)) - 1; k >= 0; --k) v = v << 8 | b[k];
        return static_cast<T>(v);
    }

    // n values of `bytes` each (4: float, 8: double) as floats. The vector
    // grows as the data inflates: a count that lies allocates no more than
    // the stream holds.
    std::vector<float> reals(size_t n, int bytes, const char* what) {
        std::vector<float> out;
        std::vector<uint8_t> buf(std::min<size_t>(n, 1 << 16) * bytes);
        for (size_t done = 0; done < n;) {
            const size_t k = std::min(n - done, buf.size() / bytes);
            read(buf.data(), k * bytes, what);
            out.resize(done + k);
            for (size_t i = 0; i < k; ++i) {
                if (bytes == 4) {
                    uint32_t u = 0;
                    for (int b = 3; b >= 0; --b) u = u << 8 | buf[i * 4 + b];
                    float f;
                    std::memcpy(&f, &u, 4);
                    out[done + i] = f;
                } else {
                    uint64_t u = 0;
                    for (int b = 7; b >= 0; --b) u = u << 8 | buf[i * 8 + b];
                    double d;
                    std::memcpy(&d, &u, 8);
                    out[done + i] = static_cast<float>(d);
                }
            }
            done += k;
        }
        return out;
    }

    [[noreturn]] void fail(const std::string& what) const { throw SceneError(path_, 0, what); }

private:
    const std::string& path_;
    z_stream zs_{};
    size_t rest_in_ = 0;
};

std::string hex(uint64_t v) {
    std::ostringstream h;
    h << "0x" << std::hex << v;
    return h.str();
}

}  // namespace

Mesh load_serialized(const std::string& path, int shape_index, size_t max_triangles) {
    const std::string data = read_whole_file(path);
    auto fail = [&](const std::string& what) { throw SceneError(path, 0, what); };
    const uint64_t size = data.size();
    if (size < 8) fail("not a Mitsuba serialized mesh: only " + std::to_string(size) + " bytes");
    if (read_le(data, 0, 2) != kFormatId)
        fail("not a Mitsuba serialized mesh: the file starts with " + hex(read_le(data, 0, 2)) +
             ", expected the format identifier 0x041C");
    const uint64_t file_version = read_le(data, 2, 2);
    if (file_version != 3 && file_version != 4)
        fail("unsupported serialized format version " + std::to_string(file_version) + " (expected 3 or 4)");

    // The dictionary at the end: offsets, then the mesh count.
    const uint64_t count = read_le(data, size - 4, 4);
    const uint64_t entry = file_version == 4 ? 8 : 4;
    if (count == 0) fail("the dictionary at the end of the file says it holds no meshes");
    if (count * entry > size - 4 - 4)
        fail("the dictionary at the end of the file claims " + std::to_string(count) +
             " meshes, more than the file can hold (truncated or not a serialized file?)");
    const uint64_t dict_start = size - 4 - count * entry;
    if (shape_index < 0 || static_cast<uint64_t>(shape_index) >= count)
        fail("shape_index " + std::to_string(shape_index) + " is out of range: the file holds " +
             std::to_string(count) + (count == 1 ? " mesh" : " meshes") + " (shape_index 0 to " +
             std::to_string(count - 1) + ")");
    auto offset = [&](uint64_t i) { return read_le(data, dict_start + i * entry, static_cast<int>(entry)); };
    const uint64_t start = offset(shape_index);
    // The mesh's compressed bytes end where the next mesh (or the dictionary) starts.
    uint64_t end = dict_start;
    for (uint64_t i = 0; i < count; ++i)
        if (uint64_t o = offset(i); o > start && o < end) end = o;
    const std::string where = "mesh " + std::to_string(shape_index) + " (offset " + std::to_string(start) + ")";
    if (start >= end || end - start <= 4)
        fail(where + ": the offset is outside the file's mesh data (ends at " + std::to_string(dict_start) + ")");
    if (read_le(data, start, 2) != kFormatId)
        fail(where + ": no format identifier 0x041C there (a wrong offset in the dictionary?)");
    const uint64_t version = read_le(data, start + 2, 2);
    if (version != 3 && version != 4)
        fail(where + ": unsupported format version " + std::to_string(version) + " (expected 3 or 4)");

    const uint64_t compressed = end - start - 4;
    Inflater z(path, data.data() + start + 4, static_cast<size_t>(compressed));
    auto zfail = [&](const std::string& what) { z.fail(where + ": " + what); };
    try {
        const uint32_t flags = z.value<uint32_t>("flags");
        // Files written by other tools (Tungsten's, in Bitterli's scene
        // collection: version 3, flags 0x103) name no precision; their sizes
        // are those of single precision, which is what a missing flag means.
        bool single = flags & kSinglePrecision;
        const bool dbl = flags & kDoublePrecision;
        if (single && dbl)
            zfail("the flags (" + hex(flags) + ") name both precisions (0x1000 single and 0x2000 double)");
        if (!single && !dbl) single = true;
        const int real = single ? 4 : 8;
        Mesh m;
        m.kind = ShapeKind::Mesh;
        if (version == 4) {
            std::string name;
            for (char c = z.value<char>("mesh name"); c != '\0'; c = z.value<char>("mesh name")) {
                if (name.size() >= kMaxNameBytes) zfail("the mesh name is not terminated within 64 KiB");
                name += c;
            }
            m.name = name;
        }
        const uint64_t vertices = z.value<uint64_t>("vertex count");
        const uint64_t triangles = z.value<uint64_t>("triangle count");
        if (vertices == 0) zfail("the mesh has no vertices");
        if (triangles == 0) zfail("the mesh has no faces");
        if (vertices > 0xFFFFFFFFull)
            zfail(std::to_string(vertices) +
                  " vertices: more than 32-bit indices can address (and than this file holds)");
        if (triangles > (1ull << 31))
            zfail(std::to_string(triangles) + " triangles: more than this loader accepts (2^31)");
        if (triangles > max_triangles) zfail(triangle_limit_message(max_triangles, "the mesh"));
        const uint64_t per_vertex =
            3 + ((flags & kHasNormals) ? 3 : 0) + ((flags & kHasUvs) ? 2 : 0) + ((flags & kHasColors) ? 3 : 0);
        const uint64_t expected = vertices * per_vertex * real + triangles * 3 * 4;
        if (expected > compressed * kMaxInflateRatio + 1024)
            zfail(std::to_string(vertices) + " vertices and " + std::to_string(triangles) + " triangles need " +
                  std::to_string(expected) + " bytes, more than the " + std::to_string(compressed) +
                  " compressed bytes can hold (a corrupt count?)");

        const size_t nv = static_cast<size_t>(vertices);
        std::vector<float> pos = z.reals(nv * 3, real, "positions");
        for (float v : pos)
            if (!std::isfinite(v)) zfail("a vertex position is not finite (or too large for single precision)");
        m.positions.resize(nv);
        for (size_t i = 0; i < nv; ++i) m.positions[i] = {pos[3 * i], pos[3 * i + 1], pos[3 * i + 2]};
        pos = {};
        if (flags & kHasNormals) {
            std::vector<float> n = z.reals(nv * 3, real, "normals");
            m.normals.resize(nv);
            for (size_t i = 0; i < nv; ++i) m.normals[i] = {n[3 * i], n[3 * i + 1], n[3 * i + 2]};
        }
        if (flags & kHasUvs) {
            std::vector<float> t = z.reals(nv * 2, real, "texture coordinates");
            for (float v : t)
                if (!std::isfinite(v)) zfail("a texture coordinate is not finite");
            m.uvs.resize(nv);
            for (size_t i = 0; i < nv; ++i) m.uvs[i] = {t[2 * i], t[2 * i + 1]};
        }
        if (flags & kHasColors) (void)z.reals(nv * 3, real, "vertex colours");  // not used by the renderer

        m.indices.resize(static_cast<size_t>(triangles));
        std::vector<uint8_t> buf(std::min<size_t>(m.indices.size(), 1 << 16) * 12);
        for (size_t done = 0; done < m.indices.size();) {
            const size_t k = std::min(m.indices.size() - done, buf.size() / 12);
            z.read(buf.data(), k * 12, "indices");
            for (size_t i = 0; i < k; ++i) {
                glm::uvec3 t;
                for (int c = 0; c < 3; ++c) {
                    const uint8_t* b = &buf[i * 12 + c * 4];
                    t[c] = uint32_t(b[0]) | uint32_t(b[1]) << 8 | uint32_t(b[2]) << 16 | uint32_t(b[3]) << 24;
                    if (t[c] >= vertices)
                        zfail("triangle " + std::to_string(done + i) + " uses vertex " + std::to_string(t[c]) +
                              ", past the " + std::to_string(vertices) + " vertices");
                }
                m.indices[done + i] = t;
            }
            done += k;
        }
        remove_degenerate_triangles(m);
        if (m.indices.empty()) zfail("every triangle of the mesh is degenerate");
        repair_normals(m);
        return m;
    } catch (const std::bad_alloc&) {
        zfail("out of memory for " + std::to_string(compressed) + " compressed bytes");
    }
    return {};  // not reached
}

}  // namespace vkmech
