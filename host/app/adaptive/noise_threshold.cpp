#include "adaptive/noise_threshold.hpp"

#include "allocation/threshold.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <map>

namespace vkmech {

namespace {
// A round's dispatches take up to this many samples per pixel when few pixels are left (RenderSpec::max_batch_spp).
constexpr uint32_t kMaxRoundBatch = 256;
}  // namespace

ThresholdResult render_to_threshold(Renderer& renderer, const ThresholdSettings& s, const ThresholdCallbacks& cb) {
    const std::vector<uint32_t> ladder = alloc::sample_ladder(s.min_spp, s.max_spp);
    using clock = std::chrono::steady_clock;
    const auto t0 = clock::now();
    auto since = [](clock::time_point t) { return std::chrono::duration<double>(clock::now() - t).count(); };
    ThresholdResult out;
    std::vector<double> err;  // the map the round in progress was planned from (empty in the first)

    // One render of samples [first, end(p)) of the seed, its frame merged into out.frame.
    auto render_part = [&](RenderSpec spec, uint32_t done_before, uint32_t round_total) {
        spec.seed = s.seed;
        spec.batch_spp = s.batch_spp;
        spec.max_batch_spp = std::max(s.batch_spp, kMaxRoundBatch);  // late rounds: few pixels, many samples each
        spec.progress = [&, done_before, round_total](uint32_t d, uint32_t) {
            if (cb.progress) cb.progress(done_before + d, round_total);
        };
        if (cb.on_frame)
            spec.on_frame = [&](const Frame& partial) {
                if (cb.frame_due && !cb.frame_due()) return;
                if (out.frame.pixels.empty()) return cb.on_frame(partial, err);
                Frame so_far = out.frame;
                so_far.merge(partial);
                cb.on_frame(so_far, err);
            };
        Frame part = renderer.render(spec);
        if (out.frame.pixels.empty())
            out.frame = std::move(part);
        else
            out.frame.merge(part);
    };

    // The first round: every pixel takes samples [0, min_spp).
    ThresholdRound first;
    {
        const auto t = clock::now();
        RenderSpec spec;
        spec.spp = s.min_spp;
        render_part(spec, 0, s.min_spp);
        first.samples = out.frame.samples;
        first.pixels = out.frame.pixels.size();
        first.seconds = since(t);
    }
    out.rounds.push_back(first);
    if (cb.on_round) cb.on_round(first, 0);
    double rate = first.seconds > 0 ? static_cast<double>(first.samples) / first.seconds : 0.0;  // samples / s

    std::vector<uint32_t> n;
    for (;;) {
        const auto t_plan = clock::now();
        err = alloc::relative_error(out.frame, s.rule, s.traits);
        n = alloc::pixel_samples(out.frame);
        std::vector<uint32_t> target = alloc::threshold_targets(n, err, s.threshold, ladder);
        ThresholdRound round;
        for (double e : err) {
            round.above += e > s.threshold ? 1 : 0;
            if (std::isfinite(e)) round.worst = std::max(round.worst, e);
        }
        uint64_t want = 0;
        for (size_t p = 0; p < n.size(); ++p) want += target[p] - n[p];
        if (want == 0) break;  // every pixel below T or at max-spp
        // The samples the time left affords at the last round's rate, and the budget's samples left.
        uint64_t budget = UINT64_MAX;
        bool by_time = false;
        if (s.time_limit > 0) {
            const double left = s.time_limit - since(t0);
            budget = static_cast<uint64_t>(left > 0 && rate > 0 ? std::min(std::floor(left * rate), 1e18) : 0.0);
            by_time = true;
        }
        if (s.sample_budget > 0) {
            const uint64_t left = s.sample_budget > out.frame.samples ? s.sample_budget - out.frame.samples : 0;
            if (left <= budget) by_time = false;
            budget = std::min(budget, left);
        }
        if (budget < want) {
            const uint64_t fitted = alloc::fit_round(target, n, err, ladder, budget);
            if (fitted == 0) {
                (by_time ? out.time_limit_reached : out.budget_reached) = true;
                break;
            }
            round.cut_by_time = true;
            want = fitted;
        }
        round.plan_seconds = since(t_plan);

        // One render per starting rung: pixel p takes samples [n(p), target(p)).
        std::map<uint32_t, uint32_t> ends;  // start -> the largest target of the pixels starting there
        for (size_t p = 0; p < n.size(); ++p)
            if (target[p] > n[p]) {
                uint32_t& e = ends[n[p]];
                e = std::max(e, target[p]);
                ++round.pixels;
            }
        uint32_t round_total = 0;
        for (const auto& [start, end] : ends) round_total += end - start;
        round.first = ends.begin()->first;
        round.samples = want;
        const auto t_render = clock::now();
        uint32_t done = 0;
        for (const auto& [start, end] : ends) {
            RenderSpec spec;
            spec.first_sample = start;
            spec.sample_counts.assign(n.size(), 0u);
            for (size_t p = 0; p < n.size(); ++p)
                if (n[p] == start && target[p] > n[p]) spec.sample_counts[p] = target[p];
            render_part(std::move(spec), done, round_total);
            done += end - start;
        }
        round.seconds = since(t_render);
        if (round.seconds > 0) rate = static_cast<double>(round.samples) / round.seconds;
        out.rounds.push_back(round);
        if (cb.on_round) cb.on_round(round, out.rounds.size() - 1);
    }
    // Every way out of the loop leaves err and n those of the final frame.
    out.err = std::move(err);
    out.n = std::move(n);
    for (size_t p = 0; p < out.n.size(); ++p) {
        if (out.err[p] <= s.threshold)
            ++out.converged;
        else if (out.n[p] >= ladder.back())
            ++out.at_max;
        else
            ++out.unfinished;
    }
    out.seconds = since(t0);
    return out;
}

}  // namespace vkmech
