// The taxonomy file (`name = expression` lines) and the LPE grammar of docs/lpe.md, parsed by
// recursive descent. Precedence, loosest first: `|`, concatenation, the postfix repetitions.
#include <cctype>
#include <fstream>
#include <map>
#include <sstream>

#include "render/lpe_ast.hpp"

namespace vkmech::lpe {

namespace {

std::string format_error(const std::string& file, int line, int column, const std::string& reason) {
    std::string where = file;
    if (line > 0) where.append(":").append(std::to_string(line));
    if (line > 0 && column > 0) where.append(":").append(std::to_string(column));
    return where.append(": ").append(reason);
}

}  // namespace

LpeError::LpeError(const std::string& file, int line, int column, const std::string& reason)
    : std::runtime_error(format_error(file, line, column, reason)),
      file_(file),
      line_(line),
      column_(column),
      reason_(reason) {}

std::string Diagnostic::str() const { return format_error(file, line, column, "warning: " + message); }

namespace detail {

namespace {

const char* const kExpectedAtom =
    "an event type (C R T V L O B), a scattering type (D G S s), a 'label', '.', '(', '[' or '<'";

// One symbol of a set or a group position: a letter, a quoted label or '.'.
struct Symbol {
    enum class Kind { Type, Scatter, Label, Dot } kind;
    uint8_t bit = 0;  // Type, Scatter: 1 << the enum value
    std::string label;
    int column = 0;
};

bool type_letter(char c, uint8_t& bit) {
    static const char kLetters[] = "CRTVLOB";  // EventType order
    for (uint32_t i = 0; i < kEventTypeCount; ++i)
        if (c == kLetters[i]) {
            bit = uint8_t(1u << i);
            return true;
        }
    return false;
}
bool scatter_letter(char c, uint8_t& bit) {
    // Scatter order: None has no letter.
    const char* letters = "DGSs";
    for (uint32_t i = 0; i < 4; ++i)
        if (c == letters[i]) {
            bit = uint8_t(1u << (i + 1));
            return true;
        }
    return false;
}

class Parser {
public:
    Parser(const std::string& text, const std::string& file, int line, int column)
        : text_(text), file_(file), line_(line), column0_(column) {}

    Node parse() {
        skip_space();
        if (at_end()) fail(pos_, "expected an expression");
        Node n = alternation();
        skip_space();
        if (!at_end()) {
            if (peek() == ')') fail(pos_, "unexpected ')': no '(' is open");
            if (peek() == ']') fail(pos_, "unexpected ']': no '[' is open");
            fail(pos_, "expected '|', " + std::string(kExpectedAtom) + ", found " + found());
        }
        return n;
    }

private:
    [[noreturn]] void fail(size_t pos, const std::string& what) const {
        throw LpeError(file_, line_, column(pos), what);
    }
    int column(size_t pos) const { return column0_ + int(pos); }
    bool at_end() const { return pos_ >= text_.size(); }
    char peek() const { return text_[pos_]; }
    void skip_space() {
        while (!at_end() && (peek() == ' ' || peek() == '\t')) ++pos_;
    }
    std::string found() const {
        if (at_end()) return "the end of the expression";
        std::string quoted(3, '\'');
        quoted[1] = peek();
        return quoted;
    }
    // The alternation's and the concatenation's ends: `)`, `]`, `|` (and `>` inside a group).
    bool at_sequence_end() {
        skip_space();
        return at_end() || peek() == ')' || peek() == ']' || peek() == '|';
    }

    Node alternation() {
        Node first = concatenation();
        skip_space();
        if (at_end() || peek() != '|') return first;
        Node alt;
        alt.op = Node::Op::Alt;
        alt.column = first.column;
        alt.children.push_back(std::move(first));
        while (!at_end() && peek() == '|') {
            size_t bar = pos_++;
            if (at_sequence_end())
                fail(pos_, "expected an expression after the '|' at column " + std::to_string(column(bar)) +
                               ", found " + found());
            alt.children.push_back(concatenation());
            skip_space();
        }
        return alt;
    }

    Node concatenation() {
        skip_space();
        Node cat;
        cat.op = Node::Op::Cat;
        cat.column = column(pos_);
        while (!at_sequence_end()) cat.children.push_back(repetition());
        if (cat.children.empty()) fail(pos_, "expected an expression, found " + found());
        if (cat.children.size() == 1) return std::move(cat.children[0]);
        return cat;
    }

    Node repetition() {
        Node n = atom();
        for (;;) {
            skip_space();
            if (at_end()) return n;
            int min = 0, max = 0;
            char c = peek();
            if (c == '*') {
                min = 0, max = -1, ++pos_;
            } else if (c == '+') {
                min = 1, max = -1, ++pos_;
            } else if (c == '?') {
                min = 0, max = 1, ++pos_;
            } else if (c == '{') {
                range(min, max);
            } else {
                return n;
            }
            Node r;
            r.op = Node::Op::Repeat;
            r.column = n.column;
            r.min = min;
            r.max = max;
            r.children.push_back(std::move(n));
            n = std::move(r);
        }
    }

    // {n}, {n,} or {n,m}, n <= m <= kMaxRepeatCount.
    void range(int& min, int& max) {
        size_t open = pos_++;
        const std::string expected = "expected a repetition {n}, {n,} or {n,m} with whole numbers";
        auto number = [&](int& out) {
            size_t start = pos_;
            long long v = 0;
            while (!at_end() && std::isdigit(static_cast<unsigned char>(peek()))) {
                v = v * 10 + (peek() - '0');
                if (v > 1000000) v = 1000000;
                ++pos_;
            }
            if (pos_ == start) return false;
            if (v > kMaxRepeatCount)
                fail(start, "a repetition count is at most " + std::to_string(kMaxRepeatCount) + ", found " +
                                text_.substr(start, pos_ - start));
            out = int(v);
            return true;
        };
        if (!number(min)) fail(pos_, expected + ", found " + found());
        max = min;
        if (!at_end() && peek() == ',') {
            ++pos_;
            if (!number(max)) max = -1;
        }
        if (at_end() || peek() != '}')
            fail(pos_, "expected '}' to end the repetition that starts at column " + std::to_string(column(open)) +
                           ", found " + found());
        ++pos_;
        if (max >= 0 && max < min)
            fail(open,
                 "a repetition {n,m} needs n <= m, found {" + std::to_string(min) + "," + std::to_string(max) + "}");
    }

    Node atom() {
        skip_space();
        size_t at = pos_;
        char c = peek();
        if (c == '(') {
            ++pos_;
            Node inner = alternation();
            skip_space();
            if (at_end() || peek() != ')')
                fail(pos_,
                     "expected ')' to close the '(' at column " + std::to_string(column(at)) + ", found " + found());
            ++pos_;
            return inner;
        }
        if (c == '[') return top_level_set();
        if (c == '<') return group();
        if (c == '>') fail(pos_, "unexpected '>': no '<' is open");
        if (c == '*' || c == '+' || c == '?' || c == '{')
            fail(pos_, "'" + std::string(1, c) + "' repeats what stands before it, and nothing does here");
        Symbol s = symbol("expected " + std::string(kExpectedAtom));
        Node n = event(column(at));
        switch (s.kind) {
            case Symbol::Kind::Type:
                n.types = s.bit;
                break;
            case Symbol::Kind::Scatter:
                n.scatters = s.bit;
                break;
            case Symbol::Kind::Label:
                set_label(n.label, false, {s});
                break;
            case Symbol::Kind::Dot:
                break;
        }
        return n;
    }

    Node event(int col) const {
        Node n;
        n.op = Node::Op::Event;
        n.column = col;
        return n;
    }

    static void set_label(LabelSet& l, bool negated, const std::vector<Symbol>& symbols) {
        l.any = false;
        l.negated = negated;
        for (const Symbol& s : symbols) {
            l.names.push_back(s.label);
            l.columns.push_back(s.column);
        }
    }

    // A letter, a quoted label or '.'; `expected` names what the caller wanted.
    Symbol symbol(const std::string& expected) {
        skip_space();
        if (at_end()) fail(pos_, expected + ", found " + found());
        Symbol s;
        s.column = column(pos_);
        char c = peek();
        if (c == '\'') {
            size_t open = pos_++;
            size_t close = text_.find('\'', pos_);
            if (close == std::string::npos)
                fail(open, "expected ' to end the label that starts here, found the end of the expression");
            if (close == pos_) fail(open, "expected a label between the quotes, found ''");
            s.kind = Symbol::Kind::Label;
            s.label = text_.substr(pos_, close - pos_);
            pos_ = close + 1;
            return s;
        }
        if (c == '.') {
            ++pos_;
            s.kind = Symbol::Kind::Dot;
            return s;
        }
        if (type_letter(c, s.bit)) {
            ++pos_;
            s.kind = Symbol::Kind::Type;
            return s;
        }
        if (scatter_letter(c, s.bit)) {
            ++pos_;
            s.kind = Symbol::Kind::Scatter;
            return s;
        }
        if (c == 'x')
            fail(pos_,
                 "OSL's 'x' (no scattering) is not part of vkmech's grammar: camera and emitter events "
                 "already have no scattering type");
        fail(pos_, expected + ", found " + found());
    }

    // Whether the set opened at `open` ends here (at ']'); its missing end is an error.
    bool at_set_end(size_t open) {
        skip_space();
        if (at_end())
            fail(pos_, "expected ']' to end the set that starts at column " + std::to_string(column(open)) +
                           ", found the end of the expression");
        return peek() == ']';
    }

    // The symbols of a set after its '[' (and '^'), up to and past ']'.
    std::vector<Symbol> symbol_list(size_t open, bool negated, const char* expected) {
        std::vector<Symbol> out;
        while (!at_set_end(open)) {
            Symbol s = symbol(std::string("expected ") + expected + " or ']'");
            size_t at = size_t(s.column - column0_);
            if (s.kind == Symbol::Kind::Dot) fail(at, "'.' in a set: a set lists symbols; '.' alone is any event");
            if (!out.empty() && s.kind != out.front().kind)
                fail(at,
                     "a set holds one kind of symbol (event types, scattering types or labels), and this one "
                     "mixes them");
            out.push_back(s);
        }
        ++pos_;
        if (out.empty()) fail(open, negated ? "empty set [^]" : "empty set []");
        return out;
    }

    // Top level: [a b c] is a | b | c (each element any expression with its repetitions);
    // [^a b] is one event whose type, scattering or label is none of the listed ones.
    Node top_level_set() {
        size_t open = pos_++;
        skip_space();
        if (!at_end() && peek() == '^') {
            ++pos_;
            std::vector<Symbol> syms = symbol_list(open, true, "an event type, a scattering type or a 'label'");
            Node n = event(column(open));
            apply_set(n, syms, true);
            return n;
        }
        Node alt;
        alt.op = Node::Op::Alt;
        alt.column = column(open);
        while (!at_set_end(open)) {
            if (peek() == '|' || peek() == ')')
                fail(pos_, "expected " + std::string(kExpectedAtom) + " or ']' in the set that starts at column " +
                               std::to_string(column(open)) + ", found " + found());
            alt.children.push_back(repetition());
        }
        ++pos_;
        if (alt.children.empty()) fail(open, "empty set []");
        if (alt.children.size() == 1) return std::move(alt.children[0]);
        return alt;
    }

    static void apply_set(Node& n, const std::vector<Symbol>& syms, bool negated) {
        uint8_t bits = 0;
        for (const Symbol& s : syms) bits |= s.bit;
        switch (syms.front().kind) {
            case Symbol::Kind::Type:
                n.types = negated ? uint8_t(kAllTypes & ~bits) : bits;
                break;
            case Symbol::Kind::Scatter:
                n.scatters = negated ? uint8_t(kAllScatters & ~bits) : bits;
                break;
            case Symbol::Kind::Label:
                set_label(n.label, negated, syms);
                break;
            case Symbol::Kind::Dot:
                break;
        }
    }

    // <type scattering 'label'>: each position '.', a symbol of its kind, or a set of them;
    // positions left out are '.'.
    Node group() {
        size_t open = pos_++;
        Node n = event(column(open));
        static const Symbol::Kind kKinds[3] = {Symbol::Kind::Type, Symbol::Kind::Scatter, Symbol::Kind::Label};
        static const char* const kWhat[3] = {"an event type (C R T V L O B)", "a scattering type (D G S s)",
                                             "a 'label'"};
        static const char* const kPlace[3] = {"first", "second", "third"};
        int position = 0;
        for (;;) {
            skip_space();
            if (at_end())
                fail(pos_, "expected '>' to end the group that starts at column " + std::to_string(column(open)) +
                               ", found the end of the expression");
            if (peek() == '>') break;
            if (position == 3)
                fail(pos_,
                     "expected '>': a group has at most three positions, <type scattering 'label'>, found " + found());
            const std::string expected = std::string("expected ") + kWhat[position] + ", '.' or a set in the " +
                                         kPlace[position] + " position of <type scattering 'label'>";
            if (peek() == '[') {
                size_t set_open = pos_++;
                skip_space();
                bool negated = !at_end() && peek() == '^';
                if (negated) ++pos_;
                std::vector<Symbol> syms = symbol_list(set_open, negated, kWhat[position]);
                if (syms.front().kind != kKinds[position]) fail(set_open, expected + hint(syms.front()));
                apply_set(n, syms, negated);
            } else {
                if (peek() == '*' || peek() == '+' || peek() == '?' || peek() == '{')
                    fail(pos_, "repetitions are not allowed inside <...>: a group is one event");
                if (peek() == '(' || peek() == '<' || peek() == '|')
                    fail(pos_, expected + ", found " + found() + " (a group is one event)");
                Symbol s = symbol(expected);
                if (s.kind != Symbol::Kind::Dot) {
                    if (s.kind != kKinds[position]) fail(s.column - column0_, expected + hint(s));
                    apply_set(n, {s}, false);
                }
            }
            ++position;
        }
        ++pos_;
        return n;
    }

    static std::string hint(const Symbol& s) {
        if (s.kind == Symbol::Kind::Label)
            return ", found the label '" + s.label + "': the label is the third position, <..'" + s.label + "'>";
        if (s.kind == Symbol::Kind::Scatter)
            return ", found a scattering type: it is the second position, <." + std::string(1, scatter_char(s.bit)) +
                   ">";
        return ", found an event type: it is the first position";
    }
    static char scatter_char(uint8_t bit) {
        const char* letters = "xDGSs";
        for (int i = 0; i < 5; ++i)
            if (bit == (1u << i)) return letters[i];
        return '?';
    }

    const std::string& text_;
    const std::string& file_;
    int line_, column0_;
    size_t pos_ = 0;
};

}  // namespace

Node parse_expression(const std::string& expression, const std::string& file, int line, int column) {
    return Parser(expression, file, line, column).parse();
}

}  // namespace detail

// ---- the taxonomy file ----

namespace {

bool is_identifier(const std::string& s) {
    if (s.empty() || std::isdigit(static_cast<unsigned char>(s[0]))) return false;
    for (char c : s)
        if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_')) return false;
    return true;
}

size_t first_non_space(const std::string& s, size_t from) {
    while (from < s.size() && (s[from] == ' ' || s[from] == '\t')) ++from;
    return from;
}

// The text before a '#' that is not inside a quoted label.
std::string strip_comment(const std::string& line) {
    bool quoted = false;
    for (size_t i = 0; i < line.size(); ++i) {
        if (line[i] == '\'') quoted = !quoted;
        if (line[i] == '#' && !quoted) return line.substr(0, i);
    }
    return line;
}

struct ClassProperties {
    bool heavy = false, constant = false, rare = false;
};

// `name [heavy constant rare]`: strips the bracketed properties off `name` (trimmed) and reads them.
ClassProperties class_properties(std::string& name, const std::string& file, int lineno, int start) {
    ClassProperties p;
    if (name.empty() || name.back() != ']') return p;
    const size_t open = name.rfind('[');
    if (open == std::string::npos)
        throw LpeError(file, lineno, start + int(name.size()), "a ']' without '[' before '='");
    // The words between the brackets, each at its own column.
    size_t at = open + 1;
    while (at < name.size() - 1) {
        if (name[at] == ' ' || name[at] == '\t') {
            ++at;
            continue;
        }
        size_t end = at;
        while (end < name.size() - 1 && name[end] != ' ' && name[end] != '\t') ++end;
        const std::string w = name.substr(at, end - at);
        if (w == "heavy")
            p.heavy = true;
        else if (w == "constant")
            p.constant = true;
        else if (w == "rare")
            p.rare = true;
        else
            throw LpeError(file, lineno, start + int(at) + 1,
                           "unknown class property `" + w + "`: the properties are `heavy`, `constant` and `rare`");
        at = end;
    }
    name.resize(open);
    while (!name.empty() && (name.back() == ' ' || name.back() == '\t')) name.pop_back();
    return p;
}

// One `name = expression` line into `out`; blank and comment lines add nothing. `query`: an --lpe query, whose
// channels are lpe.NAME.* (and which has no `other` class to collide with), not a taxonomy's class.
void parse_line(const std::string& raw, int lineno, TaxonomySource& out, std::map<std::string, int>& seen, bool query) {
    std::string content = strip_comment(raw);
    while (!content.empty() && (content.back() == ' ' || content.back() == '\t' || content.back() == '\r'))
        content.pop_back();
    size_t start = first_non_space(content, 0);
    if (start == content.size()) return;
    size_t eq = content.find('=');
    if (eq == std::string::npos)
        throw LpeError(out.file, lineno, int(start) + 1, "expected `name = expression`, found no '='");
    std::string name = content.substr(start, eq - start);
    while (!name.empty() && (name.back() == ' ' || name.back() == '\t')) name.pop_back();
    const ClassProperties props = class_properties(name, out.file, lineno, int(start));
    if (name.empty()) throw LpeError(out.file, lineno, int(start) + 1, "expected a class name before '='");
    if (!is_identifier(name))
        throw LpeError(out.file, lineno, int(start) + 1,
                       "`" + name + "` is not a " + (query ? "query" : "class") +
                           " name: use letters, digits and '_', not starting with a digit (it becomes the EXR "
                           "channel " +
                           (query ? "lpe." : "bucket.") + name + ".R)");
    if (name == "other" && !query)
        throw LpeError(out.file, lineno, int(start) + 1,
                       "`other` is reserved: it is the class of the paths that no line matches");
    if (auto it = seen.find(name); it != seen.end())
        throw LpeError(out.file, lineno, int(start) + 1,
                       "`" + name + "` is already defined on line " + std::to_string(it->second));
    size_t expr = first_non_space(content, eq + 1);
    if (expr == content.size()) throw LpeError(out.file, lineno, int(eq) + 2, "expected an expression after '='");
    if (out.lines.size() == kMaxLines)
        throw LpeError(out.file, lineno, int(start) + 1,
                       "a taxonomy has at most " + std::to_string(kMaxLines) + " lines (classes)");
    seen.emplace(name, lineno);
    out.lines.push_back(
        TaxonomyLine{name, content.substr(expr), lineno, int(expr) + 1, props.heavy, props.constant, props.rare});
}

void require_lines(const TaxonomySource& s) {
    if (s.lines.empty())
        throw LpeError(s.file, 0, 0, "no classes: a taxonomy needs at least one `name = expression` line");
}

}  // namespace

TaxonomySource parse_taxonomy(const std::string& text, const std::string& file) {
    TaxonomySource out;
    out.file = file;
    std::map<std::string, int> seen;
    std::istringstream in(text);
    std::string line;
    int lineno = 0;
    while (std::getline(in, line)) parse_line(line, ++lineno, out, seen, /*query=*/false);
    require_lines(out);
    return out;
}

TaxonomySource read_taxonomy(const std::filesystem::path& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw LpeError(path.string(), 0, 0, "cannot open the taxonomy file");
    std::ostringstream text;
    text << in.rdbuf();
    return parse_taxonomy(text.str(), path.string());
}

TaxonomySource taxonomy_from_lines(const std::vector<std::string>& name_equals_expression, const std::string& file) {
    TaxonomySource out;
    out.file = file;
    std::map<std::string, int> seen;
    int lineno = 0;
    for (const std::string& l : name_equals_expression) {
        size_t before = out.lines.size();
        parse_line(l, ++lineno, out, seen, /*query=*/true);
        if (out.lines.size() == before) throw LpeError(file, lineno, 0, "expected `name = expression`");
        const TaxonomyLine& q = out.lines.back();
        const int name_column = int(first_non_space(l, 0)) + 1;
        if (q.heavy || q.constant || q.rare)
            throw LpeError(file, lineno, int(l.find('[')) + 1,
                           "a query takes no properties: [heavy], [constant] and [rare] are for a taxonomy's classes");
        if (q.name == "_rest" || q.name == "_overlap")
            throw LpeError(file, lineno, name_column,
                           "`" + q.name + "` is reserved: lpe." + q.name + " is the channel of the paths " +
                               (q.name == "_rest" ? "no query matches" : "that more than one query matches"));
    }
    require_lines(out);
    return out;
}

}  // namespace vkmech::lpe
