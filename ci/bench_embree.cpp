// Intel Embree 3 on the rays of `vkmech bench traversal --dump DIR`: builds
// each dumped scene, traces the very same rays (closest hit) on one thread
// and on every core, with rtcIntersect1 and with 8- or 16-wide packets, and
// checks Embree's hit distances against vkmech's software BVH.
//
// Standalone on purpose (no vkmech headers, no Embree headers): Debian ships
// the Embree 3 runtime (libembree3-3) without its development package on
// the CI machine, so the few entry points and structures used here are
// declared below from the documented Embree 3.13 API and the library is
// opened with dlopen. Build and run: ci/bench-embree.sh.
//
//   bench_embree [--lib PATH] [--quality low|medium|high] [--tol REL] [--repeats N] DUMP_DIR [SCENE...]
//
// Exit status: 0 on success, 1 on errors, 3 when a scene's hits disagree with
// vkmech's on more than 0.1% of its rays (the comparison is then not on the
// same work).
#include <dlfcn.h>
#include <pmmintrin.h>
#include <sys/types.h>
#include <xmmintrin.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace {

// ---- Embree 3.13 API subset (rtcore_common.h, rtcore_ray.h, rtcore_device.h,
// rtcore_geometry.h, rtcore_buffer.h, rtcore_scene.h), with the default
// build configuration RTC_MAX_INSTANCE_LEVEL_COUNT == 1 and RTC_MIN_WIDTH off.
using RTCDevice = void*;
using RTCScene = void*;
using RTCGeometry = void*;

constexpr unsigned kInvalidGeometryId = 0xFFFFFFFFu;  // RTC_INVALID_GEOMETRY_ID
constexpr int kGeometryTypeTriangle = 0;              // RTC_GEOMETRY_TYPE_TRIANGLE
constexpr int kBufferTypeIndex = 0;                   // RTC_BUFFER_TYPE_INDEX
constexpr int kBufferTypeVertex = 1;                  // RTC_BUFFER_TYPE_VERTEX
constexpr int kFormatUint3 = 0x5003;                  // RTC_FORMAT_UINT3
constexpr int kFormatFloat3 = 0x9003;                 // RTC_FORMAT_FLOAT3
constexpr int kPropertyVersion = 0;                   // RTC_DEVICE_PROPERTY_VERSION
constexpr int kPropertyNativeRay8 = 33;               // RTC_DEVICE_PROPERTY_NATIVE_RAY8_SUPPORTED
constexpr int kPropertyNativeRay16 = 34;              // RTC_DEVICE_PROPERTY_NATIVE_RAY16_SUPPORTED
constexpr int kPropertyTaskingSystem = 128;           // RTC_DEVICE_PROPERTY_TASKING_SYSTEM
constexpr int kContextIncoherent = 0;                 // RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT

struct alignas(16) Ray1 {  // struct RTCRay
    float org_x, org_y, org_z, tnear;
    float dir_x, dir_y, dir_z, time;
    float tfar;
    unsigned mask, id, flags;
};
struct alignas(16) Hit1 {  // struct RTCHit
    float Ng_x, Ng_y, Ng_z, u, v;
    unsigned primID, geomID, instID[1];
};
struct RayHit1 {  // struct RTCRayHit
    Ray1 ray;
    Hit1 hit;
};
static_assert(sizeof(Ray1) == 48 && sizeof(Hit1) == 32 && sizeof(RayHit1) == 80, "RTCRayHit layout");

template <int N>
struct alignas(4 * N) RayN {  // struct RTCRay8 / RTCRay16
    float org_x[N], org_y[N], org_z[N], tnear[N];
    float dir_x[N], dir_y[N], dir_z[N], time[N];
    float tfar[N];
    unsigned mask[N], id[N], flags[N];
};
template <int N>
struct alignas(4 * N) HitN {  // struct RTCHit8 / RTCHit16
    float Ng_x[N], Ng_y[N], Ng_z[N], u[N], v[N];
    unsigned primID[N], geomID[N], instID[1][N];
};
template <int N>
struct RayHitN {  // struct RTCRayHit8 / RTCRayHit16
    RayN<N> ray;
    HitN<N> hit;
};
static_assert(sizeof(RayN<8>) == 12 * 32 && sizeof(HitN<8>) == 8 * 32 && sizeof(RayHitN<8>) == 20 * 32 &&
                  sizeof(RayHitN<16>) == 20 * 64,
              "RTCRayHit8/16 layout: 12 ray and 8 hit arrays of N lanes");

struct IntersectContext {  // struct RTCIntersectContext
    int flags;
    void* filter;
    unsigned instID[1];
};
void init_context(IntersectContext& c) {  // rtcInitIntersectContext (an inline function in the header)
    c.flags = kContextIncoherent;
    c.filter = nullptr;
    c.instID[0] = kInvalidGeometryId;
}

struct Embree {
    RTCDevice (*newDevice)(const char*);
    void (*releaseDevice)(RTCDevice);
    int (*getDeviceError)(RTCDevice);
    ssize_t (*getDeviceProperty)(RTCDevice, int);
    RTCScene (*newScene)(RTCDevice);
    void (*setSceneBuildQuality)(RTCScene, int);
    void (*commitScene)(RTCScene);
    void (*releaseScene)(RTCScene);
    RTCGeometry (*newGeometry)(RTCDevice, int);
    void* (*setNewGeometryBuffer)(RTCGeometry, int, unsigned, int, size_t, size_t);
    void (*commitGeometry)(RTCGeometry);
    unsigned (*attachGeometry)(RTCScene, RTCGeometry);
    void (*releaseGeometry)(RTCGeometry);
    void (*intersect1)(RTCScene, IntersectContext*, RayHit1*);
    void (*intersect8)(const int*, RTCScene, IntersectContext*, RayHitN<8>*);
    void (*intersect16)(const int*, RTCScene, IntersectContext*, RayHitN<16>*);

    explicit Embree(const std::string& path) {
        void* h = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
        if (!h) {
            std::string msg = "cannot open the Embree 3 library (";
            msg += dlerror();
            msg += "); install Debian's libembree3-3";
            throw std::runtime_error(msg);
        }
        auto sym = [h](auto& fn, const char* name) {
            void* p = dlsym(h, name);
            if (!p) throw std::runtime_error(std::string("Embree library lacks ") + name);
            fn = reinterpret_cast<std::remove_reference_t<decltype(fn)>>(p);
        };
        sym(newDevice, "rtcNewDevice");
        sym(releaseDevice, "rtcReleaseDevice");
        sym(getDeviceError, "rtcGetDeviceError");
        sym(getDeviceProperty, "rtcGetDeviceProperty");
        sym(newScene, "rtcNewScene");
        sym(setSceneBuildQuality, "rtcSetSceneBuildQuality");
        sym(commitScene, "rtcCommitScene");
        sym(releaseScene, "rtcReleaseScene");
        sym(newGeometry, "rtcNewGeometry");
        sym(setNewGeometryBuffer, "rtcSetNewGeometryBuffer");
        sym(commitGeometry, "rtcCommitGeometry");
        sym(attachGeometry, "rtcAttachGeometry");
        sym(releaseGeometry, "rtcReleaseGeometry");
        sym(intersect1, "rtcIntersect1");
        sym(intersect8, "rtcIntersect8");
        sym(intersect16, "rtcIntersect16");
    }
};

// ---- the dump (host/engine/render/traversal_dump.hpp)
struct DumpRay {
    float ox, oy, oz, tmin, dx, dy, dz, tmax;
};
struct DumpHit {
    float t;
    uint32_t triangle;
};
static_assert(sizeof(DumpRay) == 32 && sizeof(DumpHit) == 8, "dump records");

template <class T>
std::vector<T> read_records(const std::filesystem::path& p) {
    std::ifstream in(p, std::ios::binary);
    if (!in) throw std::runtime_error("cannot read " + p.string());
    in.seekg(0, std::ios::end);
    size_t bytes = static_cast<size_t>(in.tellg());
    if (bytes % sizeof(T)) throw std::runtime_error(p.string() + ": truncated");
    in.seekg(0);
    std::vector<T> v(bytes / sizeof(T));
    in.read(reinterpret_cast<char*>(v.data()), static_cast<std::streamsize>(bytes));
    return v;
}

double json_number(const std::string& json, const std::string& key, double fallback) {
    size_t at = json.find("\"" + key + "\":");
    if (at == std::string::npos) return fallback;
    const char* p = json.c_str() + at + key.size() + 3;
    char* end = nullptr;
    double v = std::strtod(p, &end);
    return end == p ? fallback : v;
}

struct Scene {
    std::string name;
    std::vector<float> tris;  // 9 per triangle
    std::vector<DumpRay> rays;
    std::vector<DumpHit> hits;
    double vk_rays_per_second = 0.0;
    double vk_per_invocation_rays_per_second = 0.0;  // 0: a dump from before the column existed
    std::string device;
};

Scene read_scene(const std::filesystem::path& dir, const std::string& name) {
    Scene s;
    s.name = name;
    std::ifstream js(dir / (name + ".json"));
    if (!js) throw std::runtime_error("cannot read " + (dir / (name + ".json")).string());
    std::stringstream ss;
    ss << js.rdbuf();
    const std::string json = ss.str();
    s.tris = read_records<float>(dir / (name + ".tris.bin"));
    s.rays = read_records<DumpRay>(dir / (name + ".rays.bin"));
    s.hits = read_records<DumpHit>(dir / (name + ".hits.bin"));
    s.vk_rays_per_second = json_number(json, "bvh_rays_per_second", 0.0);
    s.vk_per_invocation_rays_per_second = json_number(json, "bvh_per_invocation_rays_per_second", 0.0);
    if (s.tris.size() % 9 || s.hits.size() != s.rays.size() ||
        json_number(json, "triangles", -1) != static_cast<double>(s.tris.size() / 9) ||
        json_number(json, "rays", -1) != static_cast<double>(s.rays.size()))
        throw std::runtime_error(name + ": the dump's files and JSON counts disagree");
    size_t d = json.find("\"device\": \"");
    if (d != std::string::npos) s.device = json.substr(d + 11, json.find('"', d + 11) - d - 11);
    return s;
}

// ---- tracing
struct Result {
    float t;       // -1: miss
    unsigned tri;  // kInvalidGeometryId: miss
};

void flush_denormals() {
    _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON);
    _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON);
}

void trace1(const Embree& e, RTCScene scene, const DumpRay* r, Result* out, size_t n) {
    IntersectContext ctx;
    init_context(ctx);
    for (size_t i = 0; i < n; ++i) {
        RayHit1 rh;
        rh.ray = {r[i].ox, r[i].oy, r[i].oz, r[i].tmin, r[i].dx, r[i].dy, r[i].dz, 0.0f, r[i].tmax, ~0u, 0u, 0u};
        rh.hit.geomID = kInvalidGeometryId;
        rh.hit.instID[0] = kInvalidGeometryId;
        e.intersect1(scene, &ctx, &rh);
        bool hit = rh.hit.geomID != kInvalidGeometryId;
        out[i] = {hit ? rh.ray.tfar : -1.0f, hit ? rh.hit.primID : kInvalidGeometryId};
    }
}

template <int N>
void traceN(const Embree& e, RTCScene scene, const DumpRay* r, Result* out, size_t n) {
    IntersectContext ctx;
    init_context(ctx);
    RayHitN<N> rh;
    alignas(4 * N) int valid[N];
    for (size_t base = 0; base < n; base += N) {
        for (int k = 0; k < N; ++k) {
            size_t i = base + k;
            valid[k] = i < n ? -1 : 0;
            const DumpRay& x = r[i < n ? i : base];
            rh.ray.org_x[k] = x.ox;
            rh.ray.org_y[k] = x.oy;
            rh.ray.org_z[k] = x.oz;
            rh.ray.tnear[k] = x.tmin;
            rh.ray.dir_x[k] = x.dx;
            rh.ray.dir_y[k] = x.dy;
            rh.ray.dir_z[k] = x.dz;
            rh.ray.time[k] = 0.0f;
            rh.ray.tfar[k] = x.tmax;
            rh.ray.mask[k] = ~0u;
            rh.ray.id[k] = 0u;
            rh.ray.flags[k] = 0u;
            rh.hit.geomID[k] = kInvalidGeometryId;
            rh.hit.instID[0][k] = kInvalidGeometryId;
        }
        if constexpr (N == 8) e.intersect8(valid, scene, &ctx, &rh);
        else e.intersect16(valid, scene, &ctx, &rh);
        for (int k = 0; k < N && base + k < n; ++k) {
            bool hit = rh.hit.geomID[k] != kInvalidGeometryId;
            out[base + k] = {hit ? rh.ray.tfar[k] : -1.0f, hit ? rh.hit.primID[k] : kInvalidGeometryId};
        }
    }
}

using TraceFn = std::function<void(const DumpRay*, Result*, size_t)>;

// Rays per second: median of `repeats` timed passes after one warm-up pass,
// the rays split into `threads` contiguous chunks (a multiple of 16 rays).
double measure(const TraceFn& fn, const std::vector<DumpRay>& rays, std::vector<Result>& out, unsigned threads,
               int repeats) {
    const size_t n = rays.size();
    auto pass = [&] {
        auto t0 = std::chrono::steady_clock::now();
        std::vector<std::thread> pool;
        size_t chunk = ((n + threads - 1) / threads + 15) / 16 * 16;
        for (unsigned k = 0; k < threads; ++k) {
            size_t lo = std::min(n, k * chunk), hi = std::min(n, lo + chunk);
            pool.emplace_back([&, lo, hi] {
                flush_denormals();
                fn(rays.data() + lo, out.data() + lo, hi - lo);
            });
        }
        for (auto& t : pool) t.join();
        return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    };
    pass();
    std::vector<double> s;
    for (int i = 0; i < repeats; ++i) s.push_back(pass());
    std::sort(s.begin(), s.end());
    return n / s[s.size() / 2];
}

struct Agreement {
    size_t rays = 0, both_miss = 0, agree = 0, same_triangle = 0, t_differs = 0, vk_only = 0, embree_only = 0;
    size_t mismatches() const { return t_differs + vk_only + embree_only; }
    double mismatch_rate() const { return rays ? static_cast<double>(mismatches()) / rays : 0.0; }
};

Agreement compare(const std::vector<DumpHit>& vk, const std::vector<Result>& em, double tol) {
    Agreement a;
    a.rays = vk.size();
    for (size_t i = 0; i < vk.size(); ++i) {
        bool vh = vk[i].t >= 0.0f, eh = em[i].t >= 0.0f;
        if (!vh && !eh) ++a.both_miss;
        else if (vh && !eh) ++a.vk_only;
        else if (!vh && eh) ++a.embree_only;
        else if (std::fabs(double(vk[i].t) - em[i].t) <= tol * std::max<double>(vk[i].t, em[i].t)) {
            ++a.agree;
            if (vk[i].triangle == em[i].tri) ++a.same_triangle;
        } else ++a.t_differs;
    }
    return a;
}

size_t differing(const std::vector<Result>& a, const std::vector<Result>& b) {
    size_t d = 0;
    for (size_t i = 0; i < a.size(); ++i) d += a[i].tri != b[i].tri || a[i].t != b[i].t;
    return d;
}

const char* quality_name(int q) { return q == 0 ? "low" : q == 1 ? "medium" : "high"; }

int run(int argc, char** argv) {
    std::string lib = "/usr/lib/x86_64-linux-gnu/libembree3.so.3";
    int quality = 1;  // RTC_BUILD_QUALITY_MEDIUM, Embree's default
    double tol = 1e-4;
    int repeats = 3;
    std::filesystem::path dir;
    std::vector<std::string> names;
    for (int i = 1; i < argc; ++i) {
        std::string a = argv[i];
        auto next = [&]() -> std::string {
            if (i + 1 >= argc) throw std::runtime_error(a + " needs a value");
            return argv[++i];
        };
        if (a == "--lib") lib = next();
        else if (a == "--quality") {
            std::string q = next();
            quality = q == "low" ? 0 : q == "medium" ? 1 : q == "high" ? 2 : -1;
            if (quality < 0) throw std::runtime_error("--quality: low, medium or high");
        } else if (a == "--tol") tol = std::stod(next());
        else if (a == "--repeats") repeats = std::max(1, std::stoi(next()));
        else if (dir.empty()) dir = a;
        else names.push_back(a);
    }
    if (dir.empty()) throw std::runtime_error("usage: bench_embree [--lib PATH] [--quality low|medium|high] [--tol REL] "
                                              "[--repeats N] DUMP_DIR [SCENE...]");
    if (names.empty()) {
        for (const auto& f : std::filesystem::directory_iterator(dir)) {
            std::string n = f.path().filename().string();
            if (n.size() > 5 && n.ends_with(".json")) names.push_back(n.substr(0, n.size() - 5));
        }
        std::sort(names.begin(), names.end());
    }
    if (names.empty()) throw std::runtime_error("no <scene>.json in " + dir.string());

    Embree e(lib);
    RTCDevice device = e.newDevice(nullptr);
    if (!device) throw std::runtime_error("rtcNewDevice failed");
    const ssize_t version = e.getDeviceProperty(device, kPropertyVersion);
    const int width = e.getDeviceProperty(device, kPropertyNativeRay16) ? 16
                      : e.getDeviceProperty(device, kPropertyNativeRay8) ? 8
                                                                          : 0;
    const ssize_t tasking = e.getDeviceProperty(device, kPropertyTaskingSystem);
    const unsigned threads = std::max(1u, std::thread::hardware_concurrency());
    std::printf("Embree %zd.%zd.%zd (%s), tasking %s, native packet width %d; %u threads; build quality %s; "
                "t agreement within %g relative; median of %d passes after a warm-up\n",
                version / 10000, version / 100 % 100, version % 100, lib.c_str(),
                tasking == 0 ? "internal" : tasking == 1 ? "TBB" : tasking == 2 ? "PPL" : "?", width, threads,
                quality_name(quality), tol, repeats);

    struct Row {
        std::string name;
        size_t tris = 0, rays = 0;
        double vk = 0, vk_inv = 0, build_ms = 0, e1 = 0, en = 0, p1 = 0, pn = 0;
        Agreement agr{};
        size_t packet_diff = 0;
    };
    std::vector<Row> rows;
    bool loud = false;
    for (const auto& name : names) {
        Scene s = read_scene(dir, name);
        const size_t nt = s.tris.size() / 9;
        auto b0 = std::chrono::steady_clock::now();
        RTCScene scene = e.newScene(device);
        e.setSceneBuildQuality(scene, quality);
        RTCGeometry geom = e.newGeometry(device, kGeometryTypeTriangle);
        auto* vb = static_cast<float*>(e.setNewGeometryBuffer(geom, kBufferTypeVertex, 0, kFormatFloat3,
                                                              3 * sizeof(float), 3 * nt));
        auto* ib = static_cast<unsigned*>(e.setNewGeometryBuffer(geom, kBufferTypeIndex, 0, kFormatUint3,
                                                                 3 * sizeof(unsigned), nt));
        if (!vb || !ib) throw std::runtime_error("rtcSetNewGeometryBuffer failed");
        std::memcpy(vb, s.tris.data(), s.tris.size() * sizeof(float));
        for (unsigned i = 0; i < 3 * nt; ++i) ib[i] = i;
        e.commitGeometry(geom);
        e.attachGeometry(scene, geom);
        e.releaseGeometry(geom);
        e.commitScene(scene);
        const double build_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - b0).count();
        if (int err = e.getDeviceError(device)) throw std::runtime_error(name + ": Embree error " + std::to_string(err));

        std::vector<Result> one(s.rays.size()), many(s.rays.size()), pk(s.rays.size());
        TraceFn f1 = [&](const DumpRay* r, Result* o, size_t n) { trace1(e, scene, r, o, n); };
        TraceFn fp = [&](const DumpRay* r, Result* o, size_t n) {
            if (width == 16) traceN<16>(e, scene, r, o, n);
            else traceN<8>(e, scene, r, o, n);
        };
        Row row{.name = name,
                .tris = nt,
                .rays = s.rays.size(),
                .vk = s.vk_rays_per_second,
                .vk_inv = s.vk_per_invocation_rays_per_second,
                .build_ms = build_ms};
        row.e1 = measure(f1, s.rays, one, 1, repeats);
        row.en = measure(f1, s.rays, many, threads, repeats);
        if (width) {
            row.p1 = measure(fp, s.rays, pk, 1, repeats);
            row.pn = measure(fp, s.rays, pk, threads, repeats);
            row.packet_diff = differing(one, pk);
        }
        row.packet_diff += differing(one, many);
        row.agr = compare(s.hits, one, tol);
        e.releaseScene(scene);
        const Agreement& a = row.agr;
        std::printf("%s: %zu triangles, %zu rays (vkmech on %s): both miss %zu, agree %zu (same triangle %zu), "
                    "t differs %zu, only vkmech hits %zu, only Embree hits %zu; mismatch %.4f%%; build %.1f ms\n",
                    name.c_str(), nt, s.rays.size(), s.device.c_str(), a.both_miss, a.agree, a.same_triangle,
                    a.t_differs, a.vk_only, a.embree_only, 100.0 * a.mismatch_rate(), build_ms);
        if (row.packet_diff)
            std::printf("%s: note: %zu results differ between Embree's own variants (1 ray, threads, packets)\n",
                        name.c_str(), row.packet_diff);
        if (a.mismatch_rate() > 0.001) {
            loud = true;
            std::printf("\n!!!!!!!! %s: Embree and vkmech DISAGREE on %.3f%% of the rays (> 0.1%%): this is NOT a "
                        "comparison on the same work !!!!!!!!\n\n",
                        name.c_str(), 100.0 * a.mismatch_rate());
            std::fprintf(stderr, "bench_embree: %s: closest hits disagree on %.3f%% of the rays\n", name.c_str(),
                         100.0 * a.mismatch_rate());
        }
        std::fflush(stdout);
        rows.push_back(row);
    }
    e.releaseDevice(device);

    const std::string pk_name = width ? "pkt" + std::to_string(width) : "pkt";
    std::printf("\nclosest-hit rays/s in millions; vkmech = software BVH on the dump's Vulkan device (all its "
                "threads), vk 1/inv = the same with one ray per invocation (as the path tracer traces); Embree: "
                "rtcIntersect1 and rtcIntersect%d, 1 thread and %u threads\n",
                width, threads);
    std::printf("%-20s %9s %9s %9s %9s %9s %9s %9s %9s %10s %9s %9s\n", "scene", "triangles", "vkmech", "vk 1/inv",
                "emb 1T", "emb NT", (pk_name + " 1T").c_str(), (pk_name + " NT").c_str(), "best/vk", "vk/embNT",
                "agree %", "build ms");
    for (const auto& r : rows) {
        double best = std::max(r.en, r.pn);
        double agree = 100.0 * (1.0 - r.agr.mismatch_rate());
        std::printf("%-20s %9zu %9.3f %9.3f %9.3f %9.3f %9.3f %9.3f %8.2fx %9.3f %9.3f %9.1f\n", r.name.c_str(),
                    r.tris, r.vk / 1e6, r.vk_inv / 1e6, r.e1 / 1e6, r.en / 1e6, r.p1 / 1e6, r.pn / 1e6,
                    r.vk > 0 ? best / r.vk : 0.0, r.en > 0 ? r.vk / r.en : 0.0, agree, r.build_ms);
    }
    if (loud) {
        std::printf("\n!!!!!!!! at least one scene's closest hits disagree on more than 0.1%% of the rays !!!!!!!!\n");
        return 3;
    }
    return 0;
}

}  // namespace

int main(int argc, char** argv) {
    try {
        return run(argc, argv);
    } catch (const std::exception& ex) {
        std::fprintf(stderr, "bench_embree: %s\n", ex.what());
        return 1;
    }
}
