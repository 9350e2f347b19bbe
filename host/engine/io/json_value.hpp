// A small strict JSON reader (RFC 8259): what vkmech must read back whole and
// refuse when malformed (the sentinel records, docs/descriptor.md §9). Objects
// keep their members in file order; numbers are doubles.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace vkmech {

struct JsonValue {
    enum Kind { Null, Bool, Number, String, Array, Object } kind = Null;
    bool boolean = false;
    double number = 0.0;
    std::string string;
    std::vector<JsonValue> array;
    std::vector<std::pair<std::string, JsonValue>> object;

    // Defined in json_value.cpp, where JsonValue is complete: a member vector of
    // pair<string, JsonValue> cannot be destroyed or copied in-class (clang
    // with libstdc++ refuses the incomplete pair).
    JsonValue();
    JsonValue(const JsonValue&);
    JsonValue(JsonValue&&) noexcept;
    JsonValue& operator=(const JsonValue&);
    JsonValue& operator=(JsonValue&&) noexcept;
    ~JsonValue();

    // The member `key` of an object (the first one), or nullptr.
    const JsonValue* find(const std::string& key) const;
};

// Parses `text` as one JSON value (surrounding whitespace allowed). Nullopt
// with *why ("line L column C: what") on malformed input, duplicate object
// keys or nesting deeper than 64.
std::optional<JsonValue> parse_json(const std::string& text, std::string* why = nullptr);

}  // namespace vkmech
