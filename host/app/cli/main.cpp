// vkmech: the command-line entry. Exit codes (DESIGN): 0 ok, 1 runtime
// failure, 2 bad usage or bad input.
#include "cli/commands.hpp"
#include "cli/resources.hpp"

#include "scene/scene.hpp"
#include "study/study_runner.hpp"
#include "vk/buffer.hpp"
#include "vk/context.hpp"

#include <CLI/CLI.hpp>

#include <cstring>
#include <iostream>

int main(int argc, char** argv) {
    using namespace vkmech;
    // `vkmech --scene X ...` is shorthand for `vkmech render --scene X ...`.
    std::vector<std::string> args(argv + 1, argv + argc);
    if (!args.empty() && args[0].rfind("-", 0) == 0 && args[0] != "-h" && args[0] != "--help" && args[0] != "--version")
        args.insert(args.begin(), "render");

    CLI::App app{"vkmech: a Vulkan path tracer that labels every pixel with how its light arrived\n"
                 "(the seven-bucket transport-mechanism descriptor).",
                 "vkmech"};
    app.set_version_flag("--version", std::string("vkmech ") + VKMECH_VERSION);
    app.require_subcommand(1);
    app.footer("Examples:\n  vkmech --scene ring_caustic --spp 64\n  vkmech check --scene my_scene.xml\n  vkmech devices\n"
               "  vkmech paths\n"
               "  vkmech bench traversal\n"
               "  vkmech study all --preset quick --out out/study\n"
               "  vkmech verify outputs out/ring_caustic\n"
               "  vkmech sentinel register --scene cubes_dof --out cubes_dof.sentinel.json\n"
               "  vkmech sentinel evaluate cubes_dof.sentinel.json\n"
               "Exit codes: 0 ok, 1 runtime failure, 2 bad usage or bad input.");

    RenderOptions render_opts;
    auto* render = app.add_subcommand("render", "Render a scene to a multi-layer EXR and PNG previews");
    add_common_options(render, render_opts.common);
    render->add_option("--spp", render_opts.spp, "Samples per pixel")->check(CLI::Range(1u, 1u << 20));
    render->add_option("--seed", render_opts.seed, "Random seed (docs/descriptor.md §4)");
    render->add_option("--batch", render_opts.batch_spp, "Samples per GPU dispatch")->check(CLI::Range(1u, 4096u));
    render->add_option("--out", render_opts.out_dir, "Output directory (default: out/<scene>)");
    render->add_option("--estimator", render_opts.estimator,
                       "Estimator: mis (default), nee (the paper's; the default with --adaptive) or mis-restricted")
        ->check(CLI::IsMember({"nee", "mis-restricted", "mis"}));
    render->add_option("--light-selection", render_opts.light_selection,
                       "How NEE picks an emitter: uniform (default, as Mitsuba) or power")
        ->check(CLI::IsMember({"uniform", "power"}));
    render->add_option("--end-vertex", render_opts.end_vertex,
                       "Label's end vertex: last-nondelta (default) or literal (the last surface vertex)")
        ->check(CLI::IsMember({"last-nondelta", "literal"}));
    render->add_option("--exposure", render_opts.exposure,
                       "Exposure of the PNG preview in stops (EV; the EXR is never scaled)")
        ->check(CLI::Range(-30.0f, 30.0f));
    render->add_option("--capture", render_opts.capture, "Mechanism descriptor capture: on (default) or off")
        ->check(CLI::IsMember({"on", "off"}));
    render->add_option("--extra-output", render_opts.extra_outputs,
                       "Optional extra outputs (comma-separated): direct_glossy = the direct bucket's energy whose end "
                       "vertex is glossy, as EXR channel lum.direct_glossy and a JSON share (docs/descriptor.md "
                       "§3.4; a second shader variant, needs --capture on)")
        ->delimiter(',')
        ->check(CLI::IsMember({"direct_glossy"}));
    render->add_flag("--generic", render_opts.generic, "Use the unspecialized pipeline (every effect compiled in)");
    render->add_flag("--preview", render_opts.preview, "Fast direct-light preview instead of the full estimator");
    render->add_option("--adaptive", render_opts.adaptive,
                       "Two-stage adaptive rendering (docs/descriptor.md §6) with this allocation strategy: uniform, observed-var, "
                       "bucket-floor, robust-var, robust-floor, placebo, robust-placebo, guarded (bucket-floor with at least "
                       "the uniform share where the pilot cannot be trusted), shrink (the pilot variance shrunk towards its label's "
                       "empirical-Bayes prior), robust-adaptive (median-of-means with the block count chosen per pixel from its pilot "
                       "label: the plain variance on delta_mediated and specular_direct pixels, ceil(sqrt(N0)) blocks elsewhere)");
    render->add_option("--pilot", render_opts.pilot, "Adaptive: pilot samples per pixel N0 (default 16)")
        ->check(CLI::Range(2u, 4096u));
    render->add_option("--budget", render_opts.budget,
                       "Adaptive: extra samples per pixel on average, on top of the baseline of 1 (default 32)")
        ->check(CLI::Range(0u, 255u));
    render->add_option("--floor", render_opts.floor, "Adaptive: minimum samples per pixel (default 1)")
        ->check(CLI::Range(1u, 256u));
    render->add_option("--pilot-draw", render_opts.pilot_draw, "Adaptive: pilot draw k (pilot seed 100000 + 1000k)")
        ->check(CLI::Range(0u, 899u));
    render->add_option("--curve", render_opts.curve,
                       "Adaptive: frozen label-reliability curve (default: predictor_curve.json, see `vkmech paths`)");

    auto* devices = app.add_subcommand("devices", "List Vulkan devices with their ray-query support and limits");
    auto* paths = app.add_subcommand(
        "paths", "Where the scenes, the figure script and the predictor curve are found: $VKMECH_SCENE_DIR, "
                 "$VKMECH_PLOT_SCRIPT, $VKMECH_DATA_DIR (a data root), ./scenes, <prefix>/share/vkmech next to "
                 "<prefix>/bin/vkmech, then the source tree; exit 1 when one is missing");

    CommonOptions check_opts;
    auto* check = app.add_subcommand(
        "check", "Load a scene without rendering: shapes, materials and their lobes, emitters, camera, the features the "
                 "renderer specializes on, and every warning and substitution");
    add_common_options(check, check_opts);

    BenchOptions bench_opts;
    auto* bench = app.add_subcommand("bench", "Benchmarks (not tests)");
    auto* bench_trav = bench->add_subcommand("traversal", "Rays/s of ray query and of the software BVH on each scene (the BVH twice: "
                                             "its ray kernel's default, which on CPU devices hands each invocation "
                                             "the next ray of its workgroup's slice when its own is done, and one "
                                             "ray per invocation, as the path tracer traces)");
    bench->require_subcommand(1);
    bench_trav->add_option("--scenes", bench_opts.scenes, "Comma-separated scene names or paths (default: all in scenes/)")
        ->delimiter(',');
    bench_trav->add_option("--rays", bench_opts.rays, "Rays per measurement")->check(CLI::Range(1000u, 1u << 26));
    bench_trav->add_option("--device", bench_opts.device, "Vulkan device index (see `vkmech devices`)");
    bench_trav->add_option("--dump", bench_opts.dump_dir,
                           "Write each scene's triangles, rays, software-BVH closest hits and rays/s to DIR "
                           "(<scene>.tris.bin, .rays.bin, .hits.bin, .json; layout in docs/performance.md) for "
                           "ci/bench-embree.sh")
        ->type_name("DIR");
    bench_trav->add_flag("--counters", bench_opts.counters,
                         "Also trace the rays once with the instrumented software-BVH shader and print its work per "
                         "ray: interior nodes, leaves, triangles tested (mean, and mean of the maximum over groups of "
                         "8 and 32 consecutive rays: one SIMD vector on lavapipe, one warp on NVIDIA), deepest stack");
    bench_trav->add_flag("--bvh-only", bench_opts.bvh_only,
                         "Measure the software BVH alone, not ray query (shorter; a profiler attached to the process "
                         "then samples only the software BVH)");
    bench_trav->add_flag("--slices", bench_opts.slices,
                         "Measure the `bvh` column with slices on any device that has subgroup ballot, GPUs included "
                         "(by default only CPU devices use them: they have not been measured on a GPU)");
    add_pipeline_cache_option(bench_trav, bench_opts.pipeline_cache);
    add_kernel_option(bench_trav, bench_opts.kernel);

    auto* bench_render = bench->add_subcommand(
        "render", "Paths/s per scene: specialized vs generic pipeline, capture on vs off, ray query vs BVH");
    bench_render->add_option("--scenes", bench_opts.scenes, "Comma-separated scene names or paths (default: all)")
        ->delimiter(',');
    bench_render->add_option("--res", bench_opts.res, "Film width")->check(CLI::Range(8u, 4096u));
    bench_render->add_option("--spp", bench_opts.spp, "Samples per pixel per measurement")->check(CLI::Range(1u, 4096u));
    bench_render->add_option("--device", bench_opts.device, "Vulkan device index");
    bench_render->add_flag("--profile", bench_opts.profile,
                           "Where the render's time goes (parameter upload, dispatch = submit + wait, readback, host "
                           "accumulation) for each --batches size, instead of the specialization table");
    bench_render->add_option("--batches", bench_opts.batches, "--profile: samples per dispatch to try (default 1,8,64)")
        ->delimiter(',')
        ->check(CLI::Range(1u, 4096u));
    bench_render->add_flag("--counters", bench_opts.counters,
                           "--profile: also render each scene once with the instrumented software-BVH shader and "
                           "print the traversal's work (traces per path, interior nodes, leaves and triangles per "
                           "trace, deepest stack) and where the invocations' time goes, by the shader's own clock "
                           "(VK_KHR_shader_clock): camera-ray, later and shadow traces, NEE, other shading, waiting "
                           "for the longer paths of the SIMD vector or warp, accumulation");
    bench_render->add_flag("--ablation", bench_opts.ablation,
                           "What each specialization is worth: per scene, the specialized pipeline, then the same with "
                           "one effect the scene does not call for compiled in (as the generic pipeline has it), one "
                           "effect at a time, then the generic pipeline; instead of the specialization table");
    add_pipeline_cache_option(bench_render, bench_opts.pipeline_cache);
    add_kernel_option(bench_render, bench_opts.kernel);

    StudyOptions study_opts;
    auto* study = app.add_subcommand(
        "study", "Regenerate the paper's analyses (docs/descriptor.md §5) on a scene set: tables, figures, maps and report.md");
    add_study_options(study, study_opts);

    // A delimited list of nothing (`--scenes ,,,`): CLI11 drops the empty items and would take the next
    // argument (`--out`) as the list; say what is wrong instead.
    for (size_t i = 0; i < args.size(); ++i)
        for (const std::string opt : {"--scenes", "--spp-levels"}) {
            std::string value;
            if (args[i] == opt && i + 1 < args.size()) value = args[i + 1];
            else if (args[i].rfind(opt + "=", 0) == 0) value = args[i].substr(opt.size() + 1);
            else continue;
            if (value.find_first_not_of(", \t") == std::string::npos) {
                std::cerr << "vkmech: error: " << opt << ": empty " << (opt == "--scenes" ? "scene list" : "list") << "\n";
                return 2;
            }
        }

    std::string verify_dir;
    auto* verify = app.add_subcommand("verify", "Check written results: output sets against their manifests, or a render cache");
    verify->require_subcommand(1);
    auto* verify_outputs = verify->add_subcommand(
        "outputs", "Check every output set in DIR against its manifest (complete, pending or bad); exit 1 when one is bad");
    verify_outputs->add_option("dir", verify_dir, "Output directory (a render's --out)")->required();
    auto* verify_cache = verify->add_subcommand(
        "cache", "Check every file of a render cache (key, size, checksum, finite data): good, bad or stale; exit 1 when "
                 "one is bad");
    verify_cache->add_option("dir", verify_dir, "Cache directory (a study's --cache, default <out>/cache)")->required();

    SentinelOptions sentinel_opts;
    std::string sentinel_file;
    auto* sentinel = app.add_subcommand(
        "sentinel", "Pre-registered predictions on a scene (docs/descriptor.md §9): register from a pilot alone, verify a record, "
        "evaluate it against a reference");
    sentinel->require_subcommand(1);
    auto* sentinel_register = sentinel->add_subcommand(
        "register", "Render only the pilot and write a SHA-256-sealed record of every prediction it supports");
    add_common_options(sentinel_register, sentinel_opts.common);
    sentinel_register->add_option("--pilot", sentinel_opts.pilot, "Pilot samples per pixel N0 (default 64, the curve's)")
        ->check(CLI::Range(2u, 4096u));
    sentinel_register->add_option("--pilot-draw", sentinel_opts.pilot_draw, "Pilot draw k (pilot seed 100000 + 1000k)")
        ->check(CLI::Range(0u, 899u));
    sentinel_register->add_option("--out", sentinel_opts.out, "The record (default sentinel_<scene>.json)");
    sentinel_register->add_option("--curve", sentinel_opts.curve,
                                  "Frozen label-reliability curve (default: predictor_curve.json, see `vkmech paths`)");
    sentinel_register->add_flag("--force", sentinel_opts.force, "Overwrite an existing record");
    sentinel_register->add_option("--name", sentinel_opts.name,
                                  "The scene's name in the record and reports (default: the file stem)");
    sentinel_register->add_option("--reference-spp", sentinel_opts.reference_spp,
                                  "Protocol: the reference's samples per pixel (default 2048, the curve's; a multiple of 64)")
        ->check(CLI::Range(64u, 1u << 20));
    sentinel_register->add_option("--draws", sentinel_opts.draws, "Protocol: pilot draws compared (default 10)")
        ->check(CLI::Range(1u, 100u));
    sentinel_register->add_option("--extra", sentinel_opts.extra,
                                  "Protocol: extra samples per pixel of the allocation on top of 1 (default 32)")
        ->check(CLI::Range(1u, 254u));
    sentinel_register->add_option("--floor", sentinel_opts.floor, "Protocol: the allocation's per-pixel floor (default 1)")
        ->check(CLI::Range(1u, 32u));
    SentinelEvaluateOptions evaluate_opts;
    auto* sentinel_evaluate = sentinel->add_subcommand(
        "evaluate", "Refuse an edited record, render the reference and the allocation comparison, and write PASS/FAIL per "
                    "prediction with the measured values (evaluation.json, report.md)");
    sentinel_evaluate->add_option("record", evaluate_opts.record, "The record (JSON)")->required();
    sentinel_evaluate->add_option("--out", evaluate_opts.out, "Output directory (default: <record>_evaluation)");
    sentinel_evaluate->add_option("--cache", evaluate_opts.cache, "Render cache (default: <out>/cache)");
    sentinel_evaluate->add_option("--device", evaluate_opts.device, "Vulkan device index (see `vkmech devices`)");
    add_pipeline_cache_option(sentinel_evaluate, evaluate_opts.pipeline_cache);
    add_kernel_option(sentinel_evaluate, evaluate_opts.kernel);
    sentinel_evaluate->add_flag("--allow-code-change", evaluate_opts.allow_code_change,
                                "Evaluate with code other than the registered code (stated in the report)");
    sentinel_evaluate->add_flag("--force", evaluate_opts.force, "Overwrite an existing evaluation");
    auto* sentinel_verify = sentinel->add_subcommand(
        "verify", "Check a record's seal: exit 0 when intact, 1 when edited after registration, 2 when malformed");
    sentinel_verify->add_option("record", sentinel_file, "The record (JSON)")->required();

    try {
        std::vector<std::string> rev(args.rbegin(), args.rend());
        app.parse(rev);
    } catch (const CLI::ParseError& e) {
        return app.exit(e) == 0 ? 0 : 2;
    }

    try {
        if (*render) return cmd_render(render_opts);
        if (*devices) return cmd_devices();
        if (*paths) return cmd_paths();
        if (*verify_outputs) return cmd_verify_outputs(verify_dir);
        if (*verify_cache) return cmd_verify_cache(verify_dir);
        if (*sentinel_register) return cmd_sentinel_register(sentinel_opts);
        if (*sentinel_verify) return cmd_sentinel_verify(sentinel_file);
        if (*sentinel_evaluate) return cmd_sentinel_evaluate(evaluate_opts);
        if (*check) return cmd_check(check_opts);
        if (*bench_trav) return cmd_bench_traversal(bench_opts);
        if (*bench_render) {
            if (bench_opts.counters && !bench_opts.profile) throw UsageError("bench render --counters needs --profile");
            return cmd_bench_render(bench_opts);
        }
        if (*study) {
            study_opts.command_line = "vkmech";
            for (const auto& a : args) study_opts.command_line += " " + a;
            return cmd_study(study_opts);
        }
    } catch (const StudyInterrupted& e) {
        std::cerr << "\nvkmech study: " << e.what() << "; every finished render is in the cache, run the same command "
                     "again to resume\n";
        return e.exit_code();
    } catch (const Interrupted& e) {
        std::cerr << "\nvkmech: " << e.what() << "; nothing new was committed: the output directory holds the previous "
                     "complete set, if any (its temporaries are removed)\n";
        return e.exit_code();
    } catch (const vkmech::vk::OutOfMemoryError& e) {
        std::cerr << "vkmech: out of memory: " << e.what() << "\n";
        return 1;
    } catch (const SceneError& e) {
        std::cerr << "vkmech: error: " << e.what() << "\n";
        return 2;
    } catch (const UsageError& e) {
        std::cerr << "vkmech: error: " << e.what() << "\n";
        return 2;
    } catch (const vkmech::vk::VulkanError& e) {
        std::cerr << "vkmech: Vulkan error: " << e.what() << "\n";
        return 1;
    } catch (const ::vk::SystemError& e) {
        std::cerr << "vkmech: Vulkan error: " << e.what() << "\n";
        return 1;
    } catch (const std::exception& e) {
        std::cerr << "vkmech: error: " << e.what() << "\n";
        return 1;
    }
    return 0;
}
