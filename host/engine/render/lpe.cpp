// The LPE compiler (docs/lpe.md): label classes from the scene's slots, a Thompson NFA per
// line, the subset construction, Moore minimization, and the checks (state limit, lines that
// never match or never win).
#include "render/lpe.hpp"

#include <algorithm>
#include <bit>
#include <deque>
#include <map>
#include <set>

#include "io/invariant.hpp"
#include "render/lpe_ast.hpp"

namespace vkmech::lpe {

const std::array<EventKind, kKindCount> kEventKinds = {{
    {EventType::Camera, Scatter::None, "C"},
    {EventType::Reflect, Scatter::Diffuse, "RD"},
    {EventType::Reflect, Scatter::Glossy, "RG"},
    {EventType::Reflect, Scatter::Singular, "RS"},
    {EventType::Transmit, Scatter::Diffuse, "TD"},
    {EventType::Transmit, Scatter::Glossy, "TG"},
    {EventType::Transmit, Scatter::Singular, "TS"},
    {EventType::Light, Scatter::None, "L"},
    {EventType::Background, Scatter::None, "B"},
}};

namespace {

using detail::Node;

constexpr uint32_t kNfaStateCap = 200000;  // Thompson states of one line (repetitions expand)
// Subset-construction states before minimization: 64 times the limit, within these bounds.
constexpr uint32_t kMinDeterminizeCap = 4096, kMaxDeterminizeCap = 65536;

// ---- labels ----

// The quoted labels of the taxonomy, the label class of each slot, and which labels each class answers to.
struct Labels {
    std::vector<std::string> names;              // first use first
    std::vector<std::pair<int, int>> first_use;  // (line, column)
    std::map<std::string, uint32_t> index;
    std::vector<uint16_t> class_of_slot;
    std::vector<std::vector<bool>> class_answers;  // [class][label]
};

void collect_labels(const Node& n, int line, Labels& out) {
    for (size_t i = 0; i < n.label.names.size(); ++i) {
        const std::string& name = n.label.names[i];
        if (out.index.emplace(name, uint32_t(out.names.size())).second) {
            out.names.push_back(name);
            out.first_use.emplace_back(line, n.label.columns[i]);
        }
    }
    for (const Node& c : n.children) collect_labels(c, line, out);
}

}  // namespace

std::vector<std::string> taxonomy_labels(const TaxonomySource& source) {
    Labels labels;
    for (const TaxonomyLine& l : source.lines)
        collect_labels(detail::parse_expression(l.expression, source.file, l.line, l.expression_column), l.line,
                       labels);
    return labels.names;
}

namespace {

// Slots that answer to the same set of the taxonomy's labels are one class; class 0 answers to none
// (events without a slot, and slots the taxonomy names nowhere).
void label_classes(const std::vector<LabelSlot>& slots, Labels& out) {
    std::map<std::vector<bool>, uint16_t> classes;
    std::vector<bool> none(out.names.size(), false);
    classes.emplace(none, 0);
    out.class_answers.push_back(none);
    for (const LabelSlot& slot : slots) {
        std::vector<bool> answers(out.names.size(), false);
        for (const std::string& name : slot.names)
            if (auto it = out.index.find(name); it != out.index.end()) answers[it->second] = true;
        auto [it, fresh] = classes.emplace(answers, uint16_t(out.class_answers.size()));
        if (fresh) out.class_answers.push_back(answers);
        out.class_of_slot.push_back(it->second);
    }
}

// ---- Thompson NFA ----

struct Nfa {
    struct State {
        std::vector<uint32_t> eps;
        int32_t set = -1;  // index into sets: the symbols of the one labelled edge, or -1
        uint32_t to = 0;
        int32_t accept = -1;  // the line this state accepts, or -1
    };
    std::vector<State> states;
    std::vector<std::vector<uint8_t>> sets;  // [set][symbol] = 1 when the edge takes the symbol
    uint32_t add() {
        states.emplace_back();
        return uint32_t(states.size() - 1);
    }
};

struct Fragment {
    uint32_t in, out;
};

class NfaBuilder {
public:
    NfaBuilder(Nfa& nfa, const Labels& labels, uint32_t label_classes, const std::string& file, int line)
        : nfa_(nfa), labels_(labels), label_classes_(label_classes), file_(file), line_(line) {}

    Fragment build(const Node& n) {
        if (nfa_.states.size() > kNfaStateCap)
            throw LpeError(file_, line_, n.column,
                           "the expression is too large: its repetitions expand to over " +
                               std::to_string(kNfaStateCap) + " automaton states");
        switch (n.op) {
            case Node::Op::Event: {
                Fragment f{nfa_.add(), nfa_.add()};
                nfa_.states[f.in].set = int32_t(nfa_.sets.size());
                nfa_.states[f.in].to = f.out;
                nfa_.sets.push_back(symbols(n));
                return f;
            }
            case Node::Op::Cat: {
                Fragment f = build(n.children.front());
                for (size_t i = 1; i < n.children.size(); ++i) {
                    Fragment next = build(n.children[i]);
                    nfa_.states[f.out].eps.push_back(next.in);
                    f.out = next.out;
                }
                return f;
            }
            case Node::Op::Alt: {
                Fragment f{nfa_.add(), nfa_.add()};
                for (const Node& c : n.children) {
                    Fragment branch = build(c);
                    nfa_.states[f.in].eps.push_back(branch.in);
                    nfa_.states[branch.out].eps.push_back(f.out);
                }
                return f;
            }
            case Node::Op::Repeat:
                return repeat(n);
        }
        VKM_ASSERT(false, "unknown LPE node");
        return {};
    }

private:
    // min copies, then (max - min) optional ones, or a loop when max < 0.
    Fragment repeat(const Node& n) {
        const Node& child = n.children.front();
        uint32_t in = nfa_.add(), cur = in;
        for (int i = 0; i < n.min; ++i) {
            Fragment f = build(child);
            nfa_.states[cur].eps.push_back(f.in);
            cur = f.out;
        }
        if (n.max < 0) {
            uint32_t hub = nfa_.add();
            Fragment f = build(child);
            nfa_.states[cur].eps.push_back(hub);
            nfa_.states[hub].eps.push_back(f.in);
            nfa_.states[f.out].eps.push_back(hub);
            return {in, hub};
        }
        uint32_t end = nfa_.add();
        for (int i = n.min; i < n.max; ++i) {
            Fragment f = build(child);
            nfa_.states[cur].eps.push_back(end);
            nfa_.states[cur].eps.push_back(f.in);
            cur = f.out;
        }
        nfa_.states[cur].eps.push_back(end);
        return {in, end};
    }

    // The symbols an event node takes: every (kind, label class) it matches.
    std::vector<uint8_t> symbols(const Node& n) const {
        std::vector<uint8_t> set(size_t(kKindCount) * label_classes_, 0);
        for (uint32_t k = 0; k < kKindCount; ++k) {
            if (!(n.types & (1u << uint32_t(kEventKinds[k].type)))) continue;
            if (!(n.scatters & (1u << uint32_t(kEventKinds[k].scatter)))) continue;
            for (uint32_t c = 0; c < label_classes_; ++c)
                if (label_matches(n.label, c)) set[size_t(k) * label_classes_ + c] = 1;
        }
        return set;
    }
    bool label_matches(const detail::LabelSet& l, uint32_t cls) const {
        if (l.any) return true;
        bool some = false;
        for (const std::string& name : l.names) some = some || labels_.class_answers[cls][labels_.index.at(name)];
        return l.negated ? !some : some;
    }

    Nfa& nfa_;
    const Labels& labels_;
    uint32_t label_classes_;
    const std::string& file_;
    int line_;
};

// ---- DFA ----

// A complete DFA over `alphabet` symbols; accept[s] is a line index or `other`.
struct Dfa {
    uint32_t alphabet = 0;
    uint32_t other = 0;
    uint32_t start = 0;
    std::vector<uint32_t> next;  // [state * alphabet + symbol]
    std::vector<uint32_t> accept;
    uint32_t size() const { return uint32_t(accept.size()); }
    uint32_t step(uint32_t s, uint32_t a) const { return next[size_t(s) * alphabet + a]; }
};

void close_over_epsilon(const Nfa& nfa, std::vector<uint32_t>& set, std::vector<uint32_t>& mark, uint32_t stamp) {
    std::vector<uint32_t> stack(set.begin(), set.end());
    for (uint32_t s : set) mark[s] = stamp;
    while (!stack.empty()) {
        uint32_t s = stack.back();
        stack.pop_back();
        for (uint32_t t : nfa.states[s].eps)
            if (mark[t] != stamp) {
                mark[t] = stamp;
                set.push_back(t);
                stack.push_back(t);
            }
    }
    std::sort(set.begin(), set.end());
}

// The subset construction; false when it passes `cap` states. A subset accepts the first line that one of its
// NFA states accepts (`other` when none); with `all_matches`, every such line, a bit per line (0 when none).
bool determinize(const Nfa& nfa, uint32_t start, uint32_t alphabet, uint32_t other, bool all_matches, uint32_t cap,
                 Dfa& out) {
    out = Dfa{};
    out.alphabet = alphabet;
    out.other = other;
    std::vector<uint32_t> mark(nfa.states.size(), 0);
    uint32_t stamp = 0;
    std::map<std::vector<uint32_t>, uint32_t> ids;
    std::vector<std::vector<uint32_t>> subsets;
    auto intern = [&](std::vector<uint32_t>&& set) {
        auto [it, fresh] = ids.emplace(std::move(set), uint32_t(subsets.size()));
        if (fresh) {
            subsets.push_back(it->first);
            uint32_t acc = all_matches ? 0u : other;
            for (uint32_t s : it->first) {
                const int32_t line = nfa.states[s].accept;
                if (line >= 0) acc = all_matches ? acc | (1u << line) : std::min(acc, uint32_t(line));
            }
            out.accept.push_back(acc);
        }
        return it->second;
    };
    std::vector<uint32_t> first{start};
    close_over_epsilon(nfa, first, mark, ++stamp);
    out.start = intern(std::move(first));
    for (uint32_t d = 0; d < subsets.size(); ++d) {
        if (subsets.size() > cap) return false;
        out.next.resize(subsets.size() * size_t(alphabet));
        for (uint32_t a = 0; a < alphabet; ++a) {
            std::vector<uint32_t> moved;
            ++stamp;
            for (uint32_t s : subsets[d]) {
                const Nfa::State& st = nfa.states[s];
                if (st.set >= 0 && nfa.sets[st.set][a] && mark[st.to] != stamp) {
                    mark[st.to] = stamp;
                    moved.push_back(st.to);
                }
            }
            close_over_epsilon(nfa, moved, mark, ++stamp);
            uint32_t target = intern(std::move(moved));
            out.next.resize(subsets.size() * size_t(alphabet));
            out.next[size_t(d) * alphabet + a] = target;
        }
    }
    return subsets.size() <= cap;
}

// Moore's partition refinement, then the states renumbered in breadth-first order from the start
// (symbols in order), so the start is 0 and equal taxonomies give equal tables.
Dfa minimize(const Dfa& d) {
    const uint32_t n = d.size();
    std::vector<uint32_t> block(n);
    {
        std::map<uint32_t, uint32_t> by_accept;
        for (uint32_t s = 0; s < n; ++s)
            block[s] = by_accept.emplace(d.accept[s], uint32_t(by_accept.size())).first->second;
    }
    size_t blocks = 0;
    for (;;) {
        std::map<std::vector<uint32_t>, uint32_t> signatures;
        std::vector<uint32_t> refined(n);
        std::vector<uint32_t> sig(d.alphabet + 1);
        for (uint32_t s = 0; s < n; ++s) {
            sig[0] = block[s];
            for (uint32_t a = 0; a < d.alphabet; ++a) sig[a + 1] = block[d.step(s, a)];
            refined[s] = signatures.emplace(sig, uint32_t(signatures.size())).first->second;
        }
        block.swap(refined);
        if (signatures.size() == blocks) break;
        blocks = signatures.size();
    }
    // Breadth-first renumbering over the blocks.
    std::vector<uint32_t> representative(blocks, UINT32_MAX), order(blocks, UINT32_MAX);
    for (uint32_t s = 0; s < n; ++s)
        if (representative[block[s]] == UINT32_MAX) representative[block[s]] = s;
    Dfa out;
    out.alphabet = d.alphabet;
    out.other = d.other;
    std::deque<uint32_t> queue{block[d.start]};
    order[block[d.start]] = 0;
    std::vector<uint32_t> visit{block[d.start]};
    while (!queue.empty()) {
        uint32_t b = queue.front();
        queue.pop_front();
        for (uint32_t a = 0; a < d.alphabet; ++a) {
            uint32_t t = block[d.step(representative[b], a)];
            if (order[t] == UINT32_MAX) {
                order[t] = uint32_t(visit.size());
                visit.push_back(t);
                queue.push_back(t);
            }
        }
    }
    out.accept.resize(visit.size());
    out.next.resize(visit.size() * size_t(d.alphabet));
    for (uint32_t i = 0; i < visit.size(); ++i) {
        uint32_t rep = representative[visit[i]];
        out.accept[i] = d.accept[rep];
        for (uint32_t a = 0; a < d.alphabet; ++a) out.next[size_t(i) * d.alphabet + a] = order[block[d.step(rep, a)]];
    }
    out.start = 0;
    return out;
}

// ---- what a vkmech path looks like: C, then R or T events, then L or B ----

constexpr uint32_t kShapeStart = 0, kShapeInside = 1, kShapeDone = 2, kShapeNever = 3;
uint32_t shape_step(uint32_t q, uint32_t kind) {
    EventType t = kEventKinds[kind].type;
    if (q == kShapeStart) return t == EventType::Camera ? kShapeInside : kShapeNever;
    if (q == kShapeInside) {
        if (t == EventType::Reflect || t == EventType::Transmit) return kShapeInside;
        if (t == EventType::Light || t == EventType::Background) return kShapeDone;
    }
    return kShapeNever;
}

// Breadth-first over the product of `dfas` with the path shape: calls visit({shape, state of each dfa...}) at every
// reachable tuple that ends a whole vkmech path; stops when visit returns true.
template <class Visit>
bool any_whole_path(const std::vector<const Dfa*>& dfas, uint32_t label_classes, Visit visit) {
    std::set<std::vector<uint32_t>> seen;
    std::deque<std::vector<uint32_t>> queue;
    std::vector<uint32_t> first{kShapeStart};
    for (const Dfa* d : dfas) first.push_back(d->start);
    seen.insert(first);
    queue.push_back(first);
    while (!queue.empty()) {
        std::vector<uint32_t> cur = queue.front();
        queue.pop_front();
        if (cur[0] == kShapeDone && visit(cur)) return true;
        for (uint32_t k = 0; k < kKindCount; ++k) {
            uint32_t q = shape_step(cur[0], k);
            if (q == kShapeNever) continue;
            for (uint32_t c = 0; c < label_classes; ++c) {
                std::vector<uint32_t> next{q};
                for (size_t i = 0; i < dfas.size(); ++i)
                    next.push_back(dfas[i]->step(cur[i + 1], k * label_classes + c));
                if (seen.insert(next).second) queue.push_back(next);
            }
        }
    }
    return false;
}

// One line's (or the whole taxonomy's) minimal DFA; false when the subset construction passes `cap`. With
// `all_matches`, the whole taxonomy's accepting values are sets of lines (determinize).
bool line_dfa(const std::vector<Node>& asts, const std::vector<uint32_t>& lines, const TaxonomySource& src,
              const Labels& labels, uint32_t cap, Dfa& out, bool all_matches = false) {
    const uint32_t label_classes = uint32_t(labels.class_answers.size());
    Nfa nfa;
    uint32_t start = nfa.add();
    for (uint32_t i : lines) {
        NfaBuilder builder(nfa, labels, label_classes, src.file, src.lines[i].line);
        Fragment f = builder.build(asts[i]);
        nfa.states[start].eps.push_back(f.in);
        nfa.states[f.out].accept = int32_t(lines.size() == 1 ? 0 : i);
    }
    Dfa raw;
    if (!determinize(nfa, start, kKindCount * label_classes, lines.size() == 1 ? 1 : uint32_t(src.lines.size()),
                     all_matches, cap, raw))
        return false;
    out = minimize(raw);
    return true;
}

std::string quoted(const std::string& name) { return "`" + name + "`"; }

// CompileOptions::all_matches: the classes are the combinations of lines that whole vkmech paths match (fewest
// lines first, then in line order), and `other` the empty one. Renames the accepting sets of `d` to those classes
// (into `out`) and minimizes again.
Dfa by_combination(Dfa d, uint32_t label_classes, const TaxonomySource& src, CompiledTaxonomy& out) {
    std::set<uint32_t> seen;
    any_whole_path({&d}, label_classes, [&](const std::vector<uint32_t>& s) {
        if (d.accept[s[1]] != 0) seen.insert(d.accept[s[1]]);
        return false;
    });
    // Fewest lines first; among equally many, by their lines in order (a&d before b&c).
    auto lines_of = [](uint32_t m) {
        std::vector<uint32_t> l;
        for (uint32_t i = 0; i < 32; ++i)
            if (m >> i & 1u) l.push_back(i);
        return l;
    };
    std::vector<uint32_t> combos(seen.begin(), seen.end());
    std::sort(combos.begin(), combos.end(), [&](uint32_t a, uint32_t b) {
        const int pa = std::popcount(a), pb = std::popcount(b);
        return pa != pb ? pa < pb : lines_of(a) < lines_of(b);
    });
    if (combos.size() > kMaxLines)
        throw LpeError(src.file, 0, 0,
                       "the queries make " + std::to_string(combos.size()) + " combinations, over the limit of " +
                           std::to_string(kMaxLines));
    out.class_lines = combos;
    out.class_names.clear();
    std::map<uint32_t, uint32_t> class_of;
    for (uint32_t m : combos) {
        std::string name;
        for (uint32_t i = 0; i < src.lines.size(); ++i)
            if (m >> i & 1u) name += (name.empty() ? "" : "&") + src.lines[i].name;
        class_of[m] = uint32_t(out.class_names.size());
        out.class_names.push_back(name);
    }
    out.other_class = uint32_t(combos.size());
    out.class_names.push_back("other");
    for (uint32_t& a : d.accept) {
        auto it = class_of.find(a);
        a = it == class_of.end() ? out.other_class : it->second;
    }
    d.other = out.other_class;
    return minimize(d);
}

// The tables of the whole taxonomy's minimal DFA, into `out`.
void finish(const Dfa& whole, CompiledTaxonomy& out) {
    out.state_count = whole.size();
    out.start_state = uint16_t(whole.start);
    out.next_state.assign(whole.next.begin(), whole.next.end());
    out.accept_class.assign(whole.accept.begin(), whole.accept.end());
    for (uint32_t s = 0; s < whole.size(); ++s) {
        bool sink = whole.accept[s] == whole.other;
        for (uint32_t a = 0; a < whole.alphabet && sink; ++a) sink = whole.step(s, a) == s;
        if (sink) out.dead_state = uint16_t(s);
    }
}

[[noreturn]] void refuse_size(const TaxonomySource& src, const std::vector<uint32_t>& line_states, uint32_t cap,
                              const std::string& whole, uint32_t max_states, bool queries) {
    std::vector<uint32_t> order(src.lines.size());
    for (uint32_t i = 0; i < order.size(); ++i) order[i] = i;
    std::stable_sort(order.begin(), order.end(),
                     [&](uint32_t a, uint32_t b) { return line_states[a] > line_states[b]; });
    std::string each;
    for (uint32_t i : order) {
        if (!each.empty()) each += ", ";
        each += quoted(src.lines[i].name) + " (line " + std::to_string(src.lines[i].line) + ") " +
                (line_states[i] > cap ? "over " + std::to_string(cap) : std::to_string(line_states[i]));
    }
    throw LpeError(src.file, 0, 0,
                   std::string(queries ? "the queries' DFA has " : "the taxonomy's DFA has ") + whole +
                       " states, over the limit of " + std::to_string(max_states) + ". Each line alone needs: " + each +
                       ". Simplify the largest lines; lines that are small alone grow together when each tells "
                       "paths apart in its own way");
}

}  // namespace

uint32_t CompiledTaxonomy::classify(std::span<const uint32_t> symbols) const {
    uint16_t s = start_state;
    for (uint32_t a : symbols) s = step(s, a);
    return accept_class[s];
}

std::vector<uint8_t> CompiledTaxonomy::next_state_u8() const {
    VKM_ASSERT(state_count <= 256, "a DFA of more than 256 states does not fit bytes");
    return std::vector<uint8_t>(next_state.begin(), next_state.end());
}

CompiledTaxonomy compile_taxonomy(const TaxonomySource& src, const std::vector<LabelSlot>& slots,
                                  const CompileOptions& options) {
    if (src.lines.empty())
        throw LpeError(src.file, 0, 0, "no classes: a taxonomy needs at least one `name = expression` line");
    if (src.lines.size() > kMaxLines)
        throw LpeError(src.file, 0, 0, "a taxonomy has at most " + std::to_string(kMaxLines) + " lines (classes)");
    if (options.all_matches && src.lines.size() > kMaxQueryLines)
        throw LpeError(src.file, 0, 0, "at most " + std::to_string(kMaxQueryLines) + " queries");
    if (options.max_states < 1 || options.max_states > 0xFFFF)
        throw std::invalid_argument("compile_taxonomy: max_states must be in [1, 65535]");
    CompiledTaxonomy out;
    std::vector<Node> asts;
    Labels labels;
    for (const TaxonomyLine& l : src.lines) {
        asts.push_back(detail::parse_expression(l.expression, src.file, l.line, l.expression_column));
        collect_labels(asts.back(), l.line, labels);
        out.class_names.push_back(l.name);
    }
    out.other_class = uint32_t(src.lines.size());
    out.class_names.push_back("other");
    label_classes(slots, labels);
    out.labels = labels.names;
    out.label_class_of_slot = labels.class_of_slot;
    out.label_class_count = uint32_t(labels.class_answers.size());
    out.alphabet_size = kKindCount * out.label_class_count;
    for (size_t i = 0; i < labels.names.size(); ++i) {
        bool answered = false;
        for (const auto& cls : labels.class_answers) answered = answered || cls[i];
        if (!answered)
            out.warnings.push_back({src.file, labels.first_use[i].first, labels.first_use[i].second,
                                    "no material, shape or emitter of the scene has the id '" + labels.names[i] +
                                        "': the label matches nothing"});
    }

    // Each line alone: its size (for the state-limit message) and whether it can match at all.
    const uint32_t cap = std::clamp(64u * options.max_states, kMinDeterminizeCap, kMaxDeterminizeCap);
    std::vector<Dfa> alone(src.lines.size());
    std::vector<bool> measured(src.lines.size(), false), can_match(src.lines.size(), false);
    for (uint32_t i = 0; i < src.lines.size(); ++i) {
        measured[i] = line_dfa(asts, {i}, src, labels, cap, alone[i]);
        if (!measured[i]) {  // too large alone: named in the refusal below, if the whole is refused
            out.line_state_counts.push_back(cap + 1);
            continue;
        }
        out.line_state_counts.push_back(alone[i].size());
        const Dfa& d = alone[i];
        can_match[i] = any_whole_path({&d}, out.label_class_count,
                                      [&](const std::vector<uint32_t>& s) { return d.accept[s[1]] == 0; });
        if (!can_match[i])
            out.warnings.push_back({src.file, src.lines[i].line, src.lines[i].expression_column,
                                    quoted(src.lines[i].name) +
                                        " can never match: no vkmech path (C, then R or T events, then L or B, "
                                        "over the scene's labels) fits the expression"});
    }

    std::vector<uint32_t> all(src.lines.size());
    for (uint32_t i = 0; i < all.size(); ++i) all[i] = i;
    Dfa whole;
    if (!line_dfa(asts, all, src, labels, cap, whole, options.all_matches))
        refuse_size(src, out.line_state_counts, cap, "over " + std::to_string(cap), options.max_states,
                    options.all_matches);
    if (options.all_matches) whole = by_combination(whole, out.label_class_count, src, out);
    if (whole.size() > options.max_states)
        refuse_size(src, out.line_state_counts, cap, std::to_string(whole.size()), options.max_states,
                    options.all_matches);
    if (options.all_matches) {
        finish(whole, out);
        return out;
    }

    // Lines that match some path but win none: every such path goes to an earlier line.
    std::vector<bool> wins(src.lines.size() + 1, false);
    any_whole_path({&whole}, out.label_class_count, [&](const std::vector<uint32_t>& s) {
        wins[whole.accept[s[1]]] = true;
        return false;
    });
    for (uint32_t i = 0; i < src.lines.size(); ++i) {
        if (!measured[i] || !can_match[i] || wins[i]) continue;
        std::string by;
        for (uint32_t j = 0; j < i; ++j) {
            if (!measured[j]) continue;
            bool overlap =
                any_whole_path({&alone[i], &alone[j]}, out.label_class_count, [&](const std::vector<uint32_t>& s) {
                    return alone[i].accept[s[1]] == 0 && alone[j].accept[s[2]] == 0;
                });
            if (overlap) by += (by.empty() ? "" : ", ") + quoted(src.lines[j].name);
        }
        out.warnings.push_back({src.file, src.lines[i].line, src.lines[i].expression_column,
                                quoted(src.lines[i].name) +
                                    " never wins: every path it matches is taken by an earlier line (" + by + ")"});
    }

    finish(whole, out);
    return out;
}

}  // namespace vkmech::lpe
