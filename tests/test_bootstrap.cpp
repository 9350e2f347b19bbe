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
    Interval k = tile_bootstrap(a, b, 3, 3, 1, [](const Confusion& c) { return cohen_kappa(c); }, 500, 0);
    const double point = cohen_kappa(confusion(a, b, 3));
    CHECK(k.lo <= point);
    CHECK(k.hi >= point);
    CHECK(k.hi <= 1.0);
    // Every pixel one class in both maps: kappa is NaN in every resample.
    std::vector<uint8_t> same(9, 1);
    Interval nan = tile_bootstrap(same, same, 3, 3, 1, [](const Confusion& c) { return cohen_kappa(c); }, 50, 0);
    CHECK(std::isnan(nan.lo));
    CHECK_THROWS_AS(tile_bootstrap(a, std::vector<uint8_t>(8, 0), 3, 3, 1, agree), std::invalid_argument);
    CHECK_THROWS_AS(tile_bootstrap(a, b, 3, 4, 1, agree), std::invalid_argument);
    CHECK_THROWS_AS(tile_bootstrap(a, b, 3, 3, 0, agree), std::invalid_argument);
    CHECK_THROWS_AS(tile_bootstrap(a, b, 3, 3, 1, agree, 5), std::invalid_argument);
}
