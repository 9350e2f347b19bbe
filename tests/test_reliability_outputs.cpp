// docs/reliability.md: interrupted runs and damaged caches never crash,
// hang or give silent garbage. Output sets (manifest written last, recovery
// of a commit cut short, stale temporaries), SIGINT/SIGTERM/SIGKILL at exact
// steps (fault injection through $VKMECH_FAULT, no timing), --out/--cache
// checked before rendering, the render cache's integrity checks, and the CLI's
// messages for a bad --curve and an empty --scenes.
// $VKMECH_TEST_CLI runs the CLI cases against another build (cli_run.hpp).
#include "cli_run.hpp"
#include "io/digest.hpp"
#include "io/interrupt.hpp"
#include "io/output_set.hpp"
#include "study/render_cache.hpp"
#include "temp_dir.hpp"

#include "io/atomic_file.hpp"

#include <doctest/doctest.h>

#include <sys/wait.h>
#include <unistd.h>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

namespace fs = std::filesystem;
using namespace vkmech;
using vkmech::testing::TempDir;

namespace {

using vkmech::testing::run_cli;

std::string slurp(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

void put(const fs::path& p, const std::string& bytes) {
    std::ofstream out(p, std::ios::binary | std::ios::trunc);
    out << bytes;
}

Frame synthetic_frame(int w, int h, double scale) {
    Frame f;
    f.width = w;
    f.height = h;
    f.pixels.resize(static_cast<size_t>(w) * h);
    for (size_t i = 0; i < f.pixels.size(); ++i) {
        PixelStats& p = f.pixels[i];
        p.count = 16;
        for (int c = 0; c < 3; ++c) p.rgb_sum[c] = scale * (1 + (i + c) % 5);
        p.lum_mean = scale * 0.1 * (1 + i % 7);
        p.lum_m2 = 0.01 * (1 + i % 3);
        p.bucket_sum[i % 7] = scale * 2.0;
        p.glossy_sum = 0.5;
        p.depth_weighted_sum = 1.5;
        p.depth_weight = 1.0;
    }
    f.seconds = 0.25;
    f.samples = 16 * f.pixels.size();
    return f;
}

// Writes a whole set named "scene" (files a.txt/b.txt and, when `extra`, c.txt) and commits it.
std::string write_set(const fs::path& dir, const std::string& tag, bool extra) {
    OutputSet set(dir.string(), "scene");
    put(set.staged("scene.a"), "a " + tag);
    put(set.staged("scene.b"), "b " + tag + std::string(1000, 'x'));
    if (extra) put(set.staged("scene.c"), "c " + tag);
    set.commit();
    return set.run_id();
}

// A new set of three files, staged one by one as write_render_outputs does
// (a signal check and a fault point after each), then committed. Plain files:
// a forked child must not touch OpenEXR, whose thread pool a fork leaves locked.
void write_new_set(const fs::path& dir) {
    OutputSet set(dir.string(), "scene");
    for (const char* ext : {".exr", ".png", ".json"}) {
        throw_if_interrupted();
        put(set.staged(std::string("scene") + ext), std::string("new ") + ext + std::string(500, 'n'));
        fault_point((std::string("staged-") + ext).c_str());
    }
    set.commit();
}

std::vector<std::string> temporaries(const fs::path& dir) {
    std::vector<std::string> t;
    for (const auto& e : fs::directory_iterator(dir)) {
        std::string n = e.path().filename().string();
        if (n.find(".vkmech-") == 0 || n.find(".tmp-") != std::string::npos) t.push_back(n);
    }
    return t;
}

// Runs `body` in a child process with $VKMECH_FAULT set; returns the raw wait status.
template <class F>
int in_child(const std::string& fault, F&& body) {
    std::fflush(nullptr);
    pid_t pid = fork();
    REQUIRE(pid >= 0);
    if (pid == 0) {
        ::setenv("VKMECH_FAULT", fault.c_str(), 1);
        int code = 0;
        try {
            body();
        } catch (const Interrupted& e) {
            code = e.exit_code();
        } catch (...) {
            code = 99;
        }
        _exit(code);
    }
    int status = 0;
    waitpid(pid, &status, 0);
    return status;
}

}  // namespace

TEST_CASE("outputs: a committed set has a manifest that verifies - and replaces the old set as a whole") {
    TempDir tmp("rel_commit");
    const std::string old_id = write_set(tmp.path, "old", true);
    auto sets = verify_output_dir(tmp.path.string());
    REQUIRE(sets.size() == 1);
    CHECK(sets[0].kind == SetStatus::Complete);
    CHECK(sets[0].run_id == old_id);
    const std::string new_id = write_set(tmp.path, "new", false);
    sets = verify_output_dir(tmp.path.string());
    REQUIRE(sets.size() == 1);
    CHECK(sets[0].kind == SetStatus::Complete);
    CHECK(sets[0].run_id == new_id);
    CHECK(slurp(tmp.path / "scene.a") == "a new");
    CHECK_FALSE(fs::exists(tmp.path / "scene.c"));  // the old set's file the new one lacks
    CHECK(temporaries(tmp.path).empty());
    // A file changed behind the manifest's back makes the set bad.
    put(tmp.path / "scene.a", "a NEW");
    sets = verify_output_dir(tmp.path.string());
    CHECK(sets[0].kind == SetStatus::Bad);
    CHECK(sets[0].detail.find("scene.a") != std::string::npos);
    CHECK(parse_manifest("{\"vkmech_manifest\": 1, \"set\": \"x\"") == std::nullopt);
}

TEST_CASE("outputs: SIGKILL at every step of writing and committing leaves the old set or the new one - never a mix") {
    // Every fault point of write + commit, each a SIGKILL at that exact step.
    for (const char* point :
         {"staged-.exr", "staged-.png", "staged-.json", "commit-staged", "commit-moving", "commit-moved-one"}) {
        CAPTURE(point);
        TempDir tmp("rel_kill");
        const std::string old_id = write_set(tmp.path, "old", true);
        int status = in_child(std::string(point) + ":KILL", [&] { write_new_set(tmp.path); });
        REQUIRE(WIFSIGNALED(status));
        CHECK(WTERMSIG(status) == SIGKILL);
        // Right after the kill: the old set still verifies, or a pending commit holds the complete new one.
        auto sets = verify_output_dir(tmp.path.string());
        bool old_complete = false, pending = false;
        for (const auto& s : sets) {
            CHECK(s.kind != SetStatus::Bad);
            old_complete |= s.kind == SetStatus::Complete && s.run_id == old_id;
            pending |= s.kind == SetStatus::Pending;
        }
        CHECK((old_complete || pending));
        // The next run in the directory cleans up and finishes what was committed.
        { OutputSet next(tmp.path.string(), "scene"); }
        CHECK(temporaries(tmp.path).empty());
        sets = verify_output_dir(tmp.path.string());
        REQUIRE(sets.size() == 1);
        CHECK(sets[0].kind == SetStatus::Complete);
        if (sets[0].run_id == old_id) {
            CHECK(slurp(tmp.path / "scene.a") == "a old");
            CHECK_FALSE(pending);
        } else {
            CHECK(pending);  // only a committed set may replace the old one
            CHECK(fs::exists(tmp.path / "scene.exr"));
            CHECK_FALSE(fs::exists(tmp.path / "scene.a"));  // no file of the old set survives beside the new one
        }
    }
}

TEST_CASE(
    "outputs: SIGINT and SIGTERM while writing remove the temporaries - exit 130 and 143 - and keep the old set") {
    for (const char* sig : {"INT", "TERM"}) {
        CAPTURE(sig);
        TempDir tmp("rel_term");
        const std::string old_id = write_set(tmp.path, "old", true);
        int status = in_child(std::string("staged-.exr:") + sig, [&] {
            SignalGuard guard;
            write_new_set(tmp.path);
        });
        REQUIRE(WIFEXITED(status));
        CHECK(WEXITSTATUS(status) == (std::string(sig) == "INT" ? 130 : 143));
        CHECK(temporaries(tmp.path).empty());
        auto sets = verify_output_dir(tmp.path.string());
        REQUIRE(sets.size() == 1);
        CHECK(sets[0].kind == SetStatus::Complete);
        CHECK(sets[0].run_id == old_id);
        CHECK_FALSE(fs::exists(tmp.path / "scene.exr"));
    }
}

TEST_CASE("outputs: stale temporaries of dead processes are removed when a run starts - a live process's are kept") {
    TempDir tmp("rel_stale");
    std::fflush(nullptr);
    pid_t dead = fork();
    REQUIRE(dead >= 0);
    if (dead == 0) _exit(0);
    waitpid(dead, nullptr, 0);
    const std::string d = std::to_string(dead), live = std::to_string(::getpid());
    fs::create_directories(tmp.path / (".vkmech-tmp-" + d));
    put(tmp.path / (".vkmech-tmp-" + d) / "x.exr", "partial");
    put(tmp.path / ("scene.exr.tmp-" + d), "partial");
    put(tmp.path / ("scene.json.tmp-" + live), "being written");
    { OutputSet set(tmp.path.string(), "scene"); }
    CHECK_FALSE(fs::exists(tmp.path / (".vkmech-tmp-" + d)));
    CHECK_FALSE(fs::exists(tmp.path / ("scene.exr.tmp-" + d)));
    CHECK(fs::exists(tmp.path / ("scene.json.tmp-" + live)));
}

TEST_CASE("outputs: an unwritable directory is refused with its path and the reason") {
    TempDir tmp("rel_unwritable");
    put(tmp.path / "file", "x");
    const std::string bad = (tmp.path / "file" / "sub").string();
    CHECK_THROWS_WITH_AS(check_writable_dir(bad, "--out"), doctest::Contains(bad.c_str()), std::runtime_error);
    CHECK_THROWS_WITH_AS(OutputSet(bad, "scene"), doctest::Contains("not writable"), std::runtime_error);
    CHECK_NOTHROW(check_writable_dir((tmp.path / "new" / "dir").string(), "--out"));
    CHECK(temporaries(tmp.path / "new" / "dir").empty());
}

TEST_CASE("cli: --out and --cache that cannot be written are refused before rendering - exit 2") {
    TempDir tmp("rel_cli_out");
    put(tmp.path / "file", "x");
    const std::string bad = (tmp.path / "file" / "out").string();
    auto r = run_cli("render --scene cubes_dof --spp 1 --res 16 --out " + bad);
    INFO(r.output);
    CHECK(r.code == 2);
    CHECK(r.output.find(bad) != std::string::npos);
    CHECK(r.output.find("not writable") != std::string::npos);
    CHECK(r.output.find("spp") == std::string::npos);  // nothing rendered first
    r = run_cli("render --scene cubes_dof --adaptive bucket-floor --pilot 4 --budget 1 --res 16 --out " + bad);
    CHECK(r.code == 2);
    CHECK(r.output.find(bad) != std::string::npos);
    r = run_cli("study stability --preset quick --scenes cubes_dof --out " + (tmp.path / "s").string() + " --cache " +
                bad);
    INFO(r.output);
    CHECK(r.code == 2);
    CHECK(r.output.find("--cache '" + bad + "' is not writable") != std::string::npos);
    CHECK(r.output.find("renders done") == std::string::npos);
}

TEST_CASE("cli: a garbage --curve file and an empty --scenes list are reported as such - exit 2") {
    TempDir tmp("rel_cli_msg");
    put(tmp.path / "curve.json", "\x01\x02garbage{{ \"margin\": [nan, 7]");
    auto r = run_cli("study predictor --preset quick --scenes cubes_dof --curve " + (tmp.path / "curve.json").string() +
                     " --out " + (tmp.path / "p").string());
    INFO(r.output);
    CHECK(r.code == 2);
    CHECK(r.output.find("is not a valid reliability curve") != std::string::npos);
    r = run_cli("render --scene cubes_dof --adaptive bucket-floor --pilot 4 --budget 1 --res 16 --curve " +
                (tmp.path / "curve.json").string() + " --out " + (tmp.path / "a").string());
    INFO(r.output);
    CHECK(r.code == 2);
    CHECK(r.output.find("is not a valid reliability curve") != std::string::npos);
    r = run_cli("study stability --scenes ,,, --out " + (tmp.path / "x").string());
    INFO(r.output);
    CHECK(r.code == 2);
    CHECK(r.output.find("--scenes: empty scene list") != std::string::npos);
    CHECK(r.output.find("no scene named") == std::string::npos);
}

TEST_CASE("cache: flipped bytes - truncation - a frame under another key - all detected every time") {
    TempDir tmp("rel_cache");
    RenderCache cache(tmp.path.string());
    const std::string key = "0123456789abcdef0123456789abcdef", other = "fedcba9876543210fedcba9876543210";
    const Frame f = synthetic_frame(5, 4, 2.0);
    cache.store(key, f, "test frame");
    const std::string good = slurp(cache.path(key));
    REQUIRE(cache.load(key).pixels.size() == 20);
    std::mt19937 rng(12345);
    int missed_flip = 0, missed_trunc = 0;
    for (int i = 0; i < 400; ++i) {  // one flipped bit at a random position: header, pixels or description
        std::string bad = good;
        size_t pos = rng() % bad.size();
        bad[pos] = static_cast<char>(bad[pos] ^ (1u << (rng() % 8)));
        put(cache.path(key), bad);
        try {
            cache.load(key);
            ++missed_flip;
        } catch (const std::runtime_error& e) {
            CHECK(std::string(e.what()).find(cache.path(key)) != std::string::npos);
        }
    }
    for (size_t len = 0; len < good.size(); len += 1 + rng() % 23) {
        put(cache.path(key), good.substr(0, len));
        try {
            cache.load(key);
            ++missed_trunc;
        } catch (const std::runtime_error&) {
        }
    }
    CHECK(missed_flip == 0);
    CHECK(missed_trunc == 0);
    // A valid frame copied under another key.
    put(cache.path(key), good);
    fs::copy_file(cache.path(key), cache.path(other));
    CHECK_THROWS_AS(cache.load(other), std::runtime_error);
    // A NaN written over pixel data (the file's last pixel, just before the description).
    std::string nan_file = good;
    const double nan = std::nan("");
    std::memcpy(&nan_file[good.size() - 8 - std::strlen("test frame") - 8 * 5], &nan, 8);
    put(cache.path(key), nan_file);
    CHECK_THROWS_AS(cache.load(key), std::runtime_error);
}

TEST_CASE(
    "cache: a NaN sealed with a valid checksum - an old-format file - and try_load warns removes and never uses") {
    TempDir tmp("rel_cache_nan");
    RenderCache cache(tmp.path.string());
    const std::string key = "00112233445566778899aabbccddeeff";
    Frame f = synthetic_frame(3, 3, 1.0);
    f.pixels[4].lum_m2 = std::nan("");  // a statistic, not a counted non-finite sample
    put(cache.path(key), seal_cache_file("frame", key, serialize_frame(f, "nan")));
    CHECK_THROWS_WITH_AS(cache.load(key), doctest::Contains("non-finite"), CacheFileError);
    CHECK_FALSE(cache.try_load(key).has_value());
    CHECK_FALSE(fs::exists(cache.path(key)));  // removed: the study renders it again
    // Side files are sealed too: a pilot stored under one kind is not read as another.
    cache.store_payload(key, "pilot", serialize_pilot(synthetic_frame(2, 2, 1.0), {1.0, 2.0, 3.0, 4.0}));
    CHECK(cache.try_load_payload(key, "pilot").has_value());
    std::string pool = slurp(cache.path(key, "pilot"));
    pool[pool.size() / 2] ^= 0x10;
    put(cache.path(key, "pilot"), pool);
    CHECK_FALSE(cache.try_load_payload(key, "pilot").has_value());
    // verify_cache_dir: good, bad and stale files.
    cache.store(key, synthetic_frame(3, 3, 1.0), "good");
    const std::string bad_key = "ffeeddccbbaa99887766554433221100";
    fs::copy_file(cache.path(key), cache.path(bad_key));  // under another key
    put(tmp.path / "0000000000000000000000000000000a.frame", std::string("VKMFRM01") + std::string(64, '\0'));
    put(tmp.path / (key + ".frame.tmp-999999"), "partial");
    CacheVerifyReport rep = verify_cache_dir(tmp.path.string());
    CHECK(rep.good.size() == 1);
    REQUIRE(rep.bad.size() == 1);
    CHECK(rep.bad[0].first == cache.path(bad_key));
    CHECK(rep.stale.size() == 2);
}

TEST_CASE("digest: an empty buffer hashes like any other empty input (no memcpy from null)") {
    // An empty std::vector's data() may be null; under UBSan a memcpy from it was reported (study keys).
    const std::vector<float> empty;
    const char nothing[1] = {0};
    CHECK(Digest().bytes(empty.data(), 0).hex() == Digest().bytes(nothing, 0).hex());
    CHECK(Digest().bytes(nullptr, 0).hex() == Digest().bytes(nothing, 0).hex());
    CHECK(Digest().bytes(nothing, 1).hex() != Digest().hex());
}

TEST_CASE("temporaries: names carry the host and only this host's dead writers' temporaries are cleaned") {
    TempDir tmp("rel_tmp_host");
    const std::string t = atomic_temp_path((tmp.path / "k.frame").string());
    CHECK(t.find(".host-" + temp_host_name() + ".tmp-" + std::to_string(::getpid())) != std::string::npos);
    // A dead pid on this host: cleaned. The same pid on another machine sharing the directory: kept.
    put(tmp.path / ("a.frame.host-" + temp_host_name() + ".tmp-999999"), "partial");
    put(tmp.path / "b.frame.host-some_other_node.tmp-999999", "partial");
    put(tmp.path / "c.frame.tmp-999999", "partial");  // the older form: this host's
    put(tmp.path / ("d.frame.host-" + temp_host_name() + ".tmp-" + std::to_string(::getpid())), "live");
    CHECK(clean_stale_temporaries(tmp.path.string()) == 2);
    CHECK_FALSE(fs::exists(tmp.path / ("a.frame.host-" + temp_host_name() + ".tmp-999999")));
    CHECK(fs::exists(tmp.path / "b.frame.host-some_other_node.tmp-999999"));
    CHECK_FALSE(fs::exists(tmp.path / "c.frame.tmp-999999"));
    CHECK(fs::exists(tmp.path / ("d.frame.host-" + temp_host_name() + ".tmp-" + std::to_string(::getpid()))));
}

TEST_SUITE("gpu") {
    TEST_CASE(
        "cli: render writes its outputs as a set with a manifest - SIGTERM mid-write keeps the old set - exit 143") {
        TempDir tmp("rel_cli_set");
        const std::string out = (tmp.path / "o").string();
        auto r = run_cli("render --scene cubes_dof --spp 1 --res 16 --out " + out);
        INFO(r.output);
        REQUIRE(r.code == 0);
        auto sets = verify_output_dir(out);
        REQUIRE(sets.size() == 1);
        CHECK(sets[0].kind == SetStatus::Complete);
        const std::string old_id = sets[0].run_id;
        CHECK(fs::exists(fs::path(out) / "cubes_dof.manifest.json"));
        r = run_cli("render --scene cubes_dof --spp 2 --res 16 --out " + out, "VKMECH_FAULT=staged-.png:TERM");
        INFO(r.output);
        CHECK(r.code == 143);
        CHECK(temporaries(out).empty());
        sets = verify_output_dir(out);
        REQUIRE(sets.size() == 1);
        CHECK(sets[0].kind == SetStatus::Complete);
        CHECK(sets[0].run_id == old_id);
        r = run_cli("verify outputs " + out);
        CHECK(r.code == 0);
        CHECK(r.output.find("complete") != std::string::npos);
    }

    TEST_CASE("cli: --res 16384 is refused with the memory it needs and what to lower") {
        // The limit the test sets, not the machine's size, refuses it: a
        // 139 GiB GPU with 128 GiB of RAM would otherwise render it for minutes.
        auto r = run_cli("render --scene cubes_dof --spp 1 --res 16384 --out " +
                             (fs::temp_directory_path() / ("vkmech_rel_oom_" + std::to_string(::getpid()))).string(),
                         "VKMECH_MEMORY_LIMIT=4GiB");
        INFO(r.output);
        CHECK(r.code == 1);
        CHECK(r.output.find("16384x") != std::string::npos);
        CHECK(r.output.find("GiB") != std::string::npos);
        CHECK(r.output.find("lower --res") != std::string::npos);
        CHECK(r.output.find("VKMECH_MEMORY_LIMIT allows 4") != std::string::npos);
        fs::remove_all(fs::temp_directory_path() / ("vkmech_rel_oom_" + std::to_string(::getpid())));
    }
}
