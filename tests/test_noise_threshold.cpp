// The noise threshold (render --noise-threshold; docs/descriptor.md §6.8): the error estimate, the
// sample ladder, the targets and their fit to a time budget, worked out by hand in the comments; then
// on the device: every pixel ends below T or at max-spp, the rounds are exactly the samples
// [0, n(p)) of the seed, the time limit holds within one round, and the CLI's outputs.
#include "adaptive/noise_threshold.hpp"
#include "allocation/allocation.hpp"
#include "cli_run.hpp"
#include "gpu_fixture.hpp"
#include "io/exr.hpp"
#include "render_fixture.hpp"
#include "temp_dir.hpp"

#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

using namespace vkmech;
using namespace vkmech::alloc;

namespace {

// A pixel of `n` finite samples of mean luminance `lum` and unbiased variance `var`, all of its
// energy in `bucket`.
PixelStats pixel(double n, double lum, double var, uint8_t bucket) {
    PixelStats s;
    s.count = n;
    s.lum_mean = lum;
    s.rgb_sum = {lum * n, lum * n, lum * n};
    s.lum_m2 = var * (n - 1.0);
    s.bucket_sum[bucket] = lum * n;
    return s;
}

Frame frame_of(int w, int h, std::vector<PixelStats> px) {
    Frame f;
    f.width = w;
    f.height = h;
    f.pixels = std::move(px);
    return f;
}

}  // namespace

TEST_CASE("noise threshold: the ladder climbs by sqrt 2, rounded up, to max-spp") {
    // 16 * 1.41421 = 22.6 -> 23, 32.5 -> 33, 46.7 -> 47, 66.5 -> 67, 94.8 -> 95, 134.4 -> 135,
    // 190.9 -> 191, 270.1 -> 271, 383.3 -> 384, 543.1 -> 544, 769.3 -> 770, then max-spp 1024.
    CHECK(sample_ladder(16, 1024) == std::vector<uint32_t>{16, 23, 33, 47, 67, 95, 135, 191, 271, 384, 544, 770, 1024});
    CHECK(sample_ladder(2, 4) == std::vector<uint32_t>{2, 3, 4});  // 2.83 -> 3, 4.24 capped at 4
    CHECK(sample_ladder(1, 2) == std::vector<uint32_t>{1, 2});     // 1.41 -> 2
    CHECK(sample_ladder(64, 64) == std::vector<uint32_t>{64});
    CHECK_THROWS_AS(sample_ladder(65, 64), std::invalid_argument);
    CHECK_THROWS_AS(sample_ladder(0, 64), std::invalid_argument);
}

TEST_CASE("noise threshold: the relative error is the standard error of the mean over the mean plus the dark floor") {
    // Two diffuse pixels: 16 samples of mean 1, variance 4; 64 samples of mean 3, variance 1.
    // Image mean 2, delta = 0.01 * 2 = 0.02.
    const Frame f = frame_of(
        2, 1, {pixel(16, 1.0, 4.0, gpu::BUCKET_DIFFUSE_INDIRECT), pixel(64, 3.0, 1.0, gpu::BUCKET_DIFFUSE_INDIRECT)});
    for (Strategy s : {Strategy::ObservedVar, Strategy::BucketFloor, Strategy::Guarded}) {
        CAPTURE(to_string(s));
        const std::vector<double> err = relative_error(f, s);
        REQUIRE(err.size() == 2);
        CHECK(err[0] == doctest::Approx(std::sqrt(4.0 / 16.0) / 1.02).epsilon(1e-12));  // 0.5 / 1.02
        CHECK(err[1] == doctest::Approx(std::sqrt(1.0 / 64.0) / 3.02).epsilon(1e-12));  // 0.125 / 3.02
    }
    CHECK_THROWS_WITH_AS(relative_error(f, Strategy::Uniform), doctest::Contains("observed-var"),
                         std::invalid_argument);
    CHECK_THROWS_AS(relative_error(f, Strategy::RobustVar), std::invalid_argument);
}

TEST_CASE("noise threshold: the label floor keeps a glossy pixel that looks quiet from stopping") {
    // Three glossy pixels of 16 samples and mean 1, variances 0.01, 1 and 4: the bucket's median is 1,
    // so bucket-floor reads max(0.01, 1) = 1 at the first. Image mean 1, delta 0.01.
    const Frame f = frame_of(3, 1,
                             {pixel(16, 1.0, 0.01, gpu::BUCKET_GLOSSY), pixel(16, 1.0, 1.0, gpu::BUCKET_GLOSSY),
                              pixel(16, 1.0, 4.0, gpu::BUCKET_GLOSSY)});
    const std::vector<double> plain = relative_error(f, Strategy::ObservedVar);
    const std::vector<double> floored = relative_error(f, Strategy::BucketFloor);
    CHECK(plain[0] == doctest::Approx(0.1 / 4.0 / 1.01).epsilon(1e-12));  // sqrt(0.01 / 16) = 0.025
    CHECK(floored[0] == doctest::Approx(1.0 / 4.0 / 1.01).epsilon(1e-12));
    CHECK(floored[1] == plain[1]);
    CHECK(floored[2] == plain[2]);
    // At T = 0.1 the plain variance stops the first pixel; the floor does not.
    const std::vector<uint32_t> ladder = sample_ladder(16, 1024);
    const std::vector<uint32_t> n{16, 16, 16};
    CHECK(threshold_targets(n, plain, 0.1, ladder)[0] == 16u);
    CHECK(threshold_targets(n, floored, 0.1, ladder)[0] > 16u);
}

TEST_CASE("noise threshold: the guard measures a dark pixel beside lit ones against its neighbours") {
    // A 3 x 1 row: a lit diffuse pixel (mean 2, variance 1, 16 samples), a dark one (16 finite zeros),
    // and a lit one (mean 4, variance 9). The dark pixel is untrusted (dark in a lit region): observed-var
    // gives it err 0 (it stops); guarded gives it D = w^2, w the mean Neyman weight with it at w:
    // w = (1 + 3 + w) / 3 -> w = 2, D = 4, and measures it against its window's largest mean, 4.
    // Image mean (2 + 0 + 4) / 3 = 2, delta 0.02: err = sqrt(4 / 16) / 4.02.
    const Frame f =
        frame_of(3, 1,
                 {pixel(16, 2.0, 1.0, gpu::BUCKET_DIFFUSE_INDIRECT), pixel(16, 0.0, 0.0, gpu::BUCKET_DIFFUSE_INDIRECT),
                  pixel(16, 4.0, 9.0, gpu::BUCKET_DIFFUSE_INDIRECT)});
    CHECK(relative_error(f, Strategy::ObservedVar)[1] == 0.0);
    CHECK(relative_error(f, Strategy::Guarded)[1] == doctest::Approx(0.5 / 4.02).epsilon(1e-12));
    // Trusted pixels are measured as by bucket-floor.
    CHECK(relative_error(f, Strategy::Guarded)[0] == relative_error(f, Strategy::BucketFloor)[0]);
}

TEST_CASE("noise threshold: a pixel with no samples or a non-finite variance has an infinite error") {
    PixelStats none;  // no samples
    PixelStats huge = pixel(16, 1.0, 0.0, gpu::BUCKET_DIRECT);
    huge.lum_m2 = INFINITY;
    const Frame f = frame_of(3, 1, {none, huge, pixel(16, 1.0, 1.0, gpu::BUCKET_DIRECT)});
    const std::vector<double> err = relative_error(f, Strategy::ObservedVar);
    CHECK(std::isinf(err[0]));
    CHECK(std::isinf(err[1]));
    CHECK(std::isfinite(err[2]));
}

TEST_CASE("noise threshold: the targets go to the rung of the predicted need, at most 4 n, at least the next rung") {
    const std::vector<uint32_t> ladder = sample_ladder(16, 1024);  // 16 23 33 47 67 95 135 ...
    const double T = 0.1;
    const std::vector<uint32_t> n{16, 16, 16, 16, 1024, 47, 16};
    // 0: err 0.05 <= T: stays. 1: err 0.12: need 16 * 1.44 = 23.04 -> 33 (23 is below the need).
    // 2: err 0.2: need 64; the rung at or above it is 67 > 4 * 16 = 64, so the rung below, 47.
    // 3: err inf: the most a round gives, 47. 4: at max-spp: stays. 5: err 0.11 from 47: need 56.9 -> 67.
    // 6: err 0.1 exactly: not above T, stays.
    const std::vector<double> err{0.05, 0.12, 0.2, INFINITY, 5.0, 0.11, 0.1};
    CHECK(threshold_targets(n, err, T, ladder) == std::vector<uint32_t>{16, 33, 47, 47, 1024, 67, 16});
    CHECK_THROWS_WITH_AS(threshold_targets({17}, {1.0}, T, ladder), doctest::Contains("17 samples"),
                         std::invalid_argument);
}

TEST_CASE("noise threshold: a round is fitted to the time left, the worst pixels first") {
    const std::vector<uint32_t> ladder = sample_ladder(16, 1024);
    const std::vector<uint32_t> n{16, 16, 16, 33};
    const std::vector<double> err{0.2, 0.5, 0.3, 0.15};
    const std::vector<uint32_t> wanted{47, 47, 47, 67};  // 31 + 31 + 31 + 34 = 127 samples
    std::vector<uint32_t> t = wanted;
    CHECK(fit_round(t, n, err, ladder, 1000) == 127u);
    CHECK(t == wanted);
    // 100: every pixel to its next rung: 7 + 7 + 7 + 14 = 35 samples.
    t = wanted;
    CHECK(fit_round(t, n, err, ladder, 100) == 35u);
    CHECK(t == std::vector<uint32_t>{23, 23, 23, 47});
    // 20: by err, 0.5 (7), 0.3 (7); then 0.2's 7 would make 21 > 20; 0.15's 14 neither.
    t = wanted;
    CHECK(fit_round(t, n, err, ladder, 20) == 14u);
    CHECK(t == std::vector<uint32_t>{16, 23, 23, 33});
    t = wanted;
    CHECK(fit_round(t, n, err, ladder, 6) == 0u);
    CHECK(t == n);
}

TEST_SUITE("gpu") {
    TEST_CASE(
        "noise threshold: every pixel ends below T or at max-spp, and the rounds are samples 0 to n(p) of the seed") {
        VKMECH_REQUIRE_GPU(ctx);
        Renderer r = testing::project_scene_renderer(*ctx, "ring_caustic", 24);
        ThresholdSettings s;
        s.threshold = 0.15;
        s.min_spp = 8;
        s.max_spp = 256;
        s.seed = 3;
        const ThresholdResult res = render_to_threshold(r, s);
        const size_t P = res.frame.pixels.size();
        REQUIRE(res.err.size() == P);
        REQUIRE(res.n.size() == P);
        CHECK_FALSE(res.time_limit_reached);
        CHECK(res.unfinished == 0);
        CHECK(res.converged + res.at_max == P);
        // The final estimate, made again from the frame alone.
        const std::vector<double> err = relative_error(res.frame, Strategy::Guarded);
        const std::vector<uint32_t> n = pixel_samples(res.frame);
        CHECK(n == res.n);
        size_t bad = 0;
        for (size_t p = 0; p < P; ++p) bad += err[p] <= s.threshold || n[p] == s.max_spp ? 0 : 1;
        CHECK(bad == 0);
        // It adapted: the pixels did not all take the same samples, and some stopped below max-spp.
        const auto [lo, hi] = std::minmax_element(n.begin(), n.end());
        CHECK(*lo < *hi);
        CHECK(res.converged > 0);
        CHECK(res.rounds.size() >= 3);

        // The rounds are the samples [0, n(p)) of the seed: one render of those counts agrees to
        // the rounding of the merge order.
        RenderSpec once;
        once.seed = s.seed;
        once.sample_counts = res.n;
        const Frame single = r.render(once);
        CHECK(single.samples == res.frame.samples);
        size_t off = 0;
        for (size_t p = 0; p < P; ++p) {
            const PixelStats& a = res.frame.pixels[p];
            const PixelStats& b = single.pixels[p];
            auto close = [](double x, double y) { return std::abs(x - y) <= 1e-6 * std::max(1.0, std::abs(y)); };
            bool same = a.count == b.count && a.nonfinite == b.nonfinite && close(a.lum_mean, b.lum_mean) &&
                        close(a.lum_m2, b.lum_m2);
            for (int c = 0; c < 3; ++c) same = same && close(a.rgb_sum[c], b.rgb_sum[c]);
            for (uint32_t k = 0; k < gpu::BUCKET_COUNT; ++k) same = same && close(a.bucket_sum[k], b.bucket_sum[k]);
            off += same ? 0 : 1;
        }
        CHECK(off == 0);
    }

    TEST_CASE("noise threshold: the time limit holds within one round") {
        VKMECH_REQUIRE_GPU(ctx);
        Renderer r = testing::project_scene_renderer(*ctx, "glass_caustic", 32);
        ThresholdSettings s;
        s.threshold = 1e-4;  // out of reach: only max-spp or the time limit stops it
        s.min_spp = 4;
        s.max_spp = 1u << 20;
        s.time_limit = 1.5;
        const ThresholdResult res = render_to_threshold(r, s);
        CHECK(res.time_limit_reached);
        REQUIRE(res.rounds.size() >= 2);
        const ThresholdRound& last = res.rounds.back();
        CAPTURE(res.seconds);
        CAPTURE(last.seconds);
        CHECK(res.seconds <= s.time_limit + last.seconds + last.plan_seconds);
        CHECK(res.seconds >= 0.5 * s.time_limit);  // it used the time it had
        CHECK(res.unfinished > 0);
        CHECK(res.converged + res.at_max + res.unfinished == res.n.size());
    }

    TEST_CASE("noise threshold: a sample budget holds exactly and gives the same image every time") {
        VKMECH_REQUIRE_GPU(ctx);
        Renderer r = testing::project_scene_renderer(*ctx, "glass_caustic", 32);
        ThresholdSettings s;
        s.threshold = 1e-3;  // out of reach: the budget stops it
        s.min_spp = 8;
        s.max_spp = 4096;
        const ThresholdResult a0 = render_to_threshold(r, ThresholdSettings{1.0, 1, 1});  // the film's size
        const uint64_t pixels = a0.frame.pixels.size();
        s.sample_budget = 40 * pixels;
        const ThresholdResult a = render_to_threshold(r, s);
        CHECK(a.budget_reached);
        CHECK_FALSE(a.time_limit_reached);
        CHECK(a.frame.samples <= s.sample_budget);
        // The last round is cut to the samples left: less than one step of every pixel is left over.
        CHECK(a.frame.samples >= s.sample_budget - pixels * 20);
        CHECK(a.rounds.back().cut_by_time);
        const ThresholdResult b = render_to_threshold(r, s);
        CHECK(b.n == a.n);
        size_t differ = 0;
        for (size_t p = 0; p < pixels; ++p) differ += a.frame.pixels[p].lum_mean == b.frame.pixels[p].lum_mean ? 0 : 1;
        CHECK(differ == 0);
        const auto [lo, hi] = std::minmax_element(a.n.begin(), a.n.end());
        CHECK(*lo < *hi);
    }

    TEST_CASE("noise threshold: the CLI writes err and spp channels and says why the pixels stopped") {
        VKMECH_REQUIRE_GPU(ctx);
        testing::TempDir dir("threshold");
        const testing::CliRun run = testing::run_cli(
            "render --scene ring_caustic --res 24 --noise-threshold 0.2 "
            "--min-spp 8 --max-spp 128 --out " +
            dir.file("t"));
        CAPTURE(run.output);
        REQUIRE(run.code == 0);
        CHECK(run.output.find("noise threshold 0.2 (guarded rule)") != std::string::npos);
        const ExrImage img = read_exr_channels(dir.file("t/ring_caustic.exr"));
        REQUIRE(img.channels.count("err") == 1);
        REQUIRE(img.channels.count("spp") == 1);
        const auto& err = img.channels.at("err");
        const auto& spp = img.channels.at("spp");
        size_t bad = 0, below_max = 0;
        for (size_t p = 0; p < err.size(); ++p) {
            bad += err[p] <= 0.2f || spp[p] == 128.0f ? 0 : 1;
            below_max += spp[p] < 128.0f ? 1 : 0;
        }
        CHECK(bad == 0);
        CHECK(below_max > 0);
        std::ifstream json(dir.file("t/ring_caustic.json"));
        std::stringstream text;
        text << json.rdbuf();
        CHECK(text.str().find("\"noise_threshold\": {\"threshold\": 0.2, \"rule\": \"guarded\"") != std::string::npos);
        CHECK(text.str().find("\"converged_pixels\"") != std::string::npos);
    }
}

TEST_CASE("noise threshold: the CLI refuses what it cannot honour, saying why") {
    struct Bad {
        const char* args;
        const char* says;
    };
    for (const Bad& b :
         {Bad{"--noise-threshold 0.1 --spp 64", "--min-spp and --max-spp"},
          Bad{"--noise-threshold 0.1 --min-spp 64 --max-spp 32", "exceeds --max-spp"},
          Bad{"--min-spp 8", "--noise-threshold"}, Bad{"--noise-threshold 0.1 --adaptive guarded", "choose one"},
          Bad{"--noise-threshold 0.1 --sample-range 0:8", "--sample-range"},
          Bad{"--noise-threshold 0.1 --capture off", "--capture on"},
          Bad{"--noise-threshold 0.1 --noise-rule robust-var", "noise-rule"},
          Bad{"--noise-threshold 0", "noise-threshold"},
          Bad{"--noise-threshold 0.1 --spp-budget 8", "below --min-spp 16"}}) {
        testing::TempDir dir("threshold_bad");
        const testing::CliRun run =
            testing::run_cli(std::string("render --scene ring_caustic --res 16 ") + b.args + " --out " + dir.file("o"));
        CAPTURE(b.args);
        CAPTURE(run.output);
        CHECK(run.code == 2);
        CHECK(run.output.find(b.says) != std::string::npos);
    }
}
