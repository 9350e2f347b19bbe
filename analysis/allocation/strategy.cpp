#include "allocation/strategy.hpp"

#include "allocation/adaptive_mom.hpp"
#include "allocation/floor.hpp"
#include "allocation/guard.hpp"
#include "allocation/shrink.hpp"
#include "io/invariant.hpp"
#include "shared/types.h"

#include <stdexcept>
#include <string>

namespace vkmech::alloc {

const char* to_string(Strategy s) {
    switch (s) {
        case Strategy::Uniform:
            return "uniform";
        case Strategy::ObservedVar:
            return "observed-var";
        case Strategy::Oracle:
            return "oracle";
        case Strategy::BucketFloor:
            return "bucket-floor";
        case Strategy::Placebo:
            return "placebo";
        case Strategy::LabelOracle:
            return "label-oracle";
        case Strategy::RobustVar:
            return "robust-var";
        case Strategy::RobustFloor:
            return "robust-floor";
        case Strategy::RobustPlacebo:
            return "robust-placebo";
        case Strategy::Guarded:
            return "guarded";
        case Strategy::Shrink:
            return "shrink";
        case Strategy::RobustAdaptive:
            return "robust-adaptive";
        case Strategy::ShrinkGlobal:
            return "shrink-global";
    }
    return "unknown";
}

Strategy parse_strategy(const std::string& name) {
    for (Strategy s : kAllStrategies)
        if (name == to_string(s)) return s;
    std::string valid;
    for (Strategy s : kAllStrategies) {
        if (!valid.empty()) valid += ", ";
        valid += to_string(s);
    }
    throw std::invalid_argument("unknown allocation strategy '" + name + "'; valid: " + valid);
}

bool needs_mom(Strategy s) {
    return s == Strategy::RobustVar || s == Strategy::RobustFloor || s == Strategy::RobustPlacebo ||
           s == Strategy::RobustAdaptive;
}

namespace {

template <class T>
const std::vector<T>& need(const std::vector<T>* p, Strategy s, const char* field) {
    VKM_ASSERT(p != nullptr, std::string("alloc::strategy_score: strategy '") + to_string(s) + "' needs " + field +
                                 ", which is null");
    return *p;
}

}  // namespace

std::vector<double> strategy_score(Strategy s, const ScoreInputs& in, uint64_t placebo_seed) {
    switch (s) {
        case Strategy::Uniform: {
            size_t n;
            if (in.pilot_var)
                n = in.pilot_var->size();
            else if (in.pilot_labels)
                n = in.pilot_labels->size();
            else if (in.oracle_var)
                n = in.oracle_var->size();
            else if (in.reference_labels)
                n = in.reference_labels->size();
            else if (in.mom_var)
                n = in.mom_var->size();
            else
                VKM_ASSERT(false,
                           "alloc::strategy_score: strategy 'uniform' needs at least one input for the pixel count, "
                           "all are null");
            return std::vector<double>(n, 1.0);
        }
        case Strategy::ObservedVar:
            return need(in.pilot_var, s, "pilot_var");
        case Strategy::Oracle:
            return need(in.oracle_var, s, "oracle_var");
        case Strategy::BucketFloor:
            return bucket_floor(need(in.pilot_var, s, "pilot_var"), need(in.pilot_labels, s, "pilot_labels"), in.heavy);
        case Strategy::Placebo: {
            const auto& var = need(in.pilot_var, s, "pilot_var");
            return bucket_floor(var, placebo_labels(need(in.pilot_labels, s, "pilot_labels"), placebo_seed), in.heavy);
        }
        case Strategy::LabelOracle:
            return bucket_floor(need(in.pilot_var, s, "pilot_var"), need(in.reference_labels, s, "reference_labels"),
                                in.heavy);
        case Strategy::RobustVar:
            return need(in.mom_var, s, "mom_var");
        case Strategy::RobustFloor:
            return bucket_floor(need(in.mom_var, s, "mom_var"), need(in.pilot_labels, s, "pilot_labels"), in.heavy);
        case Strategy::RobustPlacebo: {
            const auto& var = need(in.mom_var, s, "mom_var");
            return bucket_floor(var, placebo_labels(need(in.pilot_labels, s, "pilot_labels"), placebo_seed), in.heavy);
        }
        case Strategy::Guarded: {
            const auto& var = need(in.pilot_var, s, "pilot_var");
            const auto& labels = need(in.pilot_labels, s, "pilot_labels");
            return guard_score(bucket_floor(var, labels, in.heavy), need(in.untrusted, s, "untrusted"));
        }
        case Strategy::Shrink:
        case Strategy::ShrinkGlobal: {
            if (in.pilot_spp < 2)
                throw std::invalid_argument(std::string("alloc::strategy_score: strategy '") + to_string(s) +
                                            "' needs pilot_spp >= 2, got " + std::to_string(in.pilot_spp));
            const auto& labels = need(in.pilot_labels, s, "pilot_labels");
            if (s == Strategy::Shrink) return shrink_score(need(in.pilot_var, s, "pilot_var"), labels, in.pilot_spp);
            std::vector<uint8_t> one(labels.size());  // every labelled pixel in population 0, unlabelled kept
            for (size_t i = 0; i < labels.size(); ++i) one[i] = labels[i] == gpu::NO_LABEL ? gpu::NO_LABEL : 0;
            return shrink_score(need(in.pilot_var, s, "pilot_var"), one, in.pilot_spp);
        }
        case Strategy::RobustAdaptive:
            return adaptive_mom_score(need(in.pilot_var, s, "pilot_var"), need(in.mom_var, s, "mom_var"),
                                      need(in.pilot_labels, s, "pilot_labels"), in.rare);
    }
    VKM_ASSERT(false, "alloc::strategy_score: unknown strategy " + std::to_string(static_cast<int>(s)));
}

}  // namespace vkmech::alloc
