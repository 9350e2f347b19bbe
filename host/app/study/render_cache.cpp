#include "study/render_cache.hpp"

#include "io/atomic_file.hpp"
#include "render/shader_modules.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <stdexcept>
#include <type_traits>

namespace fs = std::filesystem;

namespace vkmech {

namespace {
constexpr char kOldFrameMagic[8] = {'V', 'K', 'M', 'F', 'R', 'M', '0', '1'};  // format 1: no key, no checksum
constexpr char kFileMagic[8] = {'V', 'K', 'M', 'C', 'A', 'C', 'H', 'E'};
constexpr char kBlobMagic[8] = {'V', 'K', 'M', 'B', 'L', 'O', 'B', '1'};
// 2: untyped payloads; 3: every payload a typed, versioned blob.
constexpr uint32_t kFormatVersion = 3;
constexpr uint32_t kFrameBlobVersion = 1, kPilotBlobVersion = 1, kPoolBlobVersion = 1, kPilotSamplesBlobVersion = 1;
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
    template <class T>
    void get(T& v) {
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
    // The emitters at infinity (their texels are in `texels`); only where a scene has them, so
    // that the keys of scenes without them are what they were.
    if (arrays.has_infinite_lights()) d.pod(arrays.environment).vec(arrays.directional);
    // Likewise the file's tangents (their meshes' vertices come last in `vertices`).
    if (!arrays.tangents.empty()) d.vec(arrays.tangents).pod(arrays.tangent_vertex_base);
    const Camera& c = scene.camera;
    d.pod(static_cast<uint32_t>(c.type))
        .pod(c.to_world)
        .pod(c.fov_deg)
        .str(c.fov_axis)
        .pod(c.near_clip)
        .pod(c.far_clip);
    d.pod(c.aperture_radius).pod(c.focus_distance).pod(c.width).pod(c.height);
    d.pod(scene.integrator.max_depth).pod(scene.integrator.rr_depth);
    return d.hex();
}

std::string cache_key(const CacheKeyParts& k) {
    Digest d;
    d.str("vkmech-render-cache-v2").str(k.scene_digest).pod(k.width).pod(k.height).pod(k.spp).pod(k.seed);
    d.pod(k.estimator).pod(k.batch_spp).str(k.traversal).str(k.device).str(k.code_digest).pod(k.end_vertex);
    if (!k.taxonomy.empty()) d.str("taxonomy").str(k.taxonomy);  // the buckets' keys stay what they were
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

std::string open_cache_file(const std::string& b, const std::string& kind, const std::string& key,
                            const std::string& where) {
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
    if (version < kFormatVersion && version >= 2)
        fail("an older cache format (" + std::to_string(version) + "; this vkmech reads " +
             std::to_string(kFormatVersion) + ")");
    if (version != kFormatVersion)
        fail("cache format " + std::to_string(version) + ", this vkmech reads " + std::to_string(kFormatVersion));
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
        fail(b.size() - r.pos < size
                 ? "truncated (" + std::to_string(b.size() - r.pos) + " of " + std::to_string(size) + " payload bytes)"
                 : "trailing bytes after the payload");
    std::string payload = b.substr(r.pos);
    if (Digest().str(kind).str(key).str(payload).hex() != digest) fail("checksum mismatch (the data is damaged)");
    return payload;
}

BlobWriter::BlobWriter(const std::string& type, uint32_t version) : out_(kBlobMagic, sizeof kBlobMagic) {
    str(type);
    pod(version);
}

BlobWriter& BlobWriter::str(const std::string& s) {
    pod(static_cast<uint64_t>(s.size()));
    out_ += s;
    return *this;
}

BlobReader::BlobReader(const std::string& bytes, const std::string& type, uint32_t version, std::string where)
    : b_(bytes), where_(std::move(where)) {
    if (b_.size() < sizeof kBlobMagic || std::memcmp(b_.data(), kBlobMagic, sizeof kBlobMagic) != 0)
        fail("not a vkmech " + type + " (bad magic)");
    pos_ = sizeof kBlobMagic;
    const uint64_t n = pod<uint64_t>();
    if (n > 64 || n > left()) fail("truncated or damaged header");
    const std::string stored = b_.substr(pos_, n);
    pos_ += n;
    if (stored != type) fail("holds a '" + stored + "' record, expected a '" + type + "'");
    const uint32_t v = pod<uint32_t>();
    if (v != version)
        fail("a '" + type + "' record of version " + std::to_string(v) + ", this vkmech reads version " +
             std::to_string(version));
}

void BlobReader::take(void* dst, size_t n) {
    if (n > left()) fail("truncated");
    std::memcpy(dst, b_.data() + pos_, n);
    pos_ += n;
}

std::string BlobReader::str() {
    const uint64_t n = pod<uint64_t>();
    if (n > left())
        fail("truncated (a string of " + std::to_string(n) + " bytes, " + std::to_string(left()) + " left)");
    std::string s = b_.substr(pos_, n);
    pos_ += n;
    return s;
}

void BlobReader::end() const {
    if (pos_ != b_.size()) fail("trailing bytes after the record");
}

void BlobReader::fail(const std::string& what) const {
    throw CacheFileError("render cache file '" + where_ + "': " + what);
}

std::string serialize_frame(const Frame& f, const std::string& description) {
    return BlobWriter("frame", kFrameBlobVersion)
        .pod(static_cast<int32_t>(f.width))
        .pod(static_cast<int32_t>(f.height))
        .pod(f.samples)
        .pod(f.seconds)
        .array(f.pixels)
        .str(description)
        .bytes();
}

Frame deserialize_frame(const std::string& b, const std::string& where) {
    BlobReader r(b, "frame", kFrameBlobVersion, where);
    Frame f;
    const int32_t w = r.pod<int32_t>(), h = r.pod<int32_t>();
    f.samples = r.pod<uint64_t>();
    f.seconds = r.pod<double>();
    if (w <= 0 || h <= 0) r.fail("inconsistent size");
    f.pixels = r.array<PixelStats>();
    if (f.pixels.size() != static_cast<uint64_t>(w) * static_cast<uint64_t>(h)) r.fail("inconsistent size");
    f.width = w;
    f.height = h;
    (void)r.str();  // the description
    r.end();
    if (!std::isfinite(f.seconds) || f.seconds < 0) r.fail("non-finite or negative render time");
    // Non-finite samples are counted apart (PixelStats::nonfinite), so every statistic is finite.
    for (size_t p = 0; p < f.pixels.size(); ++p) {
        const double* v = reinterpret_cast<const double*>(&f.pixels[p]);
        for (int k = 0; k < 17; ++k)
            if (!std::isfinite(v[k]))
                r.fail("pixel " + std::to_string(p) +
                       " holds a non-finite statistic, though the frame counts non-finite "
                       "samples apart");
        if (f.pixels[p].count < 0 || f.pixels[p].nonfinite < 0)
            r.fail("pixel " + std::to_string(p) + " has a negative count");
    }
    return f;
}

std::string serialize_pilot(const Frame& frame, const std::vector<double>& mom_var) {
    return BlobWriter("pilot", kPilotBlobVersion).str(serialize_frame(frame, "pilot")).array(mom_var).bytes();
}

Pilot deserialize_pilot(const std::string& payload, const std::string& where) {
    BlobReader r(payload, "pilot", kPilotBlobVersion, where);
    Frame f = deserialize_frame(r.str(), where);
    std::vector<double> mom = r.array<double>();
    r.end();
    if (!mom.empty() && mom.size() != f.pixels.size())
        r.fail(std::to_string(mom.size()) + " median-of-means variances for " + std::to_string(f.pixels.size()) +
               " pixels");
    for (double v : mom)
        if (!std::isfinite(v) || v < 0) r.fail("a non-finite or negative median-of-means variance");
    return make_pilot(std::move(f), std::move(mom));
}

std::string serialize_pilot_samples(const PilotSamples& s) {
    return BlobWriter("pilot-samples", kPilotSamplesBlobVersion)
        .pod(s.samples)
        .pod(static_cast<uint64_t>(s.pixels))
        .array(s.lum)
        .bytes();
}

PilotSamples deserialize_pilot_samples(const std::string& payload, const std::string& where) {
    BlobReader r(payload, "pilot-samples", kPilotSamplesBlobVersion, where);
    PilotSamples s;
    s.samples = r.pod<uint32_t>();
    const uint64_t pixels = r.pod<uint64_t>();
    s.lum = r.array<float>();
    r.end();
    if (pixels == 0 || s.samples == 0 || s.lum.size() / pixels != s.samples || s.lum.size() != pixels * s.samples)
        r.fail("inconsistent sizes (" + std::to_string(s.samples) + " samples of " + std::to_string(pixels) +
               " pixels, " + std::to_string(s.lum.size()) + " values)");
    s.pixels = static_cast<size_t>(pixels);
    for (float x : s.lum)
        if (std::isinf(x)) r.fail("an infinite luminance (a counted-out sample is stored as NaN)");
    return s;
}

std::string serialize_pool(const SamplePool& pool) {
    return BlobWriter("pool", kPoolBlobVersion)
        .pod(pool.frames)
        .pod(static_cast<uint64_t>(pool.pixels))
        .array(pool.samples)
        .array(pool.oracle_var)
        .bytes();
}

SamplePool deserialize_pool(const std::string& payload, const std::string& where) {
    BlobReader r(payload, "pool", kPoolBlobVersion, where);
    SamplePool pool;
    pool.frames = r.pod<uint32_t>();
    const uint64_t pixels = r.pod<uint64_t>();
    pool.samples = r.array<float>();
    pool.oracle_var = r.array<double>();
    r.end();
    if (pixels == 0 || pool.frames == 0 || pool.oracle_var.size() != pixels ||
        pool.samples.size() / 4 / pixels != pool.frames || pool.samples.size() != 4 * pixels * pool.frames)
        r.fail("inconsistent sizes (" + std::to_string(pool.frames) + " frames of " + std::to_string(pixels) +
               " pixels, " + std::to_string(pool.samples.size()) + " sample values, " +
               std::to_string(pool.oracle_var.size()) + " variances)");
    pool.pixels = static_cast<size_t>(pixels);
    for (size_t i = 0; i < pool.samples.size(); i += 4) {
        const float* x = &pool.samples[i];
        if (x[3] != 0.0f && x[3] != 1.0f) r.fail("a sample's finite flag is neither 0 nor 1");
        if (x[3] == 1.0f && !(std::isfinite(x[0]) && std::isfinite(x[1]) && std::isfinite(x[2])))
            r.fail("a sample flagged finite holds a non-finite value");
    }
    for (double v : pool.oracle_var)
        if (!std::isfinite(v) || v < 0) r.fail("a non-finite or negative oracle variance");
    return pool;
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

namespace {
template <class T, class Parse>
std::optional<T> try_load_side(const RenderCache& cache, const std::string& key, const std::string& kind, Parse parse) {
    const std::string p = cache.path(key, kind);
    std::optional<std::string> payload = cache.try_load_payload(key, kind);  // warns and removes a damaged file
    if (!payload) return std::nullopt;
    try {
        return parse(*payload, p);
    } catch (const CacheFileError& e) {  // sealed but unsound (e.g. non-finite): never used
        warn_damaged(e.what());
        std::error_code ec;
        fs::remove(p, ec);
        return std::nullopt;
    }
}
}  // namespace

std::optional<Pilot> RenderCache::try_load_pilot(const std::string& key) const {
    return try_load_side<Pilot>(*this, key, "pilot", deserialize_pilot);
}

void RenderCache::store_pilot(const std::string& key, const Pilot& pilot) const {
    store_payload(key, "pilot", serialize_pilot(pilot.frame, pilot.mom_var));
}

std::optional<SamplePool> RenderCache::try_load_pool(const std::string& key) const {
    return try_load_side<SamplePool>(*this, key, "pool", deserialize_pool);
}

void RenderCache::store_pool(const std::string& key, const SamplePool& pool) const {
    store_payload(key, "pool", serialize_pool(pool));
}

std::optional<PilotSamples> RenderCache::try_load_pilot_samples(const std::string& key) const {
    return try_load_side<PilotSamples>(*this, key, "pilot-samples", deserialize_pilot_samples);
}

void RenderCache::store_pilot_samples(const std::string& key, const PilotSamples& s) const {
    store_payload(key, "pilot-samples", serialize_pilot_samples(s));
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
        std::string kind = ext == ".frame"                 ? "frame"
                           : ext == ".frame.pool"          ? "pool"
                           : ext == ".frame.pilot"         ? "pilot"
                           : ext == ".frame.pilot-samples" ? "pilot-samples"
                                                           : "";
        if (kind.empty()) continue;  // not a cache file
        try {
            std::string payload = open_cache_file(read_whole(full), kind, key, full);
            if (kind == "frame") deserialize_frame(payload, full);
            if (kind == "pilot") deserialize_pilot(payload, full);
            if (kind == "pool") deserialize_pool(payload, full);
            if (kind == "pilot-samples") deserialize_pilot_samples(payload, full);
            rep.good.push_back(full);
        } catch (const CacheFileError& e) {
            std::string what = e.what();
            if (what.find("older cache format") != std::string::npos)
                rep.stale.push_back({full, "an older cache format"});
            else
                rep.bad.push_back({full, what});
        }
    }
    return rep;
}

}  // namespace vkmech
