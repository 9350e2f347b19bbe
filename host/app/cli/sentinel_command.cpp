// `vkmech sentinel register` and `vkmech sentinel verify` (docs/descriptor.md §9).
#include "cli/commands.hpp"
#include "cli/resources.hpp"

#include "adaptive/adaptive.hpp"
#include "experiments/sentinel.hpp"
#include "io/atomic_file.hpp"
#include "io/digest.hpp"
#include "io/interrupt.hpp"
#include "io/sha256.hpp"
#include "render/features.hpp"
#include "render/session.hpp"
#include "render/shader_modules.hpp"
#include "study/sentinel_register.hpp"

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

std::string absolute(const std::string& p) {
    std::error_code ec;
    fs::path a = fs::weakly_canonical(fs::absolute(p), ec);
    return ec ? p : a.string();
}

}  // namespace

int cmd_sentinel_register(const SentinelOptions& o) {
    // Everything that can be refused is refused before the pilot renders (exit 2).
    const Resource found = o.curve.empty() ? find_predictor_curve() : Resource{};
    const std::string curve_path = o.curve.empty() ? found.path : o.curve;
    if (curve_path.empty())
        throw UsageError("sentinel register needs the frozen reliability curve: " + found.missing_message());
    if (!fs::exists(curve_path)) throw UsageError("predictor curve '" + curve_path + "' does not exist");
    ReliabilityCurve curve;
    try {
        curve = ReliabilityCurve::load(curve_path);
    } catch (const std::runtime_error& e) {
        throw UsageError(e.what());
    }
    const std::string scene_path = resolve_scene_path(o.common.scene);
    const std::string name = scene_stem(o.common.scene);
    const std::string out = o.out.empty() ? "sentinel_" + name + ".json" : o.out;
    if (fs::exists(out) && !o.force)
        throw UsageError("'" + out + "' exists: a registration is never overwritten (remove it, or --force)");
    require_writable_dir(fs::path(absolute(out)).parent_path().string(), "--out");
    Scene loaded = load_for_cli(o.common);

    sentinel::Record rec;
    rec.scene_name = name;
    rec.scene_path = absolute(scene_path);
    try {
        rec.scene_sha256 = sha256_file(scene_path);
        std::set<std::string> files;
        for (const Texture& t : loaded.textures)
            if (fs::is_regular_file(t.path)) files.insert(absolute(t.path));
        for (const auto& f : files) rec.scene_files.push_back({f, sha256_file(f)});
        rec.curve_sha256 = sha256_file(curve_path);
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
    Renderer renderer = session.renderer(features);
    std::fprintf(stderr, "vkmech: sentinel %s: %dx%d, pilot %u spp (seed %u) on '%s'; the reference is not rendered\n",
                 name.c_str(), session.scene().camera.width, session.scene().camera.height, o.pilot,
                 downstream_seeds::pilot(o.pilot_draw), ctx.info().name.c_str());
    const PilotRenderFn pilot_fn = [&](uint32_t n0, uint32_t seed, bool robust) {
        throw_if_interrupted();
        return render_pilot(renderer, n0, seed, robust);
    };
    sentinel::Record r = register_sentinel(session, pilot_fn, o.pilot, o.pilot_draw, &curve);
    throw_if_interrupted();

    r.scene_name = rec.scene_name;
    r.scene_path = rec.scene_path;
    r.scene_sha256 = rec.scene_sha256;
    r.scene_files = rec.scene_files;
    r.estimator = to_string(features.estimator);
    r.end_vertex = to_string(features.end_vertex);
    r.light_selection = to_string(lights);
    r.traversal = to_string(trav);
    const auto spirv = pathtrace_spirv(trav);
    r.version = VKMECH_VERSION;
    // The studies' code digest (study_runner.cpp StudyDevice) and a SHA-256 of the same SPIR-V.
    r.code_digest = Digest().str(VKMECH_VERSION).bytes(spirv.data(), spirv.size_bytes()).str("frame-merge-v1").hex();
    r.spirv_sha256 = Sha256().update(spirv.data(), spirv.size_bytes()).hex();
    r.registered_utc = utc_now();
    r.device = ctx.info().name;
    r.curve_path = absolute(curve_path);
    r.curve_sha256 = rec.curve_sha256;
    r.curve_pilot_spp = curve.pilot_spp;

    const std::string sealed = sentinel::seal(sentinel::record_json(r));
    write_file_atomic(out, sealed);
    std::printf("registered %zu predictions for %s from the pilot alone (%u spp, seed %u)%s\n", r.predictions.size(),
                name.c_str(), o.pilot, r.pilot_seed,
                curve.pilot_spp != 0 && curve.pilot_spp != o.pilot ? "; note: the curve was fitted on other pilots" : "");
    std::printf("wrote %s\n", out.c_str());
    return 0;
}

int cmd_sentinel_verify(const std::string& file) {
    std::ifstream in(file, std::ios::binary);
    if (!in) {
        std::cerr << "vkmech: error: cannot read sentinel record '" << file << "'\n";
        return 2;
    }
    std::stringstream ss;
    ss << in.rdbuf();
    const sentinel::Verification v = sentinel::verify_record(ss.str(), file);
    if (v.kind == sentinel::Verification::Intact) {
        std::printf("%s\n", v.message.c_str());
        return 0;
    }
    std::cerr << "vkmech: error: " << v.message << "\n";
    return v.kind == sentinel::Verification::Edited ? 1 : 2;
}

}  // namespace vkmech
