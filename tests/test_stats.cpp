// Statistics library (docs/descriptor.md §5 "Analyses"): every expected value below is a
// literal worked out by hand (the working is in the comment next to it) or a
// textbook example, never a value produced by the code under test. Property
// tests at the end compare the code with itself under transformations whose
// effect is known exactly (monotone maps, identical maps).
#include "stats/agreement.hpp"
#include "stats/binning.hpp"
#include "stats/cost.hpp"
#include "stats/firefly.hpp"
#include "stats/isotonic.hpp"
#include "stats/quantiles.hpp"
#include "stats/rank.hpp"
#include "stats/regression.hpp"
#include "stats/split_half.hpp"
#include "stats/summary.hpp"

#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <set>
#include <stdexcept>
#include <vector>

using namespace vkmech::stats;

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

doctest::Approx near(double v) { return doctest::Approx(v).epsilon(1e-12); }

void check_vec(const std::vector<double>& got, const std::vector<double>& want) {
    REQUIRE(got.size() == want.size());
    for (size_t i = 0; i < got.size(); ++i) {
        CAPTURE(i);
        CHECK(got[i] == near(want[i]));
    }
}

// Append `count` pixels labelled (la, lb) to the two maps.
void add_pixels(std::vector<uint8_t>& a, std::vector<uint8_t>& b, uint8_t la, uint8_t lb, int count) {
    for (int i = 0; i < count; ++i) {
        a.push_back(la);
        b.push_back(lb);
    }
}

// Small deterministic generator for the property tests (values only need to
// be varied, not statistically good).
struct Lcg {
    uint64_t s;
    double next() {
        s = s * 6364136223846793005ull + 1442695040888963407ull;
        return static_cast<double>(s >> 11) * 0x1.0p-53;
    }
};

// The half containing seed 0 identifies an unordered split {a, b}.
std::vector<int> canonical(const Partition& p) { return std::find(p.a.begin(), p.a.end(), 0) != p.a.end() ? p.a : p.b; }

}  // namespace

// ---------------------------------------------------------------- summary

TEST_CASE("stats: mean and sample variance of a textbook sample") {
    // {2,4,4,4,5,5,7,9}: sum 40, mean 5; squared deviations 9,1,1,1,0,0,4,16
    // sum to 32; ddof 1 -> 32/7 = 4.571428571428571.
    const std::vector<double> x = {2, 4, 4, 4, 5, 5, 7, 9};
    CHECK(mean(x) == near(5.0));
    CHECK(sample_variance(x) == near(4.571428571428571));
    // Two-pass keeps a large offset out of the squares: {4,7,13,16} + 1e9
    // has mean 1e9+10, squared deviations 36,9,9,36 -> 90/3 = 30.
    CHECK(sample_variance({1e9 + 4, 1e9 + 7, 1e9 + 13, 1e9 + 16}) == doctest::Approx(30.0).epsilon(1e-9));
    // ddof 1 on two points {1,3}: mean 2, (1+1)/1 = 2.
    CHECK(sample_variance({1.0, 3.0}) == near(2.0));
}

TEST_CASE("stats: mean and variance edge cases give NaN") {
    CHECK(std::isnan(mean({})));
    CHECK(std::isnan(sample_variance({})));
    CHECK(std::isnan(sample_variance({42.0})));  // n < 2
    CHECK(sample_variance({3.0, 3.0, 3.0}) == 0.0);
}

TEST_CASE("stats: median of odd and even counts") {
    CHECK(median({3, 1, 2}) == 2.0);     // sorted 1,2,3 -> middle 2
    CHECK(median({4, 1, 3, 2}) == 2.5);  // sorted 1,2,3,4 -> (2+3)/2
    CHECK(median({7}) == 7.0);
    CHECK(std::isnan(median({})));
    CHECK(std::isnan(median({1.0, kNaN, 3.0})));  // NaN has no place in the order
}

TEST_CASE("stats: quantile is numpy type 7") {
    // Sorted {10,20,30,40,50}, n = 5, h = (n-1) q = 4q:
    //   q = 0.3 -> h = 1.2 -> 20 + 0.2 * (30-20) = 22   (np.quantile -> 22.0)
    //   q = 0.9 -> h = 3.6 -> 40 + 0.6 * (50-40) = 46   (np.quantile -> 46.0)
    //   q = 0.5 -> h = 2   -> 30; q = 0 -> 10; q = 1 -> 50
    const std::vector<double> x = {50, 10, 40, 20, 30};
    CHECK(quantile(x, 0.3) == near(22.0));
    CHECK(quantile(x, 0.9) == near(46.0));
    CHECK(quantile(x, 0.5) == 30.0);
    CHECK(quantile(x, 0.0) == 10.0);
    CHECK(quantile(x, 1.0) == 50.0);
    // Two points {0, 1}: h = q, so the quantile is q itself; q = 0.25 -> 0.25.
    CHECK(quantile({1.0, 0.0}, 0.25) == near(0.25));
    CHECK(std::isnan(quantile({}, 0.5)));
    CHECK_THROWS_AS(quantile(x, 1.5), std::invalid_argument);
    CHECK_THROWS_AS(quantile(x, -0.1), std::invalid_argument);
    CHECK_THROWS_AS(quantile(x, kNaN), std::invalid_argument);
}

// ---------------------------------------------------------------- ranks

TEST_CASE("stats: average ranks give ties the mean rank") {
    // {10,20,20,30}: 10 -> 1, the two 20s share ranks 2,3 -> 2.5, 30 -> 4.
    check_vec(average_ranks({10, 20, 20, 30}), {1, 2.5, 2.5, 4});
    // {3,1,3,3,2}: 1 -> 1, 2 -> 2, the three 3s share ranks 3,4,5 -> 4.
    check_vec(average_ranks({3, 1, 3, 3, 2}), {4, 1, 4, 4, 2});
    // Infinity ranks like any value: {inf, -inf, 0} -> {3, 1, 2}.
    check_vec(average_ranks({kInf, -kInf, 0.0}), {3, 1, 2});
    CHECK(average_ranks({}).empty());
    CHECK_THROWS_AS(average_ranks({1.0, kNaN}), std::invalid_argument);
}

TEST_CASE("stats: pearson on a hand-computed example") {
    // x = 1..5, y = {2,4,5,4,5}: means 3 and 4; dx = -2,-1,0,1,2;
    // dy = -2,0,1,0,1; Sxy = 4+0+0+0+2 = 6, Sxx = 10, Syy = 4+0+1+0+1 = 6;
    // r = 6 / sqrt(60) = 0.7745966692414834.
    CHECK(pearson({1, 2, 3, 4, 5}, {2, 4, 5, 4, 5}) == near(0.7745966692414834));
    // Exact lines: r = +1 and -1.
    CHECK(pearson({1, 2, 3}, {10, 20, 30}) == near(1.0));
    CHECK(pearson({1, 2, 3}, {3, 2, 1}) == near(-1.0));
}

TEST_CASE("stats: spearman with ties on a hand-ranked example") {
    // x = {1,2,3,4,5} -> ranks 1..5; y = {10,20,20,40,30} -> ranks
    // {1,2.5,2.5,5,4}. Both rank means are 3; dx = -2,-1,0,1,2;
    // dy = -2,-0.5,-0.5,2,1; Sxy = 4+0.5+0+2+2 = 8.5; Sxx = 10;
    // Syy = 4+0.25+0.25+4+1 = 9.5; rho = 8.5 / sqrt(95) = 0.872081599272381.
    CHECK(spearman({1, 2, 3, 4, 5}, {10, 20, 20, 40, 30}) == near(0.872081599272381));
    // Ties on both sides: x = {1,1,2,3} -> {1.5,1.5,3,4}; y = {5,6,6,7} ->
    // {1,2.5,2.5,4}; means 2.5; dx = -1,-1,0.5,1.5; dy = -1.5,0,0,1.5;
    // Sxy = 1.5+2.25 = 3.75, Sxx = 1+1+0.25+2.25 = 4.5, Syy = 2.25+2.25 = 4.5;
    // rho = 3.75 / 4.5 = 5/6.
    CHECK(spearman({1, 1, 2, 3}, {5, 6, 6, 7}) == near(5.0 / 6.0));
    // Any strictly increasing relation is rho = 1, decreasing rho = -1.
    CHECK(spearman({1, 2, 3, 4}, {1, 8, 27, 1000}) == near(1.0));
    CHECK(spearman({1, 2, 3, 4}, {9, 7, 3, -5}) == near(-1.0));
}

TEST_CASE("stats: masked_spearman keeps the masked-in finite pairs only") {
    // The hand-ranked example above, padded with pairs the mask or a non-finite value leaves out.
    const double inf = std::numeric_limits<double>::infinity(), nan = std::numeric_limits<double>::quiet_NaN();
    const std::vector<double> x = {1, 2, 100, 3, 4, nan, 5, 7}, y = {10, 20, -50, 20, 40, 1, 30, inf};
    const std::vector<uint8_t> mask = {1, 1, 0, 1, 1, 1, 1, 1};
    CHECK(masked_spearman(x, y, mask) == near(0.872081599272381));
    CHECK(std::isnan(masked_spearman(x, y, mask, 6)));  // five pairs left: fewer than asked
    CHECK_THROWS_AS(masked_spearman(x, y, {1, 1}), std::invalid_argument);
}

TEST_CASE("stats: correlation edge cases - constant input - short input - size mismatch") {
    CHECK(std::isnan(pearson({1, 2, 3}, {4, 4, 4})));
    CHECK(std::isnan(pearson({0.1, 0.1, 0.1}, {1, 2, 3})));  // constant, despite rounding in the mean
    CHECK(std::isnan(spearman({5, 5, 5}, {1, 2, 3})));
    CHECK(std::isnan(pearson({1.0}, {2.0})));
    CHECK(std::isnan(spearman({}, {})));
    CHECK(std::isnan(pearson({1, 2, kInf}, {1, 2, 3})));
    CHECK(std::isnan(spearman({1, 2, kNaN}, {1, 2, 3})));
    CHECK_THROWS_AS(pearson({1, 2, 3}, {1, 2}), std::invalid_argument);
    CHECK_THROWS_AS(spearman({1, 2}, {1, 2, 3}), std::invalid_argument);
}

// ---------------------------------------------------------------- regression

TEST_CASE("stats: ols recovers an exact line with r2 1") {
    // (0,1),(1,3),(2,5),(3,7) lie on y = 1 + 2x.
    auto f = ols({0, 1, 2, 3}, {1, 3, 5, 7});
    CHECK(f.slope == near(2.0));
    CHECK(f.intercept == near(1.0));
    CHECK(f.r2 == near(1.0));
}

TEST_CASE("stats: ols on noisy points with known fit and r2") {
    // x = {1,2,3,4}, y = {2,3,5,4}: means 2.5, 3.5; dx = -1.5,-0.5,0.5,1.5;
    // dy = -1.5,-0.5,1.5,0.5; Sxy = 2.25+0.25+0.75+0.75 = 4, Sxx = 5;
    // slope = 0.8, intercept = 3.5 - 0.8*2.5 = 1.5; fitted 2.3,3.1,3.9,4.7;
    // residuals -0.3,-0.1,1.1,-0.7 -> SSres = 0.09+0.01+1.21+0.49 = 1.8;
    // SStot = 2.25+0.25+2.25+0.25 = 5; r2 = 1 - 1.8/5 = 0.64.
    auto f = ols({1, 2, 3, 4}, {2, 3, 5, 4});
    CHECK(f.slope == near(0.8));
    CHECK(f.intercept == near(1.5));
    CHECK(f.r2 == near(0.64));
    // docs/descriptor.md §5 use: log10 variance on log10 SPP with variance = 1/N gives
    // slope -1 (alpha_hat = 1): x = log10{16,64}, y = -x.
    auto g = ols({std::log10(16.0), std::log10(64.0)}, {-std::log10(16.0), -std::log10(64.0)});
    CHECK(g.slope == near(-1.0));
}

TEST_CASE("stats: ols edge cases - constant y gives NaN r2 - degenerate x throws") {
    auto f = ols({1, 2, 3}, {4, 4, 4});
    CHECK(f.slope == 0.0);
    CHECK(f.intercept == near(4.0));
    CHECK(std::isnan(f.r2));
    CHECK_THROWS_AS(ols({2, 2, 2}, {1, 2, 3}), std::invalid_argument);  // one distinct x
    CHECK_THROWS_AS(ols({1}, {1}), std::invalid_argument);
    CHECK_THROWS_AS(ols({}, {}), std::invalid_argument);
    CHECK_THROWS_AS(ols({1, 2}, {1, 2, 3}), std::invalid_argument);
}

// ---------------------------------------------------------------- agreement

TEST_CASE("stats: confusion - agreement and cohen kappa on the classic 2x2 example") {
    // Rows = label in a, columns = label in b:  [[20, 5], [10, 15]], N = 50.
    // Po = 35/50 = 0.7; row sums 25,25; column sums 30,20;
    // Pe = (25*30 + 25*20) / 50^2 = 1250/2500 = 0.5; kappa = 0.2/0.5 = 0.4.
    std::vector<uint8_t> a, b;
    add_pixels(a, b, 0, 0, 20);
    add_pixels(a, b, 0, 1, 5);
    add_pixels(a, b, 1, 0, 10);
    add_pixels(a, b, 1, 1, 15);
    // Pixels not labelled in both maps must not enter any score.
    add_pixels(a, b, kNoLabel, 0, 3);
    add_pixels(a, b, 1, kNoLabel, 2);
    add_pixels(a, b, kNoLabel, kNoLabel, 4);

    const Confusion c = confusion(a, b, 2);
    CHECK(c.k == 2);
    CHECK(c.total() == 50.0);
    CHECK(c.at(0, 0) == 20.0);
    CHECK(c.at(0, 1) == 5.0);  // a says 0, b says 1
    CHECK(c.at(1, 0) == 10.0);
    CHECK(c.at(1, 1) == 15.0);
    CHECK(labelled_in_one_only(a, b) == 5);  // 3 + 2; the 4 unlabelled-in-both are not counted
    CHECK(agreement(c) == near(0.7));
    CHECK(cohen_kappa(c) == near(0.4));
}

TEST_CASE("stats: pixel shares and max drift use each map's own labelled pixels") {
    // Same maps as the 2x2 example. Map a labelled: 0 -> 20+5 = 25,
    // 1 -> 10+15+2 = 27, total 52. Map b labelled: 0 -> 20+10+3 = 33,
    // 1 -> 5+15 = 20, total 53. Drift = |25/52 - 33/53| (same for class 1)
    // = |0.4807692307692308 - 0.6226415094339622| = 0.14187227866473145.
    std::vector<uint8_t> a, b;
    add_pixels(a, b, 0, 0, 20);
    add_pixels(a, b, 0, 1, 5);
    add_pixels(a, b, 1, 0, 10);
    add_pixels(a, b, 1, 1, 15);
    add_pixels(a, b, kNoLabel, 0, 3);
    add_pixels(a, b, 1, kNoLabel, 2);
    add_pixels(a, b, kNoLabel, kNoLabel, 4);
    check_vec(pixel_shares(a, 2), {0.4807692307692308, 0.5192307692307693});
    check_vec(pixel_shares(b, 2), {0.6226415094339622, 0.37735849056603776});
    CHECK(max_drift(a, b, 2) == near(0.14187227866473145));
    // Three classes, the largest change wins: shares {0.5,0.25,0.25} vs
    // {0.25,0.25,0.5} -> max(|0.25|, 0, |0.25|) = 0.25; sizes may differ.
    CHECK(max_drift({0, 0, 1, 2}, {0, 1, 2, 2, 2, 0, 1, 2}, 3) == near(0.25));
    CHECK(std::isnan(max_drift({kNoLabel, kNoLabel}, {0, 1}, 2)));
    for (double s : pixel_shares({kNoLabel}, 3)) CHECK(std::isnan(s));
}

TEST_CASE("stats: weighted kappa - struct share - unweighted kappa on a 3x3 table by hand") {
    // Classes 0,1 light-tailed, class 2 heavy. descriptor §5 weights:
    //   w = [[1, .8, 0], [.8, 1, 0], [0, 0, 1]].
    // Table (rows a, cols b), N = 30:
    //   [[10, 2, 1],
    //    [ 3, 8, 1],
    //    [ 0, 1, 4]]
    // Row sums 13,12,5; column sums 13,11,6.
    // Po_w = (10+8+4 + 0.8*(2+3)) / 30 = 26/30.
    // Pe_w * 900 = 13*13 + 12*11 + 5*6 + 0.8*(13*11 + 12*13)
    //            = 169 + 132 + 30 + 0.8*299 = 331 + 239.2 = 570.2.
    // kappa_w = (780 - 570.2) / (900 - 570.2) = 209.8 / 329.8 = 0.6361431170406306.
    // Unweighted: Po = 22/30, Pe = 331/900, kappa = (660-331)/(900-331)
    //   = 329/569 = 0.5782073813708261.
    // struct%: off-diagonal 2+1+3+1+0+1 = 8; touching class 2: (0,2)=1,
    //   (1,2)=1, (2,0)=0, (2,1)=1 -> 3; 3/8 = 0.375.
    Confusion c{3, {10, 2, 1, 3, 8, 1, 0, 1, 4}};
    const std::vector<bool> light = {true, true, false};
    const std::vector<bool> heavy = {false, false, true};
    const auto w = spec_kappa_weights(3, light);
    check_vec(w, {1, 0.8, 0, 0.8, 1, 0, 0, 0, 1});
    CHECK(agreement(c) == near(22.0 / 30.0));
    CHECK(weighted_kappa(c, w) == near(0.6361431170406306));
    CHECK(cohen_kappa(c) == near(0.5782073813708261));
    CHECK(structural_share(c, heavy) == near(0.375));
    // Identity weights reduce weighted kappa to Cohen's kappa (329/569).
    CHECK(weighted_kappa(c, {1, 0, 0, 0, 1, 0, 0, 0, 1}) == near(0.5782073813708261));
}

TEST_CASE("stats: spec kappa weights for the seven SPEC buckets") {
    // docs/descriptor.md §5: penalty 0.2 inside the light-tailed family, 1.0 otherwise.
    // Light-tailed = buckets 0,1,2; buckets 3..6 are not.
    const auto w = spec_kappa_weights(7, {true, true, true, false, false, false, false});
    REQUIRE(w.size() == 49);
    auto at = [&](int i, int j) { return w[static_cast<size_t>(i * 7 + j)]; };
    for (int i = 0; i < 7; ++i) CHECK(at(i, i) == 1.0);
    CHECK(at(0, 2) == near(0.8));
    CHECK(at(2, 1) == near(0.8));
    CHECK(at(2, 3) == 0.0);  // light <-> heavy: full penalty
    CHECK(at(4, 3) == 0.0);  // a swap inside the heavy family is penalised fully too
    CHECK(at(6, 0) == 0.0);
    CHECK_THROWS_AS(spec_kappa_weights(7, {true, false}), std::invalid_argument);
}

TEST_CASE("stats: agreement edge cases - empty - single class - bad input") {
    Confusion empty{2, {0, 0, 0, 0}};
    CHECK(std::isnan(agreement(empty)));
    CHECK(std::isnan(cohen_kappa(empty)));
    CHECK(std::isnan(structural_share(empty, {true, false})));
    // Both maps use only class 1: Po = Pe = 1, kappa is 0/0.
    Confusion one{2, {0, 0, 0, 7}};
    CHECK(agreement(one) == 1.0);
    CHECK(std::isnan(cohen_kappa(one)));
    // Independent marginals: [[25,25],[25,25]] -> Po = Pe = 0.5 -> kappa 0.
    CHECK(cohen_kappa(Confusion{2, {25, 25, 25, 25}}) == near(0.0));
    // All disagreement among light classes: struct% = 0.
    CHECK(structural_share(Confusion{2, {0, 3, 1, 0}}, {false, false}) == 0.0);

    CHECK_THROWS_AS(confusion({0, 1}, {0}, 2), std::invalid_argument);
    CHECK_THROWS_AS(confusion({0, 2}, {0, 1}, 2), std::invalid_argument);  // label 2 with k = 2
    CHECK_THROWS_AS(confusion({0}, {0}, 0), std::invalid_argument);
    CHECK_THROWS_AS(labelled_in_one_only({0, 1}, {0}), std::invalid_argument);
    CHECK_THROWS_AS(pixel_shares({5}, 3), std::invalid_argument);
    const Confusion c{2, {1, 2, 3, 4}};
    CHECK_THROWS_AS(weighted_kappa(c, {1, 0, 0}), std::invalid_argument);       // not k*k
    CHECK_THROWS_AS(weighted_kappa(c, {0.9, 0, 0, 1}), std::invalid_argument);  // diagonal != 1
    CHECK_THROWS_AS(weighted_kappa(c, {1, 1.5, 0, 1}), std::invalid_argument);  // outside [0,1]
    CHECK_THROWS_AS(structural_share(c, {true}), std::invalid_argument);
}

// ---------------------------------------------------------------- quantile bins

TEST_CASE("stats: quantile edges match numpy type 7") {
    // 1..10 (n = 10, h = 9q, value = 1 + h):
    //   3 bins: q = 1/3 -> h = 3 -> 4; q = 2/3 -> h = 6 -> 7.
    //   np.quantile(np.arange(1, 11), [1/3, 2/3]) -> [4., 7.]
    const std::vector<double> v = {10, 9, 8, 7, 6, 5, 4, 3, 2, 1};
    check_vec(quantile_edges(v, 3), {4.0, 7.0});
    //   7 bins: 1 + 9k/7 for k = 1..6 = 16/7, 25/7, 34/7, 43/7, 52/7, 61/7.
    check_vec(quantile_edges(v, 7), {2.2857142857142856, 3.5714285714285716, 4.857142857142858, 6.142857142857143,
                                     7.428571428571429, 8.714285714285715});
    // {0,0,0,1,5,9}, 3 bins: q = 1/3 -> h = 5/3 -> x[1] + (2/3)(x[2]-x[1]) = 0;
    // q = 2/3 -> h = 10/3 -> x[3] + (1/3)(5 - 1) = 1 + 4/3 = 7/3.
    check_vec(quantile_edges({9, 0, 5, 0, 1, 0}, 3), {0.0, 2.3333333333333333});
    CHECK(quantile_edges(v, 1).empty());  // one bin: no interior edge
}

TEST_CASE("stats: quantile bin counts edges strictly below - ties go to the lower bin") {
    // Edges {4,7}: 1..4 -> 0 (4 equals an edge: lower bin), 5..7 -> 1, 8..10 -> 2.
    const std::vector<uint8_t> want = {0, 0, 0, 0, 1, 1, 1, 2, 2, 2};
    CHECK(quantile_bin({1, 2, 3, 4, 5, 6, 7, 8, 9, 10}, {4.0, 7.0}) == want);
    // A tied block (three zeros, all equal to the first edge) stays together.
    const std::vector<uint8_t> want_ties = {2, 0, 2, 0, 1, 0};
    CHECK(quantile_bin({9, 0, 5, 0, 1, 0}, {0.0, 2.3333333333333333}) == want_ties);
    // Equal edges leave the bin between them empty: 2 -> 0, 3 -> 2.
    const std::vector<uint8_t> want_eq = {0, 0, 2};
    CHECK(quantile_bin({1, 2, 3}, {2.0, 2.0}) == want_eq);
    const std::vector<uint8_t> want_none = {0, 0};
    CHECK(quantile_bin({-kInf, kInf}, {}) == want_none);

    CHECK_THROWS_AS(quantile_edges({}, 3), std::invalid_argument);
    CHECK_THROWS_AS(quantile_edges({1, 2}, 0), std::invalid_argument);
    CHECK_THROWS_AS(quantile_edges({1, 2}, 256), std::invalid_argument);
    CHECK_THROWS_AS(quantile_edges({1, kNaN}, 3), std::invalid_argument);
    CHECK_THROWS_AS(quantile_bin({1.0}, {3.0, 2.0}), std::invalid_argument);
    CHECK_THROWS_AS(quantile_bin({kNaN}, {1.0}), std::invalid_argument);
}

TEST_CASE("stats: per-level quantile edges make binned agreement scale free") {
    // docs/descriptor.md §5: edges are computed independently at each SPP level, so a field
    // that is the same ordering at a different scale (variance shrinking with
    // SPP) bins identically and scores agreement 1.
    const std::vector<double> lo_spp = {3, 1, 4, 1.5, 9, 2, 6, 5, 3.5, 8};
    std::vector<double> hi_spp;
    for (double v : lo_spp) hi_spp.push_back(v * v / 64.0);  // monotone on v > 0
    const auto b1 = quantile_bin(lo_spp, quantile_edges(lo_spp, 3));
    const auto b2 = quantile_bin(hi_spp, quantile_edges(hi_spp, 3));
    CHECK(b1 == b2);
    CHECK(agreement(confusion(b1, b2, 3)) == 1.0);
}

// ---------------------------------------------------------------- split half

TEST_CASE("stats: splitmix64 matches the reference output for seed 0") {
    // Reference implementation (Vigna, splitmix64.c), state 0:
    // 0xE220A8397B1DCDAF, 0x6E789E6AA1B965F4, 0x06C45D188009454F.
    uint64_t s = 0;
    CHECK(splitmix64_next(s) == 0xE220A8397B1DCDAFull);
    CHECK(splitmix64_next(s) == 0x6E789E6AA1B965F4ull);
    CHECK(splitmix64_next(s) == 0x06C45D188009454Full);
    uint64_t t = 7;
    for (int i = 0; i < 100; ++i) CHECK(uniform_below(t, 3) < 3);
    CHECK(uniform_below(t, 1) == 0);
    CHECK_THROWS_AS(uniform_below(t, 0), std::invalid_argument);
}

TEST_CASE("stats: random halves are balanced - covering - distinct and deterministic") {
    // docs/descriptor.md §5: 20 random 5+5 partitions of 10 seeds, base seed 0.
    const auto parts = random_halves(10, 20, 0);
    REQUIRE(parts.size() == 20);
    std::set<std::vector<int>> keys;
    for (const auto& p : parts) {
        CHECK(p.a.size() == 5);
        CHECK(p.b.size() == 5);
        CHECK(std::is_sorted(p.a.begin(), p.a.end()));
        CHECK(std::is_sorted(p.b.begin(), p.b.end()));
        std::vector<int> all = p.a;
        all.insert(all.end(), p.b.begin(), p.b.end());
        std::sort(all.begin(), all.end());
        CHECK(all == std::vector<int>{0, 1, 2, 3, 4, 5, 6, 7, 8, 9});  // disjoint and covering
        keys.insert(canonical(p));
    }
    CHECK(keys.size() == 20);  // no two equal as unordered pairs {a, b}

    const auto again = random_halves(10, 20, 0);
    for (size_t i = 0; i < parts.size(); ++i) {
        CHECK(again[i].a == parts[i].a);
        CHECK(again[i].b == parts[i].b);
    }
    // A longer request extends the shorter one (one stream, in order).
    const auto longer = random_halves(10, 30, 0);
    for (size_t i = 0; i < parts.size(); ++i) CHECK(longer[i].a == parts[i].a);
    // Another base seed gives another sequence.
    const auto other = random_halves(10, 20, 1);
    bool differs = false;
    for (size_t i = 0; i < parts.size(); ++i) differs = differs || other[i].a != parts[i].a;
    CHECK(differs);
}

TEST_CASE("stats: random halves can enumerate all 126 splits of 10 but not 127") {
    // C(10,5) = 252 ordered choices of a, each unordered split counted twice -> 126.
    CHECK(distinct_half_splits(10) == 126);
    CHECK(distinct_half_splits(4) == 3);  // {01|23}, {02|13}, {03|12}
    CHECK(distinct_half_splits(2) == 1);
    const auto all = random_halves(10, 126, 0);
    std::set<std::vector<int>> keys;
    for (const auto& p : all) keys.insert(canonical(p));
    CHECK(keys.size() == 126);
    CHECK_THROWS_AS(random_halves(10, 127, 0), std::invalid_argument);
    CHECK_THROWS_AS(random_halves(9, 1, 0), std::invalid_argument);  // odd n
    CHECK_THROWS_AS(random_halves(0, 1, 0), std::invalid_argument);
    CHECK_THROWS_AS(random_halves(10, -1, 0), std::invalid_argument);
    CHECK(random_halves(10, 0, 0).empty());
    const auto two = random_halves(2, 1, 5);
    REQUIRE(two.size() == 1);
    CHECK(two[0].a.size() == 1);
    CHECK(two[0].a[0] + two[0].b[0] == 1);
}

// ---------------------------------------------------------------- cost

TEST_CASE("stats: time to quality - crossing - censoring - eps floor - non-finite") {
    // levels {16,32,64}, tau 0.1, eps 1e-4; error = |lum - ref| / max(ref, eps).
    const std::vector<uint32_t> levels = {16, 32, 64};
    const std::vector<double> ref = {1.0, 2.0, 0.0, 5e-5, 1.0, kInf, 1.0};
    const std::vector<std::vector<double>> lum = {
        // p0: 0.5 -> no | p1: 0.05 -> cross at 16 | p2: 1e-3/1e-4 = 10 -> no |
        // p3: 2e-5/1e-4 = 0.2 -> no | p4: 1.0 -> no | p5: ref inf | p6: NaN
        {1.5, 2.1, 1e-3, 7e-5, 2.0, 1.0, kNaN},
        // p0: 0.05 -> cross at 32 | p2: 5e-6/1e-4 = 0.05 -> cross at 32 |
        // p3: 8e-6/1e-4 = 0.08 -> cross at 32 (8e-6/5e-5 = 0.16 would not:
        // the floor is max(ref, eps), not ref) | p4: NaN never crosses | p6: inf
        {1.05, 3.0, 5e-6, 5.8e-5, kNaN, 1.0, kInf},
        // p4: 0.2 -> no -> censored at the cap 64 | p6: exact -> cross at 64
        {1.0, 2.0, 0.0, 5e-5, 1.2, 1.0, 1.0},
    };
    const auto c = time_to_quality(levels, lum, ref, 0.10, 1e-4);
    const std::vector<double> want_spp = {32, 16, 32, 32, 64, 64, 64};
    const std::vector<uint8_t> want_cens = {0, 0, 0, 0, 1, 1, 0};
    CHECK(c.spp == want_spp);
    CHECK(c.censored == want_cens);
}

TEST_CASE("stats: time to quality crossing is strict and the first level wins") {
    // tau = 0.25 (exact in binary): |1.25 - 1| / 1 = 0.25 is not < 0.25;
    // |1.125 - 1| = 0.125 < 0.25 crosses. Pixel 1 crosses at 8 and again at
    // 16, but the first crossing counts even though 4 had a larger error.
    const std::vector<uint32_t> levels = {4, 8, 16};
    const std::vector<double> ref = {1.0, 1.0};
    const std::vector<std::vector<double>> lum = {{1.25, 2.0}, {1.25, 1.125}, {1.25, 1.0}};
    const auto c = time_to_quality(levels, lum, ref, 0.25, 1e-4);
    const std::vector<double> want_spp = {16, 8};
    const std::vector<uint8_t> want_cens = {1, 0};
    CHECK(c.spp == want_spp);
    CHECK(c.censored == want_cens);
}

TEST_CASE("stats: time to quality rejects malformed input") {
    const std::vector<double> ref = {1.0};
    CHECK_THROWS_AS(time_to_quality({}, {}, ref), std::invalid_argument);
    CHECK_THROWS_AS(time_to_quality({32, 16}, {{1.0}, {1.0}}, ref), std::invalid_argument);  // not ascending
    CHECK_THROWS_AS(time_to_quality({16, 16}, {{1.0}, {1.0}}, ref), std::invalid_argument);  // repeated level
    CHECK_THROWS_AS(time_to_quality({16, 32}, {{1.0}}, ref), std::invalid_argument);         // missing level
    CHECK_THROWS_AS(time_to_quality({16}, {{1.0, 2.0}}, ref), std::invalid_argument);        // size mismatch
    CHECK_THROWS_AS(time_to_quality({16}, {{1.0}}, ref, 0.0), std::invalid_argument);
    CHECK_THROWS_AS(time_to_quality({16}, {{1.0}}, ref, 0.1, 0.0), std::invalid_argument);
}

TEST_CASE("stats: censored median on observed and on censored values") {
    // Costs {32,16,128c,64,128c} (c = censored at cap 128): order
    // 16,32,64,+inf,+inf; n = 5, middle position 2 -> 64, observed.
    auto m = censored_median({32, 16, 128, 64, 128}, {0, 0, 1, 0, 1});
    CHECK(m.value == 64.0);
    CHECK_FALSE(m.lower_bound);
    CHECK(m.censored_rate == near(0.4));  // 2 of 5
    CHECK(m.n == 5);
    // {16, 128c, 128c, 128c}: order 16,+inf,+inf,+inf; n = 4, lower-middle
    // position (4-1)/2 = 1 is censored -> value = cap 128, lower bound.
    m = censored_median({16, 128, 128, 128}, {0, 1, 1, 1});
    CHECK(m.value == 128.0);
    CHECK(m.lower_bound);
    CHECK(m.censored_rate == near(0.75));
    // Even count uses the lower middle, not the average: {16,32,64,128}
    // -> position 1 -> 32 (an ordinary median would say 48).
    m = censored_median({128, 16, 64, 32}, {0, 0, 0, 0});
    CHECK(m.value == 32.0);
    CHECK_FALSE(m.lower_bound);
    CHECK(m.censored_rate == 0.0);
    // {16, 32, 128c, 128c}: lower middle 32 is observed, so the median is
    // exact although averaging with the upper middle would meet +inf.
    m = censored_median({16, 32, 128, 128}, {0, 0, 1, 1});
    CHECK(m.value == 32.0);
    CHECK_FALSE(m.lower_bound);
    // A censored observed-valued cap: everything censored -> cap, lower bound.
    m = censored_median({64}, {1});
    CHECK(m.value == 64.0);
    CHECK(m.lower_bound);
    CHECK(m.censored_rate == 1.0);
}

TEST_CASE("stats: censored median edge cases") {
    auto m = censored_median({}, {});
    CHECK(std::isnan(m.value));
    CHECK_FALSE(m.lower_bound);
    CHECK(m.n == 0);
    CHECK_THROWS_AS(censored_median({1, 2}, {0}), std::invalid_argument);
    CHECK_THROWS_AS(censored_median({1, kNaN}, {0, 0}), std::invalid_argument);
}

// ---------------------------------------------------------------- isotonic

TEST_CASE("stats: isotonic regression with unit weights") {
    // [1,3,2,4,3,5]: violators (3,2) -> 2.5, (4,3) -> 3.5; result
    // [1,2.5,2.5,3.5,3.5,5] is non-decreasing.
    check_vec(isotonic_increasing({1, 3, 2, 4, 3, 5}, {1, 1, 1, 1, 1, 1}), {1, 2.5, 2.5, 3.5, 3.5, 5});
    // A fully decreasing sequence pools into one block: mean of 3,2,1 = 2.
    check_vec(isotonic_increasing({3, 2, 1}, {1, 1, 1}), {2, 2, 2});
    // A cascade: [1,4,5,2] -> (5,2) -> 3.5 < 4 -> pool (4,5,2) -> 11/3.
    check_vec(isotonic_increasing({1, 4, 5, 2}, {1, 1, 1, 1}), {1, 11.0 / 3.0, 11.0 / 3.0, 11.0 / 3.0});
    check_vec(isotonic_increasing({1, 2, 3}, {1, 1, 1}), {1, 2, 3});  // already monotone
    CHECK(isotonic_increasing({}, {}).empty());
}

TEST_CASE("stats: isotonic regression with weights and zero-weight entries") {
    // y = [1,4,2,3], w = [1,1,3,1]: (4,2) pool to (1*4 + 3*2)/4 = 2.5;
    // 3 >= 2.5 stays -> [1, 2.5, 2.5, 3].
    check_vec(isotonic_increasing({1, 4, 2, 3}, {1, 1, 3, 1}), {1, 2.5, 2.5, 3});
    // y = [3,1], w = [1,3] -> (3 + 3)/4 = 1.5 for both.
    check_vec(isotonic_increasing({3, 1}, {1, 3}), {1.5, 1.5});
    // Zero weight: index 1 (y = 100) is ignored; [1,3,2] fits to [1,2.5,2.5];
    // the empty entry takes its left neighbour's value 1.
    check_vec(isotonic_increasing({1, 100, 3, 2}, {1, 0, 1, 1}), {1, 1, 2.5, 2.5});
    // Leading zero weight takes the first block: [2,1] -> 1.5.
    check_vec(isotonic_increasing({9, 2, 1}, {0, 1, 1}), {1.5, 1.5, 1.5});
    // Trailing zero weight, y ignored even if NaN.
    check_vec(isotonic_increasing({1, 2, kNaN}, {1, 1, 0}), {1, 2, 2});
    // No data at all -> NaN everywhere.
    for (double v : isotonic_increasing({1, 2}, {0, 0})) CHECK(std::isnan(v));
    CHECK_THROWS_AS(isotonic_increasing({1, 2}, {1}), std::invalid_argument);
    CHECK_THROWS_AS(isotonic_increasing({1, 2}, {1, -1}), std::invalid_argument);
    CHECK_THROWS_AS(isotonic_increasing({1, kNaN}, {1, 1}), std::invalid_argument);
}

// ---------------------------------------------------------------- firefly

TEST_CASE("stats: firefly ratio is seed-wise max over mean") {
    // {1,1,1,5}: mean 8/4 = 2, max 5 -> 2.5.
    CHECK(firefly_ratio({1, 1, 1, 5}) == near(2.5));
    CHECK(firefly_ratio({2, 2, 2}) == near(1.0));  // no firefly
    // {0,0,0,3}: mean 0.75, max 3 -> 4 = the seed count (one seed has all).
    CHECK(firefly_ratio({0, 0, 0, 3}) == near(4.0));
    CHECK(std::isnan(firefly_ratio({0, 0})));  // mean <= 0
    CHECK(std::isnan(firefly_ratio({})));
    CHECK(std::isnan(firefly_ratio({1, kNaN})));
    CHECK(std::isnan(firefly_ratio({1, kInf})));
}

// ---------------------------------------------------------------- binning

TEST_CASE("stats: binned rate on equal-width bins") {
    // 4 bins on [0,1]: [0,.25) [.25,.5) [.5,.75) [.75,1].
    //   bin 0: 0.0(hit) 0.1(miss) -> 2, 1, 0.5
    //   bin 1: 0.25(hit)          -> 1, 1, 1
    //   bin 2: 0.5(hit) 0.74(miss)-> 2, 1, 0.5
    //   bin 3: 0.75(hit) 1.0(hit) -> 2, 2, 1   (x == hi goes into the last bin)
    //   -0.1, 1.2, NaN are outside: ignored.
    const std::vector<double> x = {0.0, 0.1, 0.25, 0.5, 0.74, 0.75, 1.0, -0.1, 1.2, kNaN};
    const std::vector<uint8_t> hit = {1, 0, 1, 1, 0, 1, 1, 1, 1, 1};
    const auto r = binned_rate(x, hit, 4, 0.0, 1.0);
    check_vec(r.lo, {0.0, 0.25, 0.5, 0.75});
    check_vec(r.hi, {0.25, 0.5, 0.75, 1.0});
    check_vec(r.count, {2, 1, 2, 2});
    check_vec(r.hits, {1, 1, 1, 2});
    check_vec(r.rate, {0.5, 1.0, 0.5, 1.0});
}

TEST_CASE("stats: binned rate empty bins and edge consistency") {
    // 5 bins on [0,1], x = {0.1, 0.9}: bins 0 and 4 filled, 1..3 empty -> NaN.
    const auto r = binned_rate({0.1, 0.9}, {1, 0}, 5, 0.0, 1.0);
    CHECK(r.rate[0] == 1.0);
    CHECK(r.rate[4] == 0.0);
    for (int b = 1; b <= 3; ++b) CHECK(std::isnan(r.rate[static_cast<size_t>(b)]));
    // A value equal to a reported lower edge lands in that bin even where the
    // scaled offset rounds below it: 5 bins on [0.1, 0.9] have lo[1] =
    // 0.1 + 0.8 * 1/5 = 0.26 in double, but (0.26 - 0.1) / 0.8 * 5 evaluates
    // to 0.9999999999999999, whose floor is bin 0.
    const auto e = binned_rate({0.26}, {1}, 5, 0.1, 0.9);
    CHECK(e.lo[1] == 0.26);
    check_vec(e.count, {0, 1, 0, 0, 0});
    CHECK_THROWS_AS(binned_rate({0.5}, {1, 0}, 4, 0.0, 1.0), std::invalid_argument);
    CHECK_THROWS_AS(binned_rate({0.5}, {1}, 0, 0.0, 1.0), std::invalid_argument);
    CHECK_THROWS_AS(binned_rate({0.5}, {1}, 4, 1.0, 1.0), std::invalid_argument);
    CHECK_THROWS_AS(binned_rate({0.5}, {1}, 4, 0.0, kInf), std::invalid_argument);
}

// ---------------------------------------------------------------- properties

TEST_CASE("stats: spearman is invariant to strictly monotone transforms") {
    Lcg g{12345};
    std::vector<double> x(200), y(200);
    for (size_t i = 0; i < x.size(); ++i) {
        x[i] = g.next();
        y[i] = x[i] + 0.5 * g.next();
        if (i % 7 == 0) y[i] = 0.25;  // a tied block
    }
    const double rho = spearman(x, y);
    REQUIRE(std::isfinite(rho));
    std::vector<double> fx(x.size()), fy(y.size()), neg(y.size());
    for (size_t i = 0; i < x.size(); ++i) {
        fx[i] = std::exp(3.0 * x[i]);
        fy[i] = y[i] * y[i] * y[i] + 2.0;
        neg[i] = -y[i];
    }
    CHECK(spearman(fx, fy) == near(rho));
    CHECK(spearman(x, neg) == near(-rho));  // a decreasing transform flips the sign
    CHECK(spearman(y, x) == near(rho));     // symmetric
}

TEST_CASE("stats: kappa is 1 for identical label maps") {
    Lcg g{777};
    std::vector<uint8_t> a(500);
    for (auto& v : a) {
        const int r = static_cast<int>(g.next() * 8.0);  // 0..7, 7 = unlabelled
        v = r == 7 ? kNoLabel : static_cast<uint8_t>(r);
    }
    const auto c = confusion(a, a, 7);
    CHECK(agreement(c) == 1.0);
    CHECK(cohen_kappa(c) == near(1.0));
    CHECK(weighted_kappa(c, spec_kappa_weights(7, {true, true, true, false, false, false, false})) == near(1.0));
    CHECK(std::isnan(structural_share(c, {false, false, false, true, true, true, false})));
    CHECK(max_drift(a, a, 7) == 0.0);
    CHECK(labelled_in_one_only(a, a) == 0);
}
