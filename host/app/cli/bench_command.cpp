// `vkmech devices`, `vkmech bench traversal` and `vkmech bench render`.
#include "cli/commands.hpp"

#include "render/features.hpp"
#include "render/gpu_scene.hpp"
#include "render/ray_caster.hpp"
#include "render/renderer.hpp"
#include "render/session.hpp"
#include "render/traversal_dump.hpp"
#include "scene/scene.hpp"
#include "vk/context.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <optional>
#include <string>
#include <vector>

namespace vkmech {

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
                    VK_API_VERSION_MINOR(d.api_version), VK_API_VERSION_PATCH(d.api_version),
                    d.ray_query ? "yes" : "no");
        std::printf(
            "    max compute workgroup invocations: %u, max storage buffer range: %llu MiB, device-local heap: %llu "
            "MiB\n",
            d.max_workgroup_invocations, static_cast<unsigned long long>(d.max_storage_buffer_range >> 20),
            static_cast<unsigned long long>(d.device_local_bytes >> 20));
    }
    return 0;
}

namespace {

std::vector<std::string> bench_scenes(const BenchOptions& o) {
    std::vector<std::string> names = o.scenes.empty() ? project_scene_names() : o.scenes;
    if (names.empty()) throw UsageError("no scenes to benchmark");
    return names;
}

vk::ContextOptions bench_context_options(const BenchOptions& o) {
    vk::ContextOptions co;
    co.device_index = o.device;
    co.pipeline_cache_dir = o.pipeline_cache;
    co.kernel = vk::parse_kernel_class(o.kernel);
    return co;
}

}  // namespace

namespace {

// `bench traversal --counters`: the software BVH's work per ray, and per group of consecutive rays
// (the invocations that run in lockstep: 8 per SIMD vector on lavapipe at 256 bits, 32 per warp on NVIDIA).
void print_traversal_work(const vk::Context& ctx, const SceneArrays& arrays, const std::vector<gpu::GpuRay>& rays) {
    GpuScene g(ctx, arrays, Traversal::Bvh);
    RayCaster caster(ctx, g);
    const std::vector<RayCaster::Work> work = caster.trace_work(rays);
    auto stat = [&](auto field) {
        double sum = 0.0, g8 = 0.0, g32 = 0.0;
        uint32_t m8 = 0, m32 = 0;
        for (size_t i = 0; i < work.size(); ++i) {
            const uint32_t v = field(work[i]);
            sum += v;
            m8 = std::max(m8, v);
            m32 = std::max(m32, v);
            if (i % 8 == 7 || i + 1 == work.size()) {
                g8 += m8;
                m8 = 0;
            }
            if (i % 32 == 31 || i + 1 == work.size()) {
                g32 += m32;
                m32 = 0;
            }
        }
        const double n = static_cast<double>(work.size());
        char buf[96];
        std::snprintf(buf, sizeof buf, "%.2f (x8 %.2f, x32 %.2f)", sum / n, g8 / std::ceil(n / 8),
                      g32 / std::ceil(n / 32));
        return std::string(buf);
    };
    uint32_t stack = 0;
    for (const auto& w : work) stack = std::max(stack, w.stack);
    std::printf("  per ray: interior nodes %s, leaves %s, triangles %s, deepest stack %u\n",
                stat([](const RayCaster::Work& w) { return w.nodes; }).c_str(),
                stat([](const RayCaster::Work& w) { return w.leaves; }).c_str(),
                stat([](const RayCaster::Work& w) { return w.triangles; }).c_str(), stack);
}

}  // namespace

int cmd_bench_traversal(const BenchOptions& o) {
    const std::vector<std::string> names = bench_scenes(o);
    vk::Context ctx(bench_context_options(o));
    if (o.slices && ctx.kernel() != vk::KernelClass::Cpu)
        throw UsageError("--slices: the ray kernel's slices are the CPU kernel's; add --kernel cpu");
    if (o.slices && !ctx.info().compute_subgroup_ballot)
        throw UsageError("--slices: " + ctx.info().name +
                         " does not report subgroup ballot in compute shaders, which the slices kernel needs");
    const RaySchedule bvh_schedule = o.slices ? RaySchedule::Slices : RaySchedule::Auto;
    std::printf("device: %s (%s), %s kernel, %u random rays per measurement (closest hit; median of 3; seed %u)%s\n",
                ctx.info().name.c_str(), ctx.info().type.c_str(), vk::to_string(ctx.kernel()), o.rays,
                kBenchTraversalSeed, o.slices ? "; bvh column: slices (--slices)" : "");
    std::printf("%-22s %10s %16s %16s %20s\n", "scene", "triangles", "rayquery Mray/s", "bvh Mray/s",
                "bvh 1 ray/inv Mray/s");
    for (const auto& n : names) {
        Scene scene = load_scene(resolve_scene_path(n));
        SceneArrays arrays = flatten_scene(scene, Traversal::Bvh);  // both traversals trace the BVH's order
        auto rays = random_rays(arrays, o.rays, kBenchTraversalSeed);
        std::vector<gpu::GpuHit> bvh_hits;
        auto measure = [&](Traversal t, RaySchedule schedule) -> double {
            GpuScene g(ctx, arrays, t);
            RayCaster caster(ctx, g);
            auto hits = caster.trace(rays, false, nullptr, schedule);  // warm-up
            if (t == Traversal::Bvh && schedule == bvh_schedule) bvh_hits = std::move(hits);
            std::vector<double> s(3);
            for (auto& x : s) caster.trace(rays, false, &x, schedule);
            std::sort(s.begin(), s.end());
            return rays.size() / s[1];
        };
        std::optional<double> rq;
        if (ctx.ray_query_enabled() && !o.bvh_only) rq = measure(Traversal::RayQuery, RaySchedule::Auto);
        const double bvh = measure(Traversal::Bvh, bvh_schedule);
        const double bvh_per_invocation = measure(Traversal::Bvh, RaySchedule::PerInvocation);
        auto mray = [](double r) { return std::to_string(r / 1e6).substr(0, 6); };
        std::string rq_text = rq ? mray(*rq) : o.bvh_only ? "skipped" : "n/a";
        std::printf("%-22s %10zu %16s %16s %20s\n", scene_stem(n).c_str(), arrays.triangles.size(), rq_text.c_str(),
                    mray(bvh).c_str(), mray(bvh_per_invocation).c_str());
        if (o.counters) print_traversal_work(ctx, arrays, rays);
        if (o.dump_dir) {
            TraversalDumpInfo info;
            info.device = ctx.info().name;
            info.seed = kBenchTraversalSeed;
            info.bvh_rays_per_second = bvh;
            info.bvh_per_invocation_rays_per_second = bvh_per_invocation;
            info.rayquery_rays_per_second = rq;
            write_traversal_dump(*o.dump_dir, scene_stem(n), make_traversal_dump(arrays, rays, bvh_hits), info);
        }
        std::fflush(stdout);
    }
    if (o.dump_dir) std::printf("dumped triangles, rays, hits and rays/s to %s\n", o.dump_dir->c_str());
    return 0;
}

namespace {

// `bench render --profile`: per scene and batch size, the render's wall time split into the batch loop's steps.
int bench_render_profile(const BenchOptions& o, const std::vector<std::string>& names, const vk::Context& ctx) {
    std::printf(
        "device: %s (%s), %s kernel; %ux%u film, %u spp per render (the median of 3 renders by wall time); "
        "seconds per render; dispatch = record + submit + wait (the device's work)\n",
        ctx.info().name.c_str(), ctx.info().type.c_str(), vk::to_string(ctx.kernel()), o.res, o.res, o.spp);
    std::printf("%-20s %-9s %6s %8s %9s %9s %9s %9s %9s %7s %9s\n", "scene", "traversal", "batch", "batches", "total",
                "upload", "dispatch", "readback", "accum.", "other", "Mpaths/s");
    for (const auto& n : names) {
        Scene scene = load_scene(resolve_scene_path(n));
        scene.camera.set_film_width(static_cast<int>(o.res));
        const Traversal t = resolve_traversal(ctx, Traversal::Auto);
        RenderSession session(ctx, scene, t);
        Renderer r = session.renderer(session.features());
        for (uint32_t b : o.batches) {
            RenderSpec spec;
            spec.spp = o.spp;
            spec.batch_spp = b;
            r.render(spec);  // warm-up
            std::vector<std::pair<double, RenderProfile>> runs;
            for (int i = 0; i < 3; ++i) {
                RenderProfile prof;
                spec.profile = &prof;
                const Frame f = r.render(spec);
                runs.emplace_back(f.seconds, prof);
            }
            std::sort(runs.begin(), runs.end(), [](const auto& x, const auto& y) { return x.first < y.first; });
            const auto& [total, p] = runs[1];
            const double other = total - p.upload - p.dispatch - p.readback - p.accumulate;
            const double paths = static_cast<double>(o.spp) * scene.camera.width * scene.camera.height;
            std::printf("%-20s %-9s %6u %8u %9.4f %9.4f %9.4f %9.4f %9.4f %7.4f %9.3f\n", scene_stem(n).c_str(),
                        to_string(t), b, p.batches, total, p.upload, p.dispatch, p.readback, p.accumulate, other,
                        paths / total / 1e6);
            std::fflush(stdout);
        }
        if (o.counters) {
            // The instrumented module on the software BVH (whatever `auto` picked for the timing).
            RenderSession bvh_session(ctx, scene, Traversal::Bvh);
            Features f = bvh_session.features();
            f.counters = true;
            Renderer rc = bvh_session.renderer(f);
            RenderSpec spec;
            spec.spp = o.spp;
            spec.batch_spp = 1;  // the counters are 32-bit totals per batch
            rc.render(spec);
            const TraversalCounters& c = rc.counters();
            const double paths = static_cast<double>(o.spp) * scene.camera.width * scene.camera.height;
            const double rays = std::max(c.rays, 1.0);
            std::printf(
                "  %s, software BVH, %u spp: %.3g traces (%.2f per path); per trace: interior nodes %.2f, "
                "leaves %.2f, triangles %.2f; deepest stack %u\n",
                scene_stem(n).c_str(), o.spp, c.rays, c.rays / paths, c.nodes / rays, c.leaves / rays,
                c.triangles / rays, c.deepest_stack);
            // The phases nest (shared/types.h): the exclusive shares of the whole.
            using namespace gpu;
            const auto& k = c.clock;
            const double whole = std::max(k[PHASE_SLOT], 1.0);
            auto pct = [&](double ticks) { return 100.0 * ticks / whole; };
            std::printf(
                "  phases, %% of the invocations' clock ticks: setup %.1f, camera-ray trace %.1f, later "
                "traces %.1f, shadow traces %.1f, NEE without its trace %.1f, other shading %.1f, "
                "path ended, waiting for the vector's longer paths %.1f, accumulation and write %.1f; all "
                "traces %.1f (%.0f intervals left out: the clock went backwards)\n",
                pct(k[PHASE_CAMERA]), pct(k[PHASE_PRIMARY]), pct(k[PHASE_BOUNCE]), pct(k[PHASE_SHADOW]),
                pct(k[PHASE_NEE] - k[PHASE_SHADOW]),
                pct(k[PHASE_BUSY] - k[PHASE_PRIMARY] - k[PHASE_BOUNCE] - k[PHASE_NEE]),
                pct(k[PHASE_PATH] - k[PHASE_BUSY]), pct(k[PHASE_SLOT] - k[PHASE_CAMERA] - k[PHASE_PATH]),
                pct(k[PHASE_PRIMARY] + k[PHASE_BOUNCE] + k[PHASE_SHADOW]), c.clock_backwards);
            if (c.clock_backwards > 0.01 * rays)
                std::printf(
                    "  warning: the shader clock went backwards in %.0f intervals (over 1%% of the traces): "
                    "it wraps or is not steady on this device, and the phases' shares are not reliable\n",
                    c.clock_backwards);
            std::fflush(stdout);
        }
    }
    return 0;
}

// Paths/s in millions of one pipeline: the median of 3 renders after a warm-up.
double measure_paths_per_second(const RenderSession& session, const Features& f, const BenchOptions& o) {
    Renderer r = session.renderer(f);
    RenderSpec spec;
    spec.spp = o.spp;
    spec.batch_spp = o.spp;
    r.render(spec);  // warm-up (pipeline caches, page faults)
    std::vector<double> mps;
    for (int i = 0; i < 3; ++i) {
        Frame fr = r.render(spec);
        mps.push_back(static_cast<double>(fr.samples) / fr.seconds / 1e6);
    }
    std::sort(mps.begin(), mps.end());
    return mps[1];
}

// `bench render --ablation`: what each effect's specialization constant is
// worth on this device. The specialized pipeline compiles out every effect the
// scene does not call for; each row compiles one of them back in.
int bench_render_ablation(const BenchOptions& o, const std::vector<std::string>& names, const vk::Context& ctx) {
    std::printf(
        "device: %s (%s), %s kernel; %ux%u film, %u spp per measurement, median of 3; paths/s in millions; "
        "each effect row: the specialized pipeline with that effect compiled in\n",
        ctx.info().name.c_str(), ctx.info().type.c_str(), vk::to_string(ctx.kernel()), o.res, o.res, o.spp);
    std::printf("%-20s %-22s %12s %9s\n", "scene", "pipeline", "Mpaths/s", "vs spec.");
    for (const auto& n : names) {
        Scene scene = load_scene(resolve_scene_path(n));
        scene.camera.set_film_width(static_cast<int>(o.res));
        RenderSession session(ctx, scene, resolve_traversal(ctx, Traversal::Auto));
        const Features spec = Features::from_scene(scene);
        const double base = measure_paths_per_second(session, spec, o);
        auto row = [&](const char* what, double mps) {
            std::printf("%-20s %-22s %12.2f %8.1f%%\n", scene_stem(n).c_str(), what, mps, 100.0 * (mps / base - 1.0));
            std::fflush(stdout);
        };
        row("specialized", base);
        auto ablate = [&](const char* what, bool on, auto&& compile_in) {
            if (on) return;
            Features f = spec;
            compile_in(f);
            row(what, measure_paths_per_second(session, f, o));
        };
        ablate("+thin-lens", spec.thin_lens, [](Features& f) { f.thin_lens = true; });
#define VKM_X(NAME, name, bit, spec_id)                                 \
    ablate("+" #name, (spec.materials & gpu::FEATURE_BIT_##NAME) != 0u, \
           [](Features& f) { f.materials |= gpu::FEATURE_BIT_##NAME; });
        VKM_MATERIAL_FEATURES(VKM_X)
#undef VKM_X
        ablate("+textures", spec.textures, [](Features& f) { f.textures = true; });
        ablate("+tangents", spec.tangents, [](Features& f) { f.tangents = true; });
        Features generic = Features::generic();
        generic.orthographic = spec.orthographic;
        row("generic", measure_paths_per_second(session, generic, o));
    }
    return 0;
}

}  // namespace

int cmd_bench_render(const BenchOptions& o) {
    const std::vector<std::string> names = bench_scenes(o);
    vk::Context ctx(bench_context_options(o));
    if (o.profile) return bench_render_profile(o, names, ctx);
    if (o.ablation) return bench_render_ablation(o, names, ctx);
    std::printf("device: %s (%s), %s kernel; %ux%u film, %u spp per measurement, median of 3; paths/s in millions\n",
                ctx.info().name.c_str(), ctx.info().type.c_str(), vk::to_string(ctx.kernel()), o.res, o.res, o.spp);
    std::printf("%-20s %-9s %12s %12s %12s %12s\n", "scene", "traversal", "specialized", "generic", "capture off",
                "spec. gain");
    for (const auto& n : names) {
        Scene scene = load_scene(resolve_scene_path(n));
        scene.camera.set_film_width(static_cast<int>(o.res));
        std::vector<Traversal> travs = {Traversal::Bvh};
        if (ctx.ray_query_enabled()) travs.insert(travs.begin(), Traversal::RayQuery);
        for (Traversal t : travs) {
            RenderSession session(ctx, scene, t);
            auto measure = [&](const Features& f) { return measure_paths_per_second(session, f, o); };
            double spec_on = measure(Features::from_scene(scene));
            double generic = measure(Features::generic());
            double cap_off = measure(Features::from_scene(scene, Estimator::Nee, false));
            std::printf("%-20s %-9s %12.4f %12.4f %12.4f %11.1f%%\n", scene_stem(n).c_str(), to_string(t), spec_on,
                        generic, cap_off, 100.0 * (spec_on / generic - 1.0));
            std::fflush(stdout);
        }
    }
    return 0;
}

// `vkmech devices`.
void register_devices(CLI::App& app, CliCommands& commands) {
    auto* devices = app.add_subcommand("devices", "List Vulkan devices with their ray-query support and limits");
    commands.push_back({devices, [](const std::vector<std::string>&) { return cmd_devices(); }});
}

// `vkmech bench traversal|render`.
void register_bench(CLI::App& app, CliCommands& commands) {
    auto o = std::make_shared<BenchOptions>();
    auto* bench = app.add_subcommand("bench", "Benchmarks (not tests)");
    auto* bench_trav =
        bench->add_subcommand("traversal",
                              "Rays/s of ray query and of the software BVH on each scene (the BVH twice: "
                              "its ray kernel's default, which on CPU devices hands each invocation "
                              "the next ray of its workgroup's slice when its own is done, and one "
                              "ray per invocation, as the path tracer traces)");
    bench->require_subcommand(1);
    bench_trav->add_option("--scenes", o->scenes, "Comma-separated scene names or paths (default: all in scenes/)")
        ->delimiter(',');
    bench_trav->add_option("--rays", o->rays, "Rays per measurement")->check(CLI::Range(1000u, 1u << 26));
    bench_trav->add_option("--device", o->device, "Vulkan device index (see `vkmech devices`)");
    bench_trav
        ->add_option("--dump", o->dump_dir,
                     "Write each scene's triangles, rays, software-BVH closest hits and rays/s to DIR "
                     "(<scene>.tris.bin, .rays.bin, .hits.bin, .json; layout in docs/performance.md) for "
                     "ci/bench-embree.sh")
        ->type_name("DIR");
    bench_trav->add_flag("--counters", o->counters,
                         "Also trace the rays once with the instrumented software-BVH shader and print its work per "
                         "ray: interior nodes, leaves, triangles tested (mean, and mean of the maximum over groups of "
                         "8 and 32 consecutive rays: one SIMD vector on lavapipe, one warp on NVIDIA), deepest stack");
    bench_trav->add_flag("--bvh-only", o->bvh_only,
                         "Measure the software BVH alone, not ray query (shorter; a profiler attached to the process "
                         "then samples only the software BVH)");
    bench_trav->add_flag("--slices", o->slices,
                         "Measure the `bvh` column with slices on any device that has subgroup ballot, GPUs included "
                         "(by default only CPU devices use them: they have not been measured on a GPU)");
    add_pipeline_cache_option(bench_trav, o->pipeline_cache);
    add_kernel_option(bench_trav, o->kernel);

    auto* bench_render = bench->add_subcommand(
        "render", "Paths/s per scene: specialized vs generic pipeline, capture on vs off, ray query vs BVH");
    bench_render->add_option("--scenes", o->scenes, "Comma-separated scene names or paths (default: all)")
        ->delimiter(',');
    bench_render->add_option("--res", o->res, "Film width")->check(CLI::Range(8u, 4096u));
    bench_render->add_option("--spp", o->spp, "Samples per pixel per measurement")->check(CLI::Range(1u, 4096u));
    bench_render->add_option("--device", o->device, "Vulkan device index");
    bench_render->add_flag("--profile", o->profile,
                           "Where the render's time goes (parameter upload, dispatch = submit + wait, readback, host "
                           "accumulation) for each --batches size, instead of the specialization table");
    bench_render->add_option("--batches", o->batches, "--profile: samples per dispatch to try (default 1,8,64)")
        ->delimiter(',')
        ->check(CLI::Range(1u, 4096u));
    bench_render->add_flag("--counters", o->counters,
                           "--profile: also render each scene once with the instrumented software-BVH shader and "
                           "print the traversal's work (traces per path, interior nodes, leaves and triangles per "
                           "trace, deepest stack) and where the invocations' time goes, by the shader's own clock "
                           "(VK_KHR_shader_clock): camera-ray, later and shadow traces, NEE, other shading, waiting "
                           "for the longer paths of the SIMD vector or warp, accumulation");
    bench_render->add_flag("--ablation", o->ablation,
                           "What each specialization is worth: per scene, the specialized pipeline, then the same with "
                           "one effect the scene does not call for compiled in (as the generic pipeline has it), one "
                           "effect at a time, then the generic pipeline; instead of the specialization table");
    add_pipeline_cache_option(bench_render, o->pipeline_cache);
    add_kernel_option(bench_render, o->kernel);

    commands.push_back({bench_trav, [o](const std::vector<std::string>&) { return cmd_bench_traversal(*o); }});
    commands.push_back({bench_render, [o](const std::vector<std::string>&) {
                            if (o->counters && !o->profile) throw UsageError("bench render --counters needs --profile");
                            return cmd_bench_render(*o);
                        }});
}

}  // namespace vkmech
