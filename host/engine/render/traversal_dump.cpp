#include "render/traversal_dump.hpp"

#include "io/json.hpp"

#include <bit>
#include <cstdio>
#include <fstream>
#include <stdexcept>

namespace vkmech {

static_assert(sizeof(gpu::GpuRay) == 32 && sizeof(DumpHit) == 8, "dump records are packed float32/uint32");
static_assert(std::endian::native == std::endian::little, "the dump is documented as little-endian");

namespace {

std::filesystem::path dump_file(const std::filesystem::path& dir, const std::string& stem, const char* suffix) {
    std::string name = stem;
    name += suffix;
    return dir / name;
}

template <class T>
void write_binary(const std::filesystem::path& path, const std::vector<T>& v) {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(v.data()), static_cast<std::streamsize>(v.size() * sizeof(T)));
    if (!out) {
        std::string msg = "cannot write ";
        msg += path.string();
        throw std::runtime_error(msg);
    }
}

template <class T>
std::vector<T> read_binary(const std::filesystem::path& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) {
        std::string msg = "cannot read ";
        msg += path.string();
        throw std::runtime_error(msg);
    }
    in.seekg(0, std::ios::end);
    auto bytes = static_cast<size_t>(in.tellg());
    if (bytes % sizeof(T) != 0) {
        std::string msg = path.string();
        msg += ": size is not a multiple of the record size";
        throw std::runtime_error(msg);
    }
    in.seekg(0);
    std::vector<T> v(bytes / sizeof(T));
    in.read(reinterpret_cast<char*>(v.data()), static_cast<std::streamsize>(bytes));
    return v;
}

std::string number(double x) {
    char buf[64];
    std::snprintf(buf, sizeof(buf), "%.6g", x);
    return buf;
}

}  // namespace

TraversalDump make_traversal_dump(const SceneArrays& arrays, std::vector<gpu::GpuRay> rays,
                                  const std::vector<gpu::GpuHit>& hits) {
    if (hits.size() != rays.size()) throw std::runtime_error("traversal dump: one hit per ray expected");
    TraversalDump d;
    d.triangles.reserve(arrays.tri_positions.size() * 3);
    for (const auto& p : arrays.tri_positions) {
        d.triangles.push_back(p.x);
        d.triangles.push_back(p.y);
        d.triangles.push_back(p.z);
    }
    d.rays = std::move(rays);
    d.hits.reserve(hits.size());
    for (const auto& h : hits) {
        DumpHit x;
        if (h.hit.x >= 0.0f) {
            x.t = h.hit.x;
            x.triangle = std::bit_cast<uint32_t>(h.hit.w);
        }
        d.hits.push_back(x);
    }
    return d;
}

void write_traversal_dump(const std::filesystem::path& dir, const std::string& stem, const TraversalDump& dump,
                          const TraversalDumpInfo& info) {
    std::filesystem::create_directories(dir);
    const auto tris = dump_file(dir, stem, ".tris.bin");
    const auto rays = dump_file(dir, stem, ".rays.bin");
    const auto hits = dump_file(dir, stem, ".hits.bin");
    write_binary(tris, dump.triangles);
    write_binary(rays, dump.rays);
    write_binary(hits, dump.hits);
    std::string j = "{\n  \"format\": \"vkmech-traversal-dump-1\",\n  \"scene\": \"";
    j += json_escape(stem);
    j += "\",\n  \"device\": \"";
    j += json_escape(info.device);
    j += "\",\n  \"triangles\": ";
    j += std::to_string(dump.triangle_count());
    j += ",\n  \"rays\": ";
    j += std::to_string(dump.rays.size());
    j += ",\n  \"seed\": ";
    j += std::to_string(info.seed);
    j += ",\n  \"bvh_rays_per_second\": ";
    j += number(info.bvh_rays_per_second);
    j += ",\n  \"bvh_per_invocation_rays_per_second\": ";
    j += number(info.bvh_per_invocation_rays_per_second);
    j += ",\n  \"rayquery_rays_per_second\": ";
    j += info.rayquery_rays_per_second ? number(*info.rayquery_rays_per_second) : std::string("null");
    j += ",\n  \"files\": {\"triangles\": \"";
    j += json_escape(tris.filename().string());
    j += "\", \"rays\": \"";
    j += json_escape(rays.filename().string());
    j += "\", \"hits\": \"";
    j += json_escape(hits.filename().string());
    j += "\"}\n}\n";
    const auto json = dump_file(dir, stem, ".json");
    std::ofstream out(json, std::ios::trunc);
    out << j;
    if (!out) {
        std::string msg = "cannot write ";
        msg += json.string();
        throw std::runtime_error(msg);
    }
}

TraversalDump read_traversal_dump(const std::filesystem::path& dir, const std::string& stem) {
    TraversalDump d;
    d.triangles = read_binary<float>(dump_file(dir, stem, ".tris.bin"));
    d.rays = read_binary<gpu::GpuRay>(dump_file(dir, stem, ".rays.bin"));
    d.hits = read_binary<DumpHit>(dump_file(dir, stem, ".hits.bin"));
    if (d.triangles.size() % 9 != 0) throw std::runtime_error("traversal dump: triangle file is not 36-byte records");
    if (d.hits.size() != d.rays.size()) throw std::runtime_error("traversal dump: hit and ray counts differ");
    return d;
}

}  // namespace vkmech
