#include "study/render_cache.hpp"

#include "io/atomic_file.hpp"
#include "render/shader_modules.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <type_traits>

namespace fs = std::filesystem;

namespace vkmech {

namespace {
constexpr char kFrameMagic[8] = {'V', 'K', 'M', 'F', 'R', 'M', '0', '2'};
constexpr char kOldFrameMagic[8] = {'V', 'K', 'M', 'F', 'R', 'M', '0', '1'};  // format 1: no key, no checksum
constexpr char kFileMagic[8] = {'V', 'K', 'M', 'C', 'A', 'C', 'H', 'E'};
constexpr uint32_t kFormatVersion = 2;
static_assert(std::is_trivially_copyable_v<PixelStats>);
static_assert(sizeof(PixelStats) == 17 * sizeof(double), "cache format assumes 17 doubles per pixel");

std::string read_whole(const std::string& p) {
    std::ifstream in(p, std::ios::binary);
    if (!in) throw CacheFileError("cannot read render cache file '" + p + "'");
    std::ostringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

void warn_damaged(const std::string& what) {
    std::fprintf(stderr, "vkmech: warning: %s; not used: removed, it will be rendered again\n", what.c_str());
}

// Reads fixed-size values from a byte string, failing with "truncated".
struct Reader {
    const std::string& b;
    size_t pos;
    const std::function<void(const std::string&)>& fail;
    template <class T> void get(T& v) {
        if (pos + sizeof v > b.size()) fail("truncated");
        std::memcpy(&v, b.data() + pos, sizeof v);
        pos += sizeof v;
    }
    std::string str(uint64_t max) {
        uint64_t n = 0;
        get(n);
        if (n > max || pos + n > b.size()) fail("truncated or damaged header");
        std::string s = b.substr(pos, n);
        pos += n;
        return s;
    }
};
}  // namespace

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
    d.str("vkmech-render-cache-v2").str(k.scene_digest).pod(k.width).pod(k.height).pod(k.spp).pod(k.seed);
    d.pod(k.estimator).pod(k.batch_spp).str(k.traversal).str(k.device).str(k.code_digest).pod(k.end_vertex);
    return d.hex();
}

std::string RenderCache::path(const std::string& key, const std::string& kind) const {
    return (fs::path(dir_) / (key + (kind == "frame" ? ".frame" : ".frame." + kind))).string();
}

bool RenderCache::contains(const std::string& key) const { return fs::exists(path(key)); }

std::string seal_cache_file(const std::string& kind, const std::string& key, const std::string& payload) {
    std::string out(kFileMagic, sizeof kFileMagic);
    auto put = [&](const auto& v) { out.append(reinterpret_cast<const char*>(&v), sizeof v); };
    auto put_str = [&](const std::string& s) {
        put(static_cast<uint64_t>(s.size()));
        out += s;
    };
    put(kFormatVersion);
    put_str(kind);
    put_str(key);
    put(static_cast<uint64_t>(payload.size()));
    out += Digest().str(kind).str(key).str(payload).hex();
    out += payload;
    return out;
}

std::string open_cache_file(const std::string& b, const std::string& kind, const std::string& key, const std::string& where) {
    std::function<void(const std::string&)> fail = [&](const std::string& what) {
        throw CacheFileError("render cache file '" + where + "': " + what);
    };
    if (b.size() >= 8 && std::memcmp(b.data(), kOldFrameMagic, 8) == 0)
        fail("an older cache format (1, without key and checksum)");
    if (b.size() < sizeof kFileMagic || std::memcmp(b.data(), kFileMagic, sizeof kFileMagic) != 0)
        fail("not a vkmech cache file (bad magic)");
    Reader r{b, sizeof kFileMagic, fail};
    uint32_t version = 0;
    r.get(version);
    if (version != kFormatVersion) fail("cache format " + std::to_string(version) + ", this vkmech reads " +
                                        std::to_string(kFormatVersion));
    const std::string stored_kind = r.str(64);
    if (stored_kind != kind) fail("holds a '" + stored_kind + "', expected a '" + kind + "'");
    const std::string stored_key = r.str(256);
    if (stored_key != key) fail("stored under key " + stored_key + ", not under its name's key " + key);
    uint64_t size = 0;
    r.get(size);
    if (r.pos + 32 > b.size()) fail("truncated");
    const std::string digest = b.substr(r.pos, 32);
    r.pos += 32;
    if (b.size() - r.pos != size)
        fail(b.size() - r.pos < size ? "truncated (" + std::to_string(b.size() - r.pos) + " of " + std::to_string(size) +
                                           " payload bytes)"
                                     : "trailing bytes after the payload");
    std::string payload = b.substr(r.pos);
    if (Digest().str(kind).str(key).str(payload).hex() != digest) fail("checksum mismatch (the data is damaged)");
    return payload;
}

std::string serialize_frame(const Frame& f, const std::string& description) {
    std::string out(kFrameMagic, sizeof kFrameMagic);
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

Frame deserialize_frame(const std::string& b, const std::string& where, size_t* used) {
    std::function<void(const std::string&)> fail = [&](const std::string& what) {
        throw CacheFileError("render cache file '" + where + "': " + what);
    };
    if (b.size() < sizeof kFrameMagic || std::memcmp(b.data(), kFrameMagic, sizeof kFrameMagic) != 0)
        fail("not a vkmech frame (bad magic)");
    Reader r{b, sizeof kFrameMagic, fail};
    Frame f;
    int32_t w = 0, h = 0;
    uint64_t n = 0;
    r.get(w);
    r.get(h);
    r.get(f.samples);
    r.get(f.seconds);
    r.get(n);
    if (w <= 0 || h <= 0 || n != static_cast<uint64_t>(w) * static_cast<uint64_t>(h)) fail("inconsistent size");
    if (r.pos + n * sizeof(PixelStats) > b.size()) fail("truncated pixel data");
    f.width = w;
    f.height = h;
    f.pixels.resize(n);
    std::memcpy(f.pixels.data(), b.data() + r.pos, n * sizeof(PixelStats));
    r.pos += n * sizeof(PixelStats);
    (void)r.str(1 << 20);  // the description
    if (!used && r.pos != b.size()) fail("trailing bytes after the frame");
    if (used) *used = r.pos;
    if (!std::isfinite(f.seconds) || f.seconds < 0) fail("non-finite or negative render time");
    // Non-finite samples are counted apart (PixelStats::nonfinite), so every statistic is finite.
    for (size_t p = 0; p < n; ++p) {
        const double* v = reinterpret_cast<const double*>(&f.pixels[p]);
        for (int k = 0; k < 17; ++k)
            if (!std::isfinite(v[k]))
                fail("pixel " + std::to_string(p) + " holds a non-finite statistic, though the frame counts non-finite "
                     "samples apart");
        if (f.pixels[p].count < 0 || f.pixels[p].nonfinite < 0) fail("pixel " + std::to_string(p) + " has a negative count");
    }
    return f;
}

std::string serialize_pilot(const Frame& frame, const std::vector<double>& mom_var) {
    std::string b = serialize_frame(frame, "pilot");
    uint64_t n = mom_var.size();
    b.append(reinterpret_cast<const char*>(&n), sizeof n);
    b.append(reinterpret_cast<const char*>(mom_var.data()), n * sizeof(double));
    return b;
}

Frame deserialize_pilot(const std::string& payload, const std::string& where, std::vector<double>* mom_var) {
    size_t used = 0;
    Frame f = deserialize_frame(payload, where, &used);
    uint64_t n = 0;
    if (used + 8 > payload.size()) throw CacheFileError("render cache file '" + where + "': truncated");
    std::memcpy(&n, payload.data() + used, 8);
    if (payload.size() - used - 8 != n * sizeof(double))
        throw CacheFileError("render cache file '" + where + "': wrong size of the pilot's variances");
    if (mom_var) {
        mom_var->resize(n);
        std::memcpy(mom_var->data(), payload.data() + used + 8, n * sizeof(double));
    }
    return f;
}

Frame RenderCache::load(const std::string& key) const {
    const std::string p = path(key);
    return deserialize_frame(open_cache_file(read_whole(p), "frame", key, p), p);
}

std::optional<Frame> RenderCache::try_load(const std::string& key) const {
    const std::string p = path(key);
    if (!fs::exists(p)) return std::nullopt;
    try {
        return load(key);
    } catch (const CacheFileError& e) {
        warn_damaged(e.what());
        std::error_code ec;
        fs::remove(p, ec);
        return std::nullopt;
    }
}

void RenderCache::store(const std::string& key, const Frame& frame, const std::string& description) const {
    write_file_atomic(path(key), seal_cache_file("frame", key, serialize_frame(frame, description)));
}

std::optional<std::string> RenderCache::try_load_payload(const std::string& key, const std::string& kind) const {
    const std::string p = path(key, kind);
    if (!fs::exists(p)) return std::nullopt;
    try {
        return open_cache_file(read_whole(p), kind, key, p);
    } catch (const CacheFileError& e) {
        warn_damaged(e.what());
        std::error_code ec;
        fs::remove(p, ec);
        return std::nullopt;
    }
}

void RenderCache::store_payload(const std::string& key, const std::string& kind, const std::string& payload) const {
    write_file_atomic(path(key, kind), seal_cache_file(kind, key, payload));
}

CacheVerifyReport verify_cache_dir(const std::string& dir) {
    CacheVerifyReport rep;
    std::vector<fs::path> files;
    for (const auto& e : fs::directory_iterator(dir))
        if (e.is_regular_file()) files.push_back(e.path());
    std::sort(files.begin(), files.end());
    for (const auto& f : files) {
        const std::string name = f.filename().string(), full = f.string();
        auto tmp = name.rfind(".tmp-");
        if (tmp != std::string::npos) {
            rep.stale.push_back({full, "a temporary left by an interrupted write (removed by the next study)"});
            continue;
        }
        auto dot = name.find('.');
        const std::string key = name.substr(0, dot), ext = dot == std::string::npos ? "" : name.substr(dot);
        std::string kind = ext == ".frame" ? "frame" : ext == ".frame.pool" ? "pool" : ext == ".frame.pilot" ? "pilot" : "";
        if (kind.empty()) continue;  // not a cache file
        try {
            std::string payload = open_cache_file(read_whole(full), kind, key, full);
            if (kind == "frame") deserialize_frame(payload, full);
            if (kind == "pilot") deserialize_pilot(payload, full, nullptr);
            rep.good.push_back(full);
        } catch (const CacheFileError& e) {
            std::string what = e.what();
            if (what.find("older cache format") != std::string::npos) rep.stale.push_back({full, "an older cache format"});
            else rep.bad.push_back({full, what});
        }
    }
    return rep;
}

}  // namespace vkmech
