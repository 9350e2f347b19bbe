// User taxonomies as light path expressions (docs/lpe.md; issue 37; SPEC §3.1): an ordered list of
// `name = expression` lines in OSL's LPE grammar, compiled on the host to one minimal DFA over
// vkmech's path events. A path carries one small integer state, updated at each vertex; a
// contribution event is classified by the state it reaches, and the first matching line wins
// (class index = line order; `other`, index = number of lines, when none matches).
// No Vulkan: the GPU gets the dense tables of CompiledTaxonomy.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

namespace vkmech::lpe {

// OSL's event types and scattering types (docs/lpe.md, "Events").
enum class EventType : uint8_t { Camera, Reflect, Transmit, Volume, Light, Object, Background };  // C R T V L O B
enum class Scatter : uint8_t { None, Diffuse, Glossy, Singular, Straight };                       // (none) D G S s
constexpr uint32_t kEventTypeCount = 7;
constexpr uint32_t kScatterCount = 5;

// The events vkmech's paths are made of, in symbol order: the camera, a reflection or
// transmission with the lobe class sampled there (D, G, S: descriptor §2.2), an area emitter (L)
// and an emitter at infinity (B). V, O and s are in the grammar but no vkmech event carries them.
struct EventKind {
    EventType type;
    Scatter scatter;
    const char* name;  // as docs/lpe.md writes it: "C", "RD", ..., "L", "B"
};
constexpr uint32_t kKindCamera = 0, kKindRD = 1, kKindRG = 2, kKindRS = 3, kKindTD = 4, kKindTG = 5, kKindTS = 6,
                   kKindLight = 7, kKindBackground = 8;
constexpr uint32_t kKindCount = 9;
extern const std::array<EventKind, kKindCount> kEventKinds;

// One thing an event can carry as its label: a shape instance, answering to its shape id and its
// material id, or an emitter, answering to its id. Quoted labels in a taxonomy match every slot
// that answers to the name. Events without a slot (the camera, say) have label class 0.
struct LabelSlot {
    std::vector<std::string> names;
};

// A malformed taxonomy: "file:line:column: what is wrong" (column 0: the whole line; line 0: the
// whole file). The CLI prints what() and exits with code 2 (bad input).
class LpeError : public std::runtime_error {
public:
    LpeError(const std::string& file, int line, int column, const std::string& reason);
    const std::string& file() const { return file_; }
    int line() const { return line_; }
    int column() const { return column_; }
    const std::string& reason() const { return reason_; }

private:
    std::string file_;
    int line_, column_;
    std::string reason_;
};

// A warning: the taxonomy compiles, but something in it is likely not what was meant.
struct Diagnostic {
    std::string file;
    int line = 0, column = 0;
    std::string message;
    std::string str() const;  // "file:line:column: warning: message"
};

// One `name = expression` line of a taxonomy file.
struct TaxonomyLine {
    std::string name;
    std::string expression;
    int line = 0;               // 1-based line in the file
    int expression_column = 0;  // 1-based column of the expression's first character
    // `name [heavy constant rare] = ...`: properties the allocation strategies read (docs/lpe.md). heavy:
    // the class is heavy-tailed (the bucket floor floors it); constant: its energy is constant per pixel
    // (an emitter seen directly), so the guard trusts a zero variance of a pixel lit by it alone; rare:
    // its variance is a rare large sample's, which robust-adaptive keeps (the plain pilot variance, not
    // median-of-means).
    bool heavy = false;
    bool constant = false;
    bool rare = false;
};
struct TaxonomySource {
    std::string file;  // for messages
    std::vector<TaxonomyLine> lines;
};

// The file syntax (names, '=', comments); expressions are checked by compile_taxonomy.
TaxonomySource parse_taxonomy(const std::string& text, const std::string& file);
TaxonomySource read_taxonomy(const std::filesystem::path& path);
// `--lpe name=EXPR` style: one query a string, named `file` in messages (line k: the k-th string). Queries take no
// properties, `_rest` and `_overlap` are reserved (query channels, docs/lpe.md), and `other` is a name like any.
TaxonomySource taxonomy_from_lines(const std::vector<std::string>& name_equals_expression, const std::string& file);

constexpr uint32_t kDefaultMaxStates = 256;
constexpr uint32_t kMaxLines = 255;  // classes (lines + other) fit a uint8_t
constexpr uint16_t kNoState = 0xFFFF;

struct CompileOptions {
    uint32_t max_states = kDefaultMaxStates;  // refused above it (at most 65535)
    // Queries (`render --lpe`, docs/lpe.md): the lines may overlap, and a path's class is the
    // combination of every line it matches, not the first. The classes are the combinations that
    // whole vkmech paths can make (fewest lines first, then by line order; CompiledTaxonomy::
    // class_lines), and `other` is a path no line matches. At most kMaxQueryLines lines.
    bool all_matches = false;
};
constexpr uint32_t kMaxQueryLines = 32;  // a bit per line

// The compiled taxonomy: everything the shader needs, in dense arrays.
//   symbol = kind * label_class_count + label_class          (kind: kKind*, label_class: per slot)
//   state' = next_state[state * alphabet_size + symbol]
//   class  = accept_class[state]                              (other_class when no line matches)
// A path starts in start_state (0) before its camera event. For an event, step over the camera,
// each vertex and the emitter, then read accept_class; the dead state (kNoState when there is
// none) is a sink of class other.
struct CompiledTaxonomy {
    std::vector<std::string> class_names;       // the lines' names, then "other"
    uint32_t other_class = 0;                   // = number of lines
    uint32_t label_class_count = 1;             // label class 0: no taxonomy label answers
    std::vector<uint16_t> label_class_of_slot;  // per LabelSlot given to compile_taxonomy
    std::vector<std::string> labels;            // the quoted labels the taxonomy names, first use first
    uint32_t alphabet_size = 0;                 // kKindCount * label_class_count
    uint32_t state_count = 0;
    uint16_t start_state = 0;
    uint16_t dead_state = kNoState;
    std::vector<uint16_t> next_state;         // state_count * alphabet_size
    std::vector<uint8_t> accept_class;        // state_count
    std::vector<uint32_t> line_state_counts;  // each line's own minimal DFA size (diagnostics)
    // CompileOptions::all_matches: each class's lines, a bit per line (class_names joins their
    // names with '&'); empty otherwise.
    std::vector<uint32_t> class_lines;
    std::vector<Diagnostic> warnings;

    uint32_t symbol(uint32_t kind, uint32_t label_class) const { return kind * label_class_count + label_class; }
    uint16_t step(uint16_t state, uint32_t symbol) const { return next_state[size_t(state) * alphabet_size + symbol]; }
    // The class of a whole event sequence (camera first, emitter last), from start_state.
    uint32_t classify(std::span<const uint32_t> symbols) const;
    // next_state as bytes, for a DFA of at most 256 states (an InternalError otherwise).
    std::vector<uint8_t> next_state_u8() const;
};

// Parses every expression, builds the DFA (Thompson NFA, subset construction, Moore
// minimization) and checks it. Throws LpeError for a malformed expression or a DFA over
// options.max_states; returns warnings for labels no slot answers to, lines that can never match
// a vkmech path, and lines every path of which an earlier line takes.
CompiledTaxonomy compile_taxonomy(const TaxonomySource& source, const std::vector<LabelSlot>& slots,
                                  const CompileOptions& options = {});

// The quoted labels the taxonomy's expressions name, first use first (CompiledTaxonomy::labels without
// compiling): parses every expression, so a malformed one throws LpeError as compile_taxonomy does.
std::vector<std::string> taxonomy_labels(const TaxonomySource& source);

}  // namespace vkmech::lpe
