#include "study/render_cache.hpp"

#include "io/atomic_file.hpp"
#include "render/shader_modules.hpp"

#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <type_traits>

namespace fs = std::filesystem;

namespace vkmech {

namespace {
constexpr char kMagic[8] = {'V', 'K', 'M', 'F', 'R', 'M', '0', '1'};
static_assert(std::is_trivially_copyable_v<PixelStats>);
static_assert(sizeof(PixelStats) == 17 * sizeof(double), "cache format assumes 17 doubles per pixel");

uint64_t mix64(uint64_t z) {  // splitmix64 finalizer
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}
}  // namespace

Digest& Digest::bytes(const void* data, size_t n) {
    const auto* p = static_cast<const unsigned char*>(data);
    size_t i = 0;
    for (; i + 8 <= n; i += 8) {
        uint64_t w;
        std::memcpy(&w, p + i, 8);
        a_ = mix64(a_ ^ w) + 0x9e3779b97f4a7c15ull;
        b_ = mix64(b_ + w * 0xff51afd7ed558ccdull) ^ (b_ >> 17);
    }
    uint64_t tail = 0;
    std::memcpy(&tail, p + i, n - i);
    tail ^= static_cast<uint64_t>(n - i) << 56;
    a_ = mix64(a_ ^ tail) + 0x9e3779b97f4a7c15ull;
    b_ = mix64(b_ + tail * 0xff51afd7ed558ccdull) ^ (b_ >> 17);
    return *this;
}

std::string Digest::hex() const {
    char buf[33];
    std::snprintf(buf, sizeof buf, "%016llx%016llx", static_cast<unsigned long long>(mix64(a_)),
                  static_cast<unsigned long long>(mix64(b_ ^ a_)));
    return buf;
}

std::string scene_digest(const Scene& scene, const SceneArrays& arrays) {
    Digest d;
    d.vec(arrays.vertices).vec(arrays.triangles).vec(arrays.triangle_mesh).vec(arrays.materials).vec(arrays.emitters);
    d.vec(arrays.light_triangles).vec(arrays.texels).vec(arrays.textures).pod(arrays.light_weight_total);
    const Camera& c = scene.camera;
    d.pod(static_cast<uint32_t>(c.type)).pod(c.to_world).pod(c.fov_deg).str(c.fov_axis).pod(c.near_clip).pod(c.far_clip);
    d.pod(c.aperture_radius).pod(c.focus_distance).pod(c.width).pod(c.height);
    d.pod(scene.integrator.max_depth).pod(scene.integrator.rr_depth);
    return d.hex();
}

std::string cache_key(const CacheKeyParts& k) {
    Digest d;
    d.str("vkmech-render-cache-v1").str(k.scene_digest).pod(k.width).pod(k.height).pod(k.spp).pod(k.seed);
    d.pod(k.estimator).pod(k.batch_spp).str(k.traversal).str(k.device).str(k.code_digest).pod(k.end_vertex);
    return d.hex();
}

std::string RenderCache::path(const std::string& key) const { return (fs::path(dir_) / (key + ".frame")).string(); }

bool RenderCache::contains(const std::string& key) const { return fs::exists(path(key)); }

std::string serialize_frame(const Frame& f, const std::string& description) {
    std::string out(kMagic, sizeof kMagic);
    auto put = [&](const auto& v) { out.append(reinterpret_cast<const char*>(&v), sizeof v); };
    put(static_cast<int32_t>(f.width));
    put(static_cast<int32_t>(f.height));
    put(f.samples);
    put(f.seconds);
    put(static_cast<uint64_t>(f.pixels.size()));
    out.append(reinterpret_cast<const char*>(f.pixels.data()), f.pixels.size() * sizeof(PixelStats));
    put(static_cast<uint64_t>(description.size()));
    out += description;
    return out;
}

Frame deserialize_frame(const std::string& b, const std::string& where) {
    size_t pos = 0;
    auto fail = [&](const char* what) { throw std::runtime_error("render cache file '" + where + "': " + what); };
    auto get = [&](auto& v) {
        if (pos + sizeof v > b.size()) fail("truncated");
        std::memcpy(&v, b.data() + pos, sizeof v);
        pos += sizeof v;
    };
    if (b.size() < sizeof kMagic || std::memcmp(b.data(), kMagic, sizeof kMagic) != 0) fail("not a vkmech frame (bad magic)");
    pos = sizeof kMagic;
    Frame f;
    int32_t w = 0, h = 0;
    uint64_t n = 0;
    get(w);
    get(h);
    get(f.samples);
    get(f.seconds);
    get(n);
    if (w <= 0 || h <= 0 || n != static_cast<uint64_t>(w) * static_cast<uint64_t>(h)) fail("inconsistent size");
    if (pos + n * sizeof(PixelStats) > b.size()) fail("truncated pixel data");
    f.width = w;
    f.height = h;
    f.pixels.resize(n);
    std::memcpy(f.pixels.data(), b.data() + pos, n * sizeof(PixelStats));
    return f;
}

Frame RenderCache::load(const std::string& key) const {
    std::string p = path(key);
    std::ifstream in(p, std::ios::binary);
    if (!in) throw std::runtime_error("cannot read render cache file '" + p + "'");
    std::ostringstream ss;
    ss << in.rdbuf();
    return deserialize_frame(ss.str(), p);
}

void RenderCache::store(const std::string& key, const Frame& frame, const std::string& description) const {
    write_file_atomic(path(key), serialize_frame(frame, description));
}

}  // namespace vkmech
