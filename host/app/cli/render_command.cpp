// `vkmech render` and `vkmech render --adaptive`.
#include "cli/commands.hpp"
#include "cli/provenance.hpp"
#include "cli/resources.hpp"

#include "adaptive/adaptive.hpp"
#include "adaptive/noise_threshold.hpp"
#include "allocation/allocation.hpp"
#include "experiments/predictor.hpp"
#include "io/display_client.hpp"
#include "io/interrupt.hpp"
#include "io/output_set.hpp"
#include "io/png.hpp"
#include "io/sha256.hpp"
#include "render/descriptor.hpp"
#include "render/features.hpp"
#include "render/live_view.hpp"
#include "render/render_outputs.hpp"
#include "render/renderer.hpp"
#include "render/session.hpp"
#include "render/taxonomy.hpp"
#include "scene/environment.hpp"
#include "scene/scene.hpp"
#include "vk/context.hpp"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>
#include <string>

namespace fs = std::filesystem;

namespace vkmech {

namespace {

// docs/reliability.md: a black image, an empty label map or a value beyond float's
// range is said on stderr (and in the JSON); the exit code stays 0.
void report_render_warnings(const WrittenFiles& files) {
    for (const auto& w : files.warnings) std::cerr << "vkmech: warning: " << w << "\n";
}

// The output set of a render (docs/reliability.md): --out must be writable before anything renders (exit 2 otherwise).
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
            std::fprintf(stderr, "\r%s: %u/%u spp (%3d%%)  %.1fs elapsed, ~%.1fs left   ", label_.c_str(), done, total,
                         pct, el, left);
            if (done == total) std::fprintf(stderr, "\n");
        } else if (pct >= next_pct_ || done == total) {
            std::fprintf(stderr, "%s: %u/%u spp (%d%%) %.1fs elapsed, ~%.1fs left\n", label_.c_str(), done, total, pct,
                         el, left);
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

// docs/descriptor.md §1: plain `render` defaults to MIS; the paper's protocol (adaptive
// rendering, studies) to NEE.
Estimator render_estimator(const RenderOptions& o, Estimator fallback) {
    return o.estimator.empty() ? fallback : parse_estimator(o.estimator);
}

RenderInfo render_info(const std::string& name, const RenderOptions& o, const vk::Context& ctx, Traversal trav,
                       Estimator estimator, const Features& features, const Scene& scene, uint32_t spp, uint32_t seed,
                       bool capture) {
    RenderInfo info{name,
                    resolve_scene_path(o.common.scene),
                    ctx.info().name,
                    to_string(trav),
                    to_string(estimator),
                    features.describe(),
                    spp,
                    seed,
                    capture};
    info.kernel = vk::to_string(ctx.kernel());
    info.provenance = make_provenance(resolve_scene_path(o.common.scene), scene, o.common.defines, ctx, trav, spp);
    info.light_selection = o.light_selection;
    info.end_vertex = o.end_vertex;
    info.exposure_ev = o.exposure;
    info.warnings = scene.warnings;
    info.substitutions = scene.substitutions;
    info.lights_at_infinity = describe_lights_at_infinity(scene);
    return info;
}

}  // namespace

std::string taxonomy_sha256_for_cli(const std::string& path) {
    try {
        return sha256_file(path);
    } catch (const std::runtime_error& e) {
        throw UsageError(std::string("--taxonomy: ") + e.what());
    }
}

ReliabilityCurve load_curve_for_cli(const std::string& path, const std::string& taxonomy_sha256) {
    ReliabilityCurve c;
    try {
        c = ReliabilityCurve::load(path);
    } catch (const std::runtime_error& e) {
        throw UsageError(e.what());
    }
    const std::string why = curve_label_mismatch(c, path, taxonomy_sha256);
    if (!why.empty()) throw UsageError(why);
    return c;
}

namespace {

// docs/descriptor.md §6.5: the pilot diagnosis as printed by `render --adaptive`, after the
// pilot and before the allocation. Abstention is said for the strategies that floor; untrusted
// pixels are warned of for every strategy that reads the pilot.
void print_diagnosis(alloc::Strategy s, const alloc::PilotDiagnosis& d) {
    using alloc::Strategy;
    auto abstention = [&](const char* floor, const char* base, size_t changed) {
        if (changed != 0) return;
        if (d.heavy == 0)
            std::printf("%s: no heavy-tailed pilot pixels, identical to %s\n", floor, base);
        else
            std::printf(
                "%s: the floor changes none of the %zu heavy-tailed pilot pixels (each at or above its "
                "label's median), identical to %s\n",
                floor, d.heavy, base);
    };
    if (s == Strategy::BucketFloor || s == Strategy::Guarded)
        abstention("bucket-floor", "observed-var", d.floor_changed);
    if (s == Strategy::RobustFloor && d.robust_checked)
        abstention("robust-floor", "robust-var", d.robust_floor_changed);
    if (s == Strategy::Guarded && d.untrusted == 0)
        std::printf("guarded: no untrusted pilot pixels, identical to bucket-floor\n");
    if (d.untrusted == 0 || s == Strategy::Uniform) return;
    char what[256];
    std::snprintf(what, sizeof what,
                  "%zu of %zu pixels (%.1f%%) have no trustworthy pilot variance: %zu seen without a usable variance, "
                  "%zu dark beside seen pixels",
                  d.untrusted, d.pixels, 100.0 * d.untrusted_share(), d.lit_no_variance, d.dark_in_lit_region);
    if (s == Strategy::Guarded)
        std::printf("guarded: %s; each gets at least the uniform share\n", what);
    else {
        std::fflush(stdout);  // the warning after the lines above, also when both streams go to one file
        std::fprintf(stderr,
                     "vkmech: warning: pilot: %s; %s can starve them (the ajar-door failure); `--adaptive guarded` "
                     "keeps at least the uniform share there\n",
                     what, alloc::to_string(s));
    }
}

// docs/descriptor.md §6.7: which block count robust-adaptive uses where, from the pilot labels alone.
// `rare`: the rare-tail classes (ClassTraits::rare); `taxonomy`: whether they are a taxonomy's `[rare]` classes
// rather than the paper's delta_mediated and specular_direct.
void print_adaptive_k(const std::vector<uint8_t>& labels, uint32_t n0, uint32_t rare_classes, bool taxonomy) {
    const size_t rare = alloc::rare_tail_pixels(labels, rare_classes);
    const int k = alloc::mom_block_count(static_cast<int>(n0));
    const char* which = taxonomy ? "of the taxonomy's [rare] classes" : "labelled delta_mediated or specular_direct";
    if (rare == 0)
        std::printf("robust-adaptive: no pilot pixels %s, identical to robust-var (k = %d everywhere)\n", which, k);
    else
        std::printf(
            "robust-adaptive: k = 1 (the plain pilot variance) on %zu pilot pixels %s, k = %d (median-of-means, as "
            "robust-var) on the other %zu\n",
            rare, which, k, labels.size() - rare);
}

struct UntrustedAllocation {
    uint32_t min_n = ~0u, max_n = 0;
    size_t below_uniform = 0;
};

UntrustedAllocation untrusted_allocation(const alloc::PilotDiagnosis& d, const std::vector<uint32_t>& n,
                                         double uniform_share) {
    UntrustedAllocation u;
    for (size_t p = 0; p < n.size(); ++p) {
        if (d.untrusted_map[p] == alloc::kTrusted) continue;
        u.min_n = std::min(u.min_n, n[p]);
        u.max_n = std::max(u.max_n, n[p]);
        u.below_uniform += static_cast<double>(n[p]) < uniform_share ? 1 : 0;
    }
    return u;
}

// The "adaptive" member of the render's JSON summary: the settings, the pilot diagnosis and the
// prediction (null without a curve or without a labelled pixel).
std::string adaptive_json(alloc::Strategy s, const RenderOptions& o, const alloc::PilotDiagnosis& d,
                          const std::optional<PilotPrediction>& pred, const AdaptivePlan& plan,
                          const UntrustedAllocation& u) {
    std::ostringstream j;
    j.precision(9);
    auto number = [&](double x) -> std::ostringstream& {
        if (std::isfinite(x))
            j << x;
        else
            j << "null";
        return j;
    };
    j << "{\"strategy\": \"" << alloc::to_string(s) << "\", \"pilot_spp\": " << o.pilot
      << ", \"pilot_seed\": " << downstream_seeds::pilot(o.pilot_draw) << ", \"budget\": " << o.budget
      << ", \"floor\": " << o.floor << ", \"total_samples\": " << plan.total << ", \"pilot_pixels\": " << d.pixels
      << ", \"pilot_labelled_pixels\": " << d.labelled << ", \"pilot_seen_pixels\": " << d.seen
      << ", \"heavy_tailed_pilot_pixels\": " << d.heavy << ", \"bucket_floor_changed_pixels\": " << d.floor_changed
      << ", \"bucket_floor_abstains\": " << (d.floor_abstains ? "true" : "false");
    if (d.robust_checked)
        j << ", \"robust_floor_changed_pixels\": " << d.robust_floor_changed
          << ", \"robust_floor_abstains\": " << (d.robust_floor_abstains ? "true" : "false");
    j << ", \"untrusted_pixels\": " << d.untrusted << ", \"untrusted_share\": ";
    number(d.untrusted_share()) << ", \"untrusted_seen_without_variance\": " << d.lit_no_variance
                                << ", \"untrusted_dark_in_lit_region\": " << d.dark_in_lit_region
                                << ", \"untrusted_below_uniform_share\": " << u.below_uniform
                                << ", \"predicted_reliability_margin\": ";
    number(pred ? pred->margin : NAN) << ", \"predicted_reliability_purity\": ";
    number(pred ? pred->purity : NAN) << ", \"predicted_reliability_covers\": \"pilot_labelled_pixels\"}";
    return j.str();
}

// `--extra-output direct_glossy` (docs/descriptor.md §3.4): the direct-glossy shader variant. It
// splits the descriptor's direct bucket, so it needs the capture.
bool wants_direct_glossy(const RenderOptions& o, bool capture) {
    const bool on = std::find(o.extra_outputs.begin(), o.extra_outputs.end(), "direct_glossy") != o.extra_outputs.end();
    if (on && !capture)
        throw UsageError("--extra-output direct_glossy needs --capture on (it splits the direct bucket)");
    return on;
}

}  // namespace

// commands.hpp.
lpe::TaxonomySource read_labels_for_cli(const std::function<lpe::TaxonomySource()>& read, Scene& scene) {
    try {
        lpe::TaxonomySource source = read();
        give_named_shapes_own_materials(scene, source);
        return source;
    } catch (const lpe::LpeError& e) {
        throw UsageError(std::string(e.file() == "--lpe" ? "" : "--taxonomy: ") + e.what());
    }
}
SceneTaxonomy compile_labels_for_cli(const lpe::TaxonomySource& source, const Scene& scene, bool queries) {
    try {
        SceneTaxonomy t = queries ? compile_scene_queries(source, scene) : compile_scene_taxonomy(source, scene);
        for (const auto& w : t.compiled.warnings) std::fprintf(stderr, "vkmech: %s\n", w.str().c_str());
        return t;
    } catch (const lpe::LpeError& e) {
        throw UsageError(std::string(queries ? "" : "--taxonomy: ") + e.what());
    }
}

namespace {

// The query channels' energy (luminance summed over the film) as shares of the image's, in channel order.
void print_query_shares(const std::vector<ExrChannel>& channels, const Frame& frame, double seconds) {
    double image = 0.0;
    for (const auto& p : frame.pixels) image += p.count > 0 ? p.lum_mean : 0.0;
    std::printf("%-18s %12s   (--lpe: a second pass over the same samples, %.2f s)\n", "query", "energy share",
                seconds);
    for (size_t k = 0; k + 2 < channels.size(); k += 3) {
        double e = 0.0;
        for (size_t i = 0; i < channels[k].data.size(); ++i)
            e += luminance(channels[k].data[i], channels[k + 1].data[i], channels[k + 2].data[i]);
        const std::string name = channels[k].name.substr(0, channels[k].name.size() - 2);  // less ".R"
        std::printf("%-18s %11.2f%%\n", name.c_str(), image > 0 ? 100.0 * e / image : 0.0);
    }
}

// What every render command starts with (render, --adaptive, --noise-threshold).
struct CliRender {
    std::string name;
    std::unique_ptr<OutputSet> set;
    std::unique_ptr<vk::Context> ctx;  // declared first, so the session and renderer go before it
    std::unique_ptr<RenderSession> session;
    Traversal trav = Traversal::Bvh;
    Features features;
    std::unique_ptr<Renderer> renderer;
    vk::PipelineStats pipes;  // creating the renderer's pipeline
    double load_seconds = 0.0, build_seconds = 0.0;
    std::optional<SceneTaxonomy> taxonomy;  // --taxonomy
    // --lpe: the queries, and the renderer of their pass (the render's features, the queries as its taxonomy).
    std::optional<SceneTaxonomy> queries;
    std::unique_ptr<Renderer> query_renderer;
    const Scene& scene() const { return session->scene(); }
    // The labels' names: a --taxonomy's classes; empty for the seven buckets.
    std::vector<std::string> class_names() const {
        return taxonomy ? taxonomy->class_names() : std::vector<std::string>{};
    }
    // The labels' heavy and constant classes for the allocation rules: a --taxonomy's declared ones, else the
    // paper's buckets'.
    alloc::ClassTraits class_traits() const { return vkmech::class_traits(taxonomy ? &*taxonomy : nullptr); }
    // A descriptor of this render's frames, its slots named by the taxonomy's classes when there is one.
    Descriptor descriptor(const Frame& f) const {
        Descriptor d = derive_descriptor(f);
        if (taxonomy) use_taxonomy_classes(d, taxonomy->class_names());
        return d;
    }
};

// Loads the scene, opens the output set (--out must be writable before anything renders), the device and
// the scene on it, and makes a renderer of the scene's features (every effect compiled in with `generic`)
// after `adjust`. The caller holds a SignalGuard.
CliRender open_cli_render(const RenderOptions& o, Estimator estimator, bool capture, bool generic,
                          const std::function<void(Features&, const Scene&)>& adjust = {}) {
    using clock = std::chrono::steady_clock;
    auto since = [](clock::time_point t) { return std::chrono::duration<double>(clock::now() - t).count(); };
    CliRender r;
    const auto t_load = clock::now();
    Scene loaded = load_for_cli(o.common);
    std::optional<lpe::TaxonomySource> taxonomy;
    if (!o.taxonomy.empty()) taxonomy = read_labels_for_cli([&] { return lpe::read_taxonomy(o.taxonomy); }, loaded);
    std::optional<lpe::TaxonomySource> queries;
    if (!o.lpe.empty()) queries = read_labels_for_cli([&] { return lpe::taxonomy_from_lines(o.lpe, "--lpe"); }, loaded);
    r.load_seconds = since(t_load);
    r.name = scene_stem(o.common.scene);
    r.set = open_output_set(o.out_dir.empty() ? "out/" + r.name : o.out_dir, r.name);
    r.ctx = std::make_unique<vk::Context>(context_options(o.common));
    r.trav = resolve_traversal(*r.ctx, parse_traversal(o.common.traversal));
    const auto t_build = clock::now();
    r.session =
        std::make_unique<RenderSession>(*r.ctx, std::move(loaded), r.trav, parse_light_selection(o.light_selection));
    r.trav = r.session->traversal();  // an instanced scene's is the software BVH
    r.build_seconds = since(t_build);
    r.features = generic ? Features::generic(estimator, capture) : r.session->features(estimator, capture);
    r.features.end_vertex = parse_end_vertex(o.end_vertex);
    r.features.direct_glossy = wants_direct_glossy(o, capture);
    if (!o.taxonomy.empty()) {
        if (!capture) throw UsageError("--taxonomy needs --capture on (its classes are what the capture records)");
        if (r.features.direct_glossy)
            throw UsageError(
                "--taxonomy and --extra-output direct_glossy: the direct-glossy split is of the built-in "
                "direct bucket; choose one");
        r.taxonomy = compile_labels_for_cli(*taxonomy, r.session->scene(), /*queries=*/false);
        r.features.taxonomy = r.taxonomy->words;
    }
    if (adjust) adjust(r.features, r.session->scene());
    const vk::PipelineStats before = r.ctx->pipeline_cache().stats();
    r.renderer = r.session->make_renderer(r.features);
    r.pipes = r.ctx->pipeline_cache().stats() - before;
    if (queries) {
        r.queries = compile_labels_for_cli(*queries, r.session->scene(), /*queries=*/true);
        Features qf = r.features;
        qf.direct_glossy = false;
        qf.taxonomy = r.queries->words;
        r.query_renderer = r.session->make_renderer(qf);
    }
    return r;
}

}  // namespace

void check_curve_for_cli(const std::string& path) {
    try {
        (void)ReliabilityCurve::load(path);
    } catch (const std::runtime_error& e) {
        throw UsageError(e.what());
    }
}

int cmd_render_adaptive(const RenderOptions& o);
int cmd_render_threshold(const RenderOptions& o);

int cmd_render(const RenderOptions& o) {
    if (!o.adaptive.empty() && o.noise_threshold > 0)
        throw UsageError("--adaptive and --noise-threshold: choose one (a fixed budget, or a noise target)");
    if (!o.lpe.empty() && (!o.adaptive.empty() || o.noise_threshold > 0))
        throw UsageError("--lpe is for a render of a fixed budget, not with --adaptive or --noise-threshold");
    if (!o.lpe.empty() && o.capture != "on")
        throw UsageError("--lpe needs --capture on (its channels are tallied as the capture's classes)");
    if ((!o.lpe.empty() || !o.taxonomy.empty()) && o.preview)
        throw UsageError(std::string(o.lpe.empty() ? "--taxonomy" : "--lpe") +
                         " and --preview: the direct-light preview tallies no paths by class; render without "
                         "--preview");
    if (!o.adaptive.empty()) return cmd_render_adaptive(o);
    if (o.noise_threshold > 0) return cmd_render_threshold(o);
    // --sample-range A:B: samples [A, B) of the seed's stream, B - A of them (else [0, --spp)).
    SampleRange range{0, o.spp};
    try {
        if (!o.sample_range.empty()) range = parse_sample_range(o.sample_range);
    } catch (const std::invalid_argument& e) {
        throw UsageError(std::string("--sample-range: ") + e.what());
    }
    const uint32_t spp = range.end - range.begin;
    const bool capture = o.capture == "on";
    SignalGuard signals;  // SIGINT/SIGTERM: stop at the next batch, remove the staged files, exit 130/143
    // --pixel-bounds: a window of the film (after --res).
    std::optional<PixelBounds> bounds;
    CliRender cr = open_cli_render(
        o, render_estimator(o, Estimator::Mis), capture, o.generic, [&](Features& f, const Scene& scene) {
            try {
                if (!o.pixel_bounds.empty())
                    bounds = parse_pixel_bounds(o.pixel_bounds, static_cast<uint32_t>(scene.camera.width),
                                                static_cast<uint32_t>(scene.camera.height));
            } catch (const std::invalid_argument& e) {
                throw UsageError(std::string("--pixel-bounds: ") + e.what());
            }
            f.window = bounds.has_value();
        });
    const std::string& name = cr.name;
    const Estimator estimator = render_estimator(o, Estimator::Mis);
    vk::Context& ctx = *cr.ctx;
    const RenderSession& session = *cr.session;
    const Traversal trav = cr.trav;
    const Scene& scene = session.scene();
    const SceneArrays& arrays = session.arrays();
    const Features& features = cr.features;
    Renderer& renderer = *cr.renderer;
    OutputSet* set = cr.set.get();
    const vk::PipelineStats pipes = cr.pipes;
    const double load_seconds = cr.load_seconds, build_seconds = cr.build_seconds;

    std::fprintf(stderr,
                 "vkmech: %s: %dx%d, %zu triangles, %zu area emitters%s, %u spp on '%s' (%s traversal, %s kernel; %s; "
                 "%s light selection)\n",
                 name.c_str(), scene.camera.width, scene.camera.height, arrays.triangles.size(), scene.emitters.size(),
                 arrays.has_infinite_lights() ? " and lights at infinity" : "", spp, ctx.info().name.c_str(),
                 to_string(trav), vk::to_string(session.gpu().kernel()), features.describe().c_str(),
                 o.light_selection.c_str());
    RenderSpec spec;
    spec.spp = spp;
    spec.first_sample = range.begin;
    spec.window = bounds;
    spec.seed = o.seed;
    spec.batch_spp = o.batch_spp;
    spec.mode = o.preview ? gpu::MODE_DIRECT_PREVIEW : gpu::MODE_PATH;
    Progress progress("render " + name);
    spec.progress = [&](uint32_t d, uint32_t t) {
        throw_if_interrupted();
        progress(d, t);
    };
    std::unique_ptr<DisplayClient> display = open_live_view(o.display_server, name);
    const std::vector<std::string> classes = cr.class_names();
    if (display)
        spec.on_frame = [&](const Frame& f) { send_live_view(*display, f, capture, /*force=*/false, {}, classes); };
    Frame frame = renderer.render(spec);
    if (display) send_live_view(*display, frame, capture, /*force=*/true, {}, classes);
    // --lpe: the same samples again (the same seed and sample indices), tallied by the queries' combinations.
    std::optional<Frame> query_frame;
    if (cr.query_renderer) {
        RenderSpec qspec = spec;
        qspec.on_frame = nullptr;
        Progress query_progress("queries " + name);
        qspec.progress = [&](uint32_t d, uint32_t t) {
            throw_if_interrupted();
            query_progress(d, t);
        };
        query_frame = cr.query_renderer->render(qspec);
    }

    RenderInfo info = render_info(name, o, ctx, trav, estimator, features, scene, spp, o.seed, capture);
    info.kernel = vk::to_string(session.gpu().kernel());
    info.provenance.sample_range = std::to_string(range.begin) + ":" + std::to_string(range.end);
    if (bounds) {
        info.provenance.pixel_bounds = o.pixel_bounds;
        info.provenance.film_size = std::to_string(scene.camera.width) + "x" + std::to_string(scene.camera.height);
    }
    info.pipeline_seconds = pipes.seconds;
    info.pipeline_cache = vk::pipeline_cache_outcome(pipes, ctx.pipeline_cache().enabled());
    // Where the time before the first sample goes (docs/performance.md): parsing the scene and its meshes, then
    // flattening, building the BVH (software BVH traversal only) and uploading.
    char timing[200];
    std::snprintf(timing, sizeof timing,
                  "{\"triangles\": %zu, \"load_seconds\": %.6f, \"build_and_upload_seconds\": %.6f}",
                  arrays.triangles.size(), load_seconds, build_seconds);
    info.extra_json.emplace_back("scene_setup", timing);
    std::optional<Descriptor> desc;
    std::optional<DescriptorSummary> summary;
    if (capture) {
        desc = cr.descriptor(frame);
        summary = summarize(frame, *desc);
    }
    if (cr.taxonomy) info.taxonomy = taxonomy_json(*cr.taxonomy);
    if (query_frame) {
        info.extra_channels = query_channels(*query_frame, *cr.queries);
        info.extra_json.emplace_back("lpe", queries_json(*cr.queries, query_frame->seconds));
        info.queries = queries_json(*cr.queries);
    }
    WrittenFiles files =
        write_render_outputs(*set, info, frame, desc ? &*desc : nullptr, summary ? &*summary : nullptr);
    set->commit();
    report_render_warnings(files);

    double paths_per_s = frame.seconds > 0 ? frame.samples / frame.seconds : 0.0;
    uint64_t nonfinite = 0;
    for (const auto& p : frame.pixels) nonfinite += static_cast<uint64_t>(p.nonfinite);
    std::printf("%s: %d x %d, %u spp, %.2f s, %.3g paths/s, non-finite samples: %llu\n", name.c_str(), frame.width,
                frame.height, spp, frame.seconds, paths_per_s, static_cast<unsigned long long>(nonfinite));
    std::printf("pipeline creation: %.2f s (%s; not in the render time)\n", info.pipeline_seconds,
                info.pipeline_cache.c_str());
    if (summary) {
        std::printf("%-18s %12s %12s\n", cr.taxonomy ? "class" : "bucket", "pixel share", "energy share");
        for (size_t b = 0; b < summary->class_names.size(); ++b)
            std::printf("%-18s %11.2f%% %11.2f%%\n", summary->class_names[b].c_str(), 100.0 * summary->pixel_share[b],
                        100.0 * summary->energy_share[b]);
        std::printf("labelled pixels: %llu of %zu; other energy: %g\n",
                    static_cast<unsigned long long>(summary->labelled_pixels), frame.pixels.size(),
                    summary->other_energy);
        if (summary->has_direct_glossy)
            std::printf("direct energy ending at a glossy vertex: %.2f%% of direct, %.2f%% of all\n",
                        100.0 * summary->direct_glossy_share_of_direct, 100.0 * summary->direct_glossy_energy_share);
    }
    if (query_frame) print_query_shares(info.extra_channels, frame, query_frame->seconds);
    double clipped = clipped_share(frame.rgb_mean(), o.exposure);
    std::printf("preview: exposure %+.2f EV, %.2f%% of pixels clip%s\n", o.exposure, 100.0 * clipped,
                clipped > 0.05 ? " (lower --exposure to see them; the EXR keeps every value)" : "");
    for (const auto& f : {files.exr, files.png, files.dominant_png, files.purity_png, files.json,
                          set->final_path(manifest_file_name(name))})
        if (!f.empty()) std::printf("wrote %s\n", f.c_str());
    return 0;
}

// `vkmech render --adaptive STRATEGY --pilot N0 --budget B`: pilot, predicted
// label reliability, Neyman allocation, final render of n(p) pool samples.
int cmd_render_adaptive(const RenderOptions& o) {
    if (!o.sample_range.empty())
        throw UsageError("--sample-range and --adaptive: an adaptive render takes samples [0, n(p)) at each pixel");
    if (!o.pixel_bounds.empty()) throw UsageError("--pixel-bounds and --adaptive: an adaptive render takes the film");
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
    (void)wants_direct_glossy(o, true);  // refused before anything loads
    // The frozen curve is read before anything renders: a bad file is bad input (exit 2).
    // Without --curve: the installed (or source tree's) frozen curve; none found means no prediction.
    // A taxonomy's labels are not the buckets the frozen curve was fitted on: a prediction only with a --curve
    // fitted on the taxonomy (`vkmech study predictor --taxonomy FILE`).
    std::string curve_path = o.curve;
    if (o.taxonomy.empty() && curve_path.empty()) {
        const Resource found = find_predictor_curve();
        curve_path = found.path;
        if (!found.found())
            std::fprintf(stderr, "vkmech: note: the pilot's label reliability is not predicted: %s\n",
                         found.missing_message().c_str());
    }
    if (!o.curve.empty() && !fs::exists(curve_path))
        throw UsageError("predictor curve '" + o.curve + "' does not exist");
    std::optional<ReliabilityCurve> curve;
    if (!curve_path.empty() && fs::exists(curve_path))
        curve =
            load_curve_for_cli(curve_path, o.taxonomy.empty() ? std::string() : taxonomy_sha256_for_cli(o.taxonomy));
    const Estimator estimator = render_estimator(o, Estimator::Nee);
    SignalGuard signals;
    CliRender cr = open_cli_render(o, estimator, true, /*generic=*/false);
    const std::string& name = cr.name;
    vk::Context& ctx = *cr.ctx;
    const RenderSession& session = *cr.session;
    const Traversal trav = cr.trav;
    const Scene& scene = session.scene();
    const Features& features = cr.features;
    Renderer& renderer = *cr.renderer;
    OutputSet* set = cr.set.get();
    const vk::PipelineStats pipes = cr.pipes;
    const std::string pipe_outcome = vk::pipeline_cache_outcome(pipes, ctx.pipeline_cache().enabled());
    std::printf("pipeline creation: %.2f s (%s; not in the render times)\n", pipes.seconds, pipe_outcome.c_str());
    const size_t pixels = static_cast<size_t>(scene.camera.width) * scene.camera.height;
    std::fprintf(stderr,
                 "vkmech: %s: %dx%d adaptive (%s, pilot %u spp, budget 1 + %u spp per pixel, floor %u) on '%s'\n",
                 name.c_str(), scene.camera.width, scene.camera.height, alloc::to_string(strategy), o.pilot, o.budget,
                 o.floor, ctx.info().name.c_str());

    throw_if_interrupted();
    Progress pilot_progress("pilot " + name);
    Pilot pilot =
        render_pilot(renderer, o.pilot, downstream_seeds::pilot(o.pilot_draw), robust, [&](uint32_t d, uint32_t t) {
            throw_if_interrupted();  // Ctrl-C stops the pilot at its next batch
            pilot_progress(d, t);
        });
    throw_if_interrupted();
    std::printf("pilot: %u spp (seed %u), %.2f s\n", o.pilot, downstream_seeds::pilot(o.pilot_draw), pilot.seconds);

    // What the pilot alone says about the strategies' assumptions (docs/descriptor.md §6.5).
    const alloc::ClassTraits traits = cr.class_traits();
    const alloc::PilotDiagnosis diag = alloc::diagnose_pilot(pilot, traits);

    // The pilot's predicted label reliability (paper §8.2), before anything is allocated. It is
    // a statement about the pixels the pilot labelled, and only about them.
    std::optional<PilotPrediction> pred;
    if (curve) {
        pred = predict_from_pilot(*curve, pilot.frame);
        std::printf(
            "predicted label reliability of the %zu of %zu pixels the pilot labelled, not of the %zu it left "
            "unlabelled: %.3f by margin, %.3f by purity (share of those labels a converged render keeps; curve "
            "%s, fitted on %u-spp pilots)\n",
            diag.labelled, diag.pixels, diag.pixels - diag.labelled, pred->margin, pred->purity, curve_path.c_str(),
            curve->pilot_spp);
        if (curve->pilot_spp != 0 && curve->pilot_spp != o.pilot)
            std::printf(
                "note: this pilot has %u spp; the curve was fitted on %u-spp pilots, so the prediction is "
                "indicative only\n",
                o.pilot, curve->pilot_spp);
    } else if (cr.taxonomy) {
        std::printf(
            "predicted label reliability: none for a taxonomy's classes (the frozen curve is of the buckets)\n");
    } else {
        std::printf("predicted label reliability: no frozen curve at %s (run `vkmech study predictor`)\n",
                    curve_path.c_str());
    }

    print_diagnosis(strategy, diag);
    if (strategy == alloc::Strategy::RobustAdaptive)
        print_adaptive_k(pilot.labels, o.pilot, traits.rare, cr.taxonomy.has_value());

    AdaptivePlan plan = plan_from_pilot(strategy, pilot, diag, o.pilot, o.budget, o.floor, o.pilot_draw, traits);
    const double uniform_share = static_cast<double>(plan.total) / static_cast<double>(pixels);
    const UntrustedAllocation untrusted_n = untrusted_allocation(diag, plan.n, uniform_share);

    RenderSpec spec = adaptive_render_spec(plan, o.batch_spp);
    Progress progress("render " + name);
    spec.progress = [&](uint32_t d, uint32_t t) {
        throw_if_interrupted();
        progress(d, t);
    };
    std::unique_ptr<DisplayClient> display = open_live_view(o.display_server, name);
    if (display && display->connected()) {  // the pilot and the allocation map, then the final render
        const Descriptor pilot_desc = cr.descriptor(pilot.frame);
        display->send_snapshot("pilot", pilot.frame.width, pilot.frame.height,
                               render_channels(pilot.frame, &pilot_desc));
        ExrChannel n{"n", std::vector<float>(plan.n.begin(), plan.n.end()), false};
        ExrChannel untrusted{"untrusted", std::vector<float>(diag.untrusted_map.begin(), diag.untrusted_map.end()),
                             false};
        display->send_snapshot("allocation", pilot.frame.width, pilot.frame.height, {n, untrusted});
        if (!display->connected()) std::fprintf(stderr, "vkmech: warning: %s\n", display->warning().c_str());
    }
    if (display)
        spec.on_frame = [&](const Frame& f) {
            send_live_view(*display, f, /*capture=*/true, /*force=*/false, {}, cr.class_names());
        };
    Frame frame = renderer.render(spec);
    if (display) send_live_view(*display, frame, /*capture=*/true, /*force=*/true, {}, cr.class_names());

    uint32_t max_n = 0, min_n = ~0u;
    for (uint32_t n : plan.n) {
        max_n = std::max(max_n, n);
        min_n = std::min(min_n, n);
    }
    RenderInfo info = render_info(name, o, ctx, trav, estimator, features, scene,
                                  static_cast<uint32_t>(plan.total / pixels), downstream_seeds::kPool, true);
    info.kernel = vk::to_string(session.gpu().kernel());
    info.features += std::string(" adaptive=") + alloc::to_string(strategy);
    info.provenance.sample_range = adaptive_sample_range(plan.n);
    info.pipeline_seconds = pipes.seconds;
    info.pipeline_cache = pipe_outcome;
    info.extra_json.emplace_back("adaptive", adaptive_json(strategy, o, diag, pred, plan, untrusted_n));
    if (cr.taxonomy) info.taxonomy = taxonomy_json(*cr.taxonomy);
    Descriptor desc = cr.descriptor(frame);
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
    if (diag.untrusted > 0)
        std::printf("untrusted pixels: n(p) from %u to %u; %zu of %zu below the uniform share of %.2f\n",
                    untrusted_n.min_n, untrusted_n.max_n, untrusted_n.below_uniform, diag.untrusted, uniform_share);
    std::printf("final: %.2f s; wall time pilot + allocation + final: %.2f s\n", frame.seconds,
                pilot.seconds + plan.allocation_ms / 1000.0 + frame.seconds);
    for (const auto& f :
         {files.exr, files.png, files.dominant_png, spp_png, files.json, set->final_path(manifest_file_name(name))})
        if (!f.empty()) std::printf("wrote %s\n", f.c_str());
    return 0;
}

namespace {

// The "noise_threshold" member of the render's JSON summary: the settings, each round, and why the
// pixels stopped.
std::string threshold_json(const RenderOptions& o, const ThresholdSettings& s, const ThresholdResult& r) {
    std::ostringstream j;
    j.precision(9);
    j << "{\"threshold\": " << s.threshold << ", \"rule\": \"" << alloc::to_string(s.rule)
      << "\", \"min_spp\": " << s.min_spp << ", \"max_spp\": " << s.max_spp << ", \"time_limit_seconds\": ";
    if (s.time_limit > 0)
        j << s.time_limit;
    else
        j << "null";
    j << ", \"spp_budget\": ";
    if (o.spp_budget > 0)
        j << o.spp_budget;
    else
        j << "null";
    j << ", \"seed\": " << o.seed << ", \"pixels\": " << r.n.size() << ", \"converged_pixels\": " << r.converged
      << ", \"at_max_spp_pixels\": " << r.at_max << ", \"unfinished_pixels\": " << r.unfinished
      << ", \"time_limit_reached\": " << (r.time_limit_reached ? "true" : "false")
      << ", \"spp_budget_reached\": " << (r.budget_reached ? "true" : "false") << ", \"seconds\": " << r.seconds
      << ", \"samples\": " << r.frame.samples << ", \"rounds\": [";
    for (size_t i = 0; i < r.rounds.size(); ++i) {
        const ThresholdRound& q = r.rounds[i];
        j << (i ? ", " : "") << "{\"pixels\": " << q.pixels << ", \"samples\": " << q.samples
          << ", \"above_before\": " << q.above << ", \"worst_before\": " << q.worst << ", \"seconds\": " << q.seconds
          << ", \"plan_seconds\": " << q.plan_seconds << ", \"cut_by_time\": " << (q.cut_by_time ? "true" : "false")
          << "}";
    }
    j << "]}";
    return j.str();
}

}  // namespace

// `vkmech render --noise-threshold T`: rounds of samples where the estimated relative error is above T
// (docs/descriptor.md §6.8).
int cmd_render_threshold(const RenderOptions& o) {
    if (!o.sample_range.empty())
        throw UsageError("--sample-range and --noise-threshold: a noise-threshold render takes samples [0, n(p))");
    if (!o.pixel_bounds.empty())
        throw UsageError("--pixel-bounds and --noise-threshold: the error estimate reads the whole film");
    if (o.capture != "on") throw UsageError("--noise-threshold needs --capture on (its rule reads the labels)");
    if (o.spp_given) throw UsageError("--spp and --noise-threshold: use --min-spp and --max-spp");
    if (o.min_spp > o.max_spp)
        throw UsageError("--min-spp " + std::to_string(o.min_spp) + " exceeds --max-spp " + std::to_string(o.max_spp));
    ThresholdSettings ts;
    ts.threshold = o.noise_threshold;
    ts.min_spp = o.min_spp;
    ts.max_spp = o.max_spp;
    ts.time_limit = o.time_limit;
    if (o.spp_budget > 0 && o.spp_budget < o.min_spp) {
        char what[160];
        std::snprintf(what, sizeof what, "--spp-budget %g is below --min-spp %u (every pixel takes --min-spp first)",
                      o.spp_budget, o.min_spp);
        throw UsageError(what);
    }
    ts.rule = alloc::parse_strategy(o.noise_rule);  // CLI11 has checked the name
    ts.seed = o.seed;
    ts.batch_spp = o.batch_spp;
    const Estimator estimator = render_estimator(o, Estimator::Mis);
    SignalGuard signals;
    CliRender cr = open_cli_render(o, estimator, true, o.generic);
    const std::string& name = cr.name;
    vk::Context& ctx = *cr.ctx;
    const RenderSession& session = *cr.session;
    const Traversal trav = cr.trav;
    const Scene& scene = session.scene();
    ts.sample_budget = static_cast<uint64_t>(std::llround(o.spp_budget * scene.camera.width * scene.camera.height));
    ts.traits = cr.class_traits();
    // Every batch is read back and merged on the host: on a GPU, 8 samples a dispatch leave the device idle
    // (measured on an H100, docs/gpu.md), so the GPU kernel's default is 64.
    if (!o.batch_given && session.gpu().kernel() == vk::KernelClass::Gpu) ts.batch_spp = 64;
    const Features& features = cr.features;
    Renderer& renderer = *cr.renderer;
    OutputSet* set = cr.set.get();
    const vk::PipelineStats pipes = cr.pipes;
    char limit[64] = "";
    if (ts.time_limit > 0) std::snprintf(limit, sizeof limit, ", time limit %.1f s", ts.time_limit);
    std::fprintf(stderr,
                 "vkmech: %s: %dx%d to relative error %g (%s rule), %u to %u spp%s, on '%s' (%s traversal, %s "
                 "kernel; %s)\n",
                 name.c_str(), scene.camera.width, scene.camera.height, ts.threshold, o.noise_rule.c_str(), ts.min_spp,
                 ts.max_spp, limit, ctx.info().name.c_str(), to_string(trav), vk::to_string(session.gpu().kernel()),
                 features.describe().c_str());

    // The display shows every channel of the EXR, err included (0 until the first estimate).
    std::unique_ptr<DisplayClient> display = open_live_view(o.display_server, name);
    auto send = [&](const Frame& f, const std::vector<double>& err, bool force) {
        if (!display || !display->connected() || !display->due(force)) return;
        ExrChannel e{"err", std::vector<float>(f.pixels.size(), 0.0f), false};
        for (size_t i = 0; i < err.size() && i < e.data.size(); ++i) e.data[i] = static_cast<float>(err[i]);
        send_live_view(*display, f, /*capture=*/true, force, {e}, cr.class_names());
    };
    Progress progress("round 0 " + name);
    std::unique_ptr<Progress> round_progress;
    ThresholdCallbacks cb;
    cb.progress = [&](uint32_t d, uint32_t t) {
        throw_if_interrupted();
        (round_progress ? *round_progress : progress)(d, t);
    };
    cb.on_round = [&](const ThresholdRound& r, size_t i) {
        if (i == 0)
            std::fprintf(stderr, "noise threshold: round 0: %zu pixels x %u spp, %.2f s\n", r.pixels, ts.min_spp,
                         r.seconds);
        else
            std::fprintf(stderr,
                         "noise threshold: round %zu: %zu pixels above %g (worst %.3g); %zu of them took %llu samples "
                         "from %u spp on%s, %.2f s\n",
                         i, r.above, ts.threshold, r.worst, r.pixels, static_cast<unsigned long long>(r.samples),
                         r.first, r.cut_by_time ? " (cut to fit the time or samples left)" : "", r.seconds);
        round_progress = std::make_unique<Progress>("round " + std::to_string(i + 1) + " " + name);
    };
    if (display) {
        cb.frame_due = [&] { return display->connected() && display->due(false); };
        cb.on_frame = [&](const Frame& f, const std::vector<double>& err) { send(f, err, false); };
    }
    throw_if_interrupted();
    ThresholdResult result = render_to_threshold(renderer, ts, cb);
    if (display) send(result.frame, result.err, true);

    const Frame& frame = result.frame;
    const size_t pixels = frame.pixels.size();
    RenderInfo info = render_info(name, o, ctx, trav, estimator, features, scene,
                                  static_cast<uint32_t>(frame.samples / std::max<size_t>(pixels, 1)), o.seed, true);
    info.kernel = vk::to_string(session.gpu().kernel());
    info.features += " noise-threshold=" + o.noise_rule;
    info.provenance.sample_range = adaptive_sample_range(result.n);
    info.pipeline_seconds = pipes.seconds;
    info.pipeline_cache = vk::pipeline_cache_outcome(pipes, ctx.pipeline_cache().enabled());
    info.extra_json.emplace_back("noise_threshold", threshold_json(o, ts, result));
    ExrChannel err{"err", std::vector<float>(pixels), false};
    for (size_t i = 0; i < pixels; ++i) err.data[i] = static_cast<float>(result.err[i]);
    info.extra_channels.push_back(std::move(err));
    if (cr.taxonomy) info.taxonomy = taxonomy_json(*cr.taxonomy);
    Descriptor desc = cr.descriptor(frame);
    DescriptorSummary summary = summarize(frame, desc);
    WrittenFiles files = write_render_outputs(*set, info, frame, &desc, &summary);
    report_render_warnings(files);
    const uint32_t max_n = *std::max_element(result.n.begin(), result.n.end());
    std::vector<float> nmap(result.n.begin(), result.n.end());
    write_png_rgb8(set->staged(name + "_spp.png"), frame.width, frame.height,
                   grey_to_rgb8(nmap, 0.0f, static_cast<float>(max_n)));
    std::string spp_png = set->final_path(name + "_spp.png");
    set->commit();

    std::printf(
        "noise threshold %g (%s rule): %zu rounds, %.2f s, %llu samples (%.2f per pixel, %u to %u); %zu pixels "
        "below the threshold, %zu above it at --max-spp, %zu above it when %s\n",
        ts.threshold, o.noise_rule.c_str(), result.rounds.size(), result.seconds,
        static_cast<unsigned long long>(frame.samples), static_cast<double>(frame.samples) / pixels,
        *std::min_element(result.n.begin(), result.n.end()), max_n, result.converged, result.at_max, result.unfinished,
        result.time_limit_reached ? "the time limit stopped it"
                                  : (result.budget_reached ? "the sample budget stopped it" : "it stopped"));
    for (const auto& f :
         {files.exr, files.png, files.dominant_png, spp_png, files.json, set->final_path(manifest_file_name(name))})
        if (!f.empty()) std::printf("wrote %s\n", f.c_str());
    return 0;
}

// `vkmech render` (and `vkmech --scene ...`, which main turns into it).
void register_render(CLI::App& app, CliCommands& commands) {
    auto o = std::make_shared<RenderOptions>();
    auto* render = app.add_subcommand("render", "Render a scene to a multi-layer EXR and PNG previews");
    add_common_options(render, o->common);
    auto* spp_opt = render->add_option("--spp", o->spp, "Samples per pixel")->check(CLI::Range(1u, 1u << 20));
    spp_opt->each([o](const std::string&) { o->spp_given = true; });
    render
        ->add_option("--sample-range", o->sample_range,
                     "A:B: render exactly samples [A, B) of the seed's stream (B - A per pixel), recorded in the "
                     "outputs; disjoint ranges of one seed merge into the single render (vkmech merge)")
        ->excludes(spp_opt);
    render->add_option("--pixel-bounds", o->pixel_bounds,
                       "x0,x1,y0,y1: render only the window [x0, x1) x [y0, y1) of the film (after --res), each pixel "
                       "exactly as in the whole film's render; vkmech merge puts the windows together");
    render->add_option("--seed", o->seed, "Random seed (docs/descriptor.md §4)");
    render->add_option("--batch", o->batch_spp, "Samples per GPU dispatch")
        ->check(CLI::Range(1u, 4096u))
        ->each([o](const std::string&) { o->batch_given = true; });
    render->add_option("--out", o->out_dir, "Output directory (default: out/<scene>)");
    render
        ->add_option("--estimator", o->estimator,
                     "Estimator: mis (default), nee (the paper's; the default with --adaptive) or mis-restricted")
        ->check(CLI::IsMember({"nee", "mis-restricted", "mis"}));
    render
        ->add_option("--light-selection", o->light_selection,
                     "How NEE picks an emitter: uniform (default, as Mitsuba) or power")
        ->check(CLI::IsMember({"uniform", "power"}));
    render
        ->add_option("--end-vertex", o->end_vertex,
                     "Label's end vertex: last-nondelta (default) or literal (the last surface vertex)")
        ->check(CLI::IsMember({"last-nondelta", "literal"}));
    render->add_option("--exposure", o->exposure, "Exposure of the PNG preview in stops (EV; the EXR is never scaled)")
        ->check(CLI::Range(-30.0f, 30.0f));
    render->add_option("--capture", o->capture, "Mechanism descriptor capture: on (default) or off")
        ->check(CLI::IsMember({"on", "off"}));
    render
        ->add_option("--extra-output", o->extra_outputs,
                     "Optional extra outputs (comma-separated): direct_glossy = the direct bucket's energy whose end "
                     "vertex is glossy, as EXR channel lum.direct_glossy and a JSON share (docs/descriptor.md "
                     "§3.4; a second shader variant, needs --capture on)")
        ->delimiter(',')
        ->check(CLI::IsMember({"direct_glossy"}));
    render
        ->add_option("--taxonomy", o->taxonomy,
                     "Label paths by your own taxonomy: a file of `name = light path expression` lines (OSL's LPE "
                     "grammar, first match wins, an implicit `other`; docs/lpe.md), compiled to a DFA the path "
                     "tracer steps at each vertex; its classes replace the seven buckets in every output. At most "
                     "6 lines. With --adaptive or --noise-threshold the classes are the labels: lines declared "
                     "`name [heavy] = ...` are what the floor floors, `[constant]` ones (an emitter seen directly) "
                     "what the guard trusts at zero variance, and `[rare]` ones where robust-adaptive keeps the "
                     "plain variance. taxonomies/paper.lpe is the built-in one")
        ->check(CLI::ExistingFile);
    render
        ->add_option("--lpe", o->lpe,
                     "Add query channels: `name=EXPR`, a light path expression (docs/lpe.md), repeatable. Unlike "
                     "--taxonomy's classes they may overlap: lpe.NAME.R/G/B is the radiance of every path NAME "
                     "matches, lpe._rest of the paths no query matches, lpe._overlap the radiance counted more than "
                     "once. A second pass over the same samples; at most 6 combinations of queries that paths make")
        ->allow_extra_args(false);
    render->add_option("--display-server", o->display_server,
                       "Show the render in progress in tev (or HDRView) listening at HOST:PORT (tev's default "
                       "127.0.0.1:14158): every channel of the EXR, updated at most every 250 ms; a viewer that is "
                       "absent or goes away is a warning, never a failed render");
    render->add_flag("--generic", o->generic, "Use the unspecialized pipeline (every effect compiled in)");
    render->add_flag("--preview", o->preview, "Fast direct-light preview instead of the full estimator");
    render->add_option(
        "--adaptive", o->adaptive,
        "Two-stage adaptive rendering (docs/descriptor.md §6) with this allocation strategy: uniform, observed-var, "
        "bucket-floor, robust-var, robust-floor, placebo, robust-placebo, guarded (bucket-floor with at least "
        "the uniform share where the pilot cannot be trusted), shrink (the pilot variance shrunk towards its label's "
        "empirical-Bayes prior), robust-adaptive (median-of-means with the block count chosen per pixel from its pilot "
        "label: the plain variance on delta_mediated and specular_direct pixels, ceil(sqrt(N0)) blocks elsewhere)");
    render->add_option("--pilot", o->pilot, "Adaptive: pilot samples per pixel N0 (default 16)")
        ->check(CLI::Range(2u, 4096u));
    render
        ->add_option("--budget", o->budget,
                     "Adaptive: extra samples per pixel on average, on top of the baseline of 1 (default 32)")
        ->check(CLI::Range(0u, 255u));
    render->add_option("--floor", o->floor, "Adaptive: minimum samples per pixel (default 1)")
        ->check(CLI::Range(1u, 256u));
    render->add_option("--pilot-draw", o->pilot_draw, "Adaptive: pilot draw k (pilot seed 100000 + 1000k)")
        ->check(CLI::Range(0u, 899u));
    auto* threshold_opt =
        render
            ->add_option(
                "--noise-threshold", o->noise_threshold,
                "Render in rounds until every pixel's estimated relative error (the standard error of its mean "
                "luminance over the mean) is at most T, or the pixel has --max-spp, or --time-limit is up; "
                "writes an err channel (docs/descriptor.md §6.8)")
            ->check(CLI::Range(1e-6, 10.0));
    render->add_option("--min-spp", o->min_spp, "Noise threshold: every pixel's first samples (default 16)")
        ->check(CLI::Range(2u, 1u << 20))
        ->needs(threshold_opt);
    render->add_option("--max-spp", o->max_spp, "Noise threshold: no pixel takes more (default 1024)")
        ->check(CLI::Range(2u, 1u << 20))
        ->needs(threshold_opt);
    render
        ->add_option("--time-limit", o->time_limit,
                     "Noise threshold: seconds of rendering; each round is fitted to the time left, the worst pixels "
                     "first (default: none)")
        ->check(CLI::Range(0.0, 1e7))
        ->needs(threshold_opt);
    render
        ->add_option("--spp-budget", o->spp_budget,
                     "Noise threshold: stop when the image has taken this many samples per pixel on average (a "
                     "reproducible limit, unlike --time-limit; rounds are fitted to it the same way)")
        ->check(CLI::Range(1.0, 1048576.0))
        ->needs(threshold_opt);
    render
        ->add_option("--noise-rule", o->noise_rule,
                     "Noise threshold: the variance its error reads: guarded (default: bucket-floor's label floor, and "
                     "the guard's share where the samples cannot be trusted), bucket-floor, or observed-var (the "
                     "plain sample variance)")
        ->check(CLI::IsMember({"guarded", "bucket-floor", "observed-var"}))
        ->needs(threshold_opt);
    render->add_option("--curve", o->curve,
                       "Adaptive: frozen label-reliability curve (default: predictor_curve.json, see `vkmech paths`; "
                       "with --taxonomy, a curve fitted on that taxonomy, and none by default)");

    commands.push_back({render, [o](const std::vector<std::string>&) { return cmd_render(*o); }});
}

}  // namespace vkmech
