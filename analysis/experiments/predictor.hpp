// The label-reliability predictor (paper §8.2, docs/descriptor.md §5): agreement rate of the
// pilot label with the reference per pilot purity / argmax-margin bin, pooled
// over scenes into a 20-bin monotone (isotonic) curve. A scene's predicted
// agreement is the mean of the curve over its labelled pilot pixels.
#pragma once

#include <string>
#include <vector>

namespace vkmech {

struct ReliabilityCurve {
    int bins = 20;                       // equal-width bins on [0, 1]
    std::vector<double> margin, purity;  // monotone agreement rate per bin
    unsigned pilot_spp = 0, reference_spp = 0;
    std::vector<std::string> scenes;  // what it was fitted on
    // The labels it was fitted on: empty, the paper's buckets; else the taxonomy file (as given) and its
    // SHA-256 (`vkmech study predictor --taxonomy FILE`, docs/lpe.md). A curve predicts only labels of its own.
    std::string taxonomy_file, taxonomy_sha256;

    // Mean curve value over the given per-pixel values (margin or purity).
    static double predict(const std::vector<double>& curve, const std::vector<double>& x);
    std::string json() const;
    // Throws std::runtime_error naming the file on a missing or malformed curve.
    static ReliabilityCurve load(const std::string& path);
};

// Empty when `curve` was fitted on the labels a render uses (`taxonomy_sha256`: the SHA-256 of its taxonomy
// file, empty for the buckets); else why it cannot predict them, naming `curve_file`.
std::string curve_label_mismatch(const ReliabilityCurve& curve, const std::string& curve_file,
                                 const std::string& taxonomy_sha256);

struct Frame;
struct PilotPrediction {
    double margin = 0.0, purity = 0.0;  // predicted share of labelled pixels keeping their pilot label
    size_t labelled = 0;
};
// A scene's predicted label reliability from its own pilot (paper §8.2).
PilotPrediction predict_from_pilot(const ReliabilityCurve& curve, const Frame& pilot);

}  // namespace vkmech
