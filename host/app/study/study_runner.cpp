#include "study/study_runner.hpp"

#include "experiments/predictor.hpp"
#include "experiments/study_context.hpp"
#include "io/atomic_file.hpp"
#include "io/output_set.hpp"
#include "io/sha256.hpp"
#include "render/features.hpp"
#include "render/gpu_scene.hpp"
#include "render/live_view.hpp"
#include "render/renderer.hpp"
#include "render/session.hpp"
#include "render/shader_modules.hpp"
#include "render/taxonomy.hpp"
#include "scene/scene.hpp"
#include "study/allocation_source.hpp"
#include "study/render_cache.hpp"
#include "study/separation_gpu.hpp"
#include "vk/context.hpp"

#include <unistd.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <sstream>

namespace fs = std::filesystem;

namespace vkmech {

namespace {

using clock_type = std::chrono::steady_clock;

std::string hms(double s) {
    if (!std::isfinite(s) || s < 0) return "?";
    long t = static_cast<long>(s + 0.5);
    char b[32];
    if (t >= 3600)
        std::snprintf(b, sizeof b, "%ldh%02ldm", t / 3600, (t / 60) % 60);
    else if (t >= 60)
        std::snprintf(b, sizeof b, "%ldm%02lds", t / 60, t % 60);
    else
        std::snprintf(b, sizeof b, "%lds", t);
    return b;
}

std::string describe(const RenderRequest& r) {
    return r.scene.name + ", " + std::to_string(r.spp) + " spp, seed " + std::to_string(r.seed) + ", " +
           to_string(r.estimator) +
           (r.end_vertex == EndVertex::LastNonDelta ? "" : std::string(", end vertex ") + to_string(r.end_vertex));
}

class CacheFrames : public FrameSource {
public:
    CacheFrames(const RenderCache& cache, const std::map<RenderRequest, std::string>& keys)
        : cache_(cache), keys_(keys) {}
    Frame get(const RenderRequest& r) override {
        auto it = keys_.find(r);
        if (it == keys_.end()) throw std::logic_error("study: render not planned: " + describe(r));
        return cache_.load(it->second);
    }

private:
    const RenderCache& cache_;
    const std::map<RenderRequest, std::string>& keys_;
};

std::string now_utc() {
    std::time_t t = std::time(nullptr);
    char b[64];
    std::strftime(b, sizeof b, "%Y-%m-%d %H:%M UTC", std::gmtime(&t));
    return b;
}

}  // namespace

LoadedScene load_variant(const SceneVariant& v, int res, Traversal traversal, const lpe::TaxonomySource* taxonomy) {
    LoadOptions lo;
    lo.params = v.params;
    LoadedScene ls;
    ls.scene = load_scene(v.path, lo);
    if (taxonomy) give_named_shapes_own_materials(ls.scene, *taxonomy);
    ls.scene.camera.set_film_width(v.res > 0 ? v.res : res);  // a variant's own width wins (the sensitivity axes)
    ls.arrays = flatten_scene(ls.scene, traversal);
    ls.digest = scene_digest(ls.scene, ls.arrays);
    return ls;
}

std::string render_code_digest(Traversal t, vk::KernelClass k) {
    const auto spirv = pathtrace_spirv(t, k);
    return Digest()
        .str(VKMECH_VERSION)
        .bytes(spirv.data(), spirv.size_bytes())
        .str("frame-merge-v2")
        .hex();  // v2: bucket energies from the buckets' RGB sums
}

bool study_interrupted() { return pending_signal() != 0; }

const std::vector<std::string>& first_party_scenes() {
    static const std::vector<std::string> s = {"cubes_dof",      "glass_caustic",      "snooker",
                                               "tabletop_mixed", "tabletop_separated", "ring_caustic",
                                               "kitchen_counter"};
    return s;
}

SceneTaxonomy compile_variant_taxonomy(const lpe::TaxonomySource& source, const SceneVariant& v, const Scene& scene,
                                       bool print_warnings) {
    try {
        SceneTaxonomy t = compile_scene_taxonomy(source, scene);
        if (print_warnings)
            for (const auto& w : t.compiled.warnings)
                std::fprintf(stderr, "vkmech: %s: %s\n", v.name.c_str(), w.str().c_str());
        return t;
    } catch (const lpe::LpeError& e) {
        throw std::invalid_argument("--taxonomy on " + v.name + ": " + e.what());
    }
}

std::string taxonomy_key(const SceneTaxonomy& t) { return Digest().vec(t.words).hex(); }

namespace {

// The stages of a study: plan -> keys -> estimate -> render missing -> analyse -> plot -> report.

struct StudyPlan {
    StudyConfig cfg;
    std::vector<StudyKind> kinds;
    std::string out_dir, cache_dir;
    std::vector<RenderRequest> renders;  // every render of every requested study, deduplicated, in a stable order
    bool has(StudyKind k) const { return std::find(kinds.begin(), kinds.end(), k) != kinds.end(); }
};

// The study's device and the digest of the code that renders on it (part of every cache key).
struct StudyDevice {
    explicit StudyDevice(const StudyOptions& o) : ctx(context_options(o)), display_server(o.display_server) {
        trav = resolve_traversal(ctx, parse_traversal(o.traversal));
        code_digest = render_code_digest(trav, ctx.kernel());
    }
    static vk::ContextOptions context_options(const StudyOptions& o) {
        vk::ContextOptions co;
        co.device_index = o.device;
        co.pipeline_cache_dir = o.pipeline_cache;
        co.kernel = vk::parse_kernel_class(o.kernel);
        return co;
    }
    vk::Context ctx;
    Traversal trav = Traversal::Bvh;
    std::string code_digest;
    std::string display_server;  // --display-server: each scene variant's renders in progress, as one image
};

// Cache keys of the planned renders and which of them the cache lacks.
struct CacheState {
    std::map<RenderRequest, std::string> keys;
    std::map<SceneVariant, std::pair<int, int>> film;
    std::vector<RenderRequest> missing;
    double paths_total = 0, paths_missing = 0;
};

struct RenderTally {
    double render_seconds = 0;
    size_t done = 0;
};

StudyPlan make_plan(const StudyOptions& o) {
    StudyConfig cfg = preset_config(o.preset);
    if (o.res) cfg.res = cfg.alloc_res = *o.res;
    cfg.equal_time = o.equal_time;
    if (!o.spp_levels.empty()) cfg.stability_spp = o.spp_levels;
    if (o.seeds) cfg.variance_seeds = cfg.sweep_seeds = *o.seeds;
    if (o.pools) cfg.alloc_pools = *o.pools;
    cfg.predictor_curve = o.curve;
    cfg.sweep_roughness_scene = o.sweep_roughness_scene;
    cfg.sweep_lights_scene = o.sweep_lights_scene;
    std::map<std::string, std::string> params;
    for (const auto& d : o.defines) {
        const size_t eq = d.find('=');
        if (eq == std::string::npos || eq == 0) throw std::invalid_argument("-D expects name=value, got '" + d + "'");
        params[d.substr(0, eq)] = d.substr(eq + 1);
    }
    for (const auto& path : o.scenes) {
        std::string name = fs::path(path).stem().string();
        for (const auto& [k, v] : params) name += " " + k + "=" + v;
        cfg.scenes.push_back({name, path, params});
    }
    const std::vector<StudyKind> kinds = parse_study(o.study);
    if (!o.taxonomy.empty()) {
        try {
            cfg.taxonomy = lpe::read_taxonomy(o.taxonomy);
            cfg.taxonomy_sha256 = sha256_file(o.taxonomy);
            const lpe::CompiledTaxonomy probe = lpe::compile_taxonomy(*cfg.taxonomy, {});  // errors before rendering
            if (probe.class_names.size() > gpu::BUCKET_COUNT)
                throw lpe::LpeError(o.taxonomy, cfg.taxonomy->lines[gpu::BUCKET_COUNT - 1].line, 0,
                                    "a taxonomy has at most " + std::to_string(gpu::BUCKET_COUNT - 1) +
                                        " lines (one tally slot per class, `other` included)");
        } catch (const lpe::LpeError& e) {
            throw std::invalid_argument(std::string("--taxonomy: ") + e.what());
        }
    }
    if (!cfg.predictor_curve.empty() && std::find(kinds.begin(), kinds.end(), StudyKind::Predictor) != kinds.end()) {
        std::string why;  // a curve predicts only the labels it was fitted on: refused before anything renders
        try {
            why = curve_label_mismatch(ReliabilityCurve::load(cfg.predictor_curve), cfg.predictor_curve,
                                       cfg.taxonomy_sha256);
        } catch (const std::runtime_error& e) {
            why = e.what();
        }
        if (!why.empty()) throw std::invalid_argument("--curve: " + why);
    }
    cfg.validate(std::find(kinds.begin(), kinds.end(), StudyKind::Cost) != kinds.end());
    const std::string out_dir = o.out_dir;
    const std::string cache_dir = o.cache_dir.empty() ? (fs::path(out_dir) / "cache").string() : o.cache_dir;
    if (!o.plan_only) {  // before anything renders (and after the arguments are known good): exit 2 otherwise
        try {
            check_writable_dir(out_dir, "--out");
            check_writable_dir(cache_dir, "--cache");
        } catch (const std::runtime_error& e) {
            throw std::invalid_argument(e.what());
        }
    }

    // The plan: every render of every requested study, deduplicated, in a stable order.
    std::vector<RenderRequest> plan;
    std::set<RenderRequest> seen;
    for (StudyKind k : kinds)
        for (auto& r : plan_renders(cfg, k))
            if (seen.insert(r).second) plan.push_back(r);
    return StudyPlan{std::move(cfg), kinds, out_dir, cache_dir, std::move(plan)};
}

// The taxonomy's key for a variant's renders, its errors and warnings said before anything renders.
std::string taxonomy_key(const lpe::TaxonomySource& source, const SceneVariant& v, const Scene& scene) {
    return taxonomy_key(compile_variant_taxonomy(source, v, scene, /*print_warnings=*/true));
}

CacheState key_renders(const StudyPlan& p, const StudyDevice& dev, const RenderCache& cache) {
    const StudyConfig& cfg = p.cfg;
    const auto& plan = p.renders;
    const vk::Context& ctx = dev.ctx;
    const Traversal trav = dev.trav;
    const std::string& code_digest = dev.code_digest;
    CacheState cs;
    auto& keys = cs.keys;
    auto& film = cs.film;
    // Keys: load each scene variant once to digest its content at the study's film size.
    {
        std::map<SceneVariant, std::string> digests, taxonomy_keys;
        for (const auto& r : plan) {
            if (!digests.count(r.scene)) {
                LoadedScene ls = load_variant(r.scene, cfg.res, trav, cfg.taxonomy ? &*cfg.taxonomy : nullptr);
                digests[r.scene] = ls.digest;
                if (cfg.taxonomy) taxonomy_keys[r.scene] = taxonomy_key(*cfg.taxonomy, r.scene, ls.scene);
                film[r.scene] = {ls.scene.camera.width, ls.scene.camera.height};
            }
            auto [w, h] = film[r.scene];
            keys[r] =
                cache_key({digests[r.scene], w, h, r.spp, r.seed, static_cast<uint32_t>(r.estimator), cfg.batch_spp,
                           to_string(trav), ctx.info().name, code_digest, static_cast<uint32_t>(r.end_vertex),
                           cfg.taxonomy ? taxonomy_keys[r.scene] : std::string()});
        }
        // The allocation study renders through its own source, not the plan: its variants' taxonomy errors and
        // warnings are said here too, before anything renders.
        if (cfg.taxonomy && p.has(StudyKind::Allocation))
            for (const auto& v : cfg.scenes)
                if (!taxonomy_keys.count(v))
                    taxonomy_key(*cfg.taxonomy, v, load_variant(v, cfg.alloc_res, trav, &*cfg.taxonomy).scene);
    }

    for (const auto& r : plan) {
        auto [w, h] = film[r.scene];
        double paths = static_cast<double>(r.spp) * w * h;
        cs.paths_total += paths;
        if (!cache.try_load(keys[r])) {  // absent, or damaged (warned, removed): render it
            cs.missing.push_back(r);
            cs.paths_missing += paths;
        }
    }
    return cs;
}

// Expected cost: prints the plan and returns the allocation study's own paths (estimated).
double estimate(const StudyPlan& p, const StudyDevice& dev, const CacheState& cs) {
    const StudyConfig& cfg = p.cfg;
    const auto& plan = p.renders;
    const vk::Context& ctx = dev.ctx;
    const Traversal trav = dev.trav;
    const auto& missing = cs.missing;
    const auto& film = cs.film;
    const double paths_missing = cs.paths_missing;
    // Expected cost: a short probe render (4 spp) of every scene file with something to render,
    // and the allocation study's renders (reference, pool, pilots, timing renders) estimated alike.
    std::map<std::string, double> rate;  // scene file -> paths/s
    auto probe = [&](const SceneVariant& v, int res) {
        if (rate.count(v.path)) return rate[v.path];
        LoadedScene ls = load_variant(v, res, trav);
        RenderSession session(ctx, std::move(ls.scene), std::move(ls.arrays), trav);
        Renderer r = session.renderer(session.features());
        RenderSpec spec;
        spec.spp = 4;
        spec.batch_spp = 4;
        r.render(spec);  // warm-up (pipeline compilation)
        Frame f = r.render(spec);
        return rate[v.path] = f.seconds > 0 ? f.samples / f.seconds : 1e6;
    };
    double expected_s = 0;
    for (const auto& r : missing) {
        auto [w, h] = film.at(r.scene);
        expected_s += static_cast<double>(r.spp) * w * h / probe(r.scene, cfg.res);
    }
    double alloc_paths = 0;
    if (p.has(StudyKind::Allocation)) {
        const double per_pixel = allocation_paths_per_pixel(cfg);
        for (const auto& sc : cfg.scenes) {
            LoadedScene ls = load_variant(sc, cfg.alloc_res, trav);
            double paths = per_pixel * ls.scene.camera.width * ls.scene.camera.height;
            alloc_paths += paths;
            expected_s += paths / probe(sc, cfg.res);
        }
    }
    std::fprintf(stderr,
                 "vkmech study: plan %zu renders (%zu cached, %zu to render), %.3g paths to trace%s; probed %zu scene "
                 "files -> expected render time ~%s on this device (the progress line refines it)\n",
                 plan.size(), plan.size() - missing.size(), missing.size(), paths_missing,
                 alloc_paths > 0
                     ? (" + about " + report::format("%.3g", alloc_paths) + " for the allocation study").c_str()
                     : "",
                 rate.size(), hms(expected_s).c_str());
    return alloc_paths;
}

RenderTally render_missing(const StudyPlan& p, const StudyDevice& dev, RenderCache& cache, const CacheState& cs) {
    const StudyConfig& cfg = p.cfg;
    const vk::Context& ctx = dev.ctx;
    const Traversal trav = dev.trav;
    const auto& missing = cs.missing;
    const auto& film = cs.film;
    const auto& keys = cs.keys;
    const double paths_missing = cs.paths_missing;
    RenderTally t;
    double& render_seconds = t.render_seconds;
    size_t& done = t.done;
    // Render what is missing, grouped by scene variant; each finished render is cached atomically.
    double paths_done = 0;
    const bool tty = isatty(STDERR_FILENO);
    const auto t_render = clock_type::now();
    {
        std::vector<SceneVariant> order;
        for (const auto& r : missing)
            if (std::find(order.begin(), order.end(), r.scene) == order.end()) order.push_back(r.scene);
        for (const auto& variant : order) {
            LoadedScene ls = load_variant(variant, cfg.res, trav, cfg.taxonomy ? &*cfg.taxonomy : nullptr);
            RenderSession session(ctx, std::move(ls.scene), std::move(ls.arrays), trav);
            std::map<std::pair<Estimator, EndVertex>, std::unique_ptr<Renderer>> renderers;
            std::vector<uint32_t> taxonomy_words;  // the taxonomy against this variant's labels
            std::vector<std::string> taxonomy_classes;
            if (cfg.taxonomy) {
                const SceneTaxonomy t =
                    compile_scene_taxonomy(*cfg.taxonomy, session.scene());  // key_renders checked it
                taxonomy_words = t.words;
                taxonomy_classes = t.class_names();
            }
            // The variant's renders, one after another, in one image (a viewer that is absent is a warning).
            std::unique_ptr<DisplayClient> display = open_live_view(dev.display_server, "study " + variant.name);
            for (const auto& r : missing) {
                if (!(r.scene == variant)) continue;
                if (int sig = pending_signal()) throw StudyInterrupted(sig);
                auto& rr = renderers[{r.estimator, r.end_vertex}];
                if (!rr) {
                    Features f = session.features(r.estimator);
                    f.end_vertex = r.end_vertex;
                    f.taxonomy = taxonomy_words;
                    rr = session.make_renderer(f);
                }
                RenderSpec spec;
                spec.spp = r.spp;
                spec.seed = r.seed;
                spec.batch_spp = std::min(cfg.batch_spp, r.spp);
                auto [w, h] = film.at(r.scene);
                const double px = static_cast<double>(w) * h;
                spec.progress = [&](uint32_t d, uint32_t) {
                    if (int sig = pending_signal()) throw StudyInterrupted(sig);
                    double spent = std::chrono::duration<double>(clock_type::now() - t_render).count();
                    double traced = paths_done + d * px;
                    double left = traced > 0 ? spent * (paths_missing - traced) / traced : NAN;
                    if (tty) {
                        std::fprintf(stderr, "\rstudy: %zu/%zu renders done, %s spent, ~%s left | %s: %u/%u spp      ",
                                     done, missing.size(), hms(spent).c_str(), hms(left).c_str(), r.scene.name.c_str(),
                                     d, r.spp);
                        std::fflush(stderr);
                    }
                };
                if (display)
                    spec.on_frame = [&](const Frame& fr) {
                        send_live_view(*display, fr, true, false, {}, taxonomy_classes);
                    };
                Frame f = rr->render(spec);
                if (display) send_live_view(*display, f, true, true, {}, taxonomy_classes);
                cache.store(keys.at(r), f, describe(r) + ", " + std::to_string(w) + "x" + std::to_string(h));
                render_seconds += f.seconds;
                paths_done += r.spp * px;
                ++done;
                double spent = std::chrono::duration<double>(clock_type::now() - t_render).count();
                double left = spent * (paths_missing - paths_done) / std::max(paths_done, 1.0);
                if (tty) std::fprintf(stderr, "\r\033[K");
                std::fprintf(stderr, "study: %zu/%zu renders done, %s spent, ~%s left (%s: %.1fs)\n", done,
                             missing.size(), hms(spent).c_str(), hms(left).c_str(), describe(r).c_str(), f.seconds);
            }
        }
    }
    if (done > 0)
        std::fprintf(stderr, "study: rendered %zu in %.1f s (%.1f s of it on the device)\n", done,
                     std::chrono::duration<double>(clock_type::now() - t_render).count(), render_seconds);
    return t;
}

void analyse(const StudyPlan& p, const StudyDevice& dev, StudyOutput& out, FrameSource& frames,
             AllocationSource* allocation) {
    const StudyConfig& cfg = p.cfg;
    const vk::Context& ctx = dev.ctx;
    const Traversal trav = dev.trav;
    std::map<SceneVariant, SeparationMeasures> separations;
    StudyContext sc{cfg,
                    frames,
                    out,
                    ctx.info().name,
                    [&](const SceneVariant& v) {
                        auto it = separations.find(v);
                        if (it != separations.end()) return it->second;
                        LoadedScene ls = load_variant(v, cfg.res, trav);
                        RenderSession session(ctx, std::move(ls.scene), std::move(ls.arrays), trav);
                        return separations[v] = measure_separation(session);
                    },
                    allocation};
    for (StudyKind k : p.kinds) {
        std::fprintf(stderr, "study: analysing %s\n", to_string(k));
        const auto t0 = clock_type::now();
        study_function(k)(sc);
        std::fprintf(stderr, "study: analysed %s in %.1f s\n", to_string(k),
                     std::chrono::duration<double>(clock_type::now() - t0).count());
    }
}

// Returns 0, or 1 when plotting failed (the figure specs stay).
int plot(const StudyOptions& o, const std::string& out_dir) {
    // Figures: matplotlib draws the JSON specs (analysis/plot_figures.py).
    int rc = 0;
    std::string fig_dir = (fs::path(out_dir) / "figures").string();
    if (!o.no_plots && fs::exists(fig_dir) && o.plot_script.empty()) {
        std::fprintf(stderr, "vkmech study: cannot draw the figures: %s; the figure specs are in %s\n",
                     o.plot_script_missing.c_str(), fig_dir.c_str());
        rc = 1;
    } else if (!o.no_plots && fs::exists(fig_dir)) {
        std::string cmd = "python3 '" + o.plot_script + "' '" + fig_dir + "' > /dev/null";
        const auto t0 = clock_type::now();
        int status = std::system(cmd.c_str());
        std::fprintf(stderr, "study: figures drawn in %.1f s\n",
                     std::chrono::duration<double>(clock_type::now() - t0).count());
        if (status != 0) {
            std::fprintf(stderr, "vkmech study: plotting failed (%s); the figure specs are in %s\n", cmd.c_str(),
                         fig_dir.c_str());
            rc = 1;
        }
    }
    return rc;
}

std::string report_header(const StudyOptions& o, const StudyPlan& p, const StudyDevice& dev, FrameSource& frames,
                          const RenderTally& t, double paths_total, double alloc_paths,
                          clock_type::time_point t_start) {
    const StudyConfig& cfg = p.cfg;
    const auto& plan = p.renders;
    const auto& kinds = p.kinds;
    const vk::Context& ctx = dev.ctx;
    const Traversal trav = dev.trav;
    const double render_seconds = t.render_seconds;
    const size_t done = t.done;
    // GPU time of every render the tables rest on (this run's and the cached ones), as recorded in the cache.
    double all_render_seconds = 0;
    for (const auto& r : plan) all_render_seconds += frames.get(r).seconds;
    const double wall = std::chrono::duration<double>(clock_type::now() - t_start).count();
    std::ostringstream header;
    header << "# vkmech study: " << o.study << "\n\n";
    header << "Generated " << now_utc() << " by vkmech " << VKMECH_VERSION << ".\n\n";
    header << "- Command: `" << o.command_line << "`\n";
    header << "- Protocol: " << cfg.describe() << ".\n";
    header << "- Scenes: ";
    for (size_t i = 0; i < cfg.scenes.size(); ++i) header << (i ? ", " : "") << cfg.scenes[i].name;
    header << "\n- Device: " << ctx.info().name << " (" << ctx.info().type << "), " << to_string(trav)
           << " traversal.\n";
    if (!plan.empty())
        header << "- Renders: " << plan.size() << " (" << done << " rendered in this run, " << plan.size() - done
               << " from the cache), " << report::format("%.3g", paths_total) << " paths in all.\n";
    if (std::find(kinds.begin(), kinds.end(), StudyKind::Allocation) != kinds.end())
        header << "- The allocation study renders its reference chunks, its 256-frame pool and its pilot draws itself "
                  "(cached in the same cache, about "
               << report::format("%.3g", alloc_paths)
               << " paths), and re-renders each timed strategy's final image on every run: its time tables "
                  "(alloc_time, equal_time) are measurements that vary run to run; every other table is "
                  "regenerated identically from the cache.\n";
    header << "- Wall time of this run: " << hms(wall);
    if (!plan.empty())
        header << " (GPU time of the planned renders done in this run: " << hms(render_seconds) << "); GPU time of all "
               << plan.size() << " planned renders, cached ones included: " << hms(all_render_seconds);
    header << ".\n\n";
    header << "Tables are in `tables/` (Markdown and CSV), figures in `figures/` (PNG drawn by "
              "`analysis/plot_figures.py` from the JSON beside each), maps in `maps/`. Re-running the same command "
              "reuses the render cache and regenerates every table identically.\n";
    return header.str();
}

// ---- scale-out: work units, shards, job lists ----

struct WorkUnit {
    bool allocation = false;
    size_t render = 0;   // index into the plan (a render unit)
    SceneVariant scene;  // the allocation unit's scene
};

std::vector<WorkUnit> work_units(const StudyPlan& p) {
    std::vector<WorkUnit> u;
    for (size_t i = 0; i < p.renders.size(); ++i) u.push_back({false, i, {}});
    if (p.has(StudyKind::Allocation))
        for (const auto& s : p.cfg.scenes) u.push_back({true, 0, s});
    return u;
}

std::string shell_quote(const std::string& s) {
    if (!s.empty() && s.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_-./=:,+@%") ==
                          std::string::npos)
        return s;
    std::string q = "'";
    for (char c : s) {
        if (c == '\'')
            q += "'\\''";
        else
            q += c;
    }
    return q + "'";
}

std::string absolute_path(const std::string& p) {
    std::error_code ec;
    const fs::path a = fs::absolute(p, ec);
    return ec ? p : a.lexically_normal().string();
}

// The command that renders work unit k of M: this study's options with absolute paths, plus --shard k/M.
std::string unit_command(const StudyOptions& o, const StudyPlan& p, size_t k, size_t M) {
    std::error_code ec;
    fs::path exe = fs::read_symlink("/proc/self/exe", ec);
    std::vector<std::string> a = {ec ? std::string("vkmech") : exe.string(), "study", o.study, "--preset", o.preset};
    if (!o.scenes.empty()) {
        std::string list;
        for (size_t i = 0; i < o.scenes.size(); ++i) {
            if (i) list += ',';
            list += absolute_path(o.scenes[i]);
        }
        a.insert(a.end(), {"--scenes", list});
    }
    for (const std::string& d : o.defines) a.insert(a.end(), {"-D", d});
    if (!o.taxonomy.empty()) a.insert(a.end(), {"--taxonomy", absolute_path(o.taxonomy)});
    if (o.res) a.insert(a.end(), {"--res", std::to_string(*o.res)});
    if (!o.spp_levels.empty()) {
        std::string list;
        for (size_t i = 0; i < o.spp_levels.size(); ++i) {
            if (i) list += ',';
            list += std::to_string(o.spp_levels[i]);
        }
        a.insert(a.end(), {"--spp-levels", list});
    }
    if (o.seeds) a.insert(a.end(), {"--seeds", std::to_string(*o.seeds)});
    if (o.pools) a.insert(a.end(), {"--pools", std::to_string(*o.pools)});
    a.insert(a.end(), {"--out", absolute_path(p.out_dir), "--cache", absolute_path(p.cache_dir)});
    if (!o.curve.empty()) a.insert(a.end(), {"--curve", absolute_path(o.curve)});
    if (o.device) a.insert(a.end(), {"--device", std::to_string(*o.device)});
    if (o.pipeline_cache) a.insert(a.end(), {"--pipeline-cache", *o.pipeline_cache});
    a.insert(a.end(), {"--traversal", o.traversal});
    if (o.kernel != "auto") a.insert(a.end(), {"--kernel", o.kernel});
    if (o.equal_time) a.push_back("--equal-time");
    a.insert(a.end(), {"--shard", std::to_string(k) + "/" + std::to_string(M)});
    std::string cmd;
    for (size_t i = 0; i < a.size(); ++i) {
        if (i) cmd += ' ';
        cmd += shell_quote(a[i]);
    }
    return cmd;
}

}  // namespace

int run_study(const StudyOptions& o) {
    const auto t_start = clock_type::now();
    const StudyPlan p = make_plan(o);
    StudyDevice dev(o);
    std::fprintf(stderr, "vkmech study %s: %s\n", o.study.c_str(), p.cfg.describe().c_str());
    std::fprintf(stderr, "vkmech study: device '%s', %s traversal; cache %s\n", dev.ctx.info().name.c_str(),
                 to_string(dev.trav), p.cache_dir.c_str());
    RenderCache cache(p.cache_dir);
    if (!o.plan_only) clean_stale_temporaries(p.cache_dir);  // `*.tmp-<pid>` of dead processes
    // Scale-out: the work units, and the ones this run looks at (all, or this shard's: a shard keys and loads
    // only its own scenes, so that a job list of one-unit commands stays cheap).
    const std::vector<WorkUnit> units = work_units(p);
    std::map<RenderRequest, size_t> unit_of;
    for (size_t u = 0; u < units.size(); ++u)
        if (!units[u].allocation) unit_of[p.renders[units[u].render]] = u;
    auto in_shard = [&](size_t u) { return !o.shard || u % o.shard->second == o.shard->first; };
    const bool scale_out = !o.jobs_file.empty() || o.analyse_only || o.shard;
    StudyPlan shard_plan;
    if (o.shard) {
        shard_plan = StudyPlan{p.cfg, p.kinds, p.out_dir, p.cache_dir, {}};
        for (const auto& r : p.renders)
            if (in_shard(unit_of.at(r))) shard_plan.renders.push_back(r);
    }
    CacheState cs = key_renders(o.shard ? shard_plan : p, dev, cache);
    // The missing units (and what they lack), for --jobs, --analyse-only and --shard only.
    std::set<size_t> missing_units;
    std::vector<std::string> missing_lines;
    if (scale_out)
        for (const auto& r : cs.missing) {
            missing_units.insert(unit_of.at(r));
            missing_lines.push_back(describe(r));
        }
    // The allocation study renders its own data during its analysis (and its missing units for a shard).
    std::optional<RenderedAllocationSource> alloc_source;
    if (p.has(StudyKind::Allocation)) {
        alloc_source.emplace(p.cfg, dev.ctx, dev.trav, cache, dev.code_digest, [] { return study_interrupted(); });
        alloc_source->set_offline(o.analyse_only);
    }
    if (alloc_source && scale_out) {
        for (size_t u = 0; u < units.size(); ++u)
            if (units[u].allocation && in_shard(u)) {
                const auto m = alloc_source->missing(units[u].scene);
                if (!m.empty()) missing_units.insert(u);
                missing_lines.insert(missing_lines.end(), m.begin(), m.end());
            }
    }
    if (!o.jobs_file.empty()) {
        std::string jobs;
        for (size_t u : missing_units) jobs += unit_command(o, p, u, units.size()) + "\n";
        write_file_atomic(o.jobs_file, jobs);
        std::printf(
            "vkmech study %s: %zu of %zu work units are missing from the cache; wrote one command each to %s "
            "(run them in any order, on any machines sharing the cache, then `vkmech study %s ... "
            "--analyse-only`)\n",
            o.study.c_str(), missing_units.size(), units.size(), o.jobs_file.c_str(), o.study.c_str());
        return 0;
    }
    if (o.analyse_only && !missing_units.empty()) {
        std::fprintf(stderr,
                     "vkmech: error: --analyse-only: the cache %s lacks %zu of %zu work units (%zu renders or "
                     "inputs); the first ones:\n",
                     p.cache_dir.c_str(), missing_units.size(), units.size(), missing_lines.size());
        for (size_t i = 0; i < missing_lines.size() && i < 20; ++i)
            std::fprintf(stderr, "  %s\n", missing_lines[i].c_str());
        std::fprintf(stderr,
                     "render them with this command without --analyse-only, with --shard i/N, or with the "
                     "commands of --jobs FILE\n");
        return 1;
    }
    const double alloc_paths = o.shard ? 0.0 : estimate(p, dev, cs);
    if (o.shard)
        std::fprintf(stderr, "vkmech study: shard %u/%u: %zu of its renders missing, %zu allocation units\n",
                     o.shard->first, o.shard->second, cs.missing.size(), missing_units.size() - cs.missing.size());
    if (o.plan_only) return 0;

    SignalGuard guard;  // SIGINT/SIGTERM until the end: the allocation study renders during its analysis
    const RenderTally tally = render_missing(p, dev, cache, cs);
    if (o.shard) {
        const auto [i, N] = *o.shard;
        size_t alloc_units = 0;
        for (size_t u = 0; u < units.size(); ++u)
            if (units[u].allocation && in_shard(u) && missing_units.count(u)) {
                alloc_source->render_all(units[u].scene);
                ++alloc_units;
            }
        std::printf(
            "vkmech study %s: shard %u/%u: %zu renders and %zu allocation inputs rendered into %s; no tables "
            "(run `--analyse-only` when every shard is done)\n",
            o.study.c_str(), i, N, tally.done, alloc_units, p.cache_dir.c_str());
        return 0;
    }

    // Experiments on cached frames only: a resumed study computes from exactly the same bytes.
    fs::create_directories(p.out_dir);
    StudyOutput out(p.out_dir);
    CacheFrames frames(cache, cs.keys);
    analyse(p, dev, out, frames, alloc_source ? &*alloc_source : nullptr);
    const int rc = plot(o, p.out_dir);

    const std::string header = report_header(o, p, dev, frames, tally, cs.paths_total, alloc_paths, t_start);
    const double wall = std::chrono::duration<double>(clock_type::now() - t_start).count();
    std::string report_path = (fs::path(p.out_dir) / "report.md").string();
    write_file_atomic(report_path, build_report(out, header));
    std::printf("vkmech study %s: %zu renders (%zu new), wall time %s; report: %s\n", o.study.c_str(), p.renders.size(),
                tally.done, hms(wall).c_str(), report_path.c_str());
    return rc;
}

}  // namespace vkmech
