// `vkmech sentinel register` and `vkmech sentinel verify` (docs/descriptor.md §9).
#include "cli/commands.hpp"
#include "cli/provenance.hpp"
#include "cli/resources.hpp"

#include "adaptive/adaptive.hpp"
#include "experiments/sentinel.hpp"
#include "experiments/sentinel_eval.hpp"
#include "io/atomic_file.hpp"
#include "io/digest.hpp"
#include "io/interrupt.hpp"
#include "io/sha256.hpp"
#include "render/features.hpp"
#include "render/session.hpp"
#include "render/shader_modules.hpp"
#include "study/allocation_source.hpp"
#include "study/render_cache.hpp"
#include "study/sentinel_register.hpp"
#include "study/study_runner.hpp"

#include <chrono>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <set>
#include <sstream>

namespace fs = std::filesystem;

namespace vkmech {

namespace {

std::string utc_now() {
    const std::time_t t = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
    std::tm tm{};
    gmtime_r(&t, &tm);
    char b[32];
    std::strftime(b, sizeof b, "%Y-%m-%dT%H:%M:%SZ", &tm);
    return b;
}

}  // namespace

// Renders only the pilot and writes the sealed pre-registration record.
int cmd_sentinel_register(const SentinelOptions& o) {
    // Everything that can be refused is refused before the pilot renders (exit 2).
    // The frozen curve predicts the labels it was fitted on: the buckets' (found as `vkmech paths` says), or with
    // --taxonomy only a --curve fitted on that taxonomy (`vkmech study predictor --taxonomy FILE`); a taxonomy's
    // record without one predicts no label reliability.
    const bool by_taxonomy = !o.taxonomy.empty();
    const Resource found = o.curve.empty() && !by_taxonomy ? find_predictor_curve() : Resource{};
    const std::string curve_path = o.curve.empty() ? found.path : o.curve;
    if (curve_path.empty() && !by_taxonomy)
        throw UsageError("sentinel register needs the frozen reliability curve: " + found.missing_message());
    if (!curve_path.empty() && !fs::exists(curve_path))
        throw UsageError("predictor curve '" + curve_path + "' does not exist");
    const bool with_curve = !curve_path.empty();
    ReliabilityCurve curve;
    if (with_curve)
        curve = load_curve_for_cli(curve_path, by_taxonomy ? taxonomy_sha256_for_cli(o.taxonomy) : std::string());
    if (o.common.substitute)
        throw UsageError(
            "sentinel register does not take --substitute: the evaluation must load the scene as registered");
    const std::string scene_path = resolve_scene_path(o.common.scene);
    const std::string name = o.name.empty() ? scene_stem(o.common.scene) : o.name;
    const std::string out = o.out.empty() ? "sentinel_" + name + ".json" : o.out;
    if (fs::exists(out) && !o.force)
        throw UsageError("'" + out + "' exists: a registration is never overwritten (remove it, or --force)");
    require_writable_dir(fs::path(canonical_path(out)).parent_path().string(), "--out");
    Scene loaded = load_for_cli(o.common);
    std::optional<lpe::TaxonomySource> taxonomy;
    if (by_taxonomy) taxonomy = read_labels_for_cli([&] { return lpe::read_taxonomy(o.taxonomy); }, loaded);

    sentinel::Record rec;
    rec.scene_name = name;
    rec.scene_path = canonical_path(scene_path);
    rec.params = parse_defines(o.common.defines);
    if (o.reference_spp % 64 != 0)
        throw UsageError("--reference-spp " + std::to_string(o.reference_spp) + " is not a multiple of 64");
    if (o.extra + 1 > downstream_seeds::kPoolSize)
        throw UsageError("--extra " + std::to_string(o.extra) + " exceeds the shared pool");
    rec.protocol = {o.reference_spp, o.draws, o.extra, o.floor};
    try {
        rec.scene_sha256 = sha256_file(scene_path);
        for (const auto& [path, sha] : scene_input_files(loaded)) rec.scene_files.push_back({path, sha});
        if (with_curve) rec.curve_sha256 = sha256_file(curve_path);
    } catch (const std::runtime_error& e) {
        throw UsageError(e.what());
    }

    SignalGuard signals;
    vk::Context ctx(context_options(o.common));
    const Traversal trav = resolve_traversal(ctx, parse_traversal(o.common.traversal));
    const LightSelection lights = LightSelection::Uniform;
    RenderSession session(ctx, std::move(loaded), trav, lights);
    // The paper's protocol (as render --adaptive): NEE, the descriptor captured, the default end vertex.
    Features features = session.features(Estimator::Nee, true);
    std::optional<sentinel::TaxonomyRecord> tax_record;
    if (taxonomy) {  // the pilot labelled by its classes (docs/lpe.md)
        const SceneTaxonomy t = compile_labels_for_cli(*taxonomy, session.scene(), /*queries=*/false);
        features.taxonomy = t.words;
        try {
            tax_record = sentinel::TaxonomyRecord{canonical_path(o.taxonomy), sha256_file(o.taxonomy), t.class_names(),
                                                  class_traits(&t)};
        } catch (const std::runtime_error& e) {
            throw UsageError(e.what());
        }
    }
    Renderer renderer = session.renderer(features);
    std::fprintf(stderr, "vkmech: sentinel %s: %dx%d, pilot %u spp (seed %u) on '%s'; the reference is not rendered\n",
                 name.c_str(), session.scene().camera.width, session.scene().camera.height, o.pilot,
                 downstream_seeds::pilot(o.pilot_draw), ctx.info().name.c_str());
    const PilotRenderFn pilot_fn = [&](uint32_t n0, uint32_t seed, bool robust) {
        throw_if_interrupted();
        return render_pilot(renderer, n0, seed, robust);
    };
    sentinel::Record r = register_sentinel(session, pilot_fn, o.pilot, o.pilot_draw, with_curve ? &curve : nullptr,
                                           tax_record ? &*tax_record : nullptr);
    throw_if_interrupted();

    r.scene_name = rec.scene_name;
    r.scene_path = rec.scene_path;
    r.scene_sha256 = rec.scene_sha256;
    r.scene_files = rec.scene_files;
    r.estimator = to_string(features.estimator);
    r.end_vertex = to_string(features.end_vertex);
    r.light_selection = to_string(lights);
    r.traversal = to_string(trav);
    const auto spirv = pathtrace_spirv(trav, ctx.kernel());
    r.version = VKMECH_VERSION;
    // The studies' code digest (study_runner.hpp) and a SHA-256 of the same SPIR-V.
    r.code_digest = render_code_digest(trav, ctx.kernel());
    r.spirv_sha256 = Sha256().update(spirv.data(), spirv.size_bytes()).hex();
    r.registered_utc = utc_now();
    r.device = ctx.info().name;
    if (with_curve) {
        r.curve_path = canonical_path(curve_path);
        r.curve_sha256 = rec.curve_sha256;
        r.curve_pilot_spp = curve.pilot_spp;
        r.curve_reference_spp = curve.reference_spp;
    }
    r.params = rec.params;
    r.protocol = rec.protocol;

    const std::string sealed = sentinel::seal(sentinel::record_json(r));
    write_file_atomic(out, sealed);
    std::printf(
        "registered %zu predictions for %s from the pilot alone (%u spp, seed %u)%s\n", r.predictions.size(),
        name.c_str(), o.pilot, r.pilot_seed,
        curve.pilot_spp != 0 && curve.pilot_spp != o.pilot ? "; note: the curve was fitted on other pilots" : "");
    std::printf("wrote %s\n", out.c_str());
    return 0;
}

namespace {
// A record file's bytes; UsageError (exit 2) when it cannot be read.
std::string read_record(const std::string& file) {
    std::ifstream in(file, std::ios::binary);
    if (!in) throw UsageError("cannot read sentinel record '" + file + "'");
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
}
}  // namespace

// Exit 0 with a one-line summary when the record is intact, 1 when it was
// edited after registration, 2 when it is unreadable, malformed, lacks a
// member or has an unknown format version.
int cmd_sentinel_verify(const std::string& file) {
    const sentinel::Verification v = sentinel::verify_record(read_record(file), file);
    if (v.kind == sentinel::Verification::Intact) {
        std::printf("%s\n", v.message.c_str());
        return 0;
    }
    std::cerr << "vkmech: error: " << v.message << "\n";
    return v.kind == sentinel::Verification::Edited ? 1 : 2;
}

// Refuses an edited record (exit 1), a changed scene (exit 1) or other code
// (exit 2, unless allowed); renders the reference, pool and pilot draws and
// writes PASS/FAIL per prediction (exit 0 whatever the verdicts).
int cmd_sentinel_evaluate(const SentinelEvaluateOptions& o) {
    const std::string text = read_record(o.record);
    const sentinel::Verification v = sentinel::verify_record(text, o.record);
    if (v.kind != sentinel::Verification::Intact) {
        std::cerr << "vkmech: error: " << v.message << "; refusing to evaluate it\n";
        return v.kind == sentinel::Verification::Edited ? 1 : 2;
    }
    sentinel::Record r;
    std::string seal;
    try {
        const std::optional<JsonValue> doc = parse_json(text);
        r = sentinel::parse_record(*doc);
        seal = doc->find("sha256")->string;
    } catch (const std::runtime_error& e) {
        throw UsageError(std::string(e.what()) + " ('" + o.record + "')");
    }
    // The scene must be the registered one, byte for byte.
    if (!fs::is_regular_file(r.scene_path))
        throw UsageError("the registered scene '" + r.scene_path +
                         "' does not exist (moved? the record names it absolutely)");
    std::vector<std::pair<std::string, std::string>> files = {{r.scene_path, r.scene_sha256}};
    for (const auto& f : r.scene_files) files.emplace_back(f.path, f.sha256);
    if (r.taxonomy) {  // the taxonomy too, byte for byte
        if (!fs::is_regular_file(r.taxonomy->path))
            throw UsageError("the registered taxonomy '" + r.taxonomy->path +
                             "' does not exist (moved? the record names it absolutely)");
        files.emplace_back(r.taxonomy->path, r.taxonomy->sha256);
    }
    for (const auto& [path, digest] : files) {
        std::string now;
        try {
            now = sha256_file(path);
        } catch (const std::runtime_error& e) {
            throw UsageError(e.what());
        }
        if (now != digest) {
            std::cerr << "vkmech: error: '" << path << "' changed since registration (SHA-256 " << now.substr(0, 16)
                      << "..., registered " << digest.substr(0, 16) << "...); refusing to evaluate a record of another "
                      << (r.taxonomy && path == r.taxonomy->path ? "taxonomy" : "scene") << "\n";
            return 1;
        }
    }
    const fs::path rec_path(o.record);
    const std::string out =
        o.out.empty() ? (rec_path.parent_path() / (rec_path.stem().string() + "_evaluation")).string() : o.out;
    if (fs::exists(fs::path(out) / "evaluation.json") && !o.force)
        throw UsageError("'" + out + "' already holds an evaluation (remove it, or --force)");
    std::error_code ec;
    fs::create_directories(out, ec);
    require_writable_dir(out, "--out");
    const std::string cache_dir = o.cache.empty() ? (fs::path(out) / "cache").string() : o.cache;
    fs::create_directories(cache_dir, ec);
    require_writable_dir(cache_dir, "--cache");

    SignalGuard signals;
    vk::ContextOptions co;
    co.device_index = o.device;
    co.pipeline_cache_dir = o.pipeline_cache;
    co.kernel = vk::parse_kernel_class(o.kernel);
    vk::Context ctx(co);
    Traversal trav;
    try {
        trav = resolve_traversal(ctx, parse_traversal(r.traversal));
    } catch (const std::exception& e) {
        throw UsageError("the record's traversal '" + r.traversal + "' is not available here: " + e.what());
    }
    const std::string digest = render_code_digest(trav, ctx.kernel());
    std::vector<std::string> notes;
    if (digest != r.code_digest) {
        if (!o.allow_code_change)
            throw UsageError("the code differs from the registered code (digest " + digest.substr(0, 16) +
                             "..., registered " + r.code_digest.substr(0, 16) + "..., version " + r.version +
                             "); evaluate with the registered build and kernel (this run's: --kernel " +
                             std::string(vk::to_string(ctx.kernel())) +
                             "), or pass --allow-code-change (the report says so)");
        notes.push_back("evaluated with code other than the registered code (digest " + digest.substr(0, 16) +
                        "..., registered " + r.code_digest.substr(0, 16) + "...), --allow-code-change");
    }
    if (ctx.info().name != r.device)
        notes.push_back("evaluated on '" + ctx.info().name + "', registered on '" + r.device + "'");

    StudyConfig cfg = preset_config("quick");
    cfg.scenes = {SceneVariant{r.scene_name, r.scene_path, r.params}};
    cfg.alloc_res = r.width;
    cfg.alloc_draws = static_cast<int>(r.protocol.draws);
    cfg.alloc_ref_chunk_spp = r.protocol.reference_spp % 256 == 0 ? 256 : r.protocol.reference_spp;
    cfg.alloc_ref_chunks = r.protocol.reference_spp / cfg.alloc_ref_chunk_spp;
    if (r.taxonomy) {  // every render labelled by the registered taxonomy's classes
        try {
            cfg.taxonomy = lpe::read_taxonomy(r.taxonomy->path);
        } catch (const lpe::LpeError& e) {
            throw UsageError(std::string("the registered taxonomy: ") + e.what());
        }
    }
    const RenderCache cache(cache_dir);
    RenderedAllocationSource source(cfg, ctx, trav, cache, digest, [] { return pending_signal() != 0; });
    const SceneVariant& sv = cfg.scenes.front();
    std::fprintf(
        stderr,
        "vkmech: sentinel evaluate %s: reference %u spp, pool %u, %u pilot draws of %u spp on '%s' (cache %s)\n",
        r.scene_name.c_str(), r.protocol.reference_spp, downstream_seeds::kPoolSize, r.protocol.draws, r.pilot_spp,
        ctx.info().name.c_str(), cache_dir.c_str());
    sentinel::EvalInputs ein;
    std::vector<std::string> renders;
    // The pilots first (the registered draw first): nothing new is learned from them.
    for (uint32_t k = 0; k < r.protocol.draws; ++k) {
        const uint32_t draw = r.pilot_draw + k;
        ein.pilots.push_back(source.pilot(sv, r.pilot_spp, draw));
        renders.push_back("pilot draw " + std::to_string(draw) + ": " + std::to_string(r.pilot_spp) + " spp, seed " +
                          std::to_string(downstream_seeds::pilot(draw)) + (k == 0 ? " (the registered pilot)" : ""));
    }
    if (ein.pilots.front().frame.width != r.width || ein.pilots.front().frame.height != r.height)
        throw UsageError("the scene loads at " + std::to_string(ein.pilots.front().frame.width) + "x" +
                         std::to_string(ein.pilots.front().frame.height) + ", the record's film is " +
                         std::to_string(r.width) + "x" + std::to_string(r.height));
    const SamplePool pool = source.pool(sv, 0);
    renders.push_back("the shared pool: " + std::to_string(downstream_seeds::kPoolSize) + " spp of seed " +
                      std::to_string(downstream_seeds::kPool) + ", one frame per sample");
    const Frame ref = source.reference(sv);
    for (uint32_t c = 0; c < cfg.alloc_ref_chunks; ++c)
        renders.push_back("reference chunk " + std::to_string(c) + ": " + std::to_string(cfg.alloc_ref_chunk_spp) +
                          " spp, seed " + std::to_string(downstream_seeds::reference_chunk(c)));
    ein.reference = &ref;
    ein.pool = &pool;
    throw_if_interrupted();

    sentinel::Evaluation e = sentinel::evaluate(r, ein);
    for (const auto& n : notes) e.checks.push_back(n);
    write_file_atomic((fs::path(out) / "evaluation.json").string(), sentinel::evaluation_json(r, seal, e));
    write_file_atomic((fs::path(out) / "report.md").string(),
                      sentinel::evaluation_markdown(r, rec_path.filename().string(), seal, e, renders));
    std::printf("%s: %d PASS, %d FAIL, %d INDETERMINATE of %zu predictions%s\n", r.scene_name.c_str(), e.pass, e.fail,
                e.indeterminate, e.outcomes.size(),
                e.pilot_reproduced ? "" : " (the registered pilot was NOT reproduced)");
    for (const auto& x : e.outcomes)
        if (x.verdict != "PASS")
            std::printf("  %s %s: predicted %s, measured %s\n", x.verdict.c_str(), x.name.c_str(), x.predicted.c_str(),
                        x.measured.c_str());
    std::printf("wrote %s/evaluation.json and %s/report.md\n", out.c_str(), out.c_str());
    return 0;
}

// `vkmech sentinel register|evaluate|verify`.
void register_sentinel(CLI::App& app, CliCommands& commands) {
    auto o = std::make_shared<SentinelOptions>();
    auto file = std::make_shared<std::string>();
    auto* sentinel = app.add_subcommand(
        "sentinel",
        "Pre-registered predictions on a scene (docs/descriptor.md §9): register from a pilot alone, verify a record, "
        "evaluate it against a reference");
    sentinel->require_subcommand(1);
    auto* sentinel_register = sentinel->add_subcommand(
        "register", "Render only the pilot and write a SHA-256-sealed record of every prediction it supports");
    add_common_options(sentinel_register, o->common);
    sentinel_register->add_option("--pilot", o->pilot, "Pilot samples per pixel N0 (default 64, the curve's)")
        ->check(CLI::Range(2u, 4096u));
    sentinel_register->add_option("--pilot-draw", o->pilot_draw, "Pilot draw k (pilot seed 100000 + 1000k)")
        ->check(CLI::Range(0u, 899u));
    sentinel_register->add_option("--out", o->out, "The record (default sentinel_<scene>.json)");
    sentinel_register->add_option("--curve", o->curve,
                                  "Frozen label-reliability curve (default: predictor_curve.json, see `vkmech paths`; "
                                  "with --taxonomy, a curve fitted on that taxonomy, and none by default)");
    sentinel_register->add_flag("--force", o->force, "Overwrite an existing record");
    sentinel_register
        ->add_option("--taxonomy", o->taxonomy,
                     "Label the pilot by a user taxonomy's classes (docs/lpe.md): coverage is predicted per class and "
                     "the allocation rules read the classes its lines declare [heavy] and [constant]; label "
                     "reliability only with a --curve fitted on this taxonomy (`study predictor --taxonomy`), and no "
                     "Finding 1 prediction (defined on the buckets); the record (format version 2) names the file by "
                     "its SHA-256, and evaluate labels by it")
        ->check(CLI::ExistingFile);
    sentinel_register->add_option("--name", o->name,
                                  "The scene's name in the record and reports (default: the file stem)");
    sentinel_register
        ->add_option("--reference-spp", o->reference_spp,
                     "Protocol: the reference's samples per pixel (default 2048, the curve's; a multiple of 64)")
        ->check(CLI::Range(64u, 1u << 20));
    sentinel_register->add_option("--draws", o->draws, "Protocol: pilot draws compared (default 10)")
        ->check(CLI::Range(1u, 100u));
    sentinel_register
        ->add_option("--extra", o->extra,
                     "Protocol: extra samples per pixel of the allocation on top of 1 (default 32)")
        ->check(CLI::Range(1u, 254u));
    sentinel_register->add_option("--floor", o->floor, "Protocol: the allocation's per-pixel floor (default 1)")
        ->check(CLI::Range(1u, 32u));
    auto eval = std::make_shared<SentinelEvaluateOptions>();
    auto* sentinel_evaluate = sentinel->add_subcommand(
        "evaluate",
        "Refuse an edited record, render the reference and the allocation comparison, and write PASS/FAIL per "
        "prediction with the measured values (evaluation.json, report.md)");
    sentinel_evaluate->add_option("record", eval->record, "The record (JSON)")->required();
    sentinel_evaluate->add_option("--out", eval->out, "Output directory (default: <record>_evaluation)");
    sentinel_evaluate->add_option("--cache", eval->cache, "Render cache (default: <out>/cache)");
    sentinel_evaluate->add_option("--device", eval->device, "Vulkan device index (see `vkmech devices`)");
    add_pipeline_cache_option(sentinel_evaluate, eval->pipeline_cache);
    add_kernel_option(sentinel_evaluate, eval->kernel);
    sentinel_evaluate->add_flag("--allow-code-change", eval->allow_code_change,
                                "Evaluate with code other than the registered code (stated in the report)");
    sentinel_evaluate->add_flag("--force", eval->force, "Overwrite an existing evaluation");
    auto* sentinel_verify = sentinel->add_subcommand(
        "verify", "Check a record's seal: exit 0 when intact, 1 when edited after registration, 2 when malformed");
    sentinel_verify->add_option("record", *file, "The record (JSON)")->required();
    commands.push_back({sentinel_register, [o](const std::vector<std::string>&) { return cmd_sentinel_register(*o); }});
    commands.push_back(
        {sentinel_evaluate, [eval](const std::vector<std::string>&) { return cmd_sentinel_evaluate(*eval); }});
    commands.push_back(
        {sentinel_verify, [file](const std::vector<std::string>&) { return cmd_sentinel_verify(*file); }});
}

}  // namespace vkmech
