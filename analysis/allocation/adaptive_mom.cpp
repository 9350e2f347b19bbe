#include "allocation/adaptive_mom.hpp"

#include "allocation/mom.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace vkmech::alloc {

int adaptive_mom_k(uint8_t label, int n0, uint32_t rare) {
    if (!mom_defined(n0))
        throw std::invalid_argument("alloc::adaptive_mom_k: median-of-means is not defined at N0 = " +
                                    std::to_string(n0));
    return is_rare_tail(label, rare) ? 1 : mom_block_count(n0);
}

std::vector<double> adaptive_mom_score(const std::vector<double>& plain_var, const std::vector<double>& mom_var,
                                       const std::vector<uint8_t>& labels, uint32_t rare) {
    if (plain_var.size() != labels.size() || mom_var.size() != labels.size())
        throw std::invalid_argument("alloc::adaptive_mom_score: " + std::to_string(plain_var.size()) +
                                    " plain variances, " + std::to_string(mom_var.size()) +
                                    " median-of-means variances and " + std::to_string(labels.size()) +
                                    " labels; the sizes must agree");
    std::vector<double> d(labels.size());
    for (size_t p = 0; p < labels.size(); ++p) d[p] = is_rare_tail(labels[p], rare) ? plain_var[p] : mom_var[p];
    return d;
}

size_t rare_tail_pixels(const std::vector<uint8_t>& labels, uint32_t rare) {
    return static_cast<size_t>(
        std::count_if(labels.begin(), labels.end(), [rare](uint8_t l) { return is_rare_tail(l, rare); }));
}

}  // namespace vkmech::alloc
