// The parsed form of one light path expression (docs/lpe.md), between the parser
// (lpe_parse.cpp) and the automaton construction (lpe.cpp). Internal to the LPE compiler.
#pragma once

#include "render/lpe.hpp"

#include <string>
#include <vector>

namespace vkmech::lpe::detail {

constexpr uint8_t kAllTypes = (1u << kEventTypeCount) - 1u;
constexpr uint8_t kAllScatters = (1u << kScatterCount) - 1u;

// The label position of an event: any label, one of `names`, or (negated) none of them.
struct LabelSet {
    bool any = true;
    bool negated = false;
    std::vector<std::string> names;
    std::vector<int> columns;  // where each name is written (1-based, in the file's line)
};

struct Node {
    enum class Op { Event, Cat, Alt, Repeat };
    Op op = Op::Event;
    int column = 0;  // 1-based column in the file's line
    // Event: one path event whose type is in `types` (bit EventType), whose scattering is in
    // `scatters` (bit Scatter) and whose label matches `label`.
    uint8_t types = kAllTypes;
    uint8_t scatters = kAllScatters;
    LabelSet label;
    // Repeat: children[0], at least `min` and at most `max` times (max < 0: unbounded).
    int min = 0, max = 0;
    std::vector<Node> children;  // Cat: in order; Alt: the alternatives; Repeat: one
};

constexpr int kMaxRepeatCount = 32;  // the largest n or m in {n}, {n,}, {n,m}

// Parses `expression`, whose first character stands at `column` of line `line` of `file`.
// Throws LpeError naming file:line:column and what was expected.
Node parse_expression(const std::string& expression, const std::string& file, int line, int column);

}  // namespace vkmech::lpe::detail
