// The tile bootstrap of agreement and kappa (analysis/stats/bootstrap.hpp)
// against binomial theory and against a spatially correlated map.
#include "stats/bootstrap.hpp"

#include <doctest/doctest.h>

#include <cmath>
#include <random>
#include <stdexcept>

using namespace vkmech::stats;

namespace {
double agree(const Confusion& c) { return agreement(c); }
}  // namespace

TEST_CASE("bootstrap: a pixel bootstrap of independent disagreements matches the binomial interval") {
    // 128 x 128 pixels, each disagreeing independently with probability 0.2.
    const int w = 128, n = w * w;
    std::mt19937 rng(7);
    std::bernoulli_distribution flip(0.2);
    std::vector<uint8_t> a(n), b(n);
    for (int i = 0; i < n; ++i) {
        a[i] = static_cast<uint8_t>(i % 3);
        b[i] = flip(rng) ? static_cast<uint8_t>((a[i] + 1) % 3) : a[i];
    }
    const double p = agreement(confusion(a, b, 3));
    Interval ci = tile_bootstrap(a, b, 3, w, 1, agree, 2000, 1);
    const double half = 1.959964 * std::sqrt(p * (1 - p) / n);  // normal approximation of the binomial
    CHECK(ci.lo < p);
    CHECK(ci.hi > p);
    CHECK((ci.hi - ci.lo) == doctest::Approx(2 * half).epsilon(0.15));
    // Deterministic for a seed, different for another.
    Interval again = tile_bootstrap(a, b, 3, w, 1, agree, 2000, 1);
    CHECK(again.lo == ci.lo);
    CHECK(again.hi == ci.hi);
    Interval other = tile_bootstrap(a, b, 3, w, 1, agree, 2000, 2);
    CHECK((other.lo != ci.lo || other.hi != ci.hi));
}

TEST_CASE("bootstrap: disagreement in whole tiles widens the tile interval well beyond the pixel interval") {
    // The same 20% disagreement, but in whole 8 x 8 blocks: 256 independent units instead of 16384.
    const int w = 128, n = w * w;
    std::mt19937 rng(11);
    std::bernoulli_distribution flip(0.2);
    std::vector<bool> block_flips(256);
    for (auto&& f : block_flips) f = flip(rng);
    std::vector<uint8_t> a(n, 0), b(n, 0);
    for (int y = 0; y < w; ++y)
        for (int x = 0; x < w; ++x)
            if (block_flips[(y / 8) * 16 + x / 8]) b[y * w + x] = 1;
    const double p = agreement(confusion(a, b, 2));
    Interval pixel = tile_bootstrap(a, b, 2, w, 1, agree, 1000, 3);
    Interval tiled = tile_bootstrap(a, b, 2, w, 8, agree, 1000, 3);
    const double half = 1.959964 * std::sqrt(p * (1 - p) / 256);  // 256 independent blocks
    CHECK((tiled.hi - tiled.lo) == doctest::Approx(2 * half).epsilon(0.2));
    CHECK((tiled.hi - tiled.lo) > 5 * (pixel.hi - pixel.lo));
}

TEST_CASE("bootstrap: kappa intervals - unlabelled pixels left out - NaN scores dropped - bad input refused") {
    std::vector<uint8_t> a = {0, 1, 2, 0, 1, 2, 255, 0, 1}, b = {0, 1, 2, 0, 2, 2, 1, 255, 1};
    Interval k = tile_bootstrap(
        a, b, 3, 3, 1, [](const Confusion& c) { return cohen_kappa(c); }, 500, 0);
    const double point = cohen_kappa(confusion(a, b, 3));
    CHECK(k.lo <= point);
    CHECK(k.hi >= point);
    CHECK(k.hi <= 1.0);
    // Every pixel one class in both maps: kappa is NaN in every resample.
    std::vector<uint8_t> same(9, 1);
    Interval nan = tile_bootstrap(
        same, same, 3, 3, 1, [](const Confusion& c) { return cohen_kappa(c); }, 50, 0);
    CHECK(std::isnan(nan.lo));
    CHECK_THROWS_AS(tile_bootstrap(a, std::vector<uint8_t>(8, 0), 3, 3, 1, agree), std::invalid_argument);
    CHECK_THROWS_AS(tile_bootstrap(a, b, 3, 4, 1, agree), std::invalid_argument);
    CHECK_THROWS_AS(tile_bootstrap(a, b, 3, 3, 0, agree), std::invalid_argument);
    CHECK_THROWS_AS(tile_bootstrap(a, b, 3, 3, 1, agree, 5), std::invalid_argument);
}

TEST_CASE(
    "bootstrap: Spearman intervals - exact for a monotone pair - 1/sqrt(n) for independent pixels - blocks widen it") {
    const int w = 128, n = w * w;
    std::mt19937 rng(5);
    std::normal_distribution<double> g(0.0, 1.0);
    std::vector<double> x(n), y(n);
    for (int i = 0; i < n; ++i) x[i] = g(rng);
    // A monotone relation: every resample has rho exactly 1.
    for (int i = 0; i < n; ++i) y[i] = 2.0 * x[i] + 1.0;
    Interval mono = tile_bootstrap_spearman(x, y, w, 8, 200, 0);
    CHECK(mono.lo == 1.0);
    CHECK(mono.hi == 1.0);
    // Independent pixels: the sampling sd of Spearman's rho under independence is 1/sqrt(n - 1).
    for (int i = 0; i < n; ++i) y[i] = g(rng);
    Interval ind = tile_bootstrap_spearman(x, y, w, 1, 1000, 1);
    CHECK(ind.lo < 0.0);
    CHECK(ind.hi > 0.0);
    CHECK((ind.hi - ind.lo) == doctest::Approx(2 * 1.959964 / std::sqrt(n - 1.0)).epsilon(0.15));
    // Values constant over 8 x 8 blocks: 256 independent units, so the tile interval is about sqrt(64) = 8x wider.
    std::vector<double> bx(256), by(256);
    for (int b = 0; b < 256; ++b) {
        bx[b] = g(rng);
        by[b] = g(rng);
    }
    for (int py = 0; py < w; ++py)
        for (int px = 0; px < w; ++px) {
            x[py * w + px] = bx[(py / 8) * 16 + px / 8];
            y[py * w + px] = by[(py / 8) * 16 + px / 8];
        }
    Interval pixel = tile_bootstrap_spearman(x, y, w, 1, 500, 2);
    Interval tiled = tile_bootstrap_spearman(x, y, w, 8, 500, 2);
    CHECK((tiled.hi - tiled.lo) == doctest::Approx(2 * 1.959964 / std::sqrt(255.0)).epsilon(0.25));
    CHECK((tiled.hi - tiled.lo) > 5 * (pixel.hi - pixel.lo));
}

TEST_CASE("bootstrap: Spearman intervals leave NaN pixels out and refuse bad input") {
    // Unlabelled pixels (NaN) carry arbitrary partners; left out, the rest is a monotone pair.
    std::vector<double> x = {1, 2, 3, NAN, 5, 6, 7, 8, 9}, y = {1, 2, 3, -100, 5, 6, NAN, 8, 9};
    Interval ci = tile_bootstrap_spearman(x, y, 3, 1, 100, 0);
    CHECK(ci.lo == 1.0);
    CHECK(ci.hi == 1.0);
    // A constant field: rho is NaN in every resample.
    std::vector<double> c(9, 1.0);
    CHECK(std::isnan(tile_bootstrap_spearman(c, y, 3, 1, 50, 0).lo));
    CHECK_THROWS_AS(tile_bootstrap_spearman(x, std::vector<double>(8, 0.0), 3, 1), std::invalid_argument);
    CHECK_THROWS_AS(tile_bootstrap_spearman(x, y, 4, 1), std::invalid_argument);
    CHECK_THROWS_AS(tile_bootstrap_spearman(x, y, 3, 0), std::invalid_argument);
    CHECK_THROWS_AS(tile_bootstrap_spearman(x, y, 3, 1, 5), std::invalid_argument);
}
