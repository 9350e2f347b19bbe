// The pilot's guard rails (docs/descriptor.md §6.5): abstention
// of the bucket floor, untrusted pixels, and the `guarded` strategy. Expected
// values are worked out by hand in the comments; the GPU cases check that the
// guard stays silent on cubes_dof and speaks on a scene lit through a slit.
#include "adaptive/adaptive.hpp"
#include "allocation/allocation.hpp"
#include "cli_run.hpp"
#include "gpu_fixture.hpp"
#include "io/invariant.hpp"
#include "render_fixture.hpp"
#include "temp_dir.hpp"

#include <doctest/doctest.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <numeric>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

using namespace vkmech;
using namespace vkmech::alloc;

namespace {

bool bit_identical(const std::vector<double>& a, const std::vector<double>& b) {
    return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0);
}

uint64_t sum_of(const std::vector<uint32_t>& n) { return std::accumulate(n.begin(), n.end(), uint64_t{0}); }

// A pixel of a 4-sample pilot: `count` finite samples of mean luminance `lum`
// and variance `var`, all of its energy in `bucket`.
PixelStats pixel(double lum, double var, uint8_t bucket, double count = 4.0, double nonfinite = 0.0) {
    PixelStats s;
    s.count = count;
    s.nonfinite = nonfinite;
    s.lum_mean = lum;
    s.rgb_sum = {lum * count, lum * count, lum * count};
    s.lum_m2 = count > 1.0 ? var * (count - 1.0) : 0.0;
    s.bucket_sum[bucket] = lum * count;
    return s;
}

PixelStats dark() { return pixel(0.0, 0.0, gpu::BUCKET_DIRECT); }

// A w x h frame of lit diffuse-indirect pixels with distinct variances 0.5 + 0.01 p.
Frame lit_frame(int w, int h) {
    Frame f;
    f.width = w;
    f.height = h;
    for (int p = 0; p < w * h; ++p) f.pixels.push_back(pixel(1.0, 0.5 + 0.01 * p, gpu::BUCKET_DIFFUSE_INDIRECT));
    return f;
}

PixelStats& at(Frame& f, int x, int y) { return f.pixels[static_cast<size_t>(y) * f.width + x]; }

ScoreInputs inputs(const Pilot& pilot, const PilotDiagnosis& d) {
    ScoreInputs in;
    in.pilot_var = &pilot.var;
    in.pilot_labels = &pilot.labels;
    in.untrusted = &d.untrusted_map;
    return in;
}

}  // namespace

TEST_CASE("guard: without heavy-tailed pilot labels bucket-floor abstains and equals observed-var bit for bit") {
    // 8 x 6 lit pixels, labels direct (1) and diffuse_indirect (2) only.
    Frame f = lit_frame(8, 6);
    for (int x = 0; x < 8; x += 2) at(f, x, 2) = pixel(2.0, 0.25 + 0.1 * x, gpu::BUCKET_DIRECT);
    const Pilot pilot = make_pilot(f, {});
    const PilotDiagnosis d = diagnose_pilot(pilot);
    CHECK(d.pixels == 48);
    CHECK(d.labelled == 48);
    CHECK(d.heavy == 0);
    CHECK(d.floor_changed == 0);
    CHECK(d.floor_abstains);
    CHECK_FALSE(d.robust_checked);  // no median-of-means variance in this pilot
    CHECK(d.untrusted == 0);

    const ScoreInputs in = inputs(pilot, d);
    const auto obs = strategy_score(Strategy::ObservedVar, in, 0);
    CHECK(bit_identical(strategy_score(Strategy::BucketFloor, in, 0), obs));
    CHECK(bit_identical(strategy_score(Strategy::Guarded, in, 0), obs));
    const AdaptivePlan a = plan_allocation(Strategy::ObservedVar, in, 32, 1, 0);
    const AdaptivePlan b = plan_allocation(Strategy::BucketFloor, in, 32, 1, 0);
    CHECK(a.n == b.n);
    CHECK(a.total == b.total);

    // Heavy-tailed pixels whose variances are all equal: the floor (their
    // median, the same value) changes none of them, so it still abstains.
    Frame g = f;
    for (int x = 0; x < 8; ++x) at(g, x, 0) = pixel(1.0, 0.75, gpu::BUCKET_GLOSSY);
    const Pilot flat = make_pilot(g, {});
    const PilotDiagnosis df = diagnose_pilot(flat);
    CHECK(df.heavy == 8);
    CHECK(df.floor_changed == 0);
    CHECK(df.floor_abstains);
    const ScoreInputs fin = inputs(flat, df);
    CHECK(bit_identical(strategy_score(Strategy::BucketFloor, fin, 0), strategy_score(Strategy::ObservedVar, fin, 0)));

    // And where the floor acts it does not abstain: glossy variances
    // 0.1 .. 0.8 in row 0, median (0.4 + 0.5) / 2 = 0.45, so the four below
    // it (0.1, 0.2, 0.3, 0.4) are raised. The median-of-means map given here
    // has the same variances: robust-floor acts on the same four pixels.
    for (int x = 0; x < 8; ++x) at(g, x, 0) = pixel(1.0, 0.1 * (x + 1), gpu::BUCKET_GLOSSY);
    Pilot acting = make_pilot(g, {});
    acting.mom_var = acting.var;
    const PilotDiagnosis da = diagnose_pilot(acting);
    CHECK(da.heavy == 8);
    CHECK(da.floor_changed == 4);
    CHECK_FALSE(da.floor_abstains);
    CHECK(da.robust_checked);
    CHECK(da.robust_floor_changed == 4);
    CHECK_FALSE(da.robust_floor_abstains);
}

TEST_CASE("guard: with no untrusted pixel guarded equals bucket-floor bit for bit") {
    // Heavy-tailed row (the floor acts), every pixel lit with a positive variance.
    Frame f = lit_frame(8, 6);
    for (int x = 0; x < 8; ++x) at(f, x, 0) = pixel(1.0, 0.1 * (x + 1), gpu::BUCKET_DELTA_MEDIATED);
    // A light seen directly: zero variance, all energy emitter_direct: trusted.
    at(f, 4, 3) = pixel(10.0, 0.0, gpu::BUCKET_EMITTER_DIRECT);
    const Pilot pilot = make_pilot(f, {});
    const PilotDiagnosis d = diagnose_pilot(pilot);
    CHECK(d.untrusted == 0);
    CHECK(d.floor_changed == 4);
    const ScoreInputs in = inputs(pilot, d);
    const auto floor = strategy_score(Strategy::BucketFloor, in, 0);
    CHECK_FALSE(bit_identical(floor, strategy_score(Strategy::ObservedVar, in, 0)));
    CHECK(bit_identical(strategy_score(Strategy::Guarded, in, 0), floor));
    CHECK(plan_allocation(Strategy::Guarded, in, 32, 1, 0).n == plan_allocation(Strategy::BucketFloor, in, 32, 1, 0).n);
    // guard_score leaves any map alone when no pixel is untrusted.
    const std::vector<double> odd = {1.5, 0.0, -2.0, std::numeric_limits<double>::quiet_NaN()};
    CHECK(bit_identical(guard_score(odd, {0, 0, 0, 0}), odd));
}

TEST_CASE("guard: starved pixels of a synthetic pilot are flagged and guarded gives each at least the uniform share") {
    // 8 x 6 pilot of N0 = 4 (x right, y down):
    //   A (1,1) lit, zero variance                          -> lit without variance
    //   B (3,1) lit, 1 finite sample + 3 counted out         -> lit without variance
    //   C (5,1) a light seen directly (emitter_direct only)  -> trusted
    //   E (3,4) lit, variance +inf                           -> lit without variance
    //   D (1,3) dark inside lit pixels                       -> dark in a lit region
    //   block x 5..7, y 3..5 dark: (5,3) (6,3) (7,3) touch row 2 and (5,4) (5,5)
    //     touch column 4 -> dark in a lit region; (6,4) (7,4) (6,5) (7,5) see only
    //     dark pixels in their 3 x 3 windows -> trusted (truly black)
    //   row 0 glossy with variances 0.1 .. 0.8 (the floor acts on four).
    Frame f = lit_frame(8, 6);
    for (int x = 0; x < 8; ++x) at(f, x, 0) = pixel(1.0, 0.1 * (x + 1), gpu::BUCKET_GLOSSY);
    at(f, 1, 1) = pixel(1.0, 0.0, gpu::BUCKET_DIFFUSE_INDIRECT);
    at(f, 3, 1) = pixel(1.0, 0.0, gpu::BUCKET_DIFFUSE_INDIRECT, 1.0, 3.0);
    at(f, 5, 1) = pixel(10.0, 0.0, gpu::BUCKET_EMITTER_DIRECT);
    at(f, 3, 4).lum_m2 = std::numeric_limits<double>::infinity();
    at(f, 1, 3) = dark();
    for (int y = 3; y < 6; ++y)
        for (int x = 5; x < 8; ++x) at(f, x, y) = dark();
    const Pilot pilot = make_pilot(f, {});
    const PilotDiagnosis d = diagnose_pilot(pilot);
    CHECK(d.seen == 38);  // 48 - D - the 9 block pixels
    CHECK(d.labelled == 38);
    CHECK(d.lit_no_variance == 3);
    CHECK(d.dark_in_lit_region == 6);
    CHECK(d.untrusted == 9);
    CHECK(d.untrusted_share() == doctest::Approx(9.0 / 48.0));
    std::vector<uint8_t> expected(48, kTrusted);
    for (auto [x, y] : {std::pair{1, 1}, {3, 1}, {3, 4}}) expected[y * 8 + x] = kLitNoVariance;
    for (auto [x, y] : {std::pair{1, 3}, {5, 3}, {6, 3}, {7, 3}, {5, 4}, {5, 5}})
        expected[y * 8 + x] = kDarkInLitRegion;
    CHECK(d.untrusted_map == expected);

    // Observed-var starves them: score 0 (or not finite) -> the floor of 1.
    // Guarded gives each at least the uniform share of 1 + 32 = 33; every
    // strategy spends exactly 48 * 33 = 1584 samples.
    const ScoreInputs in = inputs(pilot, d);
    const AdaptivePlan obs = plan_allocation(Strategy::ObservedVar, in, 32, 1, 0);
    const AdaptivePlan floor = plan_allocation(Strategy::BucketFloor, in, 32, 1, 0);
    const AdaptivePlan guarded = plan_allocation(Strategy::Guarded, in, 32, 1, 0);
    const AdaptivePlan uniform = plan_allocation(Strategy::Uniform, in, 32, 1, 0);
    for (const AdaptivePlan* p : {&obs, &floor, &guarded, &uniform}) CHECK(sum_of(p->n) == 1584u);
    CHECK(uniform.n == std::vector<uint32_t>(48, 33u));
    size_t starved = 0, guarded_below = 0;
    for (size_t p = 0; p < 48; ++p) {
        if (expected[p] == kTrusted) continue;
        starved += obs.n[p] == 1 ? 1 : 0;
        guarded_below += guarded.n[p] < 33 ? 1 : 0;
    }
    CHECK(starved == 9);
    CHECK(guarded_below == 0);
    // Trusted pixels keep their bucket-floor scores bit for bit.
    const auto gs = strategy_score(Strategy::Guarded, in, 0), fs = strategy_score(Strategy::BucketFloor, in, 0);
    for (size_t p = 0; p < 48; ++p)
        if (expected[p] == kTrusted) CHECK(std::memcmp(&gs[p], &fs[p], sizeof(double)) == 0);
    // The same holds with the f = 4 control floor.
    const AdaptivePlan g4 = plan_allocation(Strategy::Guarded, in, 32, 4, 0);
    CHECK(sum_of(g4.n) == 1584u);
    for (size_t p = 0; p < 48; ++p)
        if (expected[p] != kTrusted) CHECK(g4.n[p] >= 33u);
}

TEST_CASE("guard: the guarded score by hand") {
    // D0 = 4 1 0 0, the last two untrusted: trusted weights 2 + 1 = 3,
    // untrusted weights 0 0; w = 3 / (4 - 2) = 1.5 and no untrusted weight
    // exceeds it -> D = 4 1 2.25 2.25 (mean weight (2 + 1 + 1.5 + 1.5) / 4 = 1.5).
    CHECK(guard_score({4, 1, 0, 0}, {0, 0, 1, 1}) == std::vector<double>{4, 1, 2.25, 2.25});
    // D0 = 1 1 100 NaN, the last two untrusted: trusted weights 1 + 1 = 2,
    // untrusted 10 and 0 (NaN weighs 0). w0 = 2 / 2 = 1 < 10, so 10 is kept:
    // w1 = (2 + 10) / 3 = 4 >= 0 -> D = 1 1 100 16 (weights 1 1 10 4, mean 4).
    const double nan = std::numeric_limits<double>::quiet_NaN();
    CHECK(guard_score({1, 1, 100, nan}, {0, 0, 1, 2}) == std::vector<double>{1, 1, 100, 16});
    // Neyman with 4 x 33 = 132 samples, floor 1: 128 shared over weights
    // summing to 16 -> 1 + 8 w = 9 9 81 33: the untrusted NaN pixel gets the
    // uniform share exactly.
    CHECK(neyman_allocation({1, 1, 100, 16}, 132, 1, 256) == std::vector<uint32_t>{9, 9, 81, 33});
    // Every pixel untrusted: nothing to trust, uniform.
    CHECK(guard_score({5, 0, nan}, {1, 2, 1}) == std::vector<double>{1, 1, 1});
    // Every weight zero: nothing to raise, D stays 0 (NaN -> 0), and Neyman's
    // all-zero rule shares uniformly.
    CHECK(guard_score({0, 0, nan}, {0, 1, 1}) == std::vector<double>{0, 0, 0});
    CHECK_THROWS_AS(guard_score({1, 2}, {0}), std::invalid_argument);
    ScoreInputs in;
    const std::vector<double> var = {1, 2};
    const std::vector<uint8_t> labels = {1, 1};
    in.pilot_var = &var;
    in.pilot_labels = &labels;
    CHECK_THROWS_WITH_AS(strategy_score(Strategy::Guarded, in, 0), doctest::Contains("untrusted"), InternalError);
    CHECK(parse_strategy("guarded") == Strategy::Guarded);
}

TEST_CASE("guard: the lit-region window is clipped at the image border and sizes are checked") {
    // 3 x 1: dark, lit, dark -> both dark pixels touch the lit one.
    Frame f;
    f.width = 3;
    f.height = 1;
    f.pixels = {dark(), pixel(1.0, 0.5, gpu::BUCKET_DIRECT), dark()};
    PilotDiagnosis d = diagnose_pilot(make_pilot(f, {}));
    CHECK(d.untrusted_map == std::vector<uint8_t>{kDarkInLitRegion, kTrusted, kDarkInLitRegion});
    // 4 x 1: lit, dark, dark, dark -> only the neighbour of the lit pixel.
    f.width = 4;
    f.pixels = {pixel(1.0, 0.5, gpu::BUCKET_DIRECT), dark(), dark(), dark()};
    d = diagnose_pilot(make_pilot(f, {}));
    CHECK(d.untrusted_map == std::vector<uint8_t>{kTrusted, kDarkInLitRegion, kTrusted, kTrusted});
    // A pixel whose every sample was counted out was seen, without a variance.
    f.pixels[3] = pixel(0.0, 0.0, gpu::BUCKET_DIRECT, 0.0, 4.0);
    d = diagnose_pilot(make_pilot(f, {}));
    CHECK(d.untrusted_map == std::vector<uint8_t>{kTrusted, kDarkInLitRegion, kDarkInLitRegion, kLitNoVariance});
    // An all-black pilot: nothing seen, nothing untrusted.
    f.pixels.assign(4, dark());
    d = diagnose_pilot(make_pilot(f, {}));
    CHECK(d.untrusted == 0);
    CHECK(d.seen == 0);

    const Pilot pilot = make_pilot(f, {});
    const std::vector<double> short_var = {1.0};
    CHECK_THROWS_WITH_AS(diagnose_pilot(pilot.frame, short_var, pilot.labels), doctest::Contains("variance map"),
                         std::invalid_argument);
    const std::vector<double> short_mom = {1.0, 2.0};
    CHECK_THROWS_WITH_AS(diagnose_pilot(pilot.frame, pilot.var, pilot.labels, &short_mom),
                         doctest::Contains("median-of-means"), std::invalid_argument);
}

TEST_SUITE("gpu") {
    TEST_CASE(
        "guard: on cubes_dof bucket-floor abstains and the guard is silent at N0 = 64 and flags only lit pixels at N0 "
        "= 4") {
        VKMECH_REQUIRE_GPU(ctx);
        Renderer r = testing::project_scene_renderer(*ctx, "cubes_dof", 32);

        // At the pilot the frozen curve was fitted on (64 spp) the pilot sees
        // every pixel with a usable variance: nothing is untrusted, and
        // observed-var, bucket-floor and guarded allocate identically.
        {
            const Pilot pilot = render_pilot(r, 64, downstream_seeds::pilot(0), true);
            const PilotDiagnosis d = diagnose_pilot(pilot);
            CHECK(d.pixels == 1024);
            CHECK(d.seen == 1024);
            CHECK(d.heavy == 0);
            CHECK(d.floor_abstains);
            CHECK(d.robust_checked);
            CHECK(d.robust_floor_abstains);
            CHECK(d.untrusted == 0);
            const ScoreInputs in = inputs(pilot, d);
            const AdaptivePlan obs = plan_allocation(Strategy::ObservedVar, in, 32, 1, 0);
            CHECK(plan_allocation(Strategy::BucketFloor, in, 32, 1, 0).n == obs.n);
            CHECK(plan_allocation(Strategy::Guarded, in, 32, 1, 0).n == obs.n);
        }

        // At N0 = 4 the near cube's camera-facing side, lit only indirectly,
        // is black in a few per cent of the pilot's pixels (18 to 26 of 1024 on
        // lavapipe, draws 0-2). The guard flags them, and rightly: a converged
        // render (1024 spp) shows every flagged pixel lit. No pixel is seen
        // without a usable variance, and bucket-floor still abstains.
        RenderSpec ref_spec;
        ref_spec.spp = 1024;
        ref_spec.seed = downstream_seeds::reference_chunk(0);
        ref_spec.batch_spp = 64;
        const Frame ref = r.render(ref_spec);
        for (uint32_t draw = 0; draw < 3; ++draw) {
            INFO("N0 = 4, draw " << draw);
            const Pilot pilot = render_pilot(r, 4, downstream_seeds::pilot(draw), false);
            const PilotDiagnosis d = diagnose_pilot(pilot);
            CHECK(d.heavy == 0);
            CHECK(d.floor_abstains);
            CHECK(d.lit_no_variance == 0);
            CHECK(d.untrusted > 0);
            CHECK(d.untrusted_share() < 0.05);
            size_t false_alarms = 0;
            for (size_t p = 0; p < d.pixels; ++p)
                if (d.untrusted_map[p] != kTrusted && !(ref.pixels[p].lum_mean > 0.0)) ++false_alarms;
            CHECK(false_alarms == 0);
            const ScoreInputs in = inputs(pilot, d);
            const AdaptivePlan floor = plan_allocation(Strategy::BucketFloor, in, 32, 1, draw);
            const AdaptivePlan guarded = plan_allocation(Strategy::Guarded, in, 32, 1, draw);
            CHECK(sum_of(guarded.n) == sum_of(floor.n));
            size_t starved = 0, below = 0;
            for (size_t p = 0; p < d.pixels; ++p) {
                if (d.untrusted_map[p] == kTrusted) continue;
                starved += floor.n[p] < 33 ? 1 : 0;
                below += guarded.n[p] < 33 ? 1 : 0;
            }
            CHECK(starved == d.untrusted);  // bucket-floor (= observed-var here) gives them less than uniform
            CHECK(below == 0);
        }
    }

    TEST_CASE("guard: render --adaptive says when bucket-floor abstains and what the reliability covers") {
        VKMECH_REQUIRE_GPU(ctx);
        testing::TempDir dir("guard_cli");
        auto r = testing::run_cli("render --scene cubes_dof --res 16 --adaptive guarded --pilot 64 --budget 4 --out " +
                                  dir.file("out"));
        INFO(r.output);
        REQUIRE(r.code == 0);
        CHECK(r.output.find("bucket-floor: no heavy-tailed pilot pixels, identical to observed-var") !=
              std::string::npos);
        CHECK(r.output.find("guarded: no untrusted pilot pixels, identical to bucket-floor") != std::string::npos);
        CHECK(r.output.find("predicted label reliability of the 256 of 256 pixels the pilot labelled, not of the 0 it "
                            "left unlabelled") != std::string::npos);
        CHECK(r.output.find("warning: pilot") == std::string::npos);
        std::ifstream json(dir.file("out") + "/cubes_dof.json");
        std::stringstream ss;
        ss << json.rdbuf();
        const std::string j = ss.str();
        CHECK(j.find("\"adaptive\": {\"strategy\": \"guarded\"") != std::string::npos);
        CHECK(j.find("\"bucket_floor_abstains\": true") != std::string::npos);
        CHECK(j.find("robust_floor") == std::string::npos);  // guarded renders no median-of-means pilot
        CHECK(j.find("\"untrusted_pixels\": 0,") != std::string::npos);
        CHECK(j.find("\"labelled_pixels\": ") != std::string::npos);  // the existing keys stay
        CHECK(j.find("\"buckets\": {") != std::string::npos);
        // At N0 = 4 the same scene has starved pixels (previous case): observed-var warns.
        r = testing::run_cli("render --scene cubes_dof --res 32 --adaptive observed-var --pilot 4 --budget 4 --out " +
                             dir.file("out4"));
        INFO(r.output);
        REQUIRE(r.code == 0);
        CHECK(r.output.find("vkmech: warning: pilot: ") != std::string::npos);
        CHECK(r.output.find("dark beside seen pixels; observed-var can starve them") != std::string::npos);
        CHECK(r.output.find("bucket-floor: ") == std::string::npos);  // said only for the strategies that floor
    }

    TEST_CASE("guard: render --adaptive warns on a room lit through a slit and guarded keeps the uniform share there") {
        VKMECH_REQUIRE_GPU(ctx);
        testing::TempDir dir("guard_slit");
        // The ajar-door mode in small: a floor under a ceiling with a 0.1 m slit
        // above x = 0.25; the light sits above the slit. The camera, under the
        // ceiling, sees the floor from x = -0.33 to 0.33: the right part is lit
        // through the slit, the left only by light bounced off the ceiling
        // from the lit patch, which a 2-sample pilot mostly misses.
        std::ofstream(dir.file("slit.xml")) << R"(<scene version="3.0.0">
    <sensor type="perspective">
        <float name="fov" value="40"/>
        <transform name="to_world"><lookat origin="0, 0, 0.9" target="0, 0, 0" up="0, 1, 0"/></transform>
    </sensor>
    <shape type="rectangle"><transform name="to_world"><scale value="10"/></transform><bsdf type="diffuse"/></shape>
    <shape type="rectangle">
        <transform name="to_world"><scale x="5.1" y="10"/><rotate x="1" angle="180"/><translate x="-4.9" z="1"/></transform>
        <bsdf type="diffuse"/>
    </shape>
    <shape type="rectangle">
        <transform name="to_world"><scale x="5" y="10"/><rotate x="1" angle="180"/><translate x="5.3" z="1"/></transform>
        <bsdf type="diffuse"/>
    </shape>
    <shape type="rectangle">
        <transform name="to_world"><scale x="0.05" y="10"/><rotate x="1" angle="180"/><translate x="0.25" z="1.5"/></transform>
        <emitter type="area"><rgb name="radiance" value="20, 20, 20"/></emitter>
    </shape>
</scene>
)";
        auto untrusted_below = [](const std::string& out) {
            const auto at = out.find("untrusted pixels: n(p) from");
            if (at == std::string::npos) return -1L;
            const auto semi = out.find("; ", at);
            return std::stol(out.substr(semi + 2));
        };
        const std::string base = "render --scene " + dir.file("slit.xml") + " --res 24 --pilot 2 --budget 8 --out ";
        auto r = testing::run_cli(base + dir.file("obs") + " --adaptive observed-var");
        INFO(r.output);
        REQUIRE(r.code == 0);
        CHECK(r.output.find("vkmech: warning: pilot: ") != std::string::npos);
        CHECK(r.output.find("`--adaptive guarded`") != std::string::npos);
        CHECK(untrusted_below(r.output) > 0);  // observed-var starves some of them
        r = testing::run_cli(base + dir.file("guarded") + " --adaptive guarded");
        INFO(r.output);
        REQUIRE(r.code == 0);
        CHECK(r.output.find("have no trustworthy pilot variance") != std::string::npos);
        CHECK(r.output.find("each gets at least the uniform share") != std::string::npos);
        CHECK(untrusted_below(r.output) == 0);
    }
}

TEST_CASE("guard: the heavy and the constant classes are the caller's, as a taxonomy declares them") {
    // Row 0: class 1 (the paper's direct, light-tailed) with variances 0.1 .. 0.8; everything else
    // class 2 (diffuse_indirect) except one zero-variance pixel lit by class 0 alone.
    Frame f = lit_frame(8, 6);
    for (int x = 0; x < 8; ++x) at(f, x, 0) = pixel(1.0, 0.1 * (x + 1), 1);
    at(f, 4, 3) = pixel(10.0, 0.0, 0);
    const Pilot pilot = make_pilot(f, {});
    // The paper's buckets: no heavy label, and class 0 is emitter_direct, trusted at zero variance.
    const PilotDiagnosis paper = diagnose_pilot(pilot);
    CHECK(paper.heavy == 0);
    CHECK(paper.floor_abstains);
    CHECK(paper.untrusted == 0);
    // A taxonomy whose class 1 is heavy and whose constant class is 2: row 0 is floored at its median
    // (0.45: four pixels raised), and the pixel lit by class 0 alone is no longer vouched for.
    ClassTraits t;
    t.heavy = 1u << 1;
    t.constant = 1u << 2;
    const PilotDiagnosis d = diagnose_pilot(pilot, t);
    CHECK(d.heavy == 8);
    CHECK(d.floor_changed == 4);
    CHECK(d.lit_no_variance == 1);
    CHECK(d.untrusted_map[3 * 8 + 4] == kLitNoVariance);
    ScoreInputs in = inputs(pilot, d);
    in.heavy = t.heavy;
    const std::vector<double> floor = strategy_score(Strategy::BucketFloor, in, 0);
    CHECK(floor == bucket_floor(pilot.var, pilot.labels, t.heavy));
    for (int x = 0; x < 8; ++x) CHECK(floor[static_cast<size_t>(x)] == doctest::Approx(std::max(0.1 * (x + 1), 0.45)));
    // No heavy class at all: every floor abstains, bit for bit.
    in.heavy = 0;
    CHECK(bit_identical(strategy_score(Strategy::BucketFloor, in, 0), pilot.var));
    CHECK(diagnose_pilot(pilot, ClassTraits{0, 0}).floor_abstains);
}
