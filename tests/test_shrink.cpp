// The empirical-Bayes `shrink` strategy (analysis/allocation/shrink.hpp):
// trigamma against closed forms, a hand-computed prior and posterior, the
// limits (no shrinkage for a long pilot, strong shrinkage when the spread is
// all noise) and the pixels no prior speaks for.
#include "allocation/shrink.hpp"
#include "allocation/strategy.hpp"

#include <doctest/doctest.h>

#include <cmath>
#include <random>
#include <stdexcept>

using namespace vkmech::alloc;

namespace {
const double kPi = 3.14159265358979323846;
}

TEST_CASE("shrink: trigamma against closed forms") {
    CHECK(trigamma(1.0) == doctest::Approx(kPi * kPi / 6.0).epsilon(1e-13));
    CHECK(trigamma(0.5) == doctest::Approx(kPi * kPi / 2.0).epsilon(1e-13));
    double tail = kPi * kPi / 6.0;  // trigamma(10) = pi^2/6 - sum_{k=1}^{9} 1/k^2
    for (int k = 1; k <= 9; ++k) tail -= 1.0 / (k * k);
    CHECK(trigamma(10.0) == doctest::Approx(tail).epsilon(1e-12));
    CHECK(trigamma(1e4) == doctest::Approx(1e-4 + 0.5e-8).epsilon(1e-9));  // 1/x + 1/(2x^2) + ...
    CHECK(log_variance_noise(3) == doctest::Approx(kPi * kPi / 6.0).epsilon(1e-13));
    CHECK_THROWS_AS(trigamma(0.0), std::invalid_argument);
    CHECK_THROWS_AS(trigamma(NAN), std::invalid_argument);
    CHECK_THROWS_AS(log_variance_noise(1), std::invalid_argument);
}

TEST_CASE("shrink: a hand-computed prior and posterior") {
    // N0 = 3: v = trigamma(1) = pi^2/6.
    // label 1: variances 1 and e^4 (y = 0, 4) and one pixel with 0 -> mu = 2, S2 = 8, tau2 = 8 - v, w = tau2 / 8;
    //          the zero pixel gets e^mu.
    // label 4: a single pixel (5) -> tau2 = 0, w = 0, D = exp(log 5) = 5.
    // label 0: only a zero variance -> no prior, D stays 0.
    // unlabelled (255): left as given.
    const double e4 = std::exp(4.0);
    const std::vector<double> var = {1.0, e4, 0.0, 5.0, 0.0, 0.0, 2.0};
    const std::vector<uint8_t> lab = {1, 1, 1, 4, 0, 255, 255};
    const double v = kPi * kPi / 6.0, w = (8.0 - v) / 8.0;
    const std::vector<double> D = shrink_score(var, lab, 3);
    REQUIRE(D.size() == var.size());
    CHECK(D[0] == doctest::Approx(std::exp(2.0 - 2.0 * w)).epsilon(1e-12));
    CHECK(D[1] == doctest::Approx(std::exp(2.0 + 2.0 * w)).epsilon(1e-12));
    CHECK(D[2] == doctest::Approx(std::exp(2.0)).epsilon(1e-12));
    CHECK(D[3] == doctest::Approx(5.0).epsilon(1e-12));
    CHECK(D[4] == 0.0);
    CHECK(D[5] == 0.0);
    CHECK(D[6] == 2.0);
    const auto prior = fit_shrink_priors(var, lab, 3);
    CHECK(prior[1].pixels == 2);
    CHECK(prior[1].mu == doctest::Approx(2.0));
    CHECK(prior[1].tau2 == doctest::Approx(8.0 - v));
    CHECK(prior[4].weight == 0.0);
    CHECK(prior[0].pixels == 0);
    // Through the strategy table, which needs N0.
    ScoreInputs in;
    in.pilot_var = &var;
    in.pilot_labels = &lab;
    CHECK_THROWS_AS(strategy_score(Strategy::Shrink, in, 0), std::invalid_argument);
    in.pilot_spp = 3;
    CHECK(strategy_score(Strategy::Shrink, in, 0) == D);
    CHECK(parse_strategy("shrink") == Strategy::Shrink);
}

TEST_CASE("shrink: a long pilot keeps each pixel's own variance - pure noise is shrunk to the label's mean") {
    std::mt19937 rng(3);
    std::normal_distribution<double> g(0.0, 1.0);
    const size_t P = 2000;
    // True variances spread over two decades, one label: with N0 = 4096 the noise v is 5e-4 against a spread of
    // about 1 in log, so w > 0.999 and D is within 0.5% of sigma^2.
    std::vector<double> var(P);
    std::vector<uint8_t> lab(P, 2);
    for (auto& x : var) x = std::exp(g(rng));
    std::vector<double> D = shrink_score(var, lab, 4096);
    for (size_t p = 0; p < P; ++p) CHECK(D[p] == doctest::Approx(var[p]).epsilon(0.005));
    // Every pixel with the same true variance 1, measured by a 4-sample pilot: the spread of log s^2 is all noise,
    // so the posterior spread is far smaller than the measured one.
    const int n0 = 4;
    for (auto& x : var) {
        double s = 0.0, ss = 0.0;
        double xs[n0];
        for (double& xi : xs) s += (xi = g(rng));
        const double m = s / n0;
        for (double xi : xs) ss += (xi - m) * (xi - m);
        x = ss / (n0 - 1);
    }
    D = shrink_score(var, lab, n0);
    auto log_sd = [](const std::vector<double>& x) {
        double s = 0.0, ss = 0.0;
        for (double v : x) s += std::log(v);
        const double m = s / x.size();
        for (double v : x) ss += (std::log(v) - m) * (std::log(v) - m);
        return std::sqrt(ss / (x.size() - 1));
    };
    CHECK(log_sd(D) < 0.3 * log_sd(var));
    CHECK_THROWS_AS(shrink_score(var, std::vector<uint8_t>(P - 1, 2), 4), std::invalid_argument);
}

TEST_CASE("shrink: the global placebo fits one prior over every labelled pixel, whatever their labels") {
    // Two labels with different typical variances; the placebo must pool them.
    const std::vector<double> var = {1.0, 2.0, 4.0, 100.0, 200.0, 400.0, 7.0};
    const std::vector<uint8_t> labels = {1, 1, 1, 3, 3, 3, 255};
    ScoreInputs in;
    in.pilot_var = &var;
    in.pilot_labels = &labels;
    in.pilot_spp = 4;
    const auto global = strategy_score(Strategy::ShrinkGlobal, in, 0);
    // By hand: y = log var over the six labelled pixels, one population.
    double mu = 0, s2 = 0;
    for (int i = 0; i < 6; ++i) mu += std::log(var[i]) / 6;
    for (int i = 0; i < 6; ++i) s2 += (std::log(var[i]) - mu) * (std::log(var[i]) - mu) / 5;
    const double v = log_variance_noise(4), tau2 = std::max(0.0, s2 - v), w = tau2 / (tau2 + v);
    REQUIRE(global.size() == var.size());
    for (int i = 0; i < 6; ++i) CHECK(global[i] == doctest::Approx(std::exp(mu + w * (std::log(var[i]) - mu))));
    CHECK(global[6] == 7.0);  // unlabelled: no prior speaks for it
    // The same pixels under one label: the placebo is shrink itself.
    const std::vector<uint8_t> one = {2, 2, 2, 2, 2, 2, 255};
    ScoreInputs same = in;
    same.pilot_labels = &one;
    CHECK(strategy_score(Strategy::Shrink, same, 0) == global);
    // With the two labels, shrink keeps the labels' own means: different from the placebo.
    CHECK(strategy_score(Strategy::Shrink, in, 0) != global);
    CHECK(std::string(to_string(Strategy::ShrinkGlobal)) == "shrink-global");
    CHECK(parse_strategy("shrink-global") == Strategy::ShrinkGlobal);
}
