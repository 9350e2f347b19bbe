#include "scene/xml_node.hpp"

#include "scene/scene.hpp"
#include "scene/text_parse.hpp"

#include <glm/gtc/matrix_transform.hpp>

#include <algorithm>
#include <cmath>
#include <set>

namespace vkmech {

namespace {

bool is_ident_char(char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; }

float srgb_to_linear(float c) { return c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f); }

bool is_one_of(const std::string& s, std::initializer_list<const char*> set) {
    return std::any_of(set.begin(), set.end(), [&](const char* t) { return s == t; });
}

std::string join(std::initializer_list<const char*> names) {
    std::string out;
    for (const char* n : names) {
        if (!out.empty()) out += '/';
        out += n;
    }
    return out;
}

}  // namespace

const std::string* XmlParams::find(const std::string& name) const {
    auto it = values_.find(name);
    if (it == values_.end()) return nullptr;
    used_.insert(name);
    return &it->second;
}

std::vector<std::string> XmlParams::unused_overrides() const {
    std::vector<std::string> out;
    for (const auto& n : overrides_)
        if (!used_.count(n)) out.push_back(n);
    return out;
}

// ---- XNode ----

void XNode::fail(const std::string& what) const { throw SceneError(file(), line(), what); }

std::string XNode::describe() const {
    // Built by appending: GCC 12 -O3 warns (-Wrestrict, a false positive)
    // on `"literal" + std::string&&`.
    std::string out("<");
    out += node_.name();
    if (pugi::xml_attribute type = node_.attribute("type")) {
        out += " type=\"";
        out += type.value();
        out += '"';
    }
    out += '>';
    return out;
}

std::string XNode::substitute(std::string_view raw) const {
    // Mitsuba: `$name` anywhere in an attribute value is replaced by the
    // parameter's value (a -D override, else the <default>).
    std::string out;
    for (size_t i = 0; i < raw.size(); ++i) {
        if (raw[i] != '$' || i + 1 >= raw.size() || !is_ident_char(raw[i + 1])) {
            out += raw[i];
            continue;
        }
        size_t j = i + 1;
        while (j < raw.size() && is_ident_char(raw[j])) ++j;
        std::string name(raw.substr(i + 1, j - i - 1));
        const std::string* v = params_->find(name);
        if (!v)
            fail("unbound parameter '$" + name + "' (no <default name=\"" + name + "\"> and no -D " + name + "=...)");
        out += *v;
        i = j - 1;
    }
    return out;
}

std::optional<std::string> XNode::attr(const char* name) const {
    pugi::xml_attribute a = node_.attribute(name);
    if (!a) return std::nullopt;
    return substitute(a.value());
}

std::string XNode::required(const char* name) const {
    auto v = attr(name);
    if (!v) fail(describe() + " is missing the required attribute '" + name + "'");
    return *v;
}

std::vector<XNode> XNode::children() const {
    std::vector<XNode> out;
    for (pugi::xml_node c = node_.first_child(); c; c = c.next_sibling())
        if (c.type() == pugi::node_element) out.emplace_back(*doc_, c, *params_);
    return out;
}

double XNode::number(std::string_view s, std::string_view what) const {
    std::string why;
    auto v = text::to_finite_float(s, why);
    if (!v) fail(why + " (" + std::string(what) + ")");
    return *v;
}

int XNode::integer(std::string_view s, std::string_view what) const {
    auto v = text::to_int(s);
    if (!v || *v < INT32_MIN || *v > INT32_MAX)
        fail("cannot parse '" + std::string(text::trim(s)) + "' as an integer (" + std::string(what) + ")");
    return static_cast<int>(*v);
}

std::vector<double> XNode::numbers(std::string_view s, std::string_view what) const {
    std::vector<double> out;
    for (auto tok : text::split_list(s)) out.push_back(number(tok, what));
    return out;
}

float XNode::as_float() const {
    if (tag() == "integer") return static_cast<float>(as_int());
    return static_cast<float>(number(required("value"), describe()));
}

int XNode::as_int() const { return integer(required("value"), describe()); }

bool XNode::as_bool() const {
    std::string v = text::lower(text::trim(required("value")));
    if (v == "true" || v == "1") return true;
    if (v == "false" || v == "0") return false;
    fail("cannot parse '" + v + "' as a boolean (expected true or false)");
}

std::string XNode::as_string() const { return required("value"); }

glm::vec3 XNode::as_color() const {
    const std::string t = tag();
    if (t == "blackbody") {
        // Planck's law sampled at the RGB primaries' wavelengths (650, 550,
        // 450 nm, as for <spectrum> below) and normalized to unit luminance,
        // times `scale`: the colour of the temperature, its brightness given
        // by `scale` (vkmech has no absolute spectral units).
        double temp = number(required("temperature"), "temperature");
        if (!(temp > 0.0)) fail("<blackbody> temperature must be positive, got " + required("temperature"));
        double scale = attr("scale") ? number(*attr("scale"), "scale") : 1.0;
        auto planck = [&](double nm) {
            const double c = 2.99792458e8, h = 6.62607015e-34, k = 1.380649e-23, l = nm * 1e-9;
            return 2.0 * h * c * c / (l * l * l * l * l) / std::expm1(h * c / (l * k * temp));
        };
        glm::dvec3 rgb(planck(650.0), planck(550.0), planck(450.0));
        double lum = gpu::LUM_R * rgb.x + gpu::LUM_G * rgb.y + gpu::LUM_B * rgb.z;
        if (!(lum > 0.0) || !std::isfinite(lum))
            fail("<blackbody> temperature " + required("temperature") + " K gives no visible light");
        return glm::vec3(rgb / lum * scale);
    }
    if (t == "spectrum" && attr("filename")) fail("<spectrum filename=...> is not supported (give an <rgb> value)");
    std::string v = required("value");
    std::string_view sv = text::trim(v);
    if ((t == "rgb" || t == "srgb") && !sv.empty() && sv.front() == '#') {
        // "#rrggbb": a display colour, decoded from sRGB.
        if (sv.size() != 7) fail("cannot parse colour '" + v + "' (expected #rrggbb)");
        glm::vec3 c;
        for (int i = 0; i < 3; ++i) {
            auto h = std::string(sv.substr(1 + 2 * i, 2));
            char* end = nullptr;
            long x = std::strtol(h.c_str(), &end, 16);
            if (*end != '\0') fail("cannot parse colour '" + v + "' (expected #rrggbb)");
            c[i] = srgb_to_linear(static_cast<float>(x) / 255.0f);
        }
        return c;
    }
    if (t == "spectrum" && sv.find(':') != std::string_view::npos) {
        // Wavelength:value pairs, reduced to RGB by sampling at 650/550/450
        // nm (the same primaries as the conductor table).
        std::vector<std::pair<double, double>> pts;
        for (auto tok : text::split_list(sv)) {
            size_t colon = tok.find(':');
            if (colon == std::string_view::npos) fail("cannot parse spectrum entry '" + std::string(tok) + "'");
            pts.push_back(
                {number(tok.substr(0, colon), "wavelength"), number(tok.substr(colon + 1), "spectrum value")});
        }
        std::sort(pts.begin(), pts.end());
        auto at = [&](double l) {
            if (l <= pts.front().first) return pts.front().second;
            if (l >= pts.back().first) return pts.back().second;
            for (size_t i = 1; i < pts.size(); ++i)
                if (l <= pts[i].first) {
                    double f = (l - pts[i - 1].first) / (pts[i].first - pts[i - 1].first);
                    return pts[i - 1].second + f * (pts[i].second - pts[i - 1].second);
                }
            return pts.back().second;
        };
        return glm::vec3(at(650.0), at(550.0), at(450.0));
    }
    std::vector<double> n = numbers(v, describe());
    glm::vec3 c;
    if (n.size() == 1)
        c = glm::vec3(static_cast<float>(n[0]));
    else if (n.size() == 3 && t != "spectrum" && t != "float" && t != "integer")
        c = glm::vec3(n[0], n[1], n[2]);
    else
        fail(describe() + (t == "rgb" || t == "srgb" ? " needs 1 or 3 values" : " needs 1 value") + ", got " +
             std::to_string(n.size()));
    if (t == "srgb") c = glm::vec3(srgb_to_linear(c.x), srgb_to_linear(c.y), srgb_to_linear(c.z));
    return c;
}

glm::vec3 XNode::vec3_attrs(float fallback, bool allow_single) const {
    auto value = attr("value");
    bool has_xyz = node_.attribute("x") || node_.attribute("y") || node_.attribute("z");
    if (value) {
        if (has_xyz) fail(describe() + ": give either value=\"x y z\" or x/y/z attributes, not both");
        std::vector<double> n = numbers(*value, describe());
        if (n.size() == 1 && allow_single) return glm::vec3(static_cast<float>(n[0]));
        if (n.size() != 3) fail(describe() + " needs 3 values, got " + std::to_string(n.size()));
        return glm::vec3(n[0], n[1], n[2]);
    }
    glm::vec3 v(fallback);
    const char* names[3] = {"x", "y", "z"};
    for (int i = 0; i < 3; ++i)
        if (auto a = attr(names[i])) v[i] = static_cast<float>(number(*a, describe()));
    return v;
}

glm::vec3 XNode::as_vector() const { return vec3_attrs(0.0f, false); }

glm::mat4 XNode::transform_step(const XNode& op) const {
    const std::string t = op.tag();
    if (t == "translate") return glm::translate(glm::mat4(1.0f), op.vec3_attrs(0.0f, false));
    if (t == "scale") return glm::scale(glm::mat4(1.0f), op.vec3_attrs(1.0f, true));
    if (t == "rotate") {
        glm::vec3 axis;
        if (auto a = op.attr("axis")) {
            auto n = op.numbers(*a, "<rotate axis>");
            if (n.size() != 3) op.fail("<rotate> axis needs 3 values, got " + std::to_string(n.size()));
            axis = glm::vec3(n[0], n[1], n[2]);
        } else {
            axis = op.vec3_attrs(0.0f, false);
        }
        float angle = static_cast<float>(op.number(op.required("angle"), "<rotate angle>"));
        if (!(glm::length(axis) > 0.0f)) op.fail("<rotate> has a zero rotation axis");
        return glm::rotate(glm::mat4(1.0f), glm::radians(angle), glm::normalize(axis));
    }
    if (t == "matrix") {
        std::vector<double> n = op.numbers(op.required("value"), "<matrix>");
        glm::mat4 m(1.0f);
        if (n.size() == 16) {
            for (int r = 0; r < 4; ++r)
                for (int c = 0; c < 4; ++c) m[c][r] = static_cast<float>(n[r * 4 + c]);  // row-major text
        } else if (n.size() == 9) {
            for (int r = 0; r < 3; ++r)
                for (int c = 0; c < 3; ++c) m[c][r] = static_cast<float>(n[r * 3 + c]);
        } else {
            op.fail("<matrix> needs 16 values (row-major 4x4), got " + std::to_string(n.size()));
        }
        return m;
    }
    if (t == "lookat" || t == "lookAt") {
        auto vec = [&](const char* name, bool required) -> std::optional<glm::vec3> {
            auto a = required ? std::optional<std::string>(op.required(name)) : op.attr(name);
            if (!a) return std::nullopt;
            auto n = op.numbers(*a, std::string("<lookat ") + name + ">");
            if (n.size() != 3)
                op.fail(std::string("<lookat> '") + name + "' needs 3 values, got " + std::to_string(n.size()));
            return glm::vec3(n[0], n[1], n[2]);
        };
        glm::vec3 origin = *vec("origin", true), target = *vec("target", true);
        glm::vec3 dir = target - origin;
        if (!(glm::length(dir) > 0.0f)) op.fail("<lookat> origin and target coincide");
        dir = glm::normalize(dir);
        glm::vec3 up;
        if (auto u = vec("up", false)) {
            up = *u;
        } else {
            // Mitsuba picks any up perpendicular to dir when none is given.
            up = std::abs(dir.y) < 0.9f ? glm::vec3(0, 1, 0) : glm::vec3(0, 0, 1);
        }
        glm::vec3 left = glm::cross(up, dir);
        if (!(glm::length(left) > 1e-6f * glm::length(up)))
            op.fail("<lookat> 'up' is zero or parallel to the viewing direction");
        left = glm::normalize(left);
        glm::vec3 new_up = glm::cross(dir, left);
        // Mitsuba's look_at: columns (left, up, dir, origin).
        glm::mat4 m(1.0f);
        m[0] = glm::vec4(left, 0.0f);
        m[1] = glm::vec4(new_up, 0.0f);
        m[2] = glm::vec4(dir, 0.0f);
        m[3] = glm::vec4(origin, 1.0f);
        return m;
    }
    op.fail("unknown transform operation <" + t + "> (expected translate, rotate, scale, matrix or lookat)");
}

glm::mat4 XNode::as_transform() const {
    // Each operation left-multiplies what came before (Mitsuba's order).
    glm::mat4 m(1.0f);
    for (const XNode& op : children()) m = transform_step(op) * m;
    for (int c = 0; c < 4; ++c)
        for (int r = 0; r < 4; ++r)
            if (!std::isfinite(m[c][r])) fail("the transform is not finite");
    return m;
}

// ---- XProps ----

XProps::XProps(const XNode& plugin) : plugin_(plugin) {
    static const std::set<std::string> value_tags = {"float",    "integer",   "boolean", "string", "rgb",      "srgb",
                                                     "spectrum", "blackbody", "point",   "vector", "transform"};
    static const std::set<std::string> object_tags = {"bsdf",    "emitter",    "shape",  "film",   "sampler",
                                                      "rfilter", "integrator", "sensor", "medium", "phase",
                                                      "volume",  "texture",    "ref"};
    for (const XNode& c : plugin.children()) {
        const std::string t = c.tag();
        bool named_object = (t == "texture" || t == "ref") && c.raw().attribute("name");
        if (value_tags.count(t) || named_object) {
            std::string name = c.required("name");
            auto [it, inserted] = props_.try_emplace(name, c);
            if (!inserted)
                c.fail("duplicate property '" + name + "' (first given at line " + std::to_string(it->second.line()) +
                       ")");
        } else if (object_tags.count(t)) {
            objects_.push_back(c);
        } else {
            c.fail("unknown element <" + t + "> inside " + plugin.describe());
        }
    }
}

std::vector<XNode> XProps::unused() const {
    std::vector<XNode> out;
    for (const auto& [name, node] : props_)
        if (!used_.count(name)) out.push_back(node);
    std::sort(out.begin(), out.end(), [](const XNode& a, const XNode& b) { return a.line() < b.line(); });
    return out;
}

const XNode* XProps::find(std::initializer_list<const char*> names) const {
    const XNode* found = nullptr;
    const char* found_name = nullptr;
    for (const char* n : names) {
        auto it = props_.find(n);
        if (it == props_.end()) continue;
        used_.insert(n);
        if (found) it->second.fail(std::string("'") + n + "' and '" + found_name + "' name the same property");
        found = &it->second;
        found_name = n;
    }
    return found;
}

const XNode& XProps::expect(const XNode& n, std::initializer_list<const char*> tags, const std::string& what) const {
    if (!is_one_of(n.tag(), tags)) {
        std::string hint = n.tag() == "texture" || n.tag() == "ref"
                               ? " (textures are supported on colour-valued BSDF parameters only)"
                               : "";
        n.fail("property '" + what + "' must be <" + join(tags) + ">, not <" + n.tag() + ">" + hint);
    }
    return n;
}

std::optional<float> XProps::opt_float(std::initializer_list<const char*> names) const {
    const XNode* n = find(names);
    if (!n) return std::nullopt;
    for (const char* name : names)
        if (auto it = floats_.find(name); it != floats_.end()) return it->second;
    return expect(*n, {"float", "integer"}, *names.begin()).as_float();
}

float XProps::get_float(std::initializer_list<const char*> names, float fallback) const {
    return opt_float(names).value_or(fallback);
}

std::optional<int> XProps::opt_int(std::initializer_list<const char*> names) const {
    const XNode* n = find(names);
    if (!n) return std::nullopt;
    return expect(*n, {"integer"}, *names.begin()).as_int();
}

bool XProps::get_bool(std::initializer_list<const char*> names, bool fallback) const {
    const XNode* n = find(names);
    if (!n) return fallback;
    return expect(*n, {"boolean"}, *names.begin()).as_bool();
}

std::optional<std::string> XProps::opt_string(std::initializer_list<const char*> names) const {
    const XNode* n = find(names);
    if (!n) return std::nullopt;
    return expect(*n, {"string"}, *names.begin()).as_string();
}

std::optional<glm::vec3> XProps::opt_color(std::initializer_list<const char*> names) const {
    const XNode* n = find(names);
    if (!n) return std::nullopt;
    return expect(*n, {"rgb", "srgb", "spectrum", "float", "integer", "blackbody"}, *names.begin()).as_color();
}

glm::vec3 XProps::get_color(std::initializer_list<const char*> names, glm::vec3 fallback) const {
    return opt_color(names).value_or(fallback);
}

glm::vec3 XProps::get_vector(std::initializer_list<const char*> names, glm::vec3 fallback) const {
    const XNode* n = find(names);
    if (!n) return fallback;
    return expect(*n, {"point", "vector"}, *names.begin()).as_vector();
}

glm::mat4 XProps::get_transform(std::initializer_list<const char*> names) const {
    const XNode* n = find(names);
    if (!n) return glm::mat4(1.0f);
    return expect(*n, {"transform"}, *names.begin()).as_transform();
}

}  // namespace vkmech
