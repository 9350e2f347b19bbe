// `vkmech.stats`: the statistics of the paper's analyses (docs/descriptor.md §5, §6) on numpy
// arrays, the very functions the studies run (analysis/stats, analysis/allocation).
#include "allocation/neyman.hpp"
#include "experiments/study_context.hpp"
#include "stats/agreement.hpp"
#include "stats/rank.hpp"
#include "stats/split_half.hpp"
#include "stats/summary.hpp"

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cmath>
#include <string>
#include <vector>

namespace py = pybind11;

namespace vkmech {

namespace {

using DoubleArray = py::array_t<double, py::array::c_style | py::array::forcecast>;

constexpr size_t kMinPairs = 3;  // as the variance study: a Spearman over fewer pixels is NaN

std::vector<double> flat(const DoubleArray& a) { return std::vector<double>(a.data(), a.data() + a.size()); }

// A label map (the `dominant` channel, any numeric dtype) as bytes: 0..6, or 255 for no label.
std::vector<uint8_t> labels(const DoubleArray& a, const char* what) {
    std::vector<uint8_t> out(static_cast<size_t>(a.size()));
    const double* d = a.data();
    for (size_t i = 0; i < out.size(); ++i) {
        const double v = d[i];
        const bool bucket = v >= 0 && v < gpu::BUCKET_COUNT && v == std::floor(v);
        if (!bucket && v != gpu::NO_LABEL)
            throw py::value_error(std::string(what) + ": value " + std::to_string(v) + " at index " +
                                  std::to_string(i) + " is neither a bucket index 0..6 nor 255 (no label)");
        out[i] = static_cast<uint8_t>(v);
    }
    return out;
}

std::vector<uint8_t> mask_of(const std::optional<DoubleArray>& mask, size_t n) {
    if (!mask) return std::vector<uint8_t>(n, 1);
    if (static_cast<size_t>(mask->size()) != n) throw py::value_error("mask has another size than the fields");
    std::vector<uint8_t> m(n);
    for (size_t i = 0; i < n; ++i) m[i] = mask->data()[i] != 0.0;
    return m;
}

py::dict label_agreement(const DoubleArray& a, const DoubleArray& b) {
    if (a.size() != b.size()) throw py::value_error("the two label maps differ in size");
    const std::vector<uint8_t> la = labels(a, "a"), lb = labels(b, "b");
    const int k = static_cast<int>(gpu::BUCKET_COUNT);
    const stats::Confusion c = stats::confusion(la, lb, k);
    py::dict d;
    d["agreement"] = stats::agreement(c);
    d["kappa"] = stats::cohen_kappa(c);
    d["weighted_kappa"] = stats::weighted_kappa(c, stats::spec_kappa_weights(k, light_tailed_buckets()));
    d["struct_share"] = stats::structural_share(c, heavy_buckets());
    d["max_drift"] = stats::max_drift(la, lb, k);
    d["pixels_compared"] = c.total();
    d["labelled_in_one_only"] = stats::labelled_in_one_only(la, lb);
    return d;
}

double spearman(const DoubleArray& x, const DoubleArray& y, const std::optional<DoubleArray>& mask) {
    if (x.size() != y.size()) throw py::value_error("x and y differ in size");
    return stats::masked_spearman(flat(x), flat(y), mask_of(mask, static_cast<size_t>(x.size())), kMinPairs);
}

// docs/descriptor.md §5 split-half reliability: `means` holds S per-seed mean-luminance fields
// (S, ...); each random half's sigma^2 field is the variance (ddof 1) over its seeds; the result
// is the Spearman between the two halves' fields, per partition.
py::tuple split_half(const DoubleArray& means, int partitions, uint64_t seed, const std::optional<DoubleArray>& mask) {
    if (means.ndim() < 2) throw py::value_error("means must be (seeds, pixels...): one field per seed");
    const int S = static_cast<int>(means.shape(0));
    if (S < 2 || S % 2 != 0) throw py::value_error("split_half needs an even number of seeds, at least 2");
    const size_t P = static_cast<size_t>(means.size()) / static_cast<size_t>(S);
    const std::vector<uint8_t> m = mask_of(mask, P);
    std::vector<stats::Partition> parts;
    try {
        parts = stats::random_halves(S, partitions, seed);
    } catch (const std::invalid_argument& e) {
        throw py::value_error(e.what());
    }
    auto field = [&](const std::vector<int>& half) {
        std::vector<double> v(P), x(half.size());
        for (size_t p = 0; p < P; ++p) {
            for (size_t i = 0; i < half.size(); ++i) x[i] = means.data()[static_cast<size_t>(half[i]) * P + p];
            v[p] = stats::sample_variance(x);
        }
        return v;
    };
    py::array_t<double> rhos(static_cast<py::ssize_t>(parts.size()));
    double sum = 0.0;
    for (size_t i = 0; i < parts.size(); ++i) {
        const double r = stats::masked_spearman(field(parts[i].a), field(parts[i].b), m, kMinPairs);
        rhos.mutable_data()[i] = r;
        sum += r;
    }
    return py::make_tuple(parts.empty() ? NAN : sum / static_cast<double>(parts.size()), rhos);
}

py::array_t<uint32_t> neyman(const DoubleArray& score, uint64_t total, uint32_t floor, uint32_t cap) {
    std::vector<uint32_t> n;
    try {
        n = alloc::neyman_allocation(flat(score), total, floor, cap);
    } catch (const std::invalid_argument& e) {
        throw py::value_error(e.what());
    }
    std::vector<py::ssize_t> shape(score.shape(), score.shape() + score.ndim());
    py::array_t<uint32_t> out(shape);
    std::copy(n.begin(), n.end(), out.mutable_data());
    return out;
}

}  // namespace

void bind_stats(py::module_& parent) {
    py::module_ m = parent.def_submodule("stats", "The statistics of the paper's analyses, on numpy arrays");
    m.def("label_agreement", &label_agreement, py::arg("a"), py::arg("b"),
          "Two `dominant` maps (0..6, 255 = no label) compared over the pixels labelled in both: agreement, Cohen's "
          "kappa, the weighted kappa and struct% of docs/descriptor.md §5, and the max drift of the pixel shares");
    m.def("spearman", &spearman, py::arg("x"), py::arg("y"), py::arg("mask") = py::none(),
          "Spearman's rho with average ranks for ties (as scipy), over the finite pairs where mask is set");
    m.def("split_half", &split_half, py::arg("means"), py::arg("partitions") = 20, py::arg("seed") = 0,
          py::arg("mask") = py::none(),
          "Split-half reliability of sigma^2: means is (seeds, H, W) per-seed mean luminance; returns (mean rho, "
          "rho per random half split)");
    m.def("neyman_allocation", &neyman, py::arg("score"), py::arg("total"), py::arg("floor") = 1, py::arg("cap") = 256,
          "n(p) proportional to sqrt(score), at least floor and at most cap, summing to total exactly; the same "
          "shape as score (uint32)");
}

}  // namespace vkmech
