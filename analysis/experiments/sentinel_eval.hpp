// `vkmech sentinel evaluate` without the renderer (docs/descriptor.md §9.4):
// a verified record's predictions against what the reference and the
// allocation comparison measure, each PASS, FAIL or INDETERMINATE by the rule
// the record wrote down before the reference existed. Pure CPU: the app
// layer renders (or takes from its cache) the reference, the shared pool and
// the pilot draws, and writes the report this returns.
#pragma once

#include "allocation/plan.hpp"
#include "experiments/sentinel.hpp"
#include "render/frame.hpp"

#include <string>
#include <vector>

namespace vkmech::sentinel {

struct EvalInputs {
    const Frame* reference = nullptr;  // the independent reference (protocol.reference_spp)
    const SamplePool* pool = nullptr;  // the shared pool every final image is drawn from
    std::vector<Pilot> pilots;         // protocol.draws pilot draws; pilots[0] is the registered draw
};

struct Outcome {
    std::string name, covers, predicted, measured;
    std::string verdict;  // "PASS", "FAIL" or "INDETERMINATE"
    std::string detail;   // how the measured value was obtained
};

struct StrategyScore {
    std::string name;
    std::vector<double> mse;  // per pilot draw (unclamped linear RGB)
    double psnr_mean = 0.0;   // mean over draws of the per-draw PSNR (peak: the reference's largest RGB value)
    double psnr_std = 0.0;    // seed std over draws
    int wins_vs_uniform = 0;  // draws with a lower MSE than uniform
    bool identical_to_observed_var = false;  // same n(p) as observed-var on the registered draw
};

struct Evaluation {
    std::vector<Outcome> outcomes;
    std::vector<StrategyScore> strategies;
    double peak = 1.0;
    std::vector<std::string> checks;  // reproducibility checks (the registered pilot re-rendered, ...)
    bool pilot_reproduced = false;
    int pass = 0, fail = 0, indeterminate = 0;
};

// Throws std::invalid_argument if the inputs' sizes disagree with the record
// (film, pool, draws). A null reference or pool is the caller's bug (InternalError).
Evaluation evaluate(const Record& r, const EvalInputs& in);

// The evaluation as JSON (with the record's seal, so it names what it tests)
// and as a Markdown report.
std::string evaluation_json(const Record& r, const std::string& record_sha256, const Evaluation& e);
std::string evaluation_markdown(const Record& r, const std::string& record_file, const std::string& record_sha256,
                                const Evaluation& e, const std::vector<std::string>& renders);

}  // namespace vkmech::sentinel
