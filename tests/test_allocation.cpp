// Downstream allocation library (docs/descriptor.md §6, paper §7): every expected value
// below is a literal worked out by hand, with the working in the comment next
// to it, never a value produced by the code under test. Property tests
// (exact totals, class sizes, determinism) compare the code with invariants
// that hold for every input.
#include "allocation/allocation.hpp"
#include "io/invariant.hpp"
#include "stats/split_half.hpp"

#include <doctest/doctest.h>

#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <string>
#include <vector>

using namespace vkmech::alloc;

namespace {

const double kNaN = std::numeric_limits<double>::quiet_NaN();
const double kInf = std::numeric_limits<double>::infinity();

uint64_t sum_of(const std::vector<uint32_t>& n) { return std::accumulate(n.begin(), n.end(), uint64_t{0}); }

bool bit_identical(const std::vector<double>& a, const std::vector<double>& b) {
    return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0);
}

double uniform01(uint64_t& state) {
    return static_cast<double>(vkmech::stats::splitmix64_next(state) >> 11) * 0x1.0p-53;
}

// A random per-pixel variance field mixing light pixels, heavy outliers,
// zeros and (optionally) non-finite values.
std::vector<double> random_field(uint64_t& state, size_t n, bool with_nonfinite) {
    std::vector<double> d(n);
    for (size_t i = 0; i < n; ++i) {
        const double u = uniform01(state);
        const double r = uniform01(state);
        if (u < 0.1)
            d[i] = 0.0;
        else if (u < 0.2)
            d[i] = 1e6 * r;  // heavy outliers
        else if (with_nonfinite && u < 0.23)
            d[i] = (r < 0.5) ? kNaN : kInf;
        else if (u < 0.26)
            d[i] = -r;  // negative: treated as 0
        else
            d[i] = r * r;
    }
    return d;
}

std::vector<uint8_t> random_labels(uint64_t& state, size_t n) {
    static const uint8_t kClasses[] = {0, 1, 2, 3, 4, 5, 6, 255};
    std::vector<uint8_t> l(n);
    for (auto& v : l) v = kClasses[vkmech::stats::uniform_below(state, 8)];
    return l;
}

std::array<size_t, 256> class_sizes(const std::vector<uint8_t>& l) {
    std::array<size_t, 256> c{};
    for (uint8_t v : l) ++c[v];
    return c;
}

}  // namespace

// ---------------------------------------------------------------------------
// Strategy names

TEST_CASE("allocation: strategy names round-trip and unknown names are refused") {
    CHECK(std::string(to_string(Strategy::Uniform)) == "uniform");
    CHECK(std::string(to_string(Strategy::ObservedVar)) == "observed-var");
    CHECK(std::string(to_string(Strategy::Oracle)) == "oracle");
    CHECK(std::string(to_string(Strategy::BucketFloor)) == "bucket-floor");
    CHECK(std::string(to_string(Strategy::Placebo)) == "placebo");
    CHECK(std::string(to_string(Strategy::LabelOracle)) == "label-oracle");
    CHECK(std::string(to_string(Strategy::RobustVar)) == "robust-var");
    CHECK(std::string(to_string(Strategy::RobustFloor)) == "robust-floor");
    CHECK(std::string(to_string(Strategy::RobustPlacebo)) == "robust-placebo");
    CHECK(std::string(to_string(Strategy::Guarded)) == "guarded");
    for (Strategy s : kAllStrategies) CHECK(parse_strategy(to_string(s)) == s);
    CHECK_THROWS_WITH_AS(parse_strategy("bucket_floor"), doctest::Contains("observed-var, oracle, bucket-floor"),
                         std::invalid_argument);
    CHECK_THROWS_WITH_AS(parse_strategy(""), doctest::Contains("robust-placebo"), std::invalid_argument);
    CHECK(needs_mom(Strategy::RobustVar));
    CHECK(needs_mom(Strategy::RobustFloor));
    CHECK(needs_mom(Strategy::RobustPlacebo));
    CHECK_FALSE(needs_mom(Strategy::BucketFloor));
}

// ---------------------------------------------------------------------------
// Neyman allocation

TEST_CASE("allocation: Neyman hand case with largest remainder") {
    // D = {1, 4, 9, 0}, total 12, floor 1: R = 12 - 4 = 8 shared as
    // sqrt(D) = 1:2:3:0 (sum 6): 8/6 = 1.333, 16/6 = 2.667, 24/6 = 4, 0.
    // Targets 2.333, 3.667, 5, 1 -> floors 2, 3, 5, 1 (sum 11); one sample
    // missing goes to the largest remainder 0.667 (pixel 1) -> {2, 4, 5, 1}.
    size_t bad = 99;
    const auto n = neyman_allocation({1.0, 4.0, 9.0, 0.0}, 12, 1, 256, &bad);
    CHECK(n == std::vector<uint32_t>{2, 4, 5, 1});
    CHECK(bad == 0);

    // Same D, floor 4 (the f = 4 control), total 24: R = 24 - 16 = 8 is shared
    // exactly as above on top of 4 -> {4+1.333, 4+2.667, 4+4, 4} -> {5, 7, 8, 4}.
    CHECK(neyman_allocation({1.0, 4.0, 9.0, 0.0}, 24, 4) == std::vector<uint32_t>{5, 7, 8, 4});

    // Ties go to the lower index: D = {1, 1, 1}, total 5, floor 1: R = 2,
    // 2/3 each -> targets 1.667 x3 -> floors 1, 1, 1 (sum 3), 2 missing go
    // to pixels 0 and 1 -> {2, 2, 1}.
    CHECK(neyman_allocation({1.0, 1.0, 1.0}, 5, 1) == std::vector<uint32_t>{2, 2, 1});
}

TEST_CASE("allocation: Neyman cap water-filling") {
    // D = {100, 64, 1, 0}, floor 1, cap 10, total 24: R = 20.
    // Round 1: sqrt(D) = 10, 8, 1, 0 (sum 19): pixel 0 target 1 + 200/19 =
    //   11.5 > 10 -> fixed at 10 (uses 9 of R).
    // Round 2: R = 11 over weights 8, 1, 0 (sum 9): pixel 1 target
    //   1 + 88/9 = 10.8 > 10 -> fixed at 10 (uses 9).
    // Round 3: R = 2 over weights 1, 0: pixel 2 gets 1 + 2 = 3, pixel 3 gets 1.
    // -> {10, 10, 3, 1}, sum 24.
    CHECK(neyman_allocation({100.0, 64.0, 1.0, 0.0}, 24, 1, 10) == std::vector<uint32_t>{10, 10, 3, 1});

    // D = {100, 1, 1, 1}, floor 1, cap 10, total 20: R = 16; weights 10, 1, 1, 1
    // (sum 13): pixel 0 target 1 + 160/13 = 13.3 > 10 -> 10 (uses 9). R = 7
    // over three equal weights: 7/3 = 2.333 -> targets 3.333 x3 -> floors
    // 3, 3, 3 + 10 = 19; the missing sample goes to the lowest index tied
    // remainder (pixel 1) -> {10, 4, 3, 3}.
    CHECK(neyman_allocation({100.0, 1.0, 1.0, 1.0}, 20, 1, 10) == std::vector<uint32_t>{10, 4, 3, 3});

    // Budget left after every positive-weight pixel is capped goes uniformly
    // to the zero-weight pixels: D = {4, 0, 0}, floor 1, cap 5, total 12:
    // R = 9, pixel 0 target 10 > 5 -> 5 (uses 4); R = 5 over two zero
    // weights -> 2.5 each -> targets 3.5, 3.5 -> floors 3, 3 + 5 = 11; the
    // missing sample goes to pixel 1 -> {5, 4, 3}.
    CHECK(neyman_allocation({4.0, 0.0, 0.0}, 12, 1, 5) == std::vector<uint32_t>{5, 4, 3});

    // total == cap * P: everyone at the cap whatever D is.
    CHECK(neyman_allocation({0.0, 9.0, kNaN}, 12, 1, 4) == std::vector<uint32_t>{4, 4, 4});
    // total == floor * P: everyone at the floor.
    CHECK(neyman_allocation({0.0, 9.0, 1e9}, 12, 4, 256) == std::vector<uint32_t>{4, 4, 4});
}

TEST_CASE("allocation: Neyman degenerate scores share uniformly and count non-finite") {
    // All zero: R = 10 - 3 = 7, 7/3 = 2.333 each -> targets 3.333 -> floors
    // 3, 3, 3 (sum 9); the missing sample goes to pixel 0 -> {4, 3, 3}.
    size_t bad = 99;
    CHECK(neyman_allocation({0.0, 0.0, 0.0}, 10, 1, 256, &bad) == std::vector<uint32_t>{4, 3, 3});
    CHECK(bad == 0);
    // All non-finite (NaN, +inf, -inf): treated as 0, same result, 3 counted.
    CHECK(neyman_allocation({kNaN, kInf, -kInf}, 10, 1, 256, &bad) == std::vector<uint32_t>{4, 3, 3});
    CHECK(bad == 3);
    // Mixed: NaN -> 0; D = {NaN, 1, 4}, total 9, floor 1: R = 6 over weights
    // 0, 1, 2 -> 0, 2, 4 -> {1, 3, 5}; one non-finite.
    CHECK(neyman_allocation({kNaN, 1.0, 4.0}, 9, 1, 256, &bad) == std::vector<uint32_t>{1, 3, 5});
    CHECK(bad == 1);
    // Negative D is clamped to 0 (not counted as non-finite): D = {-1, 1},
    // total 6, floor 1: R = 4 all to pixel 1 -> {1, 5}.
    CHECK(neyman_allocation({-1.0, 1.0}, 6, 1, 256, &bad) == std::vector<uint32_t>{1, 5});
    CHECK(bad == 0);
    // Empty image, total 0.
    CHECK(neyman_allocation({}, 0, 1, 256, &bad).empty());
    CHECK(bad == 0);
}

TEST_CASE("allocation: Neyman refuses impossible totals") {
    // P = 4, floor 1 -> total >= 4; cap 2 -> total <= 8.
    const std::vector<double> d = {1.0, 2.0, 3.0, 4.0};
    CHECK_THROWS_AS(neyman_allocation(d, 3, 1, 256), std::invalid_argument);
    CHECK_THROWS_AS(neyman_allocation(d, 9, 1, 2), std::invalid_argument);
    CHECK_THROWS_AS(neyman_allocation(d, 15, 4, 256), std::invalid_argument);  // 15 < 4 * 4
    CHECK_THROWS_AS(neyman_allocation(d, 8, 5, 4), std::invalid_argument);     // floor > cap
    CHECK_THROWS_AS(neyman_allocation({}, 1, 1, 256), std::invalid_argument);  // 1 > cap * 0
    CHECK_NOTHROW(neyman_allocation(d, 4, 1, 2));
    CHECK_NOTHROW(neyman_allocation(d, 8, 1, 2));
}

TEST_CASE("allocation: Neyman totals are exact and bounds honoured on random inputs") {
    uint64_t state = 20240611;
    const uint32_t caps[] = {4, 8, 33, 64, 256};
    int cases = 0;
    for (int iter = 0; iter < 400; ++iter) {
        const size_t P = 1 + static_cast<size_t>(vkmech::stats::uniform_below(state, 700));
        const auto d = random_field(state, P, iter % 2 == 0);
        for (uint32_t floor : {1u, 4u}) {
            for (uint32_t cap : caps) {
                if (cap < floor) continue;
                const uint64_t lo = uint64_t{floor} * P, hi = uint64_t{cap} * P;
                // A random feasible total, plus the two extremes now and then.
                uint64_t total = lo + vkmech::stats::uniform_below(state, hi - lo + 1);
                if (iter % 37 == 0) total = lo;
                if (iter % 41 == 0) total = hi;
                const auto n = neyman_allocation(d, total, floor, cap);
                REQUIRE(n.size() == P);
                CHECK(sum_of(n) == total);
                bool in_bounds = true;
                for (uint32_t v : n) in_bounds = in_bounds && v >= floor && v <= cap;
                CHECK(in_bounds);
                ++cases;
            }
        }
    }
    CHECK(cases == 4000);  // 400 inputs x 2 floors x 5 caps (every cap >= 4, none skipped)
}

TEST_CASE("allocation: study budget and identical totals across strategies") {
    // 256^2 pixels, baseline 1 + extra 32: total = 65536 * 33 = 2162688.
    CHECK(study_total(65536) == 2162688u);
    CHECK(study_total(65536, 128) == 65536u * 129u);

    // Uniform at the study budget: 33 samples per pixel, exactly.
    const size_t P = 64 * 64;
    const std::vector<double> ones(P, 1.0);
    const auto u = neyman_allocation(ones, study_total(P), kStudyBaselineSpp, kStudyPoolFrames);
    CHECK(u == std::vector<uint32_t>(P, 33u));

    uint64_t state = 7;
    const auto pilot = random_field(state, P, false);
    const auto oracle = random_field(state, P, false);
    const auto mom = random_field(state, P, true);
    const auto labels = random_labels(state, P);
    const auto ref_labels = random_labels(state, P);
    std::vector<uint8_t> untrusted(P);
    for (auto& u : untrusted) u = vkmech::stats::uniform_below(state, 10) == 0 ? 1 : 0;
    ScoreInputs in;
    in.pilot_var = &pilot;
    in.pilot_labels = &labels;
    in.oracle_var = &oracle;
    in.reference_labels = &ref_labels;
    in.mom_var = &mom;
    in.untrusted = &untrusted;
    in.pilot_spp = 16;
    for (uint32_t floor : {kStudyBaselineSpp, kStudyControlFloor}) {
        for (Strategy s : kAllStrategies) {
            const auto d = strategy_score(s, in, 12345);
            REQUIRE(d.size() == P);
            const auto n = neyman_allocation(d, study_total(P), floor, kStudyPoolFrames);
            CHECK(sum_of(n) == 135168u);  // 4096 * 33 for every strategy
            uint32_t lo = 1000;
            for (uint32_t v : n) lo = std::min(lo, v);
            CHECK(lo >= floor);
        }
    }
}

// ---------------------------------------------------------------------------
// Bucket floor and placebo

TEST_CASE("allocation: bucket floor hand case") {
    // labels:   3    3    3    1    1    4    4    255  5    2
    // var:      1    5    3    0.5  2    10   7    4    0.25 0.1
    // glossy (3): {1, 5, 3}, median 3 -> max(1,3)=3, 5, max(3,3)=3
    // direct (1), diffuse (2), 255: light/unlabelled -> unchanged
    // delta (4): {10, 7}, median (7 + 10) / 2 = 8.5 -> 10, 8.5
    // specular (5): single pixel, median = itself -> 0.25
    const std::vector<double> var = {1, 5, 3, 0.5, 2, 10, 7, 4, 0.25, 0.1};
    const std::vector<uint8_t> lab = {3, 3, 3, 1, 1, 4, 4, 255, 5, 2};
    const auto d = bucket_floor(var, lab);
    CHECK(d == std::vector<double>{3, 5, 3, 0.5, 2, 10, 8.5, 4, 0.25, 0.1});

    // Light pixels with a small variance are NOT floored even when their
    // class median is larger: direct (1) {0.1, 9, 8} stays as is.
    CHECK(bucket_floor({0.1, 9, 8}, {1, 1, 1}) == std::vector<double>{0.1, 9, 8});

    // Non-finite variances: the median is over the finite values of the
    // class; a non-finite pixel passes through. glossy {NaN, 2, 6, 1}:
    // finite {2, 6, 1}, median 2 -> NaN, 2, 6, 2.
    const auto e = bucket_floor({kNaN, 2, 6, 1}, {3, 3, 3, 3});
    CHECK(std::isnan(e[0]));
    CHECK(e[1] == 2.0);
    CHECK(e[2] == 6.0);
    CHECK(e[3] == 2.0);

    CHECK_THROWS_AS(bucket_floor({1.0, 2.0}, {3}), std::invalid_argument);
    CHECK(bucket_floor({}, {}).empty());
}

TEST_CASE("allocation: bucket floor without heavy labels is bit-identical to its input") {
    // A cubes_dof-like map: only direct (1) and diffuse_indirect (2), plus the
    // unlabelled class and the other light classes 0 and 6; odd values (-0.0,
    // NaN, denormals) included so any arithmetic would show in the bits.
    std::vector<double> var = {0.3, -0.0, kNaN, 1e-310, 7.0, 0.1, 2.5, kInf};
    const std::vector<uint8_t> lab = {1, 2, 1, 2, 255, 0, 6, 1};
    const auto d = bucket_floor(var, lab);
    CHECK(bit_identical(d, var));

    uint64_t state = 99;
    auto big = random_field(state, 5000, true);
    std::vector<uint8_t> big_lab(big.size());
    for (size_t i = 0; i < big.size(); ++i) big_lab[i] = (i % 3 == 0) ? 2 : 1;
    CHECK(bit_identical(bucket_floor(big, big_lab), big));
}

TEST_CASE("allocation: placebo labels keep class sizes and are seeded") {
    // 1000 pixels: 300 x 1, 200 x 2, 150 x 3, 100 x 4, 50 x 5, 50 x 6,
    // 50 x 0, 100 x 255, laid out in contiguous runs.
    std::vector<uint8_t> lab;
    const std::pair<uint8_t, int> runs[] = {{1, 300}, {2, 200}, {3, 150}, {4, 100},
                                            {5, 50},  {6, 50},  {0, 50},  {255, 100}};
    for (auto [c, k] : runs) lab.insert(lab.end(), static_cast<size_t>(k), c);
    REQUIRE(lab.size() == 1000);

    const auto a = placebo_labels(lab, 1);
    const auto a2 = placebo_labels(lab, 1);
    const auto b = placebo_labels(lab, 2);
    CHECK(class_sizes(a) == class_sizes(lab));
    CHECK(class_sizes(b) == class_sizes(lab));
    CHECK(class_sizes(a)[255] == 100);
    CHECK(a == a2);   // deterministic per seed
    CHECK(a != lab);  // shuffled
    CHECK(a != b);    // differs across seeds
    // A shuffle of contiguous runs leaves far fewer pixels in place than
    // the run layout: expected matches = sum_c n_c^2 / 1000 =
    // (90000 + 40000 + 22500 + 10000 + 2500 * 3 + 10000) / 1000 = 180.
    int same = 0;
    for (size_t i = 0; i < lab.size(); ++i) same += (a[i] == lab[i]);
    CHECK(same < 400);

    // Trivial maps: empty, one pixel, one class.
    CHECK(placebo_labels({}, 5).empty());
    CHECK(placebo_labels({4}, 5) == std::vector<uint8_t>{4});
    CHECK(placebo_labels(std::vector<uint8_t>(10, 3), 5) == std::vector<uint8_t>(10, 3));
}

// ---------------------------------------------------------------------------
// Median-of-means

TEST_CASE("allocation: median-of-means block rule") {
    // k = ceil(sqrt(N0)); size = floor(N0 / k); remainder discarded.
    CHECK(mom_block_count(1) == 1);
    CHECK(mom_block_count(4) == 2);
    CHECK(mom_block_count(9) == 3);
    CHECK(mom_block_count(10) == 4);  // sqrt(10) = 3.16
    CHECK(mom_block_count(16) == 4);
    CHECK(mom_block_count(17) == 5);
    CHECK(mom_block_count(64) == 8);
    CHECK(mom_block_size(9) == 3);
    CHECK(mom_block_size(16) == 4);
    CHECK(mom_block_size(64) == 8);
    CHECK(mom_discarded(9) == 0);
    CHECK(mom_discarded(16) == 0);
    CHECK(mom_discarded(64) == 0);
    CHECK(mom_block_size(13) == 3);  // k = 4, 13 / 4 = 3
    CHECK(mom_discarded(13) == 1);   // 13 - 12
    CHECK(mom_block_size(17) == 3);  // k = 5, 17 / 5 = 3
    CHECK(mom_discarded(17) == 2);   // 17 - 15
    // N0 = 4: k = 2 blocks of 2 -> refused.
    CHECK_THROWS_WITH_AS(mom_block_size(4),
                         "median-of-means needs blocks of at least 3 samples; N0 = 4 gives 2 blocks of 2: not defined",
                         std::invalid_argument);
    CHECK_THROWS_WITH_AS(mom_discarded(4), doctest::Contains("N0 = 4"), std::invalid_argument);
    // N0 = 10: k = 4 blocks of 2 -> refused too.
    CHECK_THROWS_WITH_AS(mom_block_size(10), doctest::Contains("4 blocks of 2: not defined"), std::invalid_argument);
    CHECK_THROWS_AS(mom_block_count(0), std::invalid_argument);

    // Explicit k (block-count sweep): N0 = 16, k = 8 -> blocks of 2 allowed;
    // N0 = 16, k = 5 -> 3, 1 discarded; k = 9 -> blocks of 1 refused.
    CHECK(mom_block_size(16, 8) == 2);
    CHECK(mom_block_size(16, 5) == 3);
    CHECK(mom_discarded(16, 5) == 1);
    CHECK_THROWS_AS(mom_block_size(16, 9), std::invalid_argument);
    CHECK_THROWS_AS(mom_block_size(16, 0), std::invalid_argument);
}

TEST_CASE("allocation: median-of-means variance hand case") {
    // Welford moments of three blocks of three samples:
    //   {1, 2, 3}: mean 2, m2 = 1 + 0 + 1 = 2,      var 2/2 = 1
    //   {0, 0, 6}: mean 2, m2 = 4 + 4 + 16 = 24,    var 24/2 = 12
    //   {2, 4, 6}: mean 4, m2 = 4 + 0 + 4 = 8,      var 8/2 = 4
    const double samples[3][3] = {{1, 2, 3}, {0, 0, 6}, {2, 4, 6}};
    BlockMoments m[3];
    for (int b = 0; b < 3; ++b)
        for (double x : samples[b]) accumulate(m[b], x);
    CHECK(m[0].n == 3.0);
    CHECK(m[0].mean == doctest::Approx(2.0));
    CHECK(m[0].m2 == doctest::Approx(2.0));
    CHECK(m[1].mean == doctest::Approx(2.0));
    CHECK(m[1].m2 == doctest::Approx(24.0));
    CHECK(m[2].mean == doctest::Approx(4.0));
    CHECK(m[2].m2 == doctest::Approx(8.0));

    // Pixel 0: the three blocks above -> median of {1, 12, 4} = 4.
    // Pixel 1: literal moments with variances 1, 10, 7 (m2 = 2, 20, 14 over
    //          n = 3) -> median 7.
    // Pixel 2: a zero-spread block and two others: variances 0, 3, 5 -> 3.
    const std::vector<std::vector<BlockMoments>> blocks = {
        {{3, 2, 2}, {3, 0, 2}, {3, 1, 0}},
        {{3, 2, 24}, {3, 0, 20}, {3, 1, 6}},
        {{3, 4, 8}, {3, 0, 14}, {3, 1, 10}},
    };
    const auto v = mom_variance(blocks);
    REQUIRE(v.size() == 3);
    CHECK(v[0] == doctest::Approx(4.0));
    CHECK(v[1] == doctest::Approx(7.0));
    CHECK(v[2] == doctest::Approx(3.0));

    // Even block count: variances 1, 3, 5, 100 (m2 = 3, 9, 15, 300 over
    // n = 4) -> median (3 + 5) / 2 = 4; the outlier block does not move it.
    const std::vector<std::vector<BlockMoments>> four = {{{4, 0, 3}}, {{4, 0, 300}}, {{4, 0, 9}}, {{4, 0, 15}}};
    CHECK(mom_variance(four)[0] == doctest::Approx(4.0));

    // A block left with one finite sample has no variance and is dropped: the median of the others (m2 = 1, 9
    // over n = 3 -> 0.5, 4.5 -> 2.5); with no block left the pixel gets 0.
    CHECK(mom_variance({{{1, 0, 0}}, {{3, 0, 1}}, {{3, 0, 9}}})[0] == doctest::Approx(2.5));
    CHECK(mom_variance({{{1, 0, 0}}, {{0, 0, 0}}})[0] == 0.0);

    // Refusals: no blocks, ragged blocks.
    CHECK_THROWS_AS(mom_variance({}), std::invalid_argument);
    CHECK_THROWS_AS(mom_variance({{{3, 0, 1}}, {}}), std::invalid_argument);
}

// ---------------------------------------------------------------------------
// Strategy scores

TEST_CASE("allocation: strategy scores dispatch to the right inputs") {
    // pilot var / labels as in the bucket-floor hand case (shortened):
    //   var    1  5  3  0.5  10  7
    //   pilot  3  3  3  1    4   4   -> floor: 3 5 3 0.5 10 8.5
    //   ref    1  1  3  3    1   1   -> glossy {3, 0.5} median 1.75:
    //                                   1 5 3 1.75 10 7
    const std::vector<double> pilot = {1, 5, 3, 0.5, 10, 7};
    const std::vector<uint8_t> plab = {3, 3, 3, 1, 4, 4};
    const std::vector<uint8_t> rlab = {1, 1, 3, 3, 1, 1};
    const std::vector<double> oracle = {2, 2, 2, 2, 2, 9};
    // MoM var with the pilot labels: glossy {4, 1, 2} median 2 -> 4 2 2;
    // light 6 unchanged; delta {0, 3} median 1.5 -> 1.5 3.
    const std::vector<double> mom = {4, 1, 2, 6, 0, 3};
    ScoreInputs in;
    in.pilot_var = &pilot;
    in.pilot_labels = &plab;
    in.oracle_var = &oracle;
    in.reference_labels = &rlab;
    in.mom_var = &mom;

    CHECK(strategy_score(Strategy::Uniform, in, 0) == std::vector<double>(6, 1.0));
    CHECK(bit_identical(strategy_score(Strategy::ObservedVar, in, 0), pilot));
    CHECK(bit_identical(strategy_score(Strategy::Oracle, in, 0), oracle));
    CHECK(strategy_score(Strategy::BucketFloor, in, 0) == std::vector<double>{3, 5, 3, 0.5, 10, 8.5});
    CHECK(strategy_score(Strategy::LabelOracle, in, 0) == std::vector<double>{1, 5, 3, 1.75, 10, 7});
    CHECK(bit_identical(strategy_score(Strategy::RobustVar, in, 0), mom));
    CHECK(strategy_score(Strategy::RobustFloor, in, 0) == std::vector<double>{4, 2, 2, 6, 1.5, 3});

    // Placebo on a single-class map: every shuffle is the same map, so the
    // placebo equals the plain floor. All glossy: var median of
    // {1, 5, 3, 0.5, 10, 7} = (3 + 5) / 2 = 4 -> 4 5 4 4 10 7;
    // mom median of {4, 1, 2, 6, 0, 3} = (2 + 3) / 2 = 2.5 -> 4 2.5 2.5 6 2.5 3.
    const std::vector<uint8_t> all3(6, 3);
    ScoreInputs one = in;
    one.pilot_labels = &all3;
    CHECK(strategy_score(Strategy::Placebo, one, 77) == std::vector<double>{4, 5, 4, 4, 10, 7});
    CHECK(strategy_score(Strategy::RobustPlacebo, one, 77) == std::vector<double>{4, 2.5, 2.5, 6, 2.5, 3});

    // Placebo on the real map: the floor applied to the shuffled labels.
    const auto shuffled = placebo_labels(plab, 77);
    CHECK(strategy_score(Strategy::Placebo, in, 77) == bucket_floor(pilot, shuffled));
    CHECK(strategy_score(Strategy::RobustPlacebo, in, 77) == bucket_floor(mom, shuffled));

    // Cubes-like map (labels only {1, 2}): bucket-floor == observed-var and
    // robust-floor == robust-var, bit for bit, as are their placebos.
    uint64_t state = 3;
    const auto v = random_field(state, 4096, false);
    std::vector<uint8_t> cubes(v.size());
    for (size_t i = 0; i < v.size(); ++i) cubes[i] = (i * 7 % 5 < 2) ? 2 : 1;
    ScoreInputs c;
    c.pilot_var = &v;
    c.pilot_labels = &cubes;
    c.mom_var = &v;
    const auto obs = strategy_score(Strategy::ObservedVar, c, 0);
    CHECK(bit_identical(strategy_score(Strategy::BucketFloor, c, 0), obs));
    CHECK(bit_identical(strategy_score(Strategy::Placebo, c, 5), obs));
    CHECK(bit_identical(strategy_score(Strategy::RobustFloor, c, 0), v));
    CHECK(bit_identical(strategy_score(Strategy::RobustPlacebo, c, 5), v));
    CHECK(neyman_allocation(strategy_score(Strategy::BucketFloor, c, 0), study_total(v.size())) ==
          neyman_allocation(obs, study_total(v.size())));

    // Missing inputs are named (a bug in the caller: the front ends fill what each strategy needs).
    ScoreInputs none;
    CHECK_THROWS_WITH_AS(strategy_score(Strategy::Uniform, none, 0), doctest::Contains("uniform"),
                         vkmech::InternalError);
    CHECK_THROWS_WITH_AS(strategy_score(Strategy::ObservedVar, none, 0), doctest::Contains("pilot_var"),
                         vkmech::InternalError);
    ScoreInputs partial;
    partial.pilot_var = &pilot;
    CHECK(strategy_score(Strategy::Uniform, partial, 0).size() == 6);
    CHECK_THROWS_WITH_AS(strategy_score(Strategy::Oracle, partial, 0), doctest::Contains("oracle_var"),
                         vkmech::InternalError);
    CHECK_THROWS_WITH_AS(strategy_score(Strategy::BucketFloor, partial, 0), doctest::Contains("pilot_labels"),
                         vkmech::InternalError);
    CHECK_THROWS_WITH_AS(strategy_score(Strategy::LabelOracle, partial, 0), doctest::Contains("reference_labels"),
                         vkmech::InternalError);
    CHECK_THROWS_WITH_AS(strategy_score(Strategy::RobustVar, partial, 0), doctest::Contains("mom_var"),
                         vkmech::InternalError);
    CHECK_THROWS_WITH_AS(strategy_score(Strategy::RobustPlacebo, partial, 0), doctest::Contains("mom_var"),
                         vkmech::InternalError);
    // Size mismatch between variance and labels.
    const std::vector<uint8_t> short_lab = {3, 3};
    partial.pilot_labels = &short_lab;
    CHECK_THROWS_AS(strategy_score(Strategy::BucketFloor, partial, 0), std::invalid_argument);
}

// ---------------------------------------------------------------------------
// Metrics

TEST_CASE("allocation: error metrics on hand values") {
    // a - ref = 0, 1, 2, 3 -> squares 0, 1, 4, 9 -> mse 14 / 4 = 3.5.
    const std::vector<double> a = {1, 2, 3, 4}, ref = {1, 1, 1, 1};
    CHECK(mse(a, ref) == doctest::Approx(3.5));
    CHECK(std::isnan(mse({}, {})));
    CHECK_THROWS_AS(mse(a, {1.0}), std::invalid_argument);

    // psnr: 10 log10(1 / 0.01) = 20; 10 log10(2^2 / 0.25) = 10 log10 16 = 12.0412.
    CHECK(psnr(0.01) == doctest::Approx(20.0));
    CHECK(psnr(0.25, 2.0) == doctest::Approx(12.041199826559248));
    CHECK(psnr(1.0) == 0.0);
    CHECK(std::isinf(psnr(0.0)));
    CHECK(psnr(0.0) > 0.0);
    CHECK(std::isnan(psnr(-1.0)));

    // p99 of |a - ref| = {0, 1, 2, 3}: h = 3 * 0.99 = 2.97 -> 2 + 0.97 * 1 = 2.97.
    CHECK(p99_abs_error(a, ref) == doctest::Approx(2.97));
    // Signs do not matter: |{-3, 0, 1, -2}| = {3, 0, 1, 2} -> same 2.97.
    CHECK(p99_abs_error({-3, 0, 1, -2}, {0, 0, 0, 0}) == doctest::Approx(2.97));
    CHECK_THROWS_AS(p99_abs_error(a, {1.0}), std::invalid_argument);

    // Paired: treatment {1, 2, 3, 4, 5} vs control {2, 2, 1, 6, 5}:
    // 1<2 win, 2=2 tie, 3>1 loss, 4<6 win, 5=5 tie -> 2 wins of 5 draws;
    // control - treatment = 1, 0, -2, 2, 0 -> mean 1 / 5 = 0.2.
    const Paired p = paired_wins({1, 2, 3, 4, 5}, {2, 2, 1, 6, 5});
    CHECK(p.wins == 2);
    CHECK(p.draws == 5);
    CHECK(p.mean_delta == doctest::Approx(0.2));
    const Paired q = paired_wins({1, 1}, {1, 1});  // all ties: no wins
    CHECK(q.wins == 0);
    CHECK(q.draws == 2);
    CHECK(q.mean_delta == 0.0);
    CHECK_THROWS_AS(paired_wins({1.0}, {1.0, 2.0}), std::invalid_argument);
}
