// User taxonomies as light path expressions (docs/lpe.md): every operator on hand-worked event
// sequences through the compiled DFA, first match wins, `other`, minimization, the errors and
// warnings, the state limit, and taxonomies/paper.lpe against the cascade of docs/descriptor.md §2.4.
#include <doctest/doctest.h>

#include <algorithm>
#include <bit>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "mechanism.glsl"
#include "render/descriptor.hpp"
#include "render/lpe.hpp"
#include "render/lpe_ast.hpp"

using namespace vkmech::lpe;

namespace {

// A compiled taxonomy with the slots it was compiled for; events written as in docs/lpe.md:
// "C RD TS:glass L", a kind (kEventKinds' names) and, after ':', the first name of a slot.
struct Compiled {
    std::vector<LabelSlot> slots;
    CompiledTaxonomy t;

    std::vector<uint32_t> symbols(const std::string& events) const {
        std::istringstream in(events);
        std::string token;
        std::vector<uint32_t> out;
        while (in >> token) {
            std::string kind = token.substr(0, token.find(':'));
            uint32_t k = kKindCount;
            for (uint32_t i = 0; i < kKindCount; ++i)
                if (kind == kEventKinds[i].name) k = i;
            REQUIRE_MESSAGE(k < kKindCount, "unknown event kind in the test: " << token);
            uint32_t label_class = 0;
            if (token.find(':') != std::string::npos) {
                std::string slot = token.substr(token.find(':') + 1);
                size_t s = 0;
                while (s < slots.size() && slots[s].names.front() != slot) ++s;
                REQUIRE_MESSAGE(s < slots.size(), "unknown slot in the test: " << token);
                label_class = t.label_class_of_slot[s];
            }
            out.push_back(t.symbol(k, label_class));
        }
        return out;
    }
    std::string cls(const std::string& events) const { return t.class_names[t.classify(symbols(events))]; }
};

std::vector<LabelSlot> scene_slots() {
    return {{{"glass", "dielectric_mat"}}, {{"mirror", "chrome"}}, {{"floor", "felt"}}, {{"key"}}, {{"fill"}},
            {{"ball", "chrome"}}};
}

Compiled compile(const std::string& text, std::vector<LabelSlot> slots = scene_slots(), CompileOptions options = {}) {
    Compiled c{std::move(slots), {}};
    c.t = compile_taxonomy(parse_taxonomy(text, "test.lpe"), c.slots, options);
    return c;
}

// Does the one-line taxonomy `m = expression` take the event sequence?
bool matches(const std::string& expression, const std::string& events) {
    return compile("m = " + expression).cls(events) == "m";
}

std::string warnings(const CompiledTaxonomy& t) {
    std::string out;
    for (const Diagnostic& d : t.warnings) out += d.str() + "\n";
    return out;
}

// The LpeError of compiling `text`, as "line:column: reason".
std::string error_of(const std::string& text, CompileOptions options = {}) {
    try {
        compile(text, scene_slots(), options);
    } catch (const LpeError& e) {
        return std::to_string(e.line()) + ":" + std::to_string(e.column()) + ": " + e.reason();
    }
    return "no error";
}

}  // namespace

TEST_CASE("lpe: an event type letter matches that type with any scattering and label") {
    CHECK(matches("C R L", "C RD L"));
    CHECK(matches("C R L", "C RG L"));
    CHECK(matches("C R L", "C RS:glass L"));
    CHECK_FALSE(matches("C R L", "C TD L"));
    CHECK_FALSE(matches("C R L", "C RD B"));
    CHECK_FALSE(matches("C R L", "C L"));
    CHECK_FALSE(matches("C R L", "C RD RD L"));
    CHECK(matches("C T B", "C TS B"));
    CHECK_FALSE(matches("C T B", "C RS B"));
    CHECK(matches("C L", "C L:key"));
    CHECK(matches("C B", "C B"));
    CHECK_FALSE(matches("C B", "C L"));
}

TEST_CASE("lpe: a scattering letter matches any event with that scattering") {
    CHECK(matches("C D L", "C RD L"));
    CHECK(matches("C D L", "C TD L"));
    CHECK_FALSE(matches("C D L", "C RG L"));
    CHECK(matches("C G L", "C TG L"));
    CHECK(matches("C S S L", "C RS TS L"));
    CHECK_FALSE(matches("C S S L", "C RS TD L"));
    // The camera and the emitters have no scattering type: D matches neither.
    CHECK_FALSE(matches("D R L", "C RD L"));
    CHECK_FALSE(matches("C R D", "C RD L"));
    // s (straight) is in the grammar, but no vkmech event carries it.
    CHECK_FALSE(matches("C s L", "C RS L"));
}

TEST_CASE("lpe: the dot matches any one event") {
    CHECK(matches("C . L", "C RD L"));
    CHECK(matches("C . L", "C TS:glass L"));
    CHECK_FALSE(matches("C . L", "C L"));
    CHECK_FALSE(matches("C . L", "C RD RD L"));
    CHECK(matches(". . .", "C RD L"));
    CHECK(matches(". .", "C B"));
    CHECK_FALSE(matches(". .", "C RD B"));
}

TEST_CASE("lpe: concatenation, alternation and parentheses, with alternation looser than concatenation") {
    CHECK(matches("C R T L", "C RD TD L"));
    CHECK_FALSE(matches("C R T L", "C TD RD L"));
    // C R L | C T T L is (C R L) | (C T T L), as in a regular expression.
    CHECK(matches("C R L | C T T L", "C RD L"));
    CHECK(matches("C R L | C T T L", "C TS TS L"));
    CHECK_FALSE(matches("C R L | C T T L", "C TS L"));
    CHECK_FALSE(matches("C R L | C T T L", "C RD TS TS L"));
    CHECK(matches("C (R | T T) L", "C TS TS L"));
    CHECK(matches("C (R | T T) L", "C RG L"));
    CHECK(matches("C (R T)+ L", "C RD TD RD TD L"));
    CHECK_FALSE(matches("C (R T)+ L", "C RD TD RD L"));
    CHECK(matches("C ((R)) L", "C RD L"));
    CHECK(matches("C R L | C T L | C L", "C L"));
}

TEST_CASE("lpe: the repetitions star, plus, optional and counted ranges") {
    CHECK(matches("C D* L", "C L"));
    CHECK(matches("C D* L", "C RD TD RD L"));
    CHECK_FALSE(matches("C D* L", "C RD RG L"));
    CHECK_FALSE(matches("C D+ L", "C L"));
    CHECK(matches("C D+ L", "C RD L"));
    CHECK(matches("C D+ L", "C RD RD RD L"));
    CHECK(matches("C D? L", "C L"));
    CHECK(matches("C D? L", "C TD L"));
    CHECK_FALSE(matches("C D? L", "C RD RD L"));
    CHECK(matches("C .{2} L", "C RD RS L"));
    CHECK_FALSE(matches("C .{2} L", "C RD L"));
    CHECK_FALSE(matches("C .{2} L", "C RD RD RD L"));
    CHECK_FALSE(matches("C .{2,} L", "C RD L"));
    CHECK(matches("C .{2,} L", "C RD RS L"));
    CHECK(matches("C .{2,} L", "C RD RS RD RS RD L"));
    CHECK_FALSE(matches("C .{1,3} L", "C L"));
    CHECK(matches("C .{1,3} L", "C RD L"));
    CHECK(matches("C .{1,3} L", "C RD RD RD L"));
    CHECK_FALSE(matches("C .{1,3} L", "C RD RD RD RD L"));
    CHECK(matches("C .{0} L", "C L"));
    CHECK_FALSE(matches("C .{0} L", "C RD L"));
    // Stacked: (D+)? is D*.
    CHECK(matches("C D+? L", "C L"));
    CHECK(matches("C D+? L", "C RD RD L"));
    CHECK(matches("C (S D){2} L", "C RS RD TS TD L"));
}

TEST_CASE("lpe: sets and negated sets at the top level") {
    // [a b] is a | b, each element any expression.
    CHECK(matches("C [RT] L", "C RD L"));
    CHECK(matches("C [RT] L", "C TS L"));
    CHECK(matches("C [DG]+ L", "C RD TG L"));
    CHECK_FALSE(matches("C [DG]+ L", "C RS L"));
    CHECK(matches("C ['glass' D] L", "C RS:glass L"));
    CHECK(matches("C ['glass' D] L", "C RD:floor L"));
    CHECK_FALSE(matches("C ['glass' D] L", "C RS:floor L"));
    CHECK(matches("C [(S S) D] L", "C RS TS L"));
    // [^...] is one event whose type, scattering or label is none of those listed.
    CHECK(matches("C [^S]+ L", "C RD TG L"));
    CHECK_FALSE(matches("C [^S]+ L", "C RD RS L"));
    CHECK(matches("C [^R] L", "C TD L"));
    CHECK_FALSE(matches("C [^R] L", "C RD L"));
    CHECK(matches("C [^'glass' 'mirror']* L", "C RD:floor RS:ball L"));
    CHECK_FALSE(matches("C [^'glass' 'mirror']* L", "C RD:floor TS:glass L"));
    CHECK(matches("C [^'glass'] L", "C RD L"));  // no label at all: not 'glass'
    // A negated scattering set matches the camera and the emitters, whose scattering is none.
    CHECK(matches("[^S] [^S] [^S]", "C RD L"));
}

TEST_CASE("lpe: groups of type, scattering and label, with sets and fewer positions meaning any") {
    CHECK(matches("C <RS> L", "C RS L"));
    CHECK_FALSE(matches("C <RS> L", "C TS L"));
    CHECK_FALSE(matches("C <RS> L", "C RD L"));
    CHECK(matches("C <R> L", "C RG L"));
    CHECK(matches("C <> L", "C TD L"));
    CHECK(matches("C <.S'glass'> L", "C TS:glass L"));
    CHECK(matches("C <.S'glass'> L", "C RS:glass L"));
    CHECK_FALSE(matches("C <.S'glass'> L", "C TS:mirror L"));
    CHECK_FALSE(matches("C <.S'glass'> L", "C TD:glass L"));
    CHECK(matches("C <T S 'glass'>+ D L", "C TS:glass TS:glass RD:floor L"));
    CHECK(matches("C . <L.'key'>", "C RD L:key"));
    CHECK_FALSE(matches("C . <L.'key'>", "C RD L:fill"));
    CHECK(matches("C <[RT][DG]> L", "C TG L"));
    CHECK_FALSE(matches("C <[RT][DG]> L", "C TS L"));
    CHECK(matches("C <[^T].> L", "C RS L"));
    CHECK_FALSE(matches("C <[^T].> L", "C TS L"));
    CHECK(matches("C <.[^S]> L", "C RG L"));
    CHECK_FALSE(matches("C <.[^S]> L", "C RS L"));
    CHECK(matches("C <..['glass' 'mirror']> L", "C RS:mirror L"));
    CHECK_FALSE(matches("C <..['glass' 'mirror']> L", "C RS:ball L"));
    CHECK(matches("C <..[^'glass']> L", "C RS:ball L"));
    // OSL's spelling, without spaces, means the same.
    CHECK(matches("C<RD>*<L.'key'>", "C RD RD L:key"));
}

TEST_CASE("lpe: a quoted label matches every slot that answers to it, shape or material id") {
    CHECK(matches("C 'chrome' L", "C RS:mirror L"));
    CHECK(matches("C 'chrome' L", "C RS:ball L"));
    CHECK_FALSE(matches("C 'chrome' L", "C RS:glass L"));
    CHECK(matches("C 'ball' L", "C RS:ball L"));
    CHECK_FALSE(matches("C 'ball' L", "C RS:mirror L"));
    CHECK(matches("C .* 'key'", "C RD RD L:key"));
    CHECK_FALSE(matches("C .* 'key'", "C RD RD L:fill"));
    CHECK_FALSE(matches("C 'floor' L", "C RD L"));  // an event without a slot has no label
}

TEST_CASE("lpe: label classes: slots answering to the same taxonomy labels share one class") {
    Compiled c = compile("a = C 'chrome' L");
    // mirror and ball answer to 'chrome'; glass, floor, key, fill to nothing the taxonomy names.
    CHECK(c.t.labels == std::vector<std::string>{"chrome"});
    CHECK(c.t.label_class_count == 2);
    CHECK(c.t.alphabet_size == kKindCount * 2);
    CHECK(c.t.label_class_of_slot == std::vector<uint16_t>{0, 1, 0, 0, 0, 1});
    Compiled d = compile("a = C 'chrome' L\nb = C 'ball' L\nc = C .* 'key'");
    CHECK(d.t.labels == std::vector<std::string>{"chrome", "ball", "key"});
    CHECK(d.t.label_class_count == 4);  // none, {chrome}, {key}, {chrome, ball}
    CHECK(d.t.label_class_of_slot[1] != d.t.label_class_of_slot[5]);
    CHECK(d.t.label_class_of_slot[0] == 0);
    CHECK(d.cls("C RS:ball L") == "a");  // first match: 'chrome' before 'ball'
    CHECK(d.cls("C RD L:key") == "c");
    // No slots at all: one label class.
    Compiled e = compile("a = C D L", {});
    CHECK(e.t.label_class_count == 1);
    CHECK(e.t.alphabet_size == kKindCount);
}

TEST_CASE("lpe: a label that names nothing in the scene is a warning with line and column") {
    Compiled c = compile("# a comment\nnone = C 'window' L\nsome = C D L");
    CHECK(c.t.class_names == std::vector<std::string>{"none", "some", "other"});
    std::string w = warnings(c.t);
    CAPTURE(w);
    CHECK(w.find("test.lpe:2:10: warning: no material, shape or emitter of the scene has the id 'window'") !=
          std::string::npos);
    CHECK(w.find("test.lpe:2:8: warning: `none` can never match") != std::string::npos);
    CHECK(c.t.warnings.size() == 2);
    CHECK(c.cls("C RD L") == "some");
    // Negated, an unknown label excludes nothing.
    CHECK(matches("C [^'window'] L", "C RD:floor L"));
}

TEST_CASE("lpe: the first matching line wins and paths no line matches are other") {
    Compiled c = compile(
        "caustic = C D S+ L\n"
        "diffuse = C D+ L\n"
        "through_glass = C .* 'glass' .* L\n");
    CHECK(c.t.class_names == std::vector<std::string>{"caustic", "diffuse", "through_glass", "other"});
    CHECK(c.t.other_class == 3);
    CHECK(c.cls("C RD RS L") == "caustic");
    CHECK(c.cls("C RD TS:glass L") == "caustic");  // through_glass matches too, later
    CHECK(c.cls("C RD RD L") == "diffuse");
    CHECK(c.cls("C TS:glass L") == "through_glass");
    CHECK(c.cls("C RS L") == "other");
    CHECK(c.cls("C TG L") == "other");
    CHECK(c.cls("C L") == "other");
    CHECK(c.t.warnings.empty());
    // The same lines in another order classify by that order.
    Compiled d = compile("through_glass = C .* 'glass' .* L\ncaustic = C D S+ L\n");
    CHECK(d.cls("C RD TS:glass L") == "through_glass");
    CHECK(d.cls("C RD RS L") == "caustic");
}

TEST_CASE("lpe: queries count every line a path matches: the classes are the combinations that paths make") {
    CompileOptions queries;
    queries.all_matches = true;
    Compiled c = compile(
        "caustic = C D S+ L\n"
        "diffuse = C D+ L\n"
        "through_glass = C .* 'glass' .* L\n",
        scene_slots(), queries);
    // Fewest lines first, then by line order: {caustic}, {diffuse}, {through_glass}, then the pairs. No path is
    // both caustic and diffuse, so no combination has both.
    CHECK(c.t.class_lines == std::vector<uint32_t>{0b001, 0b010, 0b100, 0b101, 0b110});
    CHECK(c.t.class_names == std::vector<std::string>{"caustic", "diffuse", "through_glass", "caustic&through_glass",
                                                      "diffuse&through_glass", "other"});
    CHECK(c.t.other_class == 5);
    CHECK(c.cls("C RD RS L") == "caustic");
    CHECK(c.cls("C RD TS:glass L") == "caustic&through_glass");  // first match would say caustic
    CHECK(c.cls("C RD RD L") == "diffuse");
    CHECK(c.cls("C RD:glass L") == "diffuse&through_glass");
    CHECK(c.cls("C TS:glass L") == "through_glass");
    CHECK(c.cls("C RS L") == "other");
    CHECK(c.cls("C L") == "other");
    CHECK(c.t.warnings.empty());
    // Combinations of as many lines are in the order of their lines: a&d before b&c (as bit masks, 0b0110
    // would come before 0b1001).
    Compiled pairs = compile("a = C <RD> L\nb = C <RG> L\nc = C <RG> L\nd = C <RD> L\n", scene_slots(), queries);
    CHECK(pairs.t.class_names == std::vector<std::string>{"a&d", "b&c", "other"});
    CHECK(pairs.cls("C RG L") == "b&c");

    // A line inside another is no warning here (first match says it never wins), and every path it matches is
    // in the pair.
    Compiled first = compile("any_diffuse = C D+ L\none_diffuse = C <RD> L\n");
    REQUIRE(first.t.warnings.size() == 1);
    CHECK(first.t.warnings[0].message.find("never wins") != std::string::npos);
    Compiled nested = compile("any_diffuse = C D+ L\none_diffuse = C <RD> L\n", scene_slots(), queries);
    CHECK(nested.t.warnings.empty());
    CHECK(nested.t.class_names == std::vector<std::string>{"any_diffuse", "any_diffuse&one_diffuse", "other"});
    CHECK(nested.cls("C RD L") == "any_diffuse&one_diffuse");
    CHECK(nested.cls("C TD L") == "any_diffuse");
    CHECK(nested.cls("C RD RD L") == "any_diffuse");
    // One query: its class and other. A query that can never match is still warned of.
    Compiled one = compile("glassy = C .* 'glass' .* L\n", scene_slots(), queries);
    CHECK(one.t.class_lines == std::vector<uint32_t>{1});
    CHECK(one.cls("C TS:glass L") == "glassy");
    CHECK(one.cls("C RD L") == "other");
    Compiled never = compile("a = C D L\nnever = L C\n", scene_slots(), queries);
    REQUIRE(never.t.warnings.size() == 1);
    CHECK(never.t.warnings[0].message.find("`never` can never match") == 0);
    CHECK(never.t.class_names == std::vector<std::string>{"a", "other"});
}

TEST_CASE("lpe: --lpe queries take no properties and may not be named _rest or _overlap") {
    auto error_of_lines = [](const std::vector<std::string>& lines) {
        try {
            taxonomy_from_lines(lines, "--lpe");
        } catch (const LpeError& e) {
            return std::to_string(e.line()) + ":" + std::to_string(e.column()) + ": " + e.reason();
        }
        return std::string("no error");
    };
    CHECK(error_of_lines({"a = C L", "b [heavy] = C D L"}).find("2:3: a query takes no properties") == 0);
    CHECK(error_of_lines({"b [rare] = C D L"}).find("1:3: a query takes no properties") == 0);
    CHECK(error_of_lines({" _rest = C L"}).find("1:2: `_rest` is reserved") == 0);
    CHECK(error_of_lines({"_overlap=C L"}).find("1:1: `_overlap` is reserved") == 0);
    // A query's name becomes lpe.NAME.*, and `other`, a taxonomy's implicit class, is a query name like any.
    CHECK(error_of_lines({"a.b = C L"}) ==
          "1:1: `a.b` is not a query name: use letters, digits and '_', not starting with a digit (it becomes the "
          "EXR channel lpe.a.b.R)");
    CHECK(error_of_lines({"other = C L"}) == "no error");
    CHECK(error_of_lines({"other = C L", "other = C D L"}).find("2:1: `other` is already defined on line 1") == 0);
    CHECK(error_of_lines({"a = C L", "a = C D L"}).find("2:1: `a` is already defined") == 0);
    CHECK(error_of_lines({"rest = C L", "overlap = C D L"}) == "no error");
    // The file syntax keeps its properties.
    CHECK(parse_taxonomy("b [heavy] = C D L\n", "t.lpe").lines[0].heavy);
    // More than kMaxQueryLines queries.
    std::vector<std::string> many;
    for (uint32_t i = 0; i <= kMaxQueryLines; ++i) many.push_back("q" + std::to_string(i) + " = C D L");
    CompileOptions queries;
    queries.all_matches = true;
    CHECK_THROWS_WITH(compile_taxonomy(taxonomy_from_lines(many, "--lpe"), scene_slots(), queries),
                      doctest::Contains("at most 32 queries"));
}

TEST_CASE("lpe: minimization gives equal languages equal DFAs") {
    // C R* L by hand: before C, after C (looping on R), after L, and the dead state.
    Compiled star = compile("a = C R* L");
    CHECK(star.t.state_count == 4);
    Compiled either = compile("a = C (R*|R+) L");
    Compiled pairs = compile("a = C (R | R R)* L");
    Compiled sets = compile("a = C [<R.> <RD>]* L");
    for (const Compiled* c : {&either, &pairs, &sets}) {
        CHECK(c->t.state_count == 4);
        CHECK(c->t.next_state == star.t.next_state);
        CHECK(c->t.accept_class == star.t.accept_class);
    }
    // a*|a+ over whole lines, and a line repeated: as few states as one line.
    CHECK(compile("a = C D* L | C D+ L").t.state_count == compile("a = C D* L").t.state_count);
    CHECK(compile("a = C [DG] L\nb = C [DG] L").t.state_count == compile("a = C [DG] L").t.state_count);
    CHECK(star.t.line_state_counts == std::vector<uint32_t>{4});
}

TEST_CASE("lpe: the tables are dense, the start is state 0 and the dead state is a sink of class other") {
    Compiled c = compile("a = C R* L\nb = C T+ B");
    const CompiledTaxonomy& t = c.t;
    CHECK(t.start_state == 0);
    CHECK(t.next_state.size() == size_t(t.state_count) * t.alphabet_size);
    CHECK(t.accept_class.size() == t.state_count);
    CHECK(std::all_of(t.next_state.begin(), t.next_state.end(), [&](uint16_t s) { return s < t.state_count; }));
    REQUIRE(t.dead_state != kNoState);
    CHECK(t.accept_class[t.dead_state] == t.other_class);
    for (uint32_t a = 0; a < t.alphabet_size; ++a) CHECK(t.step(t.dead_state, a) == t.dead_state);
    CHECK(t.step(t.start_state, t.symbol(kKindRD, 0)) == t.dead_state);  // no path starts at a surface
    CHECK(t.next_state_u8() == std::vector<uint8_t>(t.next_state.begin(), t.next_state.end()));
    // A language that every prefix can still reach has no dead state.
    Compiled all = compile("all = .*");
    CHECK(all.t.state_count == 1);
    CHECK(all.t.dead_state == kNoState);
    CHECK(all.cls("C RD L") == "all");
    // Compiling twice gives the same tables.
    CHECK(compile("a = C R* L\nb = C T+ B").t.next_state == t.next_state);
}

TEST_CASE("lpe: whitespace between symbols is ignored") {
    Compiled spaced = compile("a = C < R D > * [ ^ S ] L");
    Compiled tight = compile("a = C<RD>*[^S]L");
    CHECK(spaced.t.next_state == tight.t.next_state);
    CHECK(spaced.t.accept_class == tight.t.accept_class);
    CHECK(spaced.cls("C RD RD TG L") == "a");
}

TEST_CASE("lpe: a malformed expression reports line, column and what was expected") {
    // "a = " puts the expression's first character at column 5.
    CHECK(error_of("a = C (R L") == "1:11: expected ')' to close the '(' at column 7, found the end of the expression");
    CHECK(error_of("a = C R) L") == "1:8: unexpected ')': no '(' is open");
    CHECK(error_of("a = C R] L") == "1:8: unexpected ']': no '[' is open");
    CHECK(error_of("a = C R> L") == "1:8: unexpected '>': no '<' is open");
    CHECK(error_of("a = C Q L")
              .find("1:7: expected an event type (C R T V L O B), a scattering type (D G S s), a "
                    "'label', '.', '(', '[' or '<', found 'Q'") == 0);
    CHECK(error_of("a = C x L").find("1:7: OSL's 'x'") == 0);
    CHECK(error_of("a = C 'glass L").find("1:7: expected ' to end the label") == 0);
    CHECK(error_of("a = C '' L").find("1:7: expected a label between the quotes") == 0);
    CHECK(error_of("a = * C L").find("1:5: '*' repeats what stands before it") == 0);
    CHECK(error_of("a = C R || L").find("1:10: expected an expression after the '|' at column 9") == 0);
    CHECK(error_of("a = C R | ").find("1:10: expected an expression after the '|'") == 0);
    CHECK(error_of("a = C () L").find("1:8: expected an expression, found ')'") == 0);
    CHECK(error_of("a = C [] L").find("1:7: empty set []") == 0);
    CHECK(error_of("a = C [^] L").find("1:7: empty set [^]") == 0);
    CHECK(error_of("a = C [R L").find("expected ']' to end the set that starts at column 7") != std::string::npos);
    CHECK(error_of("a = C [^R D] L").find("1:11: a set holds one kind of symbol") == 0);
    CHECK(error_of("a = C [^R 'glass'] L").find("1:11: a set holds one kind of symbol") == 0);
    CHECK(error_of("a = C [^.] L").find("1:9: '.' in a set") == 0);
    CHECK(error_of("a = C R{2,1} L").find("1:8: a repetition {n,m} needs n <= m") == 0);
    CHECK(error_of("a = C R{99} L").find("1:9: a repetition count is at most 32, found 99") == 0);
    CHECK(error_of("a = C R{,2} L").find("1:9: expected a repetition {n}, {n,} or {n,m}") == 0);
    CHECK(error_of("a = C R{2 L").find("1:10: expected '}' to end the repetition that starts at column 8") == 0);
    CHECK(error_of("a = C <R D 'x' .> L").find("1:16: expected '>': a group has at most three positions") == 0);
    CHECK(error_of("a = C <R D") ==
          "1:11: expected '>' to end the group that starts at column 7, found the end of the expression");
    CHECK(error_of("a = C <R D L").find("1:12: expected a 'label', '.' or a set in the third position") == 0);
    CHECK(error_of("a = C <D> L")
              .find("1:8: expected an event type (C R T V L O B), '.' or a set in the first "
                    "position of <type scattering 'label'>, found a scattering type: it is the "
                    "second position, <.D>") == 0);
    CHECK(error_of("a = C <R 'glass'> L")
              .find("1:10: expected a scattering type (D G S s), '.' or a set in the "
                    "second position") == 0);
    CHECK(error_of("a = C <R 'glass'> L").find("the label is the third position, <..'glass'>") != std::string::npos);
    CHECK(error_of("a = C <[DG]> L").find("1:8: expected an event type") == 0);
    CHECK(error_of("a = C <R*> L").find("1:9: repetitions are not allowed inside <...>") == 0);
    CHECK(error_of("a = C <(R)> L").find("1:8: expected an event type") == 0);
    // The line number counts comments and blank lines.
    CHECK(error_of("# header\n\nok = C L\nbad = C (").find("4:10: expected an expression") == 0);
    // what() is file:line:column: reason.
    try {
        compile("a = C (R L");
        FAIL("no error");
    } catch (const LpeError& e) {
        CHECK(std::string(e.what()) ==
              "test.lpe:1:11: expected ')' to close the '(' at column 7, found the end of the expression");
        CHECK(e.file() == "test.lpe");
    }
}

TEST_CASE("lpe: the taxonomy file: comments, blank lines, unique identifier names, other reserved") {
    Compiled c = compile(
        "# The paper's split of the direct light\n"
        "\n"
        "   direct_d = C D [LB]   # a trailing comment\n"
        "direct_g=C G [LB]\n"
        "\t\n"
        "hash_label = C '#1' L\n");
    CHECK(c.t.class_names == std::vector<std::string>{"direct_d", "direct_g", "hash_label", "other"});
    TaxonomySource s = parse_taxonomy("   direct_d = C D [LB]   # a trailing comment\n", "x.lpe");
    REQUIRE(s.lines.size() == 1);
    CHECK(s.lines[0].expression == "C D [LB]");
    CHECK(s.lines[0].line == 1);
    CHECK(s.lines[0].expression_column == 15);
    CHECK(c.t.labels == std::vector<std::string>{"#1"});  // '#' inside quotes is no comment

    CHECK(error_of("3d = C L") ==
          "1:1: `3d` is not a class name: use letters, digits and '_', not starting with a digit (it becomes the EXR "
          "channel bucket.3d.R)");
    CHECK(error_of("a.b = C L").find("1:1: `a.b` is not a class name") == 0);
    CHECK(error_of("  other = C L").find("1:3: `other` is reserved") == 0);
    CHECK(error_of("a = C L\n\nb = C D L\na = C G L") == "4:1: `a` is already defined on line 1");
    CHECK(error_of("a C L") == "1:1: expected `name = expression`, found no '='");
    CHECK(error_of(" = C L") == "1:2: expected a class name before '='");
    CHECK(error_of("a =   # nothing") == "1:4: expected an expression after '='");
    CHECK(error_of("# only comments\n\n") == "0:0: no classes: a taxonomy needs at least one `name = expression` line");
    std::string many;
    for (int i = 0; i < 256; ++i) many += "c" + std::to_string(i) + " = C L\n";
    CHECK(error_of(many).find("256:1: a taxonomy has at most 255 lines") == 0);

    // Class properties: `name [heavy constant rare] = ...`, in any order, for the allocation strategies.
    TaxonomySource props = parse_taxonomy(
        "a [heavy] = C D L\nb [constant heavy]= C L\nc = C S L\nd[ constant ] = C G L\ne [rare heavy] = C S D L\n",
        "p.lpe");
    REQUIRE(props.lines.size() == 5);
    for (size_t i = 0; i < 4; ++i) CHECK_FALSE(props.lines[i].rare);
    CHECK(props.lines[4].rare);
    CHECK(props.lines[4].heavy);
    CHECK_FALSE(props.lines[4].constant);
    CHECK(props.lines[0].name == "a");
    CHECK(props.lines[0].heavy);
    CHECK_FALSE(props.lines[0].constant);
    CHECK(props.lines[1].name == "b");
    CHECK(props.lines[1].heavy);
    CHECK(props.lines[1].constant);
    CHECK_FALSE(props.lines[2].heavy);
    CHECK_FALSE(props.lines[2].constant);
    CHECK(props.lines[3].name == "d");
    CHECK_FALSE(props.lines[3].heavy);
    CHECK(props.lines[3].constant);
    CHECK(error_of("a [fast] = C L") ==
          "1:4: unknown class property `fast`: the properties are `heavy`, `constant` and `rare`");
    CHECK(error_of("  a [heavy  fast] = C L") ==
          "1:13: unknown class property `fast`: the properties are `heavy`, `constant` and `rare`");
    CHECK(error_of("a] = C L") == "1:2: a ']' without '[' before '='");
    CHECK(error_of(" [heavy] = C L") == "1:2: expected a class name before '='");
    CHECK(error_of("a [heavy] b = C L").find("1:1: `a [heavy] b` is not a class name") == 0);

    // The labels a taxonomy names, without compiling it (a shape named there gets its own material).
    CHECK(taxonomy_labels(parse_taxonomy("a = C <.S'glass'> L\nb = C ['chrome' 'glass' D] L\n", "l.lpe")) ==
          std::vector<std::string>{"glass", "chrome"});
    CHECK(taxonomy_labels(parse_taxonomy("a = C D L\n", "l.lpe")).empty());
    CHECK_THROWS_AS(taxonomy_labels(parse_taxonomy("a = C (D L\n", "l.lpe")), LpeError);

    // --lpe style lines, and a file that is not there.
    TaxonomySource cli = taxonomy_from_lines({"key=C .* 'key'", "fill = C .* 'fill'"}, "--lpe");
    CHECK(cli.lines.size() == 2);
    CHECK(cli.lines[1].line == 2);
    CHECK_THROWS_AS(taxonomy_from_lines({"# no line"}, "--lpe"), LpeError);
    CHECK_THROWS_AS(read_taxonomy("/nonexistent/vkmech/x.lpe"), LpeError);
}

TEST_CASE("lpe: a DFA over the state limit is refused, naming each line's own size") {
    // "the 4th event before the emitter is RD" needs 2^4 states to remember the last four events.
    const std::string text = "small = C R* L\nbig = C .* RD . . . [LB]\n";
    Compiled fits = compile(text);
    CHECK(fits.t.line_state_counts[0] == 4);
    CHECK(fits.t.line_state_counts[1] > 16);
    CHECK(fits.t.state_count <= kDefaultMaxStates);
    std::string e = error_of(text, CompileOptions{8});
    CAPTURE(e);
    CHECK(e.find("0:0: the taxonomy's DFA has ") == 0);
    CHECK(e.find("over the limit of 8") != std::string::npos);
    CHECK(e.find("Each line alone needs: `big` (line 2) " + std::to_string(fits.t.line_state_counts[1]) +
                 ", `small` (line 1) 4") != std::string::npos);
    // The default limit, 256: the 9th event from the end needs 2^9 states.
    std::string e256 = error_of("a = C D L\nhuge = C .* RD .{8} [LB]");
    CAPTURE(e256);
    CHECK(e256.find("over the limit of 256. Each line alone needs: `huge` (line 2) ") != std::string::npos);
}

TEST_CASE("lpe: a line that can never match a vkmech path, or never wins, is a warning") {
    Compiled c = compile(
        "all = C .* [LB]\n"
        "volume = C V L\n"
        "later = C R L\n"
        "no_camera = R L\n"
        "object = C .* O\n"
        "fine = R\n");
    std::string w = warnings(c.t);
    CAPTURE(w);
    CHECK(w.find("test.lpe:2:10: warning: `volume` can never match") != std::string::npos);
    CHECK(w.find("test.lpe:3:9: warning: `later` never wins: every path it matches is taken by an earlier line "
                 "(`all`)") != std::string::npos);
    CHECK(w.find("test.lpe:4:13: warning: `no_camera` can never match") != std::string::npos);
    CHECK(w.find("test.lpe:5:10: warning: `object` can never match") != std::string::npos);
    CHECK(w.find("test.lpe:6:8: warning: `fine` can never match") != std::string::npos);
    CHECK(c.t.warnings.size() == 5);
    // Shadowed only in part: no warning.
    CHECK(compile("a = C D+ L\nb = C [DG]+ L").t.warnings.empty());
}

namespace {

// The bucket of the cascade (docs/descriptor.md §2.4) for a BSDF-sampled emitter hit after the
// surface vertices `lobes` (the last one shot the ray); an NEE event ending at a D or G vertex
// labels the same.
uint32_t cascade_bucket(bool literal, const std::vector<uint32_t>& lobes) {
    namespace sh = vkmech::shader;
    if (lobes.empty()) return sh::classify_event(0, sh::LOBE_NONE, false);
    uint32_t last_nondelta = sh::LOBE_NONE;
    bool delta_before = false;
    for (size_t i = 0; i + 1 < lobes.size(); ++i) {
        if (lobes[i] == sh::LOBE_S)
            delta_before = true;
        else
            last_nondelta = lobes[i];
    }
    uint32_t n = uint32_t(lobes.size()), lobe_n = lobes.back();
    return sh::classify_event(n, sh::bsdf_hit_end_lobe(literal, lobe_n, last_nondelta),
                              sh::bsdf_hit_delta(literal, lobe_n, last_nondelta, delta_before));
}

const uint32_t kSurfaceKinds[6] = {kKindRD, kKindRG, kKindRS, kKindTD, kKindTG, kKindTS};
const uint32_t kLobeOfKind[6] = {vkmech::shader::LOBE_D, vkmech::shader::LOBE_G, vkmech::shader::LOBE_S,
                                 vkmech::shader::LOBE_D, vkmech::shader::LOBE_G, vkmech::shader::LOBE_S};

CompiledTaxonomy paper_taxonomy(const std::string& file) {
    CompiledTaxonomy t = compile_taxonomy(read_taxonomy(file), {});
    CHECK(warnings(t).empty());
    REQUIRE(t.class_names.size() == vkmech::kBucketCount);
    for (uint32_t b = 0; b < vkmech::kBucketCount; ++b) CHECK(t.class_names[b] == vkmech::kBucketNames[b]);
    return t;
}

// Every path of up to `max_vertices` surface vertices (R or T, D G or S), ending at L and at B,
// classified by the taxonomy and by the cascade; returns the number of paths that differ.
int mismatches_up_to(const CompiledTaxonomy& t, bool literal, int max_vertices) {
    int mismatches = 0;
    for (int n = 0; n <= max_vertices; ++n) {
        int combos = 1;
        for (int i = 0; i < n; ++i) combos *= 6;
        for (int code = 0; code < combos; ++code) {
            std::vector<uint32_t> symbols{t.symbol(kKindCamera, 0)}, lobes;
            for (int i = 0, c = code; i < n; ++i, c /= 6) {
                symbols.push_back(t.symbol(kSurfaceKinds[c % 6], 0));
                lobes.push_back(kLobeOfKind[c % 6]);
            }
            uint32_t expected = cascade_bucket(literal, lobes);
            for (uint32_t emitter : {kKindLight, kKindBackground}) {
                symbols.push_back(t.symbol(emitter, 0));
                if (t.classify(symbols) != expected) ++mismatches;
                symbols.pop_back();
            }
        }
    }
    return mismatches;
}

// The cascade's own finite state after some vertices: all it reads of a path (descriptor §2.3).
struct CascadeState {
    uint32_t n = 0;  // capped at 2: the cascade tells only 0, 1 and more apart
    bool delta_before = false;
    uint32_t last_nondelta = vkmech::shader::LOBE_NONE, lobe_n = vkmech::shader::LOBE_NONE;
    CascadeState then(uint32_t lobe) const {
        CascadeState c = *this;
        if (n > 0) {
            if (lobe_n == vkmech::shader::LOBE_S)
                c.delta_before = true;
            else
                c.last_nondelta = lobe_n;
        }
        c.lobe_n = lobe;
        c.n = std::min(n + 1, 2u);
        return c;
    }
    uint32_t bucket(bool literal) const {
        namespace sh = vkmech::shader;
        if (n == 0) return sh::classify_event(0, sh::LOBE_NONE, false);
        return sh::classify_event(n, sh::bsdf_hit_end_lobe(literal, lobe_n, last_nondelta),
                                  sh::bsdf_hit_delta(literal, lobe_n, last_nondelta, delta_before));
    }
    uint32_t key() const { return n | (delta_before ? 4u : 0u) | (last_nondelta << 3) | (lobe_n << 5); }
};

// Paths of every length: a walk over the reachable pairs (taxonomy state, cascade state) after
// the camera and any vertices, each checked at both emitters. Returns the pairs that disagree.
int mismatches_any_length(const CompiledTaxonomy& t, bool literal, size_t& pairs) {
    std::set<std::pair<uint16_t, uint32_t>> seen;
    std::vector<std::pair<uint16_t, CascadeState>> todo{{t.step(t.start_state, t.symbol(kKindCamera, 0)), {}}};
    int mismatches = 0;
    while (!todo.empty()) {
        auto item = todo.back();
        todo.pop_back();
        if (!seen.insert({item.first, item.second.key()}).second) continue;
        for (uint32_t emitter : {kKindLight, kKindBackground})
            if (t.accept_class[t.step(item.first, t.symbol(emitter, 0))] != item.second.bucket(literal)) ++mismatches;
        for (int k = 0; k < 6; ++k)
            todo.push_back({t.step(item.first, t.symbol(kSurfaceKinds[k], 0)), item.second.then(kLobeOfKind[k])});
    }
    pairs = seen.size();
    return mismatches;
}

}  // namespace

TEST_CASE("lpe: taxonomies/paper.lpe is the cascade of docs/descriptor.md §2.4 on every path") {
    CompiledTaxonomy t = paper_taxonomy(VKMECH_SOURCE_DIR "/taxonomies/paper.lpe");
    CHECK(mismatches_up_to(t, false, 5) == 0);
    size_t pairs = 0;
    CHECK(mismatches_any_length(t, false, pairs) == 0);
    CHECK(pairs > 4);
    // The worked examples of descriptor §2.5 that tell the readings apart.
    Compiled c{{}, t};
    CHECK(c.cls("C RD RS L") == "delta_mediated");
    CHECK(c.cls("C RD TS TS L") == "delta_mediated");
    CHECK(c.cls("C TS TS L") == "specular_direct");
    CHECK(c.cls("C RS RD L") == "delta_mediated");
    CHECK(c.cls("C RG L") == "direct");
    CHECK(c.cls("C B") == "emitter_direct");
    MESSAGE("paper.lpe: " << t.state_count << " states, " << pairs << " (state, cascade state) pairs");
}

TEST_CASE("lpe: taxonomies/paper-literal.lpe is the cascade under --end-vertex literal on every path") {
    CompiledTaxonomy t = paper_taxonomy(VKMECH_SOURCE_DIR "/taxonomies/paper-literal.lpe");
    CHECK(mismatches_up_to(t, true, 5) == 0);
    size_t pairs = 0;
    CHECK(mismatches_any_length(t, true, pairs) == 0);
    Compiled c{{}, t};
    CHECK(c.cls("C RD RS L") == "specular_direct");
    CHECK(c.cls("C RD TS TS L") == "specular_direct");
    CHECK(c.cls("C RS RD L") == "delta_mediated");
    // The two files disagree exactly where the readings do: the walk finds it.
    CHECK(mismatches_any_length(t, false, pairs) > 0);
    // C [RT][DG] [RT]S at L and at B: 16 paths of at most 2 vertices.
    CHECK(mismatches_up_to(t, false, 2) == 16);
}

namespace {

// An independent reference: the syntax tree matched directly against a path (the set of
// positions each node can reach), labels matched by the slots' names, no automaton.
struct PathEvent {
    uint32_t kind;
    int slot;  // -1: no slot
};

bool event_matches(const vkmech::lpe::detail::Node& n, const PathEvent& e, const std::vector<LabelSlot>& slots) {
    const EventKind& k = kEventKinds[e.kind];
    if (!((n.types >> uint32_t(k.type)) & 1u) || !((n.scatters >> uint32_t(k.scatter)) & 1u)) return false;
    if (n.label.any) return true;
    bool some = false;
    for (const std::string& name : n.label.names)
        if (e.slot >= 0)
            for (const std::string& has : slots[e.slot].names) some = some || has == name;
    return n.label.negated ? !some : some;
}

std::set<size_t> advance(const vkmech::lpe::detail::Node& n, const std::vector<PathEvent>& path,
                         const std::set<size_t>& from, const std::vector<LabelSlot>& slots) {
    using Op = vkmech::lpe::detail::Node::Op;
    std::set<size_t> out;
    switch (n.op) {
        case Op::Event:
            for (size_t p : from)
                if (p < path.size() && event_matches(n, path[p], slots)) out.insert(p + 1);
            return out;
        case Op::Cat:
            out = from;
            for (const auto& c : n.children) out = advance(c, path, out, slots);
            return out;
        case Op::Alt:
            for (const auto& c : n.children) {
                std::set<size_t> one = advance(c, path, from, slots);
                out.insert(one.begin(), one.end());
            }
            return out;
        case Op::Repeat: {
            std::set<size_t> cur = from;
            for (int i = 0; i < n.min; ++i) cur = advance(n.children[0], path, cur, slots);
            out = cur;
            for (int i = n.min; n.max < 0 || i < n.max; ++i) {
                cur = advance(n.children[0], path, cur, slots);
                size_t before = out.size();
                out.insert(cur.begin(), cur.end());
                if (n.max < 0 && out.size() == before) break;
            }
            return out;
        }
    }
    return out;
}

std::string random_expression(std::mt19937& rng, int depth) {
    static const char* const kAtoms[] = {"C",        "R",           "T",     "L",           "B",
                                         "D",        "G",           "S",     ".",           "'glass'",
                                         "'chrome'", "'key'",       "<R D>", "<.S'glass'>", "<[RT][^S]>",
                                         "[^S]",     "[^'chrome']", "[RT]",  "<L.'key'>",   "<..[^'glass' 'key']>"};
    static const char* const kRepeats[] = {"*", "+", "?", "{1,2}", "{2}", "{0,1}", "{2,}"};
    int pick = depth == 0 ? 0 : int(rng() % 6);
    switch (pick) {
        case 1:
            return random_expression(rng, depth - 1) + " " + random_expression(rng, depth - 1);
        case 2:
            return "(" + random_expression(rng, depth - 1) + " | " + random_expression(rng, depth - 1) + ")";
        case 3:
            return "(" + random_expression(rng, depth - 1) + ")" + kRepeats[rng() % 7];
        case 4:
            return "[" + random_expression(rng, depth - 1) + " " + random_expression(rng, depth - 1) + "]";
        default:
            return kAtoms[rng() % 20];
    }
}

}  // namespace

namespace {

// Each line's syntax tree, for matching paths without an automaton.
std::vector<vkmech::lpe::detail::Node> syntax_trees(const std::string& text) {
    std::vector<vkmech::lpe::detail::Node> trees;
    for (const TaxonomyLine& l : parse_taxonomy(text, "random.lpe").lines)
        trees.push_back(vkmech::lpe::detail::parse_expression(l.expression, "random.lpe", l.line, l.expression_column));
    return trees;
}

}  // namespace

TEST_CASE("lpe: as queries, the DFA gives each random vkmech path the set of lines its syntax trees match") {
    std::mt19937 rng(3737);
    const std::vector<LabelSlot> slots = scene_slots();
    CompileOptions queries{4096};
    queries.all_matches = true;
    int compiled = 0, paths = 0, overlapping = 0;
    for (int round = 0; round < 100; ++round) {
        std::string text;
        for (int line = 0; line < 3; ++line) {  // as whole paths, or as something somewhere on the path, or as drawn
            std::string e = random_expression(rng, 3);
            const uint32_t form = rng() % 3;
            if (form == 0) e = "C " + e + " [LB]";
            if (form == 1) e = "C .* " + e + " .* [LB]";
            text += "q" + std::to_string(line) + " = " + e + "\n";
        }
        CAPTURE(text);
        CompiledTaxonomy t;
        try {
            t = compile_taxonomy(parse_taxonomy(text, "random.lpe"), slots, queries);
        } catch (const LpeError& e) {
            CHECK(std::string(e.what()).find("over the limit") != std::string::npos);
            continue;
        }
        ++compiled;
        const std::vector<vkmech::lpe::detail::Node> trees = syntax_trees(text);
        for (int k = 0; k < 200; ++k) {  // whole vkmech paths: C, R or T events, then L or B
            std::vector<PathEvent> path{{kKindCamera, -1}};
            for (size_t i = 0, n = rng() % 6; i < n; ++i)
                path.push_back({kKindRD + uint32_t(rng() % 6), int(rng() % (slots.size() + 1)) - 1});
            path.push_back({rng() % 2 ? kKindLight : kKindBackground, int(rng() % 3) + 2});
            uint32_t lines = 0;
            for (uint32_t i = 0; i < trees.size(); ++i)
                if (advance(trees[i], path, {0}, slots).count(path.size())) lines |= 1u << i;
            std::vector<uint32_t> symbols;
            for (const PathEvent& e : path)
                symbols.push_back(t.symbol(e.kind, e.slot < 0 ? 0 : t.label_class_of_slot[size_t(e.slot)]));
            const uint32_t cls = t.classify(symbols);
            ++paths;
            overlapping += std::popcount(lines) > 1;
            CHECK(cls <= t.other_class);
            CHECK((cls == t.other_class ? 0u : t.class_lines[cls]) == lines);
        }
    }
    MESSAGE(compiled << " random query sets, " << paths << " paths, " << overlapping << " matched by several");
    CHECK(compiled > 60);
    CHECK(overlapping > paths / 20);
}

TEST_CASE("lpe: the DFA classifies random paths as the syntax trees matched directly do, first match first") {
    std::mt19937 rng(37);
    const std::vector<LabelSlot> slots = scene_slots();
    int taxonomies = 0, refused = 0, paths = 0, matched = 0;
    for (int round = 0; round < 150; ++round) {
        std::string text;
        for (int line = 0; line < 3; ++line) {
            std::string e = random_expression(rng, 3);
            if (rng() % 2) e = "C " + e + " [LB]";
            text += "c" + std::to_string(line) + " = " + e + "\n";
        }
        CAPTURE(text);
        CompiledTaxonomy t;
        try {
            t = compile_taxonomy(parse_taxonomy(text, "random.lpe"), slots, CompileOptions{4096});
        } catch (const LpeError& e) {
            ++refused;  // over the state limit
            CHECK(std::string(e.what()).find("over the limit") != std::string::npos);
            continue;
        }
        ++taxonomies;
        const std::vector<vkmech::lpe::detail::Node> trees = syntax_trees(text);
        for (int k = 0; k < 200; ++k) {
            // Half the paths have vkmech's shape, half are any events at all.
            std::vector<PathEvent> path;
            bool shaped = rng() % 2;
            size_t n = rng() % 6;
            if (shaped) path.push_back({kKindCamera, -1});
            for (size_t i = 0; i < n; ++i)
                path.push_back({shaped ? kKindRD + uint32_t(rng() % 6) : uint32_t(rng() % kKindCount),
                                int(rng() % (slots.size() + 1)) - 1});
            if (shaped) path.push_back({rng() % 2 ? kKindLight : kKindBackground, int(rng() % 3) + 2});
            uint32_t expected = t.other_class;
            for (uint32_t i = 0; i < trees.size() && expected == t.other_class; ++i)
                if (advance(trees[i], path, {0}, slots).count(path.size())) expected = i;
            std::vector<uint32_t> symbols;
            for (const PathEvent& e : path)
                symbols.push_back(t.symbol(e.kind, e.slot < 0 ? 0 : t.label_class_of_slot[size_t(e.slot)]));
            ++paths;
            matched += expected != t.other_class;
            CHECK(t.classify(symbols) == expected);
        }
    }
    MESSAGE(taxonomies << " random taxonomies, " << refused << " refused, " << paths << " paths, " << matched
                       << " of them matched by a line");
    CHECK(taxonomies > 100);
    CHECK(matched > paths / 10);
}
