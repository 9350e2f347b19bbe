// Reading Mitsuba XML elements: `$name` parameter substitution, typed
// attribute and value-element parsing, transforms, and a plugin's named
// properties. Every failure is a SceneError at the element's file and line.
#pragma once

#include "scene/xml_document.hpp"

#include <glm/glm.hpp>

#include <initializer_list>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <vector>

namespace vkmech {

// Scene parameters: -D overrides (LoadOptions::params) win over <default>.
class XmlParams {
public:
    explicit XmlParams(std::map<std::string, std::string> overrides) : values_(std::move(overrides)) {
        for (const auto& kv : values_) overrides_.push_back(kv.first);
    }
    // A <default>: sets `name` only if nothing has set it yet.
    void add_default(const std::string& name, const std::string& value) { values_.try_emplace(name, value); }
    // Looks `name` up and remembers that it was used.
    const std::string* find(const std::string& name) const;
    // The -D overrides no `$name` ever used (docs/descriptor.md §8: a warning, never silent).
    std::vector<std::string> unused_overrides() const;

private:
    std::map<std::string, std::string> values_;
    std::vector<std::string> overrides_;
    mutable std::set<std::string> used_;
};

// An element in its document, with parameter substitution on attributes.
class XNode {
public:
    XNode(const XmlDocument& doc, pugi::xml_node node, const XmlParams& params)
        : doc_(&doc), node_(node), params_(&params) {}

    std::string tag() const { return node_.name(); }
    int line() const { return doc_->line_of(node_); }
    const XmlDocument& doc() const { return *doc_; }
    const std::string& file() const { return doc_->path(); }
    pugi::xml_node raw() const { return node_; }

    [[noreturn]] void fail(const std::string& what) const;

    // Attribute value after `$name` substitution; nullopt when absent.
    std::optional<std::string> attr(const char* name) const;
    // As attr(), but a missing attribute is an error.
    std::string required(const char* name) const;

    // Element children in document order.
    std::vector<XNode> children() const;

    // Strict numbers: the whole token, finite and within a 32-bit float's
    // range ("nan", "inf", "1e39", "1.2.3" fail).
    double number(std::string_view s, std::string_view what) const;
    int integer(std::string_view s, std::string_view what) const;
    std::vector<double> numbers(std::string_view s, std::string_view what) const;

    // Value elements (the element is this node):
    float as_float() const;          // <float>, <integer>
    int as_int() const;              // <integer>
    bool as_bool() const;            // <boolean>
    std::string as_string() const;   // <string>
    glm::vec3 as_color() const;      // <rgb>, <srgb>, <spectrum>, <float>, <integer>
    glm::vec3 as_vector() const;     // <point>, <vector>: x/y/z or value="x y z"
    glm::mat4 as_transform() const;  // <transform>: children applied in order

    // "<tag type="t">" for messages.
    std::string describe() const;

private:
    std::string substitute(std::string_view raw) const;
    glm::vec3 vec3_attrs(float fallback, bool allow_single) const;
    glm::mat4 transform_step(const XNode& op) const;

    const XmlDocument* doc_;
    pugi::xml_node node_;
    const XmlParams* params_;
};

// A plugin element's named properties (<float name=...>, <rgb name=...>,
// <texture name=...>, <ref name=...>, <transform name=...>, ...) and its
// nested unnamed objects (<bsdf>, <emitter>, <film>, <ref id=...>, ...).
// Getters take alias lists (Mitsuba 3 name first, then 0.5/0.6 camelCase).
class XProps {
public:
    explicit XProps(const XNode& plugin);

    const XNode& plugin() const { return plugin_; }
    const std::vector<XNode>& objects() const { return objects_; }

    // The property under any of `names` (two aliases at once is an error);
    // a property found is marked used.
    const XNode* find(std::initializer_list<const char*> names) const;
    // Named properties nobody asked for, in document order (docs/descriptor.md §8: the
    // loader warns about every property it does not use).
    std::vector<XNode> unused() const;
    // The property `name`, without marking it used.
    const XNode* peek(const std::string& name) const {
        auto it = props_.find(name);
        return it == props_.end() ? nullptr : &it->second;
    }

    std::optional<float> opt_float(std::initializer_list<const char*> names) const;
    // Replaces a property's value by a number (a textured float parameter
    // reduced to its texture's mean under --substitute).
    void set_float(const std::string& name, float value) { floats_[name] = value; }
    float get_float(std::initializer_list<const char*> names, float fallback) const;
    std::optional<int> opt_int(std::initializer_list<const char*> names) const;
    bool get_bool(std::initializer_list<const char*> names, bool fallback) const;
    std::optional<std::string> opt_string(std::initializer_list<const char*> names) const;
    std::optional<glm::vec3> opt_color(std::initializer_list<const char*> names) const;
    glm::vec3 get_color(std::initializer_list<const char*> names, glm::vec3 fallback) const;
    glm::vec3 get_vector(std::initializer_list<const char*> names, glm::vec3 fallback) const;
    glm::mat4 get_transform(std::initializer_list<const char*> names) const;

private:
    const XNode& expect(const XNode& n, std::initializer_list<const char*> tags, const std::string& what) const;

    XNode plugin_;
    std::map<std::string, XNode> props_;
    mutable std::set<std::string> used_;
    std::map<std::string, float> floats_;
    std::vector<XNode> objects_;
};

}  // namespace vkmech
