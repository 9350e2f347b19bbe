// The per-bucket adaptive median-of-means block count, `robust-adaptive`
// (analysis/allocation/adaptive_mom.hpp, docs/descriptor.md §6.7): the block
// count the rule picks per bucket, the single-bucket limits (robust-var at that
// bucket's k, bit for bit) and a hand-computed pilot and allocation.
#include "allocation/allocation.hpp"
#include "io/invariant.hpp"
#include "stats/split_half.hpp"

#include <doctest/doctest.h>

#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

using namespace vkmech;
using namespace vkmech::alloc;

namespace {

bool same_bits(const std::vector<double>& a, const std::vector<double>& b) {
    return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0);
}

// A pilot of n0 samples for `pixels` pixels: mostly small luminances, with a
// rare large sample (a firefly) in about one sample of 40, and a NaN now and then.
PilotSamples random_pilot(uint32_t n0, size_t pixels, uint64_t seed) {
    PilotSamples ps;
    ps.samples = n0;
    ps.pixels = pixels;
    ps.lum.resize(static_cast<size_t>(n0) * pixels);
    uint64_t state = seed;
    for (float& x : ps.lum) {
        const uint64_t r = stats::uniform_below(state, 400);
        x = r == 0 ? NAN : r < 10 ? 50.0f + static_cast<float>(r) : static_cast<float>(r % 17) / 8.0f;
    }
    return ps;
}

}  // namespace

TEST_CASE("robust-adaptive: the rule picks k = 1 on delta_mediated and specular_direct and ceil(sqrt(N0)) elsewhere") {
    const std::vector<uint8_t> mid = {gpu::BUCKET_EMITTER_DIRECT, gpu::BUCKET_DIRECT, gpu::BUCKET_DIFFUSE_INDIRECT,
                                      gpu::BUCKET_GLOSSY,         gpu::BUCKET_OTHER,  gpu::NO_LABEL};
    for (const auto& nk : {std::pair{9, 3}, std::pair{16, 4}, std::pair{64, 8}, std::pair{13, 4}}) {
        const int n0 = nk.first, k0 = nk.second;
        CAPTURE(n0);
        CHECK(adaptive_mom_k(gpu::BUCKET_DELTA_MEDIATED, n0) == 1);
        CHECK(adaptive_mom_k(gpu::BUCKET_SPECULAR_DIRECT, n0) == 1);
        for (uint8_t b : mid) CHECK(adaptive_mom_k(b, n0) == k0);
    }
    CHECK(is_rare_tail(gpu::BUCKET_DELTA_MEDIATED));
    CHECK(is_rare_tail(gpu::BUCKET_SPECULAR_DIRECT));
    CHECK_FALSE(is_rare_tail(gpu::BUCKET_GLOSSY));
    CHECK_FALSE(is_rare_tail(gpu::NO_LABEL));
    CHECK_THROWS_AS(adaptive_mom_k(gpu::BUCKET_DIRECT, 4), std::invalid_argument);  // MoM not defined at N0 = 4
    CHECK(rare_tail_pixels({4, 5, 3, 255, 4, 1}) == 3);
    // A taxonomy's own rare-tail classes (its `[rare]` lines; ClassTraits::rare): here class 3 alone.
    const uint32_t three = 1u << 3;
    CHECK(is_rare_tail(3, three));
    CHECK_FALSE(is_rare_tail(gpu::BUCKET_DELTA_MEDIATED, three));
    CHECK_FALSE(is_rare_tail(gpu::NO_LABEL, 0xFFu));
    CHECK(adaptive_mom_k(3, 16, three) == 1);
    CHECK(adaptive_mom_k(gpu::BUCKET_DELTA_MEDIATED, 16, three) == 4);
    CHECK(rare_tail_pixels({4, 5, 3, 255, 4, 1}, three) == 1);
    CHECK(rare_tail_pixels({4, 5, 3, 255, 4, 1}, 0u) == 0);
    CHECK(adaptive_mom_score({1.0, 2.0, 3.0}, {10.0, 20.0, 30.0}, {3, 4, 255}, three) ==
          std::vector<double>{1.0, 20.0, 30.0});
    CHECK(std::string(to_string(Strategy::RobustAdaptive)) == "robust-adaptive");
    CHECK(parse_strategy("robust-adaptive") == Strategy::RobustAdaptive);
    CHECK(needs_mom(Strategy::RobustAdaptive));
}

TEST_CASE("robust-adaptive: with every pixel in one bucket it is robust-var at that bucket's k bit for bit") {
    for (uint32_t n0 : {9u, 16u, 64u}) {
        CAPTURE(n0);
        const size_t P = 300;
        const PilotSamples ps = random_pilot(n0, P, 17 + n0);
        const std::vector<double> plain = ps.mom_variance(1);  // k = 1: the plain variance over all N0 samples
        const std::vector<double> mom = ps.mom_variance(mom_block_count(static_cast<int>(n0)));
        REQUIRE_FALSE(same_bits(plain, mom));  // otherwise the test could not tell the two apart
        for (int b : {0, 1, 2, 3, 4, 5, 6, 255}) {
            CAPTURE(b);
            const std::vector<uint8_t> labels(P, static_cast<uint8_t>(b));
            ScoreInputs in;
            in.pilot_var = &plain;
            in.mom_var = &mom;
            in.pilot_labels = &labels;
            in.pilot_spp = n0;
            const std::vector<double> at_k =
                ps.mom_variance(adaptive_mom_k(static_cast<uint8_t>(b), static_cast<int>(n0)));
            ScoreInputs rv = in;
            rv.mom_var = &at_k;
            CHECK(
                same_bits(strategy_score(Strategy::RobustAdaptive, in, 0), strategy_score(Strategy::RobustVar, rv, 0)));
            CHECK(plan_allocation(Strategy::RobustAdaptive, in, 32, 1, 0).n ==
                  plan_allocation(Strategy::RobustVar, rv, 32, 1, 0).n);
        }
        // Mixed labels: neither the plain variance nor the MoM alone.
        std::vector<uint8_t> mixed(P);
        for (size_t p = 0; p < P; ++p) mixed[p] = static_cast<uint8_t>(p % 7);
        const std::vector<double> d = adaptive_mom_score(plain, mom, mixed);
        for (size_t p = 0; p < P; ++p)
            CHECK(std::memcmp(&d[p], is_rare_tail(mixed[p]) ? &plain[p] : &mom[p], sizeof(double)) == 0);
    }
}

TEST_CASE("robust-adaptive: a hand-computed pilot and allocation at N0 = 9") {
    // N0 = 9: k = 3 blocks of 3 samples.
    //   A direct:          0 0 0 | 0 0 3 | 1 2 3   plain: mean 1, SS = 5*1 + 4 + 0 + 1 + 4 = 14, /8 = 1.75
    //                                               MoM: block vars 0, 3, 1 -> median 1            -> D = 1
    //   B delta_mediated:  0 0 0 | 0 0 0 | 0 0 9   plain: mean 1, SS = 8 + 64 = 72, /8 = 9
    //                                               MoM: 0, 0, 27 -> median 0 (the firefly dropped) -> D = 9 (k = 1)
    //   C glossy:          0 0 9 | 0 0 0 | 0 0 0   plain 9, MoM 0; glossy is not rare-tail         -> D = 0
    //   D unlabelled:      all 0                    plain 0, MoM 0                                  -> D = 0
    // Budget: extra 2 -> total 4 x 3 = 12, floor 1 -> 8 shared in proportion to sqrt(D) = 1 : 3 : 0 : 0 -> 2 and 6.
    const std::vector<std::vector<float>> px = {{0, 0, 0, 0, 0, 3, 1, 2, 3},
                                                {0, 0, 0, 0, 0, 0, 0, 0, 9},
                                                {0, 0, 9, 0, 0, 0, 0, 0, 0},
                                                {0, 0, 0, 0, 0, 0, 0, 0, 0}};
    PilotSamples ps;
    ps.samples = 9;
    ps.pixels = 4;
    ps.lum.resize(36);
    for (size_t p = 0; p < 4; ++p)
        for (size_t i = 0; i < 9; ++i) ps.lum[i * 4 + p] = px[p][i];
    const std::vector<double> plain = ps.mom_variance(1), mom = ps.mom_variance(3);
    CHECK(plain[0] == doctest::Approx(1.75));
    CHECK(mom[0] == doctest::Approx(1.0));
    CHECK(plain[1] == doctest::Approx(9.0));
    CHECK(mom[1] == 0.0);
    const std::vector<uint8_t> labels = {gpu::BUCKET_DIRECT, gpu::BUCKET_DELTA_MEDIATED, gpu::BUCKET_GLOSSY,
                                         gpu::NO_LABEL};
    const std::vector<double> d = adaptive_mom_score(plain, mom, labels);
    CHECK(d[0] == doctest::Approx(1.0));
    CHECK(d[1] == doctest::Approx(9.0));
    CHECK(d[2] == 0.0);
    CHECK(d[3] == 0.0);
    ScoreInputs in;
    in.pilot_var = &plain;
    in.mom_var = &mom;
    in.pilot_labels = &labels;
    CHECK(plan_allocation(Strategy::RobustAdaptive, in, 2, 1, 0).n == std::vector<uint32_t>{3, 7, 1, 1});
    CHECK(plan_allocation(Strategy::RobustVar, in, 2, 1, 0).n == std::vector<uint32_t>{9, 1, 1, 1});  // firefly starved
    // Sizes must agree; every input is needed.
    CHECK_THROWS_AS(adaptive_mom_score(plain, mom, {1, 2}), std::invalid_argument);
    ScoreInputs partial = in;
    partial.mom_var = nullptr;
    CHECK_THROWS_WITH_AS(strategy_score(Strategy::RobustAdaptive, partial, 0), doctest::Contains("mom_var"),
                         InternalError);
}
