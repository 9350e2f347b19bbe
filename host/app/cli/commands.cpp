#include "cli/commands.hpp"
#include "cli/resources.hpp"

#include "io/interrupt.hpp"
#include "io/output_set.hpp"
#include "render/render_outputs.hpp"
#include "render/descriptor.hpp"
#include "render/features.hpp"
#include "render/gpu_scene.hpp"
#include "render/ray_caster.hpp"
#include "render/renderer.hpp"
#include "scene/scene.hpp"
#include "vk/context.hpp"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <map>
#include <optional>

namespace fs = std::filesystem;

namespace vkmech {

void add_common_options(CLI::App* app, CommonOptions& o) {
    app->add_option("--scene", o.scene,
                    "Scene name in scenes/ (e.g. ring_caustic) or a path to a Mitsuba XML (.xml) or glTF (.gltf, .glb) file")
        ->required();
    app->add_option("-D,--define", o.defines, "Override a scene parameter: -D name=value (as Mitsuba's -D)");
    app->add_option("--res", o.res, "Film width in pixels (height follows the scene's aspect)")->check(CLI::Range(1u, 16384u));
    app->add_option("--device", o.device, "Vulkan device index (see `vkmech devices`)");
    app->add_option("--traversal", o.traversal, "Ray traversal: auto, rayquery or bvh")
        ->check(CLI::IsMember({"auto", "rayquery", "bvh"}));
    app->add_flag("--substitute", o.substitute,
                  "Replace what is outside the model by its nearest model, and record each replacement: environment "
                  "maps by an overhead panel of their mean radiance, point/spot/directional lights by emitters of the "
                  "same power or irradiance, phong/blendbsdf/cut-out masks/other BSDFs by the nearest material, media "
                  "ignored (README: Your own scenes)");
    app->add_option("--max-triangles", o.max_triangles,
                    "Most triangles the scene may expand to (default: $VKMECH_MAX_TRIANGLES, else 50000000)")
        ->check(CLI::PositiveNumber);
    app->add_flag("--validation", o.validation, "Enable the Vulkan validation layers when installed");
    add_pipeline_cache_option(app, o.pipeline_cache);
}

void add_pipeline_cache_option(CLI::App* app, std::optional<std::string>& dir) {
    app->add_option("--pipeline-cache", dir,
                    "Directory of the on-disk Vulkan pipeline cache, or 'off' (default: $VKMECH_CACHE_DIR, else "
                    "$XDG_CACHE_HOME/vkmech, else ~/.cache/vkmech)");
}

std::string resolve_scene_path(const std::string& arg) {
    std::string ext = fs::path(arg).extension().string();
    for (auto& ch : ext) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
    bool looks_like_path = arg.find('/') != std::string::npos || ext == ".xml" || ext == ".gltf" || ext == ".glb";
    if (looks_like_path) {
        if (!fs::exists(arg)) throw UsageError("scene file '" + arg + "' does not exist");
        return arg;
    }
    for (const auto& d : scene_dir_candidates(ResourceRoots::from_process())) {
        fs::path p = fs::path(d.path) / (arg + ".xml");
        if (fs::exists(p)) return p.string();
    }
    const Resource dir = find_scene_dir();
    if (!dir.found()) throw UsageError("no scene named '" + arg + "': " + dir.missing_message());
    std::string known;
    for (const auto& n : project_scene_names()) known += " " + n;
    throw UsageError("no scene named '" + arg + "' (known:" + known + "; searched: " + dir.searched_list() + ")");
}

std::vector<std::string> project_scene_names() {
    const Resource dir = find_scene_dir();
    if (!dir.found()) return {};
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(dir.path))
        if (e.is_regular_file() && e.path().extension() == ".xml") names.push_back(e.path().stem().string());
    std::sort(names.begin(), names.end());
    return names;
}

namespace {

LoadOptions load_options(const CommonOptions& o) {
    LoadOptions lo;
    lo.substitute_unsupported = o.substitute;
    lo.max_triangles = o.max_triangles;
    for (const auto& d : o.defines) {
        auto eq = d.find('=');
        if (eq == std::string::npos || eq == 0) throw UsageError("-D expects name=value, got '" + d + "'");
        lo.params[d.substr(0, eq)] = d.substr(eq + 1);
    }
    return lo;
}

Scene load_for_cli(const CommonOptions& o, bool report = true) {
    std::string path = resolve_scene_path(o.scene);
    Scene scene = load_scene(path, load_options(o));
    if (o.res) {
        scene.camera.set_film_width(static_cast<int>(*o.res));
    }
    if (report) {
        for (const auto& s : scene.substitutions) std::cerr << "vkmech: substitution: " << s << "\n";
        for (const auto& w : scene.warnings) std::cerr << "vkmech: warning: " << w << "\n";
    }
    return scene;
}

// Issue 10: a black image, an empty label map or a value beyond float's
// range is said on stderr (and in the JSON); the exit code stays 0.
void report_render_warnings(const WrittenFiles& files) {
    for (const auto& w : files.warnings) std::cerr << "vkmech: warning: " << w << "\n";
}

std::string scene_stem(const std::string& name_or_path) { return fs::path(name_or_path).stem().string(); }

// The output set of a render (issue 10): --out must be writable before anything renders (exit 2 otherwise).
std::unique_ptr<OutputSet> open_output_set(const std::string& out_dir, const std::string& name) {
    require_writable_dir(out_dir, "--out");
    return std::make_unique<OutputSet>(out_dir, name);
}

class Progress {
public:
    explicit Progress(std::string label) : label_(std::move(label)), tty_(isatty(STDERR_FILENO)), t0_(clock::now()) {}
    void operator()(uint32_t done, uint32_t total) {
        double el = std::chrono::duration<double>(clock::now() - t0_).count();
        double left = done > 0 ? el * (total - done) / done : 0.0;
        int pct = static_cast<int>(100.0 * done / total);
        if (tty_) {
            std::fprintf(stderr, "\r%s: %u/%u spp (%3d%%)  %.1fs elapsed, ~%.1fs left   ", label_.c_str(), done, total, pct,
                         el, left);
            if (done == total) std::fprintf(stderr, "\n");
        } else if (pct >= next_pct_ || done == total) {
            std::fprintf(stderr, "%s: %u/%u spp (%d%%) %.1fs elapsed, ~%.1fs left\n", label_.c_str(), done, total, pct, el,
                         left);
            next_pct_ = pct + 25;
        }
        std::fflush(stderr);
    }

private:
    using clock = std::chrono::steady_clock;
    std::string label_;
    bool tty_;
    clock::time_point t0_;
    int next_pct_ = 0;
};

}  // namespace

int cmd_render_adaptive(const RenderOptions& o);

namespace {

// SPEC §1: plain `render` defaults to MIS; the paper's protocol (adaptive
// rendering, studies) to NEE.
Estimator render_estimator(const RenderOptions& o, Estimator fallback) {
    return o.estimator.empty() ? fallback : parse_estimator(o.estimator);
}

RenderInfo render_info(const std::string& name, const RenderOptions& o, const vk::Context& ctx, Traversal trav,
                       Estimator estimator, const Features& features, const Scene& scene, uint32_t spp, uint32_t seed,
                       bool capture) {
    RenderInfo info{name, resolve_scene_path(o.common.scene), ctx.info().name, to_string(trav), to_string(estimator),
                    features.describe(), spp, seed, capture};
    info.light_selection = o.light_selection;
    info.end_vertex = o.end_vertex;
    info.exposure_ev = o.exposure;
    info.warnings = scene.warnings;
    info.substitutions = scene.substitutions;
    return info;
}

}  // namespace

int cmd_render(const RenderOptions& o) {
    if (!o.adaptive.empty()) return cmd_render_adaptive(o);
    Scene scene = load_for_cli(o.common);
    std::string name = scene_stem(o.common.scene);
    std::string out_dir = o.out_dir.empty() ? "out/" + name : o.out_dir;
    Estimator estimator = render_estimator(o, Estimator::Mis);
    bool capture = o.capture == "on";
    SignalGuard signals;  // SIGINT/SIGTERM: stop at the next batch, remove the staged files, exit 130/143
    std::unique_ptr<OutputSet> set = open_output_set(out_dir, name);

    vk::ContextOptions co;
    co.device_index = o.common.device;
    co.validation = o.common.validation;
    co.pipeline_cache_dir = o.common.pipeline_cache;
    vk::Context ctx(co);
    Traversal trav = resolve_traversal(ctx, parse_traversal(o.common.traversal));
    SceneArrays arrays = flatten_scene(scene, parse_light_selection(o.light_selection));
    GpuScene gpu_scene(ctx, arrays, trav);
    Features features = o.generic ? Features::generic(estimator, capture) : Features::from_scene(scene, estimator, capture);
    features.end_vertex = parse_end_vertex(o.end_vertex);
    const vk::PipelineStats before = ctx.pipeline_cache().stats();
    Renderer renderer(ctx, scene, arrays, gpu_scene, features);
    const vk::PipelineStats pipes = ctx.pipeline_cache().stats() - before;

    std::fprintf(stderr, "vkmech: %s: %dx%d, %zu triangles, %zu emitters, %u spp on '%s' (%s traversal; %s; %s light "
                 "selection)\n",
                 name.c_str(), scene.camera.width, scene.camera.height, arrays.triangles.size(), scene.emitters.size(),
                 o.spp, ctx.info().name.c_str(), to_string(trav), features.describe().c_str(), o.light_selection.c_str());
    RenderSpec spec;
    spec.spp = o.spp;
    spec.seed = o.seed;
    spec.batch_spp = o.batch_spp;
    spec.mode = o.preview ? gpu::MODE_DIRECT_PREVIEW : gpu::MODE_PATH;
    Progress progress("render " + name);
    spec.progress = [&](uint32_t d, uint32_t t) {
        throw_if_interrupted();
        progress(d, t);
    };
    Frame frame = renderer.render(spec);

    RenderInfo info = render_info(name, o, ctx, trav, estimator, features, scene, o.spp, o.seed, capture);
    info.pipeline_seconds = pipes.seconds;
    info.pipeline_cache = vk::pipeline_cache_outcome(pipes, ctx.pipeline_cache().enabled());
    std::optional<Descriptor> desc;
    std::optional<DescriptorSummary> summary;
    if (capture) {
        desc = derive_descriptor(frame);
        summary = summarize(frame, *desc);
    }
    WrittenFiles files = write_render_outputs(*set, info, frame, desc ? &*desc : nullptr, summary ? &*summary : nullptr);
    set->commit();
    report_render_warnings(files);

    double paths_per_s = frame.seconds > 0 ? frame.samples / frame.seconds : 0.0;
    uint64_t nonfinite = 0;
    for (const auto& p : frame.pixels) nonfinite += static_cast<uint64_t>(p.nonfinite);
    std::printf("%s: %d x %d, %u spp, %.2f s, %.3g paths/s, non-finite samples: %llu\n", name.c_str(), frame.width,
                frame.height, o.spp, frame.seconds, paths_per_s, static_cast<unsigned long long>(nonfinite));
    std::printf("pipeline creation: %.2f s (%s; not in the render time)\n", info.pipeline_seconds,
                info.pipeline_cache.c_str());
    if (summary) {
        std::printf("%-18s %12s %12s\n", "bucket", "pixel share", "energy share");
        for (uint32_t b = 0; b < kBucketCount; ++b)
            std::printf("%-18s %11.2f%% %11.2f%%\n", kBucketNames[b], 100.0 * summary->pixel_share[b],
                        100.0 * summary->energy_share[b]);
        std::printf("labelled pixels: %llu of %zu; other energy: %g\n",
                    static_cast<unsigned long long>(summary->labelled_pixels), frame.pixels.size(), summary->other_energy);
    }
    double clipped = clipped_share(frame.rgb_mean(), o.exposure);
    std::printf("preview: exposure %+.2f EV, %.2f%% of pixels clip%s\n", o.exposure, 100.0 * clipped,
                clipped > 0.05 ? " (lower --exposure to see them; the EXR keeps every value)" : "");
    for (const auto& f : {files.exr, files.png, files.dominant_png, files.purity_png, files.json,
                          set->final_path(manifest_file_name(name))})
        if (!f.empty()) std::printf("wrote %s\n", f.c_str());
    return 0;
}

namespace {

// SPEC §2's lobe classes a material can sample: D diffuse, G glossy, S delta.
std::string lobe_classes(const Material& m) {
    switch (m.type) {
        case BsdfType::Diffuse: return "D";
        case BsdfType::Plastic: return "D+S";
        case BsdfType::RoughPlastic: return "D+G";
        case BsdfType::Conductor:
        case BsdfType::Dielectric:
        case BsdfType::ThinDielectric: return "S";
        case BsdfType::RoughConductor:
        case BsdfType::RoughDielectric: return "G";
        case BsdfType::Principled: return m.has_diffuse() ? "D+G" : "G";
    }
    return "?";
}

}  // namespace

// `vkmech check --scene FILE`: loads without rendering and says what the
// renderer will see, so a user can trust (or fix) a third-party scene.
int cmd_check(const CommonOptions& o) {
    Scene scene = load_for_cli(o, /*report=*/false);
    SceneArrays arrays = flatten_scene(scene);
    Features f = Features::from_scene(scene, Estimator::Mis);
    std::printf("scene: %s\n", resolve_scene_path(o.scene).c_str());
    size_t tris = scene.triangle_count();
    std::map<std::string, int> kinds;
    for (const auto& m : scene.meshes) kinds[to_string(m.kind)]++;
    std::printf("shapes: %zu (", scene.meshes.size());
    bool first = true;
    for (const auto& [k, n] : kinds) std::printf("%s%d %s", first ? "" : ", ", n, k.c_str()), first = false;
    std::printf("), %zu triangles\n", tris);
    std::printf("bounds: (%g, %g, %g) .. (%g, %g, %g)\n", arrays.bbox_lo.x, arrays.bbox_lo.y, arrays.bbox_lo.z,
                arrays.bbox_hi.x, arrays.bbox_hi.y, arrays.bbox_hi.z);
    std::printf("materials: %zu\n", scene.materials.size());
    for (const auto& m : scene.materials) {
        int users = 0;
        for (const auto& mesh : scene.meshes) users += &scene.materials[mesh.material] == &m;
        std::string tex;
        if (m.reflectance.texture >= 0) tex += " reflectance=" + scene.textures[m.reflectance.texture].path;
        if (m.specular_reflectance_texture >= 0)
            tex += " specular_reflectance=" + scene.textures[m.specular_reflectance_texture].path;
        if (m.specular_transmittance_texture >= 0)
            tex += " specular_transmittance=" + scene.textures[m.specular_transmittance_texture].path;
        std::printf("  %-24s %-16s lobes %-4s %d shape%s%s%s\n", m.id.c_str(), to_string(m.type), lobe_classes(m).c_str(),
                    users, users == 1 ? "" : "s", m.twosided ? ", twosided" : "", tex.c_str());
    }
    std::printf("emitters: %zu\n", scene.emitters.size());
    for (const auto& e : scene.emitters) {
        const auto& ge = arrays.emitters[&e - scene.emitters.data()];
        std::printf("  %-24s radiance (%g, %g, %g), area %g\n", scene.meshes[e.mesh].name.c_str(), e.radiance.x,
                    e.radiance.y, e.radiance.z, ge.radiance.w);
    }
    if (scene.emitters.empty()) std::printf("  (none: the image will be black)\n");
    const Camera& c = scene.camera;
    glm::vec3 pos(c.to_world[3]), fwd(c.to_world[2]);
    std::printf("camera: %s, %d x %d, fov %g deg (%s), at (%g, %g, %g) looking along (%g, %g, %g)%s\n",
                c.type == CameraType::ThinLens ? "thinlens" : c.type == CameraType::Orthographic ? "orthographic" : "perspective",
                c.width, c.height, c.type == CameraType::Orthographic ? 0.0f : c.fov_deg,
                c.fov_axis.c_str(), pos.x, pos.y, pos.z, fwd.x, fwd.y, fwd.z,
                c.type == CameraType::ThinLens ? (", aperture " + std::to_string(c.aperture_radius)).c_str() : "");
    std::printf("integrator: max_depth %d, rr_depth %d\n", scene.integrator.max_depth, scene.integrator.rr_depth);
    std::printf("features: %s\n", f.describe().c_str());
    std::printf("substitutions: %zu\n", scene.substitutions.size());
    for (const auto& s : scene.substitutions) std::printf("  %s\n", s.c_str());
    std::printf("warnings: %zu\n", scene.warnings.size());
    for (const auto& w : scene.warnings) std::printf("  %s\n", w.c_str());
    return 0;
}

int cmd_devices() {
    auto devices = vk::Context::list_devices();
    if (devices.empty()) {
        std::cerr << "vkmech: no Vulkan device found (install Mesa lavapipe: ci/install-deps.sh)\n";
        return 1;
    }
    for (const auto& d : devices) {
        std::printf("[%u] %s (%s)\n", d.index, d.name.c_str(), d.type.c_str());
        std::printf("    driver: %s\n", d.driver.c_str());
        std::printf("    Vulkan %u.%u.%u, ray query: %s\n", VK_API_VERSION_MAJOR(d.api_version),
                    VK_API_VERSION_MINOR(d.api_version), VK_API_VERSION_PATCH(d.api_version), d.ray_query ? "yes" : "no");
        std::printf("    max compute workgroup invocations: %u, max storage buffer range: %llu MiB, device-local heap: %llu MiB\n",
                    d.max_workgroup_invocations, static_cast<unsigned long long>(d.max_storage_buffer_range >> 20),
                    static_cast<unsigned long long>(d.device_local_bytes >> 20));
    }
    return 0;
}

int cmd_bench_traversal(const BenchOptions& o) {
    std::vector<std::string> names = o.scenes.empty() ? project_scene_names() : o.scenes;
    if (names.empty()) throw UsageError("no scenes to benchmark");
    vk::ContextOptions co;
    co.device_index = o.device;
    co.pipeline_cache_dir = o.pipeline_cache;
    vk::Context ctx(co);
    std::printf("device: %s (%s), %u random rays per measurement (closest hit; median of 3)\n", ctx.info().name.c_str(),
                ctx.info().type.c_str(), o.rays);
    std::printf("%-22s %10s %16s %16s\n", "scene", "triangles", "rayquery Mray/s", "bvh Mray/s");
    for (const auto& n : names) {
        Scene scene = load_scene(resolve_scene_path(n));
        SceneArrays arrays = flatten_scene(scene);
        auto rays = random_rays(arrays, o.rays, 1);
        auto measure = [&](Traversal t) -> double {
            GpuScene g(ctx, arrays, t);
            RayCaster caster(ctx, g);
            caster.trace(rays, false);  // warm-up
            std::vector<double> s(3);
            for (auto& x : s) caster.trace(rays, false, &x);
            std::sort(s.begin(), s.end());
            return rays.size() / s[1] / 1e6;
        };
        std::string rq = ctx.ray_query_enabled() ? std::to_string(measure(Traversal::RayQuery)).substr(0, 6) : "n/a";
        std::string bvh = std::to_string(measure(Traversal::Bvh)).substr(0, 6);
        std::printf("%-22s %10zu %16s %16s\n", scene_stem(n).c_str(), arrays.triangles.size(), rq.c_str(), bvh.c_str());
        std::fflush(stdout);
    }
    return 0;
}

}  // namespace vkmech

namespace vkmech {

int cmd_bench_render(const BenchOptions& o) {
    std::vector<std::string> names = o.scenes.empty() ? project_scene_names() : o.scenes;
    if (names.empty()) throw UsageError("no scenes to benchmark");
    vk::ContextOptions co;
    co.device_index = o.device;
    co.pipeline_cache_dir = o.pipeline_cache;
    vk::Context ctx(co);
    std::printf("device: %s (%s); %ux%u film, %u spp per measurement, median of 3; paths/s in millions\n",
                ctx.info().name.c_str(), ctx.info().type.c_str(), o.res, o.res, o.spp);
    std::printf("%-20s %-9s %12s %12s %12s %12s\n", "scene", "traversal", "specialized", "generic", "capture off",
                "spec. gain");
    for (const auto& n : names) {
        Scene scene = load_scene(resolve_scene_path(n));
        scene.camera.set_film_width(static_cast<int>(o.res));
        SceneArrays arrays = flatten_scene(scene);
        std::vector<Traversal> travs = {Traversal::Bvh};
        if (ctx.ray_query_enabled()) travs.insert(travs.begin(), Traversal::RayQuery);
        for (Traversal t : travs) {
            GpuScene g(ctx, arrays, t);
            auto measure = [&](const Features& f) {
                Renderer r(ctx, scene, arrays, g, f);
                RenderSpec spec;
                spec.spp = o.spp;
                spec.batch_spp = o.spp;
                r.render(spec);  // warm-up (pipeline caches, page faults)
                std::vector<double> mps;
                for (int i = 0; i < 3; ++i) {
                    Frame fr = r.render(spec);
                    mps.push_back(fr.samples / fr.seconds / 1e6);
                }
                std::sort(mps.begin(), mps.end());
                return mps[1];
            };
            double spec_on = measure(Features::from_scene(scene));
            double generic = measure(Features::generic());
            double cap_off = measure(Features::from_scene(scene, Estimator::Nee, false));
            std::printf("%-20s %-9s %12.4f %12.4f %12.4f %11.1f%%\n", scene_stem(n).c_str(), to_string(t), spec_on, generic,
                        cap_off, 100.0 * (spec_on / generic - 1.0));
            std::fflush(stdout);
        }
    }
    return 0;
}

}  // namespace vkmech

#include "study/render_cache.hpp"
#include "study/study_runner.hpp"

namespace vkmech {

// `vkmech verify outputs DIR`: every output set in DIR checked against its manifest.
int cmd_verify_outputs(const std::string& dir) {
    if (!fs::is_directory(dir)) throw UsageError("'" + dir + "' is not a directory");
    std::vector<std::string> stale;
    auto sets = verify_output_dir(dir, &stale);
    int bad = 0;
    for (const auto& s : sets) {
        const char* kind = s.kind == SetStatus::Complete ? "complete" : s.kind == SetStatus::Pending ? "pending" : "BAD";
        std::printf("%-8s %s%s%s: %s\n", kind, s.name.c_str(), s.run_id.empty() ? "" : " (run ", s.run_id.empty() ? "" :
                    (s.run_id + ")").c_str(), s.detail.c_str());
        bad += s.kind == SetStatus::Bad;
    }
    for (const auto& f : stale) std::printf("stale    %s: a temporary of an interrupted run (the next run here removes it)\n", f.c_str());
    std::printf("%zu output sets: %d bad; %zu stale temporaries\n", sets.size(), bad, stale.size());
    return bad ? 1 : 0;
}

// `vkmech verify cache DIR`: every render-cache file checked (key, checksum, size, finite data).
int cmd_verify_cache(const std::string& dir) {
    if (!fs::is_directory(dir)) throw UsageError("'" + dir + "' is not a directory");
    CacheVerifyReport r = verify_cache_dir(dir);
    for (const auto& [f, why] : r.bad) std::printf("BAD   %s\n", why.c_str());
    for (const auto& [f, why] : r.stale) std::printf("stale %s: %s\n", f.c_str(), why.c_str());
    std::printf("%zu good, %zu bad, %zu stale cache files in %s%s\n", r.good.size(), r.bad.size(), r.stale.size(),
                dir.c_str(), r.bad.empty() ? "" : " (a study removes and re-renders bad files)");
    return r.bad.empty() ? 0 : 1;
}

void add_study_options(CLI::App* app, StudyCliOptions& o) {
    app->add_option("name", o.study,
                    "stability, variance, cost, structure, sweep-roughness, sweep-lights, predictor, allocation, or all")
        ->required()
        ->check(CLI::IsMember({"stability", "variance", "cost", "structure", "sweep-roughness", "sweep-lights", "predictor",
                               "allocation", "all"}));
    app->add_option("--preset", o.preset,
                    "quick (tiny images, low SPP: minutes, for CI), reduced (96 px, SPP 64/512/2048: what a CPU device "
                    "affords), paper (256², SPP 64/512/4096, 10 seeds per level: the paper's protocol)")
        ->check(CLI::IsMember({"quick", "reduced", "paper"}));
    app->add_option("--scenes", o.scenes, "Comma-separated scene names or paths (default: the seven first-party scenes)")
        ->delimiter(',');
    app->add_option("--res", o.res, "Film width in pixels (overrides the preset)")->check(CLI::Range(4, 4096));
    app->add_option("--spp-levels", o.spp_levels, "Stability SPP levels, ascending; the last is the reference")
        ->delimiter(',')
        ->check(CLI::Range(1u, 1u << 20));
    app->add_option("--seeds", o.seeds, "Seeds per variance level and per sweep level (even, >= 4)")->check(CLI::Range(4, 1000));
    app->add_option("--out", o.out_dir, "Output directory (default: out/study-<name>)");
    app->add_option("--cache", o.cache_dir, "Render cache directory (default: <out>/cache); share it between studies");
    app->add_option("--curve", o.curve,
                    "predictor: a frozen predictor_curve.json; predicts each scene's label reliability from its pilot only");
    app->add_option("--device", o.device, "Vulkan device index (see `vkmech devices`)");
    add_pipeline_cache_option(app, o.pipeline_cache);
    app->add_option("--traversal", o.traversal, "Ray traversal: auto, rayquery or bvh")
        ->check(CLI::IsMember({"auto", "rayquery", "bvh"}));
    app->add_flag("--no-plots", o.no_plots, "Write the figure specs (JSON) but do not run matplotlib");
    app->add_flag("--plan", o.plan_only, "Print the plan and its expected cost, render nothing");
    app->add_flag("--equal-time", o.equal_time,
                  "allocation: also compare strategies at equal wall-clock time (error versus measured seconds)");
}

int cmd_study(const StudyCliOptions& c) {
    StudyOptions o;
    o.study = c.study;
    o.preset = c.preset;
    for (const auto& s : c.scenes.empty() ? first_party_scenes() : c.scenes) o.scenes.push_back(resolve_scene_path(s));
    o.sweep_roughness_scene = resolve_scene_path("sweep_roughness");
    o.sweep_lights_scene = resolve_scene_path("sweep_lights");
    o.res = c.res;
    o.spp_levels = c.spp_levels;
    o.seeds = c.seeds;
    o.out_dir = c.out_dir.empty() ? "out/study-" + c.study : c.out_dir;
    o.cache_dir = c.cache_dir;
    o.curve = c.curve;
    const Resource script = find_plot_script();
    o.plot_script = script.path;
    if (!script.found()) o.plot_script_missing = script.missing_message() + ", or pass --no-plots";
    if (!o.curve.empty() && !fs::exists(o.curve)) throw UsageError("predictor curve '" + o.curve + "' does not exist");
    if (!o.curve.empty() && c.study != "predictor") throw UsageError("--curve applies to `vkmech study predictor` only");
    if (!o.curve.empty()) check_curve_for_cli(o.curve);
    o.device = c.device;
    o.pipeline_cache = c.pipeline_cache;
    o.traversal = c.traversal;
    o.no_plots = c.no_plots;
    o.plan_only = c.plan_only;
    o.equal_time = c.equal_time;
    o.command_line = c.command_line;
    try {
        return run_study(o);
    } catch (const std::invalid_argument& e) {
        throw UsageError(e.what());
    }
}

}  // namespace vkmech

#include "allocation/allocation.hpp"
#include "experiments/predictor.hpp"
#include "io/png.hpp"
#include "adaptive/adaptive.hpp"

namespace vkmech {

namespace {
ReliabilityCurve load_curve_for_cli(const std::string& path) {
    try {
        return ReliabilityCurve::load(path);
    } catch (const std::runtime_error& e) {
        throw UsageError(e.what());
    }
}
}  // namespace

void check_curve_for_cli(const std::string& path) { (void)load_curve_for_cli(path); }

void require_writable_dir(const std::string& dir, const std::string& option) {
    try {
        check_writable_dir(dir, option);
    } catch (const std::runtime_error& e) {
        throw UsageError(e.what());
    }
}

// `vkmech render --adaptive STRATEGY --pilot N0 --budget B`: pilot, predicted
// label reliability, Neyman allocation, final render of n(p) pool samples.
int cmd_render_adaptive(const RenderOptions& o) {
    alloc::Strategy strategy;
    try {
        strategy = alloc::parse_strategy(o.adaptive);
    } catch (const std::invalid_argument& e) {
        throw UsageError(std::string("--adaptive: ") + e.what());
    }
    if (strategy == alloc::Strategy::Oracle || strategy == alloc::Strategy::LabelOracle)
        throw UsageError(std::string("--adaptive ") + alloc::to_string(strategy) +
                         " needs a converged reference; it is a control of `vkmech study allocation`, not a renderer");
    const bool robust = alloc::needs_mom(strategy);
    if (robust) {
        try {
            alloc::mom_block_size(static_cast<int>(o.pilot));
        } catch (const std::invalid_argument& e) {
            throw UsageError(std::string("--adaptive ") + alloc::to_string(strategy) + " at --pilot " +
                             std::to_string(o.pilot) + ": " + e.what());
        }
    }
    if (o.floor > 1 + o.budget) throw UsageError("--floor exceeds the per-pixel average (1 + --budget)");
    // The frozen curve is read before anything renders: a bad file is bad input (exit 2).
    // Without --curve: the installed (or source tree's) frozen curve; none found means no prediction.
    std::string curve_path = o.curve;
    if (curve_path.empty()) {
        const Resource found = find_predictor_curve();
        curve_path = found.path;
        if (!found.found())
            std::fprintf(stderr, "vkmech: note: the pilot's label reliability is not predicted: %s\n",
                         found.missing_message().c_str());
    }
    if (!o.curve.empty() && !fs::exists(curve_path)) throw UsageError("predictor curve '" + o.curve + "' does not exist");
    std::optional<ReliabilityCurve> curve;
    if (!curve_path.empty() && fs::exists(curve_path)) curve = load_curve_for_cli(curve_path);
    Scene scene = load_for_cli(o.common);
    std::string name = scene_stem(o.common.scene);
    std::string out_dir = o.out_dir.empty() ? "out/" + name : o.out_dir;
    Estimator estimator = render_estimator(o, Estimator::Nee);
    SignalGuard signals;
    std::unique_ptr<OutputSet> set = open_output_set(out_dir, name);

    vk::ContextOptions co;
    co.device_index = o.common.device;
    co.validation = o.common.validation;
    co.pipeline_cache_dir = o.common.pipeline_cache;
    vk::Context ctx(co);
    Traversal trav = resolve_traversal(ctx, parse_traversal(o.common.traversal));
    SceneArrays arrays = flatten_scene(scene, parse_light_selection(o.light_selection));
    GpuScene gpu_scene(ctx, arrays, trav);
    Features features = Features::from_scene(scene, estimator, true);
    features.end_vertex = parse_end_vertex(o.end_vertex);
    const vk::PipelineStats before = ctx.pipeline_cache().stats();
    Renderer renderer(ctx, scene, arrays, gpu_scene, features);
    const vk::PipelineStats pipes = ctx.pipeline_cache().stats() - before;
    const std::string pipe_outcome = vk::pipeline_cache_outcome(pipes, ctx.pipeline_cache().enabled());
    std::printf("pipeline creation: %.2f s (%s; not in the render times)\n", pipes.seconds, pipe_outcome.c_str());
    const size_t pixels = static_cast<size_t>(scene.camera.width) * scene.camera.height;
    std::fprintf(stderr, "vkmech: %s: %dx%d adaptive (%s, pilot %u spp, budget 1 + %u spp per pixel, floor %u) on '%s'\n",
                 name.c_str(), scene.camera.width, scene.camera.height, alloc::to_string(strategy), o.pilot, o.budget,
                 o.floor, ctx.info().name.c_str());

    throw_if_interrupted();
    Pilot pilot = render_pilot(renderer, o.pilot, downstream_seeds::pilot(o.pilot_draw), robust);
    throw_if_interrupted();
    std::printf("pilot: %u spp (seed %u), %.2f s\n", o.pilot, downstream_seeds::pilot(o.pilot_draw), pilot.seconds);

    // The pilot's predicted label reliability (paper §8.2), before anything is allocated.
    if (curve) {
        PilotPrediction pred = predict_from_pilot(*curve, pilot.frame);
        std::printf("predicted label reliability (share of the pilot's labels a converged render keeps): %.3f by "
                    "margin, %.3f by purity (curve %s, fitted on %u-spp pilots)\n",
                    pred.margin, pred.purity, curve_path.c_str(), curve->pilot_spp);
        if (curve->pilot_spp != 0 && curve->pilot_spp != o.pilot)
            std::printf("note: this pilot has %u spp; the curve was fitted on %u-spp pilots, so the prediction is "
                        "indicative only\n",
                        o.pilot, curve->pilot_spp);
    } else {
        std::printf("predicted label reliability: no frozen curve at %s (run `vkmech study predictor`)\n",
                    curve_path.c_str());
    }

    alloc::ScoreInputs in;
    in.pilot_var = &pilot.var;
    in.pilot_labels = &pilot.labels;
    if (robust) in.mom_var = &pilot.mom_var;
    AdaptivePlan plan = plan_allocation(strategy, in, o.budget, o.floor, o.pilot_draw);

    RenderSpec spec;
    spec.seed = downstream_seeds::kPool;
    spec.batch_spp = o.batch_spp;
    spec.sample_counts = plan.n;
    Progress progress("render " + name);
    spec.progress = [&](uint32_t d, uint32_t t) {
        throw_if_interrupted();
        progress(d, t);
    };
    Frame frame = renderer.render(spec);

    uint32_t max_n = 0, min_n = ~0u;
    for (uint32_t n : plan.n) {
        max_n = std::max(max_n, n);
        min_n = std::min(min_n, n);
    }
    RenderInfo info = render_info(name, o, ctx, trav, estimator, features, scene,
                                  static_cast<uint32_t>(plan.total / pixels), downstream_seeds::kPool, true);
    info.features += std::string(" adaptive=") + alloc::to_string(strategy);
    info.pipeline_seconds = pipes.seconds;
    info.pipeline_cache = pipe_outcome;
    Descriptor desc = derive_descriptor(frame);
    DescriptorSummary summary = summarize(frame, desc);
    WrittenFiles files = write_render_outputs(*set, info, frame, &desc, &summary);
    report_render_warnings(files);
    std::vector<float> nmap(plan.n.begin(), plan.n.end());
    write_png_rgb8(set->staged(name + "_spp.png"), frame.width, frame.height,
                   grey_to_rgb8(nmap, 0.0f, static_cast<float>(max_n)));
    std::string spp_png = set->final_path(name + "_spp.png");
    set->commit();

    std::printf("allocation: %llu samples in all (%.2f per pixel), n(p) from %u to %u, %.2f ms\n",
                static_cast<unsigned long long>(plan.total), static_cast<double>(plan.total) / pixels, min_n, max_n,
                plan.allocation_ms);
    std::printf("final: %.2f s; wall time pilot + allocation + final: %.2f s\n", frame.seconds,
                pilot.seconds + plan.allocation_ms / 1000.0 + frame.seconds);
    for (const auto& f : {files.exr, files.png, files.dominant_png, spp_png, files.json,
                          set->final_path(manifest_file_name(name))})
        if (!f.empty()) std::printf("wrote %s\n", f.c_str());
    return 0;
}

}  // namespace vkmech
