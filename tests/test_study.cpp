// `vkmech study`: the render cache (keys, round trip), the seed layouts, and
// end to end: the quick preset produces every table and picture, a rerun is
// served from the cache with identical tables, and a study interrupted by
// SIGINT resumes and gives the same tables as an uninterrupted one.
#include "experiments/study_config.hpp"
#include "gpu_fixture.hpp"
#include "study/render_cache.hpp"

#include <doctest/doctest.h>

#include <sys/wait.h>
#include <unistd.h>
#include <chrono>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <thread>

namespace fs = std::filesystem;
using namespace vkmech;

namespace {

std::string slurp(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

int run_shell(const std::string& cmd) {
    int status = std::system(cmd.c_str());
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// Every file under dir/tables with its content, except the wall-time measurements
// of the allocation study (alloc_time, equal_time), which are re-measured on every run.
std::map<std::string, std::string> tables_of(const fs::path& dir) {
    std::map<std::string, std::string> t;
    for (const auto& e : fs::directory_iterator(dir / "tables")) {
        std::string name = e.path().filename().string();
        if (name.rfind("alloc_time", 0) == 0 || name.rfind("equal_time", 0) == 0) continue;
        t[name] = slurp(e.path());
    }
    return t;
}

// A study log's timing lines ("study: analysed X in N s", the figures, the wall time), one line.
std::string phase_times(const std::string& log) {
    std::istringstream in(log);
    std::string line, out;
    while (std::getline(in, line))
        if (line.rfind("study: analysed ", 0) == 0 || line.rfind("study: figures drawn", 0) == 0 ||
            line.rfind("study: rendered ", 0) == 0 || line.find("wall time") != std::string::npos)
            out += (out.empty() ? "" : "; ") + line;
    return out;
}

size_t count_frames(const fs::path& cache) {
    size_t n = 0;
    if (!fs::exists(cache)) return 0;
    for (const auto& e : fs::directory_iterator(cache))
        if (e.path().extension() == ".frame") ++n;
    return n;
}

CacheKeyParts base_key() { return {"scene", 32, 32, 16, 100, 0, 16, "bvh", "llvmpipe", "code"}; }

}  // namespace

TEST_CASE("study: a cached frame round-trips bit for bit and a corrupt file is reported with its path") {
    Frame f;
    f.width = 3;
    f.height = 2;
    f.pixels.resize(6);
    for (size_t i = 0; i < 6; ++i) {
        f.pixels[i].count = 16;
        f.pixels[i].lum_mean = 0.1 * i + 1e-17;
        f.pixels[i].lum_m2 = 1.0 / (i + 3);
        f.pixels[i].bucket_sum[3] = 7.25 * i;
        f.pixels[i].depth_weight = i;
    }
    f.seconds = 0.125;
    f.samples = 96;
    Frame g = deserialize_frame(serialize_frame(f, "test"), "memory");
    CHECK(g.width == 3);
    CHECK(g.height == 2);
    CHECK(g.seconds == 0.125);
    CHECK(g.samples == 96);
    REQUIRE(g.pixels.size() == 6);
    CHECK(std::memcmp(g.pixels.data(), f.pixels.data(), 6 * sizeof(PixelStats)) == 0);

    std::string bytes = serialize_frame(f, "test");
    CHECK_THROWS_WITH_AS(deserialize_frame(bytes.substr(0, 40), "x.frame"), doctest::Contains("x.frame"),
                         std::runtime_error);
    bytes[0] = 'Z';
    CHECK_THROWS_WITH_AS(deserialize_frame(bytes, "y.frame"), doctest::Contains("bad magic"), std::runtime_error);
}

TEST_CASE("study: the cache key changes with every input that determines a render") {
    std::set<std::string> keys;
    keys.insert(cache_key(base_key()));
    auto vary = [&](auto mutate) {
        CacheKeyParts k = base_key();
        mutate(k);
        return keys.insert(cache_key(k)).second;
    };
    CHECK(vary([](CacheKeyParts& k) { k.scene_digest = "scene2"; }));
    CHECK(vary([](CacheKeyParts& k) { k.width = 33; }));
    CHECK(vary([](CacheKeyParts& k) { k.height = 31; }));
    CHECK(vary([](CacheKeyParts& k) { k.spp = 17; }));
    CHECK(vary([](CacheKeyParts& k) { k.seed = 101; }));
    CHECK(vary([](CacheKeyParts& k) { k.estimator = 1; }));
    CHECK(vary([](CacheKeyParts& k) { k.batch_spp = 8; }));
    CHECK(vary([](CacheKeyParts& k) { k.traversal = "rayquery"; }));
    CHECK(vary([](CacheKeyParts& k) { k.device = "other"; }));
    CHECK(vary([](CacheKeyParts& k) { k.code_digest = "code2"; }));
    CHECK(cache_key(base_key()) == cache_key(base_key()));  // deterministic
    // Strings are length-prefixed: moving a character between fields changes the key.
    CacheKeyParts a = base_key(), b = base_key();
    a.traversal = "bv";
    a.device = "hllvmpipe";
    CHECK(cache_key(a) != cache_key(b));
}

TEST_CASE("study: docs/descriptor.md §4 seed layouts are disjoint across families and levels") {
    StudyConfig cfg = preset_config("paper");
    cfg.scenes = {{"s", "s.xml", {}}};
    cfg.sweep_roughness_scene = "r.xml";
    cfg.sweep_lights_scene = "l.xml";
    std::map<std::string, std::set<uint32_t>> seeds_by_family;
    std::set<uint32_t> stability, variance, cost;
    for (size_t i = 0; i < cfg.stability_spp.size(); ++i) stability.insert(seeds::stability(i));
    for (size_t l = 0; l < cfg.variance_spp.size(); ++l)
        for (int s = 0; s < cfg.variance_seeds; ++s) variance.insert(seeds::variance(l, s));
    for (size_t l = 0; l < cfg.cost_spp.size(); ++l) cost.insert(seeds::cost(l));
    CHECK(stability.size() == cfg.stability_spp.size());
    CHECK(variance.size() == cfg.variance_spp.size() * cfg.variance_seeds);
    CHECK(cost.size() == cfg.cost_spp.size());
    std::set<uint32_t> all;
    for (const auto* s : {&stability, &variance, &cost}) all.insert(s->begin(), s->end());
    all.insert(seeds::sweep_reference());
    for (int s = 0; s < cfg.sweep_seeds; ++s) all.insert(seeds::sweep(s));
    all.insert(seeds::mis_disjoint_reference());
    all.insert(seeds::nee_disjoint_reference());
    for (int s = 0; s < cfg.variance_seeds; ++s) all.insert(seeds::sensitivity(s));
    CHECK(all.size() ==
          stability.size() + variance.size() + cost.size() + 1 + cfg.sweep_seeds + 2 + cfg.variance_seeds);
    // The reference is the top stability level and its seed is used by no lower level.
    auto plan = plan_renders(cfg, StudyKind::Stability);
    uint32_t ref_seed = seeds::stability(cfg.stability_spp.size() - 1);
    for (const auto& r : plan)
        if (r.spp != cfg.stability_reference_spp()) CHECK(r.seed != ref_seed);
    CHECK(plan_renders(cfg, StudyKind::Variance).size() == 1 + cfg.variance_spp.size() * cfg.variance_seeds);
    CHECK(plan_renders(cfg, StudyKind::SweepRoughness).size() == 8 * (1 + static_cast<size_t>(cfg.sweep_seeds)));
}

TEST_CASE("study: presets and budgets are validated with a reason") {
    CHECK_THROWS_WITH_AS(preset_config("huge"), doctest::Contains("unknown preset"), std::invalid_argument);
    CHECK_THROWS_WITH_AS(parse_study("stabilty"), doctest::Contains("valid: all"), std::invalid_argument);
    StudyConfig c = preset_config("quick");
    c.stability_spp = {64, 16};
    CHECK_THROWS_WITH_AS(c.validate(), doctest::Contains("ascending"), std::invalid_argument);
    c = preset_config("quick");
    c.variance_seeds = 5;
    CHECK_THROWS_WITH_AS(c.validate(), doctest::Contains("even"), std::invalid_argument);
    c = preset_config("quick");
    c.cost_spp = {4, 8, 128};
    CHECK_THROWS_WITH_AS(c.validate(), doctest::Contains("below the reference"), std::invalid_argument);
    CHECK_NOTHROW(preset_config("paper").validate());
    CHECK_NOTHROW(preset_config("reduced").validate());
}

TEST_CASE("study: bad study arguments exit 2 with the reason") {
    auto run = [](const std::string& args) {
        fs::path log = fs::temp_directory_path() / ("vkmech_study_args_" + std::to_string(::getpid()) + ".log");
        int rc = run_shell(std::string(VKMECH_CLI) + " " + args + " > " + log.string() + " 2>&1");
        std::string text = slurp(log);
        fs::remove(log);
        return std::make_pair(rc, text);
    };
    // A directory of this process's own: bad arguments must not create it.
    const fs::path never = fs::temp_directory_path() / ("vkmech_never_" + std::to_string(::getpid()));
    auto [rc, text] = run("study stabilty");
    CHECK(rc == 2);
    std::tie(rc, text) = run("study all --seeds 5 --out " + never.string());
    CHECK(rc == 2);
    CHECK(text.find("even") != std::string::npos);
    std::tie(rc, text) = run("study stability --scenes no_such_scene");
    CHECK(rc == 2);
    CHECK(text.find("no scene named 'no_such_scene'") != std::string::npos);
    std::tie(rc, text) = run("study all --spp-levels 64,16");
    CHECK(rc == 2);
    CHECK(text.find("ascending") != std::string::npos);
    std::tie(rc, text) = run("study stability --curve /nonexistent.json");
    CHECK(rc == 2);
    CHECK_FALSE(fs::exists(never));
}

TEST_SUITE("gpu") {
    TEST_CASE("study: vkmech study all --preset quick writes every table, figure and map - and a rerun is all cache") {
        VKMECH_REQUIRE_GPU(ctx);
        fs::path out = fs::temp_directory_path() / ("vkmech_study_all_" + std::to_string(::getpid()));
        fs::remove_all(out);
        std::string cmd = std::string(VKMECH_CLI) + " study all --preset quick --equal-time --out " + out.string();
        int rc = run_shell(cmd + " > " + (out.string() + ".log") + " 2>&1");
        const std::string first_log = slurp(out.string() + ".log");
        {
            INFO(first_log);
            REQUIRE(rc == 0);
        }
        // (Outside the INFO: a MESSAGE prints the INFO context with it.)
        MESSAGE("where the time went (the GPU suite's longest case): " << phase_times(first_log));
        for (const char* t : {"cross_spp",
                              "kappa",
                              "discretized_sigma",
                              "robust_mis",
                              "coverage",
                              "bucket_shares",
                              "sigma_splithalf",
                              "sigma_perbucket",
                              "alpha_reliability",
                              "cost_by_bucket",
                              "cost_by_bucket_ms",
                              "cost_by_bucket_detail",
                              "cost_perdim",
                              "correlation_matrix",
                              "sign_reversal",
                              "sweep_roughness",
                              "sweep_lights",
                              "predictor",
                              "transitions_glass_caustic",
                              "downstream",
                              "downstream_f4",
                              "robust_alloc",
                              "perbucket_mse",
                              "downstream_all",
                              "alloc_time",
                              "equal_time",
                              "alloc_pools",
                              "alloc_firefly",
                              "per_bucket_kept",
                              "mis_flips",
                              "sidefield_drift",
                              "has_glossy"}) {
            CAPTURE(t);
            CHECK(fs::file_size(out / "tables" / (std::string(t) + ".md")) > 0);
            CHECK(fs::file_size(out / "tables" / (std::string(t) + ".csv")) > 0);
        }
        for (const char* f :
             {"per_bucket_stability", "sigma_splithalf", "cost_by_bucket", "caustic_vs_glossy", "sweep_roughness",
              "sweep_lights", "predictor", "psnr_vs_pilot", "psnr_vs_budget", "error_vs_time"}) {
            CAPTURE(f);
            fs::path png = out / "figures" / (std::string(f) + ".png");
            REQUIRE(fs::exists(png));
            CHECK(slurp(png).substr(1, 3) == "PNG");
        }
        CHECK(fs::exists(out / "maps" / "snooker_agreement.png"));
        CHECK(fs::exists(out / "maps" / "snooker_dominant_4.png"));
        CHECK(fs::exists(out / "predictor_curve.json"));
        // Every picture and table report.md links exists.
        std::string report = slurp(out / "report.md");
        size_t links = 0;
        for (size_t pos = report.find("]("); pos != std::string::npos; pos = report.find("](", pos + 2)) {
            size_t end = report.find(')', pos);
            std::string target = report.substr(pos + 2, end - pos - 2);
            if (target.rfind("#", 0) == 0) continue;
            CAPTURE(target);
            CHECK(fs::exists(out / target));
            ++links;
        }
        CHECK(links > 40);
        // `other` is 0 in every quick render (coverage table, docs/descriptor.md §3).
        std::string coverage = slurp(out / "tables" / "coverage.csv");
        std::istringstream lines(coverage);
        std::string line;
        std::getline(lines, line);  // header
        int rows = 0;
        while (std::getline(lines, line)) {
            std::vector<std::string> f;
            std::stringstream ls(line);
            std::string x;
            while (std::getline(ls, x, ',')) f.push_back(x);
            REQUIRE(f.size() >= 3);
            CAPTURE(line);
            CHECK(std::stod(f[2]) == 0.0);
            ++rows;
        }
        CHECK(rows == 7 * 5);
        // cubes_dof has no glossy surface: no pixel has glossy energy, so has_glossy is 0 and its gamma columns are
        // empty; kitchen_counter's glossy counter has it on most pixels.
        const std::string hg = slurp(out / "tables" / "has_glossy.csv");
        CAPTURE(hg);
        auto has_glossy_of = [&](const std::string& scene) {
            const size_t at = hg.find("\n" + scene + ",");
            REQUIRE(at != std::string::npos);
            std::stringstream row(hg.substr(at + 1, hg.find('\n', at + 1) - at - 1));
            std::string field;
            for (int i = 0; i < 3; ++i) std::getline(row, field, ',');
            return std::stod(field);
        };
        CHECK(has_glossy_of("cubes_dof") == 0.0);
        CHECK(has_glossy_of("kitchen_counter") > 0.5);

        // A new scene predicted from its own pilot with the frozen curve (no reference render).
        fs::path pred = out.string() + "_pred";
        rc = run_shell(std::string(VKMECH_CLI) + " study predictor --preset quick --scenes sweep_lights --curve " +
                       (out / "predictor_curve.json").string() + " --out " + pred.string() + " > /dev/null 2>&1");
        CHECK(rc == 0);
        std::string predicted = slurp(pred / "tables" / "predictor_new.csv");
        CAPTURE(predicted);
        CHECK(predicted.find("sweep_lights,4,") != std::string::npos);
        fs::remove_all(pred);

        // The first run's own command again is all cache: its plan renders nothing (--plan stops there).
        {
            REQUIRE(run_shell(cmd + " --plan > " + (out.string() + ".log") + " 2>&1") == 0);
            const std::string plan_log = slurp(out.string() + ".log");
            INFO(plan_log);
            CHECK(plan_log.find(" cached, 0 to render)") != std::string::npos);
        }
        // A rerun is all cache and gives identical tables (the timing tables are measurements). It leaves out
        // what only costs time: the equal-time renders (measurements, never cached: the tables compared leave
        // them out) and the figures.
        auto before = tables_of(out);
        CHECK(before.size() > 20);
        const std::string rerun =
            std::string(VKMECH_CLI) + " study all --preset quick --no-plots --out " + out.string();
        REQUIRE(run_shell(rerun + " > " + (out.string() + ".log") + " 2>&1") == 0);
        const std::string rerun_log = slurp(out.string() + ".log");
        MESSAGE("the rerun: " << phase_times(rerun_log));
        {
            INFO(rerun_log);
            CHECK(rerun_log.find("0 to render") != std::string::npos);
            CHECK(tables_of(out) == before);
        }
        fs::remove_all(out);
        fs::remove(out.string() + ".log");
    }

    TEST_CASE("study: a study interrupted by SIGINT resumes from the cache and gives identical tables") {
        VKMECH_REQUIRE_GPU(ctx);
        fs::path base = fs::temp_directory_path() / ("vkmech_study_int_" + std::to_string(::getpid()));
        fs::remove_all(base);
        const std::string args =
            " study stability --preset quick --scenes cubes_dof,glass_caustic --spp-levels 4,16,256";
        // Uninterrupted run.
        REQUIRE(run_shell(std::string(VKMECH_CLI) + args + " --out " + (base / "a").string() + " > /dev/null 2>&1") ==
                0);
        // Interrupted run: SIGINT once the second render is in the cache, mid-way through the plan.
        fs::path b = base / "b";
        std::fflush(nullptr);  // the child must not inherit unflushed output
        pid_t pid = fork();
        REQUIRE(pid >= 0);
        if (pid == 0) {
            std::string out = "--out=" + b.string();
            std::freopen("/dev/null", "w", stderr);
            std::freopen("/dev/null", "w", stdout);
            execl(VKMECH_CLI, VKMECH_CLI, "study", "stability", "--preset", "quick", "--scenes",
                  "cubes_dof,glass_caustic", "--spp-levels", "4,16,256", out.c_str(), static_cast<char*>(nullptr));
            _exit(127);
        }
        auto t0 = std::chrono::steady_clock::now();
        while (count_frames(b / "cache") < 2 && std::chrono::steady_clock::now() - t0 < std::chrono::seconds(300))
            std::this_thread::sleep_for(std::chrono::milliseconds(20));
        kill(pid, SIGINT);
        int status = 0;
        waitpid(pid, &status, 0);
        REQUIRE(WIFEXITED(status));
        CHECK(WEXITSTATUS(status) == 130);
        size_t cached = count_frames(b / "cache");
        CHECK(cached >= 2);
        CHECK(cached < 10);  // 2 scenes x (3 NEE + 2 MIS) renders: it stopped part-way
        CHECK_FALSE(fs::exists(b / "tables"));
        for (const auto& e : fs::directory_iterator(b / "cache"))  // no partial files
            CHECK(e.path().filename().string().find(".tmp") == std::string::npos);
        // Resume: renders only what is missing, tables identical to the uninterrupted run.
        fs::path log = base / "resume.log";
        REQUIRE(run_shell(std::string(VKMECH_CLI) + args + " --out " + b.string() + " > " + log.string() + " 2>&1") ==
                0);
        std::string text = slurp(log);
        INFO(text);
        CHECK(text.find("(" + std::to_string(cached) + " cached") != std::string::npos);
        CHECK(tables_of(base / "a") == tables_of(b));
        fs::remove_all(base);
    }
}
