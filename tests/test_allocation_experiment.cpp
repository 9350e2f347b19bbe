// The allocation study as an analysis experiment (analysis/experiments/allocation.hpp)
// run over a synthetic AllocationSource: no device, no render cache. The
// expected values are computed here from the synthetic samples, not by the
// experiment's code. Also the render cache's typed records (pilot, pool).
#include "allocation/mom.hpp"
#include "experiments/allocation.hpp"
#include "study/render_cache.hpp"
#include "temp_dir.hpp"

#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <functional>
#include <sstream>
#include <stdexcept>

using namespace vkmech;
using vkmech::testing::TempDir;

namespace {

struct Sample {
    double r, g, b;
    uint32_t bucket;
};
using SampleFn = std::function<Sample(size_t pixel, uint32_t index)>;

// The allocation study reads its data from its own source, never a study render.
struct NoFrames final : FrameSource {
    Frame get(const RenderRequest&) override { throw std::logic_error("allocation study: asked for a study render"); }
};

double lum709(double r, double g, double b) { return 0.2126 * r + 0.7152 * g + 0.0722 * b; }

uint64_t mix(uint64_t x) {  // splitmix64 finaliser
    x += 0x9e3779b97f4a7c15ull;
    x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
    x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
    return x ^ (x >> 31);
}
double unit(uint64_t a, uint64_t b, uint64_t c) { return (mix(mix(mix(a) ^ b) ^ c) >> 11) * 0x1.0p-53; }

// Samples [first, first + n) of every pixel accumulated as a renderer would:
// sums, Welford moments of luminance, luminance energy per bucket.
Frame frame_of(int w, int h, const SampleFn& sample, uint32_t first, uint32_t n) {
    Frame f;
    f.width = w;
    f.height = h;
    f.pixels.resize(static_cast<size_t>(w) * h);
    for (size_t p = 0; p < f.pixels.size(); ++p) {
        PixelStats& s = f.pixels[p];
        for (uint32_t i = first; i < first + n; ++i) {
            Sample x = sample(p, i);
            double l = lum709(x.r, x.g, x.b);
            s.count += 1;
            double delta = l - s.lum_mean;
            s.lum_mean += delta / s.count;
            s.lum_m2 += delta * (l - s.lum_mean);
            s.rgb_sum[0] += x.r;
            s.rgb_sum[1] += x.g;
            s.rgb_sum[2] += x.b;
            s.bucket_sum[x.bucket] += l;
        }
    }
    f.samples = static_cast<uint64_t>(n) * f.pixels.size();
    f.seconds = 0.01;
    return f;
}

// A 4x4 scene whose every sample is direct light (bucket 1): no heavy-tailed bucket anywhere.
struct SyntheticSource final : AllocationSource {
    int w = 4, h = 4;
    std::vector<std::string> calls;
    std::vector<uint64_t> final_totals;
    size_t pool_pixels_offset = 0;  // >0: a pool of the wrong size

    static SampleFn stream(uint64_t s) {
        return [s](size_t p, uint32_t i) {
            double base = p == 5 ? 2.5 : 0.1 + 0.08 * static_cast<double>(p % 7);  // pixel 5 beyond the display range
            double u = unit(s, p, i), v = unit(s + 17, p, i);
            double spread = p % 3 == 0 ? 1.6 : 0.4;  // some pixels noisier than others
            return Sample{base * (1 + spread * (u - 0.5)), base * (1 + spread * (v - 0.5)), base, 1u};
        };
    }
    Frame reference(const SceneVariant& v) override {
        calls.push_back("reference " + v.name);
        return frame_of(w, h, stream(9), 0, 4096);
    }
    SamplePool pool(const SceneVariant& v, uint32_t index) override {
        calls.push_back(downstream_seeds::pool_label(index) + " " + v.name);
        SamplePool pool;
        pool.frames = downstream_seeds::kPoolSize;
        pool.pixels = static_cast<size_t>(w) * h - pool_pixels_offset;
        SampleFn s = stream(index == 0 ? 1 : 500 + index);  // pools of disjoint streams
        for (uint32_t f = 0; f < pool.frames; ++f)
            for (size_t p = 0; p < pool.pixels; ++p) {
                Sample x = s(p, f);
                pool.samples.insert(pool.samples.end(), {float(x.r), float(x.g), float(x.b), 1.0f});
            }
        Frame whole = frame_of(w, h, s, 0, pool.frames);
        for (size_t p = 0; p < pool.pixels; ++p) pool.oracle_var.push_back(whole.pixels[p].lum_var());
        return pool;
    }
    Pilot pilot(const SceneVariant& v, uint32_t n0, uint32_t draw) override {
        calls.push_back("pilot " + v.name + " " + std::to_string(n0) + " " + std::to_string(draw));
        Frame f = frame_of(w, h, stream(100 + draw), 0, n0);
        std::vector<double> mom;
        if (n0 >= 9)  // where median-of-means is defined the robust strategies need one; any finite value will do
            for (const PixelStats& p : f.pixels) mom.push_back(p.lum_var());
        return make_pilot(std::move(f), std::move(mom));
    }
    PilotSamples pilot_samples(const SceneVariant& v, uint32_t n0, uint32_t draw) override {
        calls.push_back("pilot samples " + v.name + " " + std::to_string(n0) + " " + std::to_string(draw));
        PilotSamples s;
        s.samples = n0;
        s.pixels = static_cast<size_t>(w) * h;
        SampleFn f = stream(100 + draw);
        for (uint32_t i = 0; i < n0; ++i)
            for (size_t p = 0; p < s.pixels; ++p) {
                Sample x = f(p, i);
                s.lum.push_back(static_cast<float>(lum709(x.r, x.g, x.b)));
            }
        return s;
    }
    double final_render_seconds(const SceneVariant& v, const std::vector<uint32_t>& n) override {
        calls.push_back("final " + v.name);
        uint64_t t = 0;
        for (uint32_t x : n) t += x;
        final_totals.push_back(t);
        return 0.5;
    }
};

StudyConfig small_config() {
    StudyConfig cfg;
    SceneVariant v;
    v.name = "synthetic";
    v.path = "synthetic.xml";
    cfg.scenes = {v};
    cfg.alloc_pilots = {4, 16};
    cfg.alloc_draws = 3;
    cfg.alloc_extra = 32;
    cfg.alloc_budget_sweep = {32};
    cfg.alloc_floors = {1};
    cfg.equal_time = false;
    return cfg;
}

std::vector<std::vector<std::string>> read_csv(const std::string& path) {
    std::ifstream in(path);
    std::vector<std::vector<std::string>> rows;
    std::string line;
    while (std::getline(in, line)) {
        std::vector<std::string> row;
        std::stringstream ss(line);
        std::string cell;
        while (std::getline(ss, cell, ',')) row.push_back(cell);
        rows.push_back(row);
    }
    return rows;
}

}  // namespace

TEST_CASE(
    "allocation experiment: runs over a synthetic source without a device - asks for what it scores - and its uniform "
    "PSNR is the pool's") {
    TempDir tmp("alloc_exp");
    StudyConfig cfg = small_config();
    SyntheticSource src;
    StudyOutput out(tmp.path.string());
    NoFrames no_frames;
    StudyContext ctx{cfg, no_frames, out, "no device", {}, &src};
    run_allocation(ctx);

    // One reference, one pool, K pilot draws per N0, in that order, then the timing renders.
    std::vector<std::string> expect = {"reference synthetic", "pool synthetic"};
    for (uint32_t n0 : {4u, 16u})
        for (uint32_t k = 0; k < 3; ++k)
            expect.push_back("pilot synthetic " + std::to_string(n0) + " " + std::to_string(k));
    REQUIRE(src.calls.size() >= expect.size());
    CHECK(std::vector<std::string>(src.calls.begin(), src.calls.begin() + expect.size()) == expect);
    // Timing renders: uniform, observed-var, bucket-floor, guarded and shrink at N0 = 4; the three robust ones too
    // (robust-var, robust-floor, robust-adaptive) at N0 = 16.
    CHECK(src.final_totals.size() == 5 + 8);
    for (uint64_t t : src.final_totals) CHECK(t == 33u * 16u);  // every strategy spends (1 + extra) x pixels

    auto rows = read_csv(tmp.file("tables/downstream.csv"));
    REQUIRE(rows.size() == 2);
    REQUIRE(rows[0].size() >= 8);
    CHECK(rows[0][1] == "uniform");
    CHECK(rows[1][0] == "synthetic");
    // Uniform: 33 samples per pixel, the first 33 pool frames, whatever the pilot. Primary figure: unclamped linear
    // RGB, PSNR with the reference's largest value as the peak; beside it the [0, 1]-clamped PSNR with peak 1.
    SampleFn pool = SyntheticSource::stream(1), ref = SyntheticSource::stream(9);
    double se = 0, se_clamped = 0, peak = 0, rel = 0;
    for (size_t p = 0; p < 16; ++p) {
        double m[3] = {0, 0, 0}, r[3] = {0, 0, 0};
        for (uint32_t i = 0; i < 33; ++i) {
            Sample x = pool(p, i);
            m[0] += float(x.r);
            m[1] += float(x.g);
            m[2] += float(x.b);
        }
        for (uint32_t i = 0; i < 4096; ++i) {
            Sample x = ref(p, i);
            r[0] += x.r;
            r[1] += x.g;
            r[2] += x.b;
        }
        for (int c = 0; c < 3; ++c) {
            double d = m[c] / 33 - r[c] / 4096;
            se += d * d / 3;
            rel += d * d / ((r[c] / 4096) * (r[c] / 4096) + 0.01) / 3;
            double dc = std::clamp(m[c] / 33, 0.0, 1.0) - std::clamp(r[c] / 4096, 0.0, 1.0);
            se_clamped += dc * dc / 3;
            peak = std::max(peak, r[c] / 4096);
        }
    }
    const double psnr_uniform = 10 * std::log10(peak * peak / (se / 16));
    CHECK(std::stod(rows[1][1]) == doctest::Approx(psnr_uniform).epsilon(1e-6));
    auto clamped = read_csv(tmp.file("tables/downstream_clamped.csv"));
    REQUIRE(clamped.size() == 2);
    CHECK(std::stod(clamped[1][1]) == doctest::Approx(10 * std::log10(1.0 / (se_clamped / 16))).epsilon(1e-6));
    auto relm = read_csv(tmp.file("tables/downstream_relmse.csv"));
    REQUIRE(relm.size() == 2);
    CHECK(std::stod(relm[1][1]) == doctest::Approx(rel / 16).epsilon(1e-3));
    auto peaks = read_csv(tmp.file("tables/downstream_peak.csv"));
    REQUIRE(peaks.size() == 2);
    CHECK(std::stod(peaks[1][1]) == doctest::Approx(peak).epsilon(1e-3));
    // No heavy-tailed bucket: the bucket floor changes nothing, so bucket-floor ties observed-var exactly.
    CHECK(rows[1][2] == rows[1][3]);
    CHECK(rows[1][7] == "tie");
    // Every configuration is listed: 2 pilots x (6 base strategies + guarded, shrink and shrink-global) + 4 robust at
    // N0 = 16 (the budget sweep's extra 32 is the main budget). The block-count sweep asks for each N0 = 16 draw's
    // samples once, and has one row per valid k.
    CHECK(std::count(src.calls.begin(), src.calls.end(), "pilot samples synthetic 16 0") == 1);
    CHECK(std::count(src.calls.begin(), src.calls.end(), "pilot samples synthetic 4 0") == 0);  // MoM undefined at 4
    auto mom = read_csv(tmp.file("tables/mom_sweep.csv"));
    CHECK(mom.size() == 1 + 5);  // k = 2, 3, 4, 6, 8 all give blocks of >= 2 samples at N0 = 16
    auto all = read_csv(tmp.file("tables/downstream_all.csv"));
    CHECK(all.size() == 1 + 2 * 9 + 4);
    // The seed std of MSE (the paper's strict criterion, §7 Result 2): uniform's allocation is the same in every
    // draw, so its MSE is the test's own and its std 0; observed-var's follows each draw's pilot.
    REQUIRE(all[0].size() == 13);
    CHECK(all[0][7] == "MSE");
    CHECK(all[0][8] == "MSE std");
    size_t seen = 0;
    for (const auto& row : all) {
        if (row[1] != "4" || row[2] != "1" || row[3] != "32") continue;
        CAPTURE(row[4]);
        if (row[4] == "uniform") {
            CHECK(std::stod(row[7]) == doctest::Approx(se / 16).epsilon(1e-3));
            CHECK(std::stod(row[8]) == 0.0);
            ++seen;
        } else if (row[4] == "observed-var") {
            CHECK(std::stod(row[8]) > 0.0);
            ++seen;
        }
    }
    CHECK(seen == 2);
    // robust-adaptive against the others at N0 = 16 (the only pilot where median-of-means is defined here); the
    // synthetic labels have no rare-tail pixel, so it is robust-var exactly.
    auto adaptive = read_csv(tmp.file("tables/robust_adaptive.csv"));
    REQUIRE(adaptive.size() == 1 + 1);
    CHECK(adaptive[1][1] == "16");
    CHECK(adaptive[0][7] == "robust-var");
    CHECK(adaptive[0][11] == "robust-adaptive");
    REQUIRE(std::stod(adaptive[1][3]) == 0.0);
    CHECK(adaptive[1][11] == adaptive[1][7]);
    CHECK(adaptive[1][12] == "tie");
    // The strategies beyond the paper, one row per pilot; with no untrusted pilot pixel guarded is bucket-floor.
    auto beyond = read_csv(tmp.file("tables/beyond_floor.csv"));
    REQUIRE(beyond.size() == 1 + 2);
    for (size_t r = 1; r < beyond.size(); ++r) {
        CAPTURE(r);
        if (std::stod(beyond[r][2]) == 0.0) {
            CHECK(beyond[r][6] == beyond[r][5]);
            CHECK(beyond[r][10] == "tie");
        }
        // Every synthetic pixel is direct: one label, so shrink's prior is the global placebo's.
        CHECK(beyond[r][7] == beyond[r][8]);
        CHECK(beyond[r][12] == "tie");
    }
}

TEST_CASE(
    "allocation experiment: equal time covers every strategy - the plain ones at the smallest pilot and the robust "
    "ones where median-of-means is defined") {
    TempDir tmp("alloc_exp_eq");
    StudyConfig cfg = small_config();
    cfg.equal_time = true;
    cfg.equal_time_budgets = {8, 32};
    SyntheticSource src;
    StudyOutput out(tmp.path.string());
    NoFrames no_frames;
    StudyContext ctx{cfg, no_frames, out, "no device", {}, &src};
    run_allocation(ctx);
    // 13 timing renders (as above), then one render per equal-time strategy and budget at N0 = 4 and at N0 = 16.
    CHECK(src.final_totals.size() == 13 + 2 * 5 + 2 * 5);
    auto eq = read_csv(tmp.file("tables/equal_time.csv"));
    auto eq_robust = read_csv(tmp.file("tables/equal_time_robust.csv"));
    REQUIRE(eq.size() == 1 + 2 * 5);
    REQUIRE(eq_robust.size() == 1 + 2 * 5);
    std::vector<std::string> names, robust_names;
    for (size_t r = 1; r < eq.size(); r += 2) names.push_back(eq[r][1]);
    for (size_t r = 1; r < eq_robust.size(); r += 2) robust_names.push_back(eq_robust[r][1]);
    CHECK(names == std::vector<std::string>{"uniform", "observed-var", "bucket-floor", "guarded", "shrink"});
    CHECK(robust_names ==
          std::vector<std::string>{"uniform", "observed-var", "robust-var", "robust-floor", "robust-adaptive"});
}

TEST_CASE(
    "allocation experiment: resampled pools - each asked for once - uniform's PSNR is each pool's and spreads - "
    "pool 0 repeats the main table - firefly-robust companions beside") {
    TempDir tmp("alloc_pools");
    StudyConfig cfg = small_config();
    cfg.alloc_pools = 3;
    cfg.alloc_budget_sweep = {32, 64};
    SyntheticSource src;
    StudyOutput out(tmp.path.string());
    NoFrames no_frames;
    StudyContext ctx{cfg, no_frames, out, "no device", {}, &src};
    run_allocation(ctx);
    for (const char* pool : {"pool 1 synthetic", "pool 2 synthetic"})
        CHECK(std::count(src.calls.begin(), src.calls.end(), pool) == 1);
    // The budget sweep at every pilot: uniform, observed-var, bucket-floor and oracle at 64 extra SPP, N0 = 4 and 16.
    size_t swept = 0;
    for (const auto& row : read_csv(tmp.file("tables/downstream_all.csv")))
        swept += row.size() > 4 && row[2] == "1" && row[3] == "64";
    CHECK(swept == 2 * 4);
    // The scene's data is loaded once for the tables at equal samples and the pool resampling alike.
    for (const char* once : {"reference synthetic", "pool synthetic", "pilot synthetic 4 0", "pilot synthetic 16 2"})
        CHECK(std::count(src.calls.begin(), src.calls.end(), once) == 1);

    // Uniform at N0 = 4: per pool, the mean of its first 33 frames against the reference, worked out here.
    const SampleFn ref = SyntheticSource::stream(9);
    std::vector<double> per_pool;
    double peak = 0;
    std::vector<double> r(48);
    for (size_t p = 0; p < 16; ++p)
        for (int c = 0; c < 3; ++c) {
            double sum = 0;
            for (uint32_t i = 0; i < 4096; ++i) {
                const Sample x = ref(p, i);
                sum += c == 0 ? x.r : c == 1 ? x.g : x.b;
            }
            r[3 * p + c] = sum / 4096;
            peak = std::max(peak, r[3 * p + c]);
        }
    for (uint32_t j = 0; j < 3; ++j) {
        const SampleFn pool = SyntheticSource::stream(j == 0 ? 1 : 500 + j);
        double se = 0;
        for (size_t p = 0; p < 16; ++p) {
            double m[3] = {0, 0, 0};
            for (uint32_t i = 0; i < 33; ++i) {
                const Sample x = pool(p, i);
                m[0] += float(x.r);
                m[1] += float(x.g);
                m[2] += float(x.b);
            }
            for (int c = 0; c < 3; ++c) se += (m[c] / 33 - r[3 * p + c]) * (m[c] / 33 - r[3 * p + c]) / 3;
        }
        per_pool.push_back(10 * std::log10(peak * peak / (se / 16)));
    }
    const double mean = (per_pool[0] + per_pool[1] + per_pool[2]) / 3;
    double var = 0;
    for (double v : per_pool) var += (v - mean) * (v - mean) / 2;
    auto rows = read_csv(tmp.file("tables/alloc_pools.csv"));
    REQUIRE(rows.size() == 3);  // header, N0 = 4, N0 = 16
    CHECK(rows[1][0] == "synthetic");
    CHECK(rows[1][1] == "4");
    const std::string uni = rows[1][2];
    const size_t pm = uni.find("\u00b1") != std::string::npos ? uni.find("\u00b1") : uni.find("\xc2\xb1");
    REQUIRE(pm != std::string::npos);
    CHECK(std::stod(uni.substr(0, pm)) == doctest::Approx(mean).epsilon(1e-6));
    CHECK(std::stod(uni.substr(pm + 2)) == doctest::Approx(std::sqrt(var)).epsilon(1e-4));
    CHECK(std::sqrt(var) > 0.0);  // one pool alone has no spread; three disjoint ones do
    // Pool 0 and its draws are the main table's: every pool's uniform is a PSNR of its own, and the first is
    // tab:downstream's.
    auto main = read_csv(tmp.file("tables/downstream.csv"));
    CHECK(std::stod(main[1][1]) == doctest::Approx(per_pool[0]).epsilon(1e-6));
    // No heavy bucket: bucket-floor ties observed-var on every pool, by every measure.
    CHECK(rows[1][6] == "tie");
    auto ff = read_csv(tmp.file("tables/alloc_firefly.csv"));
    REQUIRE(ff.size() == 3);
    CHECK(ff[1][9] == "tie");
    CHECK(ff[1][10] == "tie");
    CHECK(ff[1][11] == "tie");
    CHECK(std::stod(ff[1][3]) > 0.0);  // a median squared error, not the mean
    // One pool: no pool tables.
    TempDir tmp1("alloc_pools1");
    cfg.alloc_pools = 1;
    SyntheticSource src1;
    StudyOutput out1(tmp1.path.string());
    StudyContext ctx1{cfg, no_frames, out1, "no device", {}, &src1};
    run_allocation(ctx1);
    CHECK_FALSE(std::filesystem::exists(tmp1.file("tables/alloc_pools.csv")));
}

TEST_CASE("allocation experiment: a pool that does not match the reference's film is refused naming the scene") {
    TempDir tmp("alloc_exp_bad");
    StudyConfig cfg = small_config();
    SyntheticSource src;
    src.pool_pixels_offset = 1;
    StudyOutput out(tmp.path.string());
    NoFrames no_frames;
    StudyContext ctx{cfg, no_frames, out, "no device", {}, &src};
    CHECK_THROWS_WITH_AS(run_allocation(ctx), doctest::Contains("pool of synthetic"), std::runtime_error);
}

TEST_CASE(
    "cache records: pilot and pool round-trip - another type - another version - truncation - bad values are refused") {
    SampleFn s = SyntheticSource::stream(5);
    Frame f = frame_of(3, 2, s, 0, 16);
    const std::vector<double> mom = {1, 2, 3, 4, 5, 6};
    const std::string pilot_bytes = serialize_pilot(f, mom);
    Pilot p = deserialize_pilot(pilot_bytes, "p.pilot");
    CHECK(std::memcmp(p.frame.pixels.data(), f.pixels.data(), f.pixels.size() * sizeof(PixelStats)) == 0);
    CHECK(p.mom_var == mom);
    REQUIRE(p.var.size() == 6);
    CHECK(p.var[2] == f.pixels[2].lum_var());
    CHECK(p.labels[0] == 1);  // all energy in bucket 1

    SamplePool pool;
    pool.frames = 2;
    pool.pixels = 3;
    pool.samples = {0.1f, 0.2f, 0.3f, 1, 0,    0,    0,    0, 0.5f, 0.5f, 0.5f, 1,
                    0.2f, 0.2f, 0.2f, 1, 0.4f, 0.1f, 0.0f, 1, 9.0f, 8.0f, 7.0f, 1};
    pool.oracle_var = {0.01, 0.0, 0.5};
    const std::string pool_bytes = serialize_pool(pool);
    SamplePool q = deserialize_pool(pool_bytes, "q.pool");
    CHECK(q.frames == 2);
    CHECK(q.pixels == 3);
    CHECK(q.samples == pool.samples);
    CHECK(q.oracle_var == pool.oracle_var);
    CHECK(*q.at(1, 2) == 9.0f);

    // A record of one type is not read as another.
    CHECK_THROWS_WITH_AS(deserialize_pool(pilot_bytes, "x"), doctest::Contains("holds a 'pilot' record"),
                         CacheFileError);
    CHECK_THROWS_WITH_AS(deserialize_frame(pool_bytes, "x"), doctest::Contains("expected a 'frame'"), CacheFileError);
    // Another version: the version field follows magic (8), the type's length (8) and the type ("pool", 4).
    std::string v2 = pool_bytes;
    v2[8 + 8 + 4] = 2;
    CHECK_THROWS_WITH_AS(deserialize_pool(v2, "v.pool"), doctest::Contains("version 2"), CacheFileError);
    // Every truncation is refused, naming the file.
    for (size_t len = 0; len < pool_bytes.size(); ++len)
        CHECK_THROWS_WITH_AS(deserialize_pool(pool_bytes.substr(0, len), "t.pool"), doctest::Contains("t.pool"),
                             CacheFileError);
    for (size_t len = 0; len < pilot_bytes.size(); len += 7)
        CHECK_THROWS_AS(deserialize_pilot(pilot_bytes.substr(0, len), "t.pilot"), CacheFileError);
    // Trailing bytes, a NaN flagged finite, a flag that is neither 0 nor 1, a negative variance, wrong sizes.
    CHECK_THROWS_WITH_AS(deserialize_pool(pool_bytes + "x", "y"), doctest::Contains("trailing"), CacheFileError);
    SamplePool bad = pool;
    bad.samples[0] = std::nanf("");
    CHECK_THROWS_WITH_AS(deserialize_pool(serialize_pool(bad), "y"), doctest::Contains("non-finite"), CacheFileError);
    bad.samples[3] = 0;  // the same NaN counted out: a sound pool
    CHECK_NOTHROW(deserialize_pool(serialize_pool(bad), "y"));
    bad = pool;
    bad.samples[7] = 0.5f;
    CHECK_THROWS_WITH_AS(deserialize_pool(serialize_pool(bad), "y"), doctest::Contains("finite flag"), CacheFileError);
    bad = pool;
    bad.oracle_var[1] = -1;
    CHECK_THROWS_WITH_AS(deserialize_pool(serialize_pool(bad), "y"), doctest::Contains("oracle variance"),
                         CacheFileError);
    bad = pool;
    bad.samples.resize(20);
    CHECK_THROWS_WITH_AS(deserialize_pool(serialize_pool(bad), "y"), doctest::Contains("inconsistent sizes"),
                         CacheFileError);
    CHECK_THROWS_WITH_AS(deserialize_pilot(serialize_pilot(f, {1, 2}), "y"), doctest::Contains("median-of-means"),
                         CacheFileError);

    // Through the cache: stored, found, and a damaged one warned about, removed and not returned.
    TempDir tmp("cache_records");
    RenderCache cache(tmp.path.string());
    const std::string key = "0123456789abcdef0123456789abcdef";
    cache.store_pool(key, pool);
    REQUIRE(cache.try_load_pool(key).has_value());
    CHECK(cache.try_load_pool(key)->samples == pool.samples);
    cache.store_pilot(key, p);
    REQUIRE(cache.try_load_pilot(key).has_value());
    CHECK(cache.try_load_pilot(key)->mom_var == mom);
    CHECK_FALSE(cache.try_load_pilot("ffffffffffffffffffffffffffffffff").has_value());
    // A pool with a bad flag sealed with a valid checksum: the record check catches it.
    bad = pool;
    bad.samples[3] = 2;
    cache.store_payload(key, "pool", serialize_pool(bad));
    CHECK_FALSE(cache.try_load_pool(key).has_value());
    CHECK_FALSE(std::filesystem::exists(cache.path(key, "pool")));
    CacheVerifyReport rep = verify_cache_dir(tmp.path.string());
    CHECK(rep.good.size() == 1);  // the pilot
    CHECK(rep.bad.empty());
}

TEST_CASE("allocation experiment: mom_defined is true exactly where mom_block_size does not throw") {
    for (int n0 = -2; n0 <= 300; ++n0) {
        bool defined = true;
        try {
            alloc::mom_block_size(n0);
        } catch (const std::invalid_argument&) {
            defined = false;
        }
        INFO("N0 = " << n0);
        CHECK(alloc::mom_defined(n0) == defined);
    }
    CHECK_FALSE(alloc::mom_defined(4));
    CHECK(alloc::mom_defined(9));
    CHECK(alloc::mom_defined(16));
}

TEST_CASE("allocation experiment: the median-of-means of a pilot's samples - by hand - NaN samples left out") {
    // 2 pixels, 8 samples; k = 2 blocks of 4, k = 3 blocks of 2 (2 samples discarded).
    PilotSamples s;
    s.samples = 8;
    s.pixels = 2;
    const float px0[8] = {1, 2, 3, 4, 10, 10, 10, 14};
    const float px1[8] = {0, 0, NAN, 1, 5, 5, 5, 5};
    for (int i = 0; i < 8; ++i) {
        s.lum.push_back(px0[i]);
        s.lum.push_back(px1[i]);
    }
    auto var = [](std::vector<double> x) {
        double m = 0, q = 0;
        for (double v : x) m += v / x.size();
        for (double v : x) q += (v - m) * (v - m);
        return q / (x.size() - 1);
    };
    std::vector<double> k2 = s.mom_variance(2);
    // Median of two block variances = their mean.
    CHECK(k2[0] == doctest::Approx((var({1, 2, 3, 4}) + var({10, 10, 10, 14})) / 2));
    CHECK(k2[1] == doctest::Approx((var({0, 0, 1}) + var({5, 5, 5, 5})) / 2));  // the NaN sample counted out
    std::vector<double> k3 = s.mom_variance(3);                                 // blocks {1,2} {3,4} {10,10}
    CHECK(k3[0] == doctest::Approx(0.5));
    CHECK(k3[1] == doctest::Approx(0.0));  // blocks {0,0} and {5,5} (the NaN block has one sample, left out): 0 and 0
    CHECK_THROWS_AS(s.mom_variance(5), std::invalid_argument);  // blocks of 1 sample
    CHECK_THROWS_AS(s.mom_variance(0), std::invalid_argument);
}

TEST_CASE("cache records: per-sample pilots round-trip - NaN kept - inconsistent sizes and infinities refused") {
    PilotSamples s;
    s.samples = 3;
    s.pixels = 2;
    s.lum = {0.5f, 1.0f, NAN, 2.0f, 0.25f, 0.0f};
    PilotSamples t = deserialize_pilot_samples(serialize_pilot_samples(s), "s.pilot-samples");
    CHECK(t.samples == 3);
    CHECK(t.pixels == 2);
    CHECK(std::isnan(t.lum[2]));
    CHECK(t.lum[3] == 2.0f);
    PilotSamples bad = s;
    bad.lum.pop_back();
    CHECK_THROWS_WITH_AS(deserialize_pilot_samples(serialize_pilot_samples(bad), "b"),
                         doctest::Contains("inconsistent"), CacheFileError);
    bad = s;
    bad.lum[0] = INFINITY;
    CHECK_THROWS_WITH_AS(deserialize_pilot_samples(serialize_pilot_samples(bad), "b"), doctest::Contains("infinite"),
                         CacheFileError);
    TempDir tmp("cache_samples");
    RenderCache cache(tmp.path.string());
    cache.store_pilot_samples("00112233445566778899aabbccddeeff", s);
    REQUIRE(cache.try_load_pilot_samples("00112233445566778899aabbccddeeff").has_value());
    CHECK(verify_cache_dir(tmp.path.string()).good.size() == 1);
}
