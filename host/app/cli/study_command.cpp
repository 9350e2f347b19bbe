// `vkmech study NAME` and `vkmech verify outputs|cache DIR`.
#include "cli/commands.hpp"
#include "cli/resources.hpp"

#include "io/exr.hpp"
#include "io/json_value.hpp"
#include "io/output_set.hpp"
#include "scene/file_read.hpp"
#include "study/render_cache.hpp"
#include "study/study_runner.hpp"

#include <cstdio>
#include <filesystem>
#include <map>
#include <string>

namespace fs = std::filesystem;

namespace vkmech {

namespace {

// A render set's provenance (render/render_outputs.hpp): the EXR header's
// attributes against the JSON's "provenance". Empty when they agree; appends
// a note to `detail` for a set written before provenance was recorded.
std::string check_provenance(const fs::path& dir, const std::string& name, std::string& detail) {
    const fs::path exr = dir / (name + ".exr"), json = dir / (name + ".json");
    if (!fs::is_regular_file(exr) || !fs::is_regular_file(json)) return "";
    std::map<std::string, std::vector<std::string>> a;
    try {
        a = read_exr_attributes(exr.string());
    } catch (const std::exception& e) {
        return e.what();
    }
    std::string text, why;
    try {
        text = read_regular_file(json.string(), "render summary", kMaxIncludedXmlBytes);
    } catch (const std::exception& e) {
        return e.what();
    }
    const auto j = parse_json(text, &why);
    if (!j) return json.string() + ": not JSON (" + why + ")";
    const JsonValue* p = j->find("provenance");
    if (a.count("vkmech.version") == 0 && !p) {
        detail += "; no provenance (written by a vkmech before 2026-11-26)";
        return "";
    }
    if (!p) return json.string() + " has no provenance but the EXR has";
    auto str = [&](const char* key) {
        const JsonValue* v = p->find(key);
        return v ? v->string : std::string("(missing)");
    };
    auto strs = [&](const char* key) {
        std::vector<std::string> out;
        if (const JsonValue* v = p->find(key))
            for (const JsonValue& e : v->array) out.push_back(e.string);
        return out;
    };
    auto one = [&](const char* attr) {
        auto it = a.find(attr);
        return it == a.end() || it->second.size() != 1 ? std::string("(missing)") : it->second[0];
    };
    const std::pair<const char*, std::pair<std::string, std::string>> pairs[] = {
        {"version", {one("vkmech.version"), str("version")}},
        {"code digest", {one("vkmech.codeDigest"), str("code_digest")}},
        {"scene SHA-256", {one("vkmech.sceneSha256"), str("scene_sha256")}},
        {"sample range", {one("vkmech.sampleRange"), str("sample_range")}},
        {"driver", {one("vkmech.driver"), str("driver")}},
        {"date", {one("capDate"), str("date_utc")}}};
    for (const auto& [what, v] : pairs)
        if (v.first != v.second || v.first == "(missing)")
            return "provenance: the EXR's " + std::string(what) + " '" + v.first + "' differs from the JSON's '" +
                   v.second + "'";
    if (a["vkmech.defines"] != strs("defines")) return "provenance: the EXR's -D values differ from the JSON's";
    if (a["vkmech.sceneFiles"] != strs("scene_files"))
        return "provenance: the EXR's scene files differ from the JSON's";
    detail += "; provenance: vkmech " + str("version") + ", code " + str("code_digest").substr(0, 12) + ", scene " +
              str("scene_sha256").substr(0, 12) + ", samples " + str("sample_range");
    return "";
}

}  // namespace

// `vkmech verify outputs DIR`: every output set in DIR checked against its
// manifest, and a render set's provenance in its EXR against its JSON. Exit 0 when
// everything checked is sound, 1 when a bad set or file exists.
int cmd_verify_outputs(const std::string& dir) {
    if (!fs::is_directory(dir)) throw UsageError("'" + dir + "' is not a directory");
    std::vector<std::string> stale;
    auto sets = verify_output_dir(dir, &stale);
    for (auto& s : sets) {
        if (s.kind != SetStatus::Complete) continue;
        if (std::string bad = check_provenance(dir, s.name, s.detail); !bad.empty()) {
            s.kind = SetStatus::Bad;
            s.detail = bad;
        }
    }
    int bad = 0;
    for (const auto& s : sets) {
        const char* kind = s.kind == SetStatus::Complete  ? "complete"
                           : s.kind == SetStatus::Pending ? "pending"
                                                          : "BAD";
        std::printf("%-8s %s%s%s: %s\n", kind, s.name.c_str(), s.run_id.empty() ? "" : " (run ",
                    s.run_id.empty() ? "" : (s.run_id + ")").c_str(), s.detail.c_str());
        bad += s.kind == SetStatus::Bad;
    }
    for (const auto& f : stale)
        std::printf("stale    %s: a temporary of an interrupted run (the next run here removes it)\n", f.c_str());
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

void add_study_options(CLI::App* app, StudyOptions& o) {
    app->add_option(
           "name", o.study,
           "stability, variance, cost, structure, sweep-roughness, sweep-lights, predictor, allocation, all (the "
           "paper's analyses), or sensitivity (beyond the paper: where its premise holds, by controlled variation "
           "of glass_caustic and cubes_dof; not part of all)")
        ->required()
        ->check(CLI::IsMember({"stability", "variance", "cost", "structure", "sweep-roughness", "sweep-lights",
                               "predictor", "allocation", "all", "sensitivity"}));
    app->add_option("--preset", o.preset,
                    "quick (tiny images, low SPP: minutes, for CI), reduced (96 px, SPP 64/512/2048: what a CPU device "
                    "affords), paper (256², SPP 64/512/4096, 10 seeds per level: the paper's protocol)")
        ->check(CLI::IsMember({"quick", "reduced", "paper"}));
    app->add_option("--scenes", o.scenes,
                    "Comma-separated scene names or paths (default: the seven first-party scenes)")
        ->delimiter(',');
    app->add_option("--res", o.res, "Film width in pixels (overrides the preset)")->check(CLI::Range(4, 4096));
    app->add_option("--spp-levels", o.spp_levels, "Stability SPP levels, ascending; the last is the reference")
        ->delimiter(',')
        ->check(CLI::Range(1u, 1u << 20));
    app->add_option("--pools", o.pools,
                    "allocation: pools of 256 frames the final images are drawn from (pool j: seed 1000 + j); pool 0 "
                    "serves every table at equal samples, the others resample it for the spread over pools "
                    "(default: 2 quick, 5 reduced and paper)")
        ->check(CLI::Range(1, 100));
    app->add_option("--seeds", o.seeds, "Seeds per variance level and per sweep level (even, >= 4)")
        ->check(CLI::Range(4, 1000));
    app->add_option("--out", o.out_dir, "Output directory (default: out/study-<name>)");
    app->add_option("--cache", o.cache_dir, "Render cache directory (default: <out>/cache); share it between studies");
    app->add_option(
        "--curve", o.curve,
        "predictor: a frozen predictor_curve.json; predicts each scene's label reliability from its pilot only");
    app->add_option("--device", o.device, "Vulkan device index (see `vkmech devices`)");
    add_pipeline_cache_option(app, o.pipeline_cache);
    add_kernel_option(app, o.kernel);
    app->add_option("--traversal", o.traversal, "Ray traversal: auto, rayquery or bvh")
        ->check(CLI::IsMember({"auto", "rayquery", "bvh"}));
    app->add_flag("--no-plots", o.no_plots, "Write the figure specs (JSON) but do not run matplotlib");
    app->add_flag("--plan", o.plan_only, "Print the plan and its expected cost, render nothing");
    app->add_flag("--equal-time", o.equal_time,
                  "allocation: also compare strategies at equal wall-clock time (error versus measured seconds)");
    app->add_option("--shard", o.shard_text,
                    "i/N: render only work units i, i + N, ... into the cache and write no table (many machines or "
                    "processes sharing one cache; then --analyse-only)");
    app->add_option("--jobs", o.jobs_file,
                    "Write one self-contained command per work unit missing from the cache to this file (for Slurm "
                    "job arrays, GNU parallel or xargs) and render nothing");
    app->add_option(
           "--taxonomy", o.taxonomy,
           "Every study (and so `study all`) by "
           "a user taxonomy's classes (a file of `name = light path expression` lines, docs/lpe.md): every render "
           "classifies "
           "by it; stability's tables are the classes' shares, their cross-SPP agreement and the "
           "binned-variance baseline; variance's and cost's per-bucket tables are per class; predictor's "
           "curve is fitted on the classes and records the taxonomy (a --curve must have been fitted on "
           "the same one); allocation's strategies read the classes and the properties their lines declare "
           "([heavy], [constant], [rare]); structure correlates every pair of the classes' shares, glossy_frac, "
           "depth and inv_purity, and its caustic side is the [rare] classes' share; sensitivity's heavy share "
           "and pixels, and the sweeps' population and firefly ratio, are the [heavy] classes'")
        ->check(CLI::ExistingFile);
    app->add_option("-D,--define", o.defines,
                    "Set a parameter of every --scenes scene: -D name=value (as Mitsuba's -D; e.g. -D lights=4 for "
                    "sweep_lights)");
    app->add_option("--display-server", o.display_server,
                    "Show the renders in progress in tev (or HDRView) listening at HOST:PORT: one image per scene "
                    "variant, each render streamed as it goes; a viewer that is absent or goes away is a warning");
    app->add_flag("--analyse-only", o.analyse_only,
                  "Build the tables from the cache alone; exit 1 listing what is missing instead of rendering it (the "
                  "allocation study's timing renders still run: they are measurements)");
}

// `vkmech study`: the options are the study runner's own (study/study_runner.hpp); the
// CLI resolves scene names to files and the default --out.
int cmd_study(StudyOptions o) {
    // The CLI's scene names become files; the study runner sees paths only.
    if (!o.defines.empty() && o.scenes.empty())
        throw UsageError("-D sets parameters of the --scenes scenes: name the scenes it is for");
    std::vector<std::string> names = o.scenes.empty() ? first_party_scenes() : o.scenes;
    o.scenes.clear();
    for (const auto& s : names) o.scenes.push_back(resolve_scene_path(s));
    o.sweep_roughness_scene = resolve_scene_path("sweep_roughness");
    o.sweep_lights_scene = resolve_scene_path("sweep_lights");
    if (o.out_dir.empty()) o.out_dir = "out/study-" + o.study;
    const Resource script = find_plot_script();
    o.plot_script = script.path;
    if (!script.found()) o.plot_script_missing = script.missing_message() + ", or pass --no-plots";
    if (!o.curve.empty() && !fs::exists(o.curve)) throw UsageError("predictor curve '" + o.curve + "' does not exist");
    if (!o.curve.empty() && o.study != "predictor")
        throw UsageError("--curve applies to `vkmech study predictor` only");
    if (!o.curve.empty()) check_curve_for_cli(o.curve);
    if (!o.shard_text.empty()) {
        unsigned i = 0, n = 0;
        char tail = 0;
        if (std::sscanf(o.shard_text.c_str(), "%u/%u%c", &i, &n, &tail) != 2 || n == 0 || i >= n)
            throw UsageError("--shard expects i/N with 0 <= i < N (e.g. 0/4), got '" + o.shard_text + "'");
        o.shard = std::make_pair(static_cast<uint32_t>(i), static_cast<uint32_t>(n));
    }
    if ((o.shard ? 1 : 0) + (o.jobs_file.empty() ? 0 : 1) + (o.analyse_only ? 1 : 0) + (o.plan_only ? 1 : 0) > 1)
        throw UsageError("--shard, --jobs, --analyse-only and --plan exclude each other");
    try {
        return run_study(o);
    } catch (const std::invalid_argument& e) {
        throw UsageError(e.what());
    }
}

// `vkmech study NAME`: the study records its command line (args) in its report.
void register_study(CLI::App& app, CliCommands& commands) {
    auto o = std::make_shared<StudyOptions>();
    auto* study = app.add_subcommand(
        "study",
        "Regenerate the paper's analyses (docs/descriptor.md §5) on a scene set: tables, figures, maps and report.md");
    add_study_options(study, *o);
    commands.push_back({study, [o](const std::vector<std::string>& args) {
                            StudyOptions run = *o;
                            run.command_line = "vkmech";
                            for (const auto& a : args) run.command_line += " " + a;
                            return cmd_study(std::move(run));
                        }});
}

// `vkmech verify outputs|cache DIR`.
void register_verify(CLI::App& app, CliCommands& commands) {
    auto dir = std::make_shared<std::string>();
    auto* verify =
        app.add_subcommand("verify", "Check written results: output sets against their manifests, or a render cache");
    verify->require_subcommand(1);
    auto* verify_outputs = verify->add_subcommand(
        "outputs",
        "Check every output set in DIR against its manifest (complete, pending or bad); exit 1 when one is bad");
    verify_outputs->add_option("dir", *dir, "Output directory (a render's --out)")->required();
    auto* verify_cache = verify->add_subcommand(
        "cache",
        "Check every file of a render cache (key, size, checksum, finite data): good, bad or stale; exit 1 when "
        "one is bad");
    verify_cache->add_option("dir", *dir, "Cache directory (a study's --cache, default <out>/cache)")->required();
    commands.push_back({verify_outputs, [dir](const std::vector<std::string>&) { return cmd_verify_outputs(*dir); }});
    commands.push_back({verify_cache, [dir](const std::vector<std::string>&) { return cmd_verify_cache(*dir); }});
}

}  // namespace vkmech
