// PLY reader (ascii, binary_little_endian, binary_big_endian).
#include "scene/mesh_io.hpp"

#include "scene/mesh_ops.hpp"
#include "scene/text_parse.hpp"
#include "scene/triangle_budget.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <sstream>

namespace vkmech {

namespace {

enum class Type { I8, U8, I16, U16, I32, U32, F32, F64 };

std::optional<Type> type_from_name(std::string_view s) {
    if (s == "char" || s == "int8") return Type::I8;
    if (s == "uchar" || s == "uint8") return Type::U8;
    if (s == "short" || s == "int16") return Type::I16;
    if (s == "ushort" || s == "uint16") return Type::U16;
    if (s == "int" || s == "int32") return Type::I32;
    if (s == "uint" || s == "uint32") return Type::U32;
    if (s == "float" || s == "float32") return Type::F32;
    if (s == "double" || s == "float64") return Type::F64;
    return std::nullopt;
}

size_t type_size(Type t) {
    switch (t) {
        case Type::I8:
        case Type::U8:
            return 1;
        case Type::I16:
        case Type::U16:
            return 2;
        case Type::I32:
        case Type::U32:
        case Type::F32:
            return 4;
        case Type::F64:
            return 8;
    }
    return 1;
}

bool is_integer(Type t) { return t != Type::F32 && t != Type::F64; }

struct Property {
    std::string name;
    Type type = Type::F32;
    bool is_list = false;
    Type count_type = Type::U8;
};

struct Element {
    std::string name;
    size_t count = 0;
    std::vector<Property> props;
    int line = 0;
};

enum class Format { Ascii, BinaryLE, BinaryBE };

class PlyReader {
public:
    PlyReader(std::string path, size_t max_triangles) : path_(std::move(path)), max_triangles_(max_triangles) {}

    Mesh read() {
        data_ = read_whole_file(path_);
        parse_header();
        for (const Element& e : elements_) {
            check_count(e);
            if (e.name == "vertex")
                read_vertices(e);
            else if (e.name == "face")
                read_faces(e);
            else
                skip_element(e);
        }
        return build();
    }

private:
    [[noreturn]] void fail(int line, const std::string& what) const { throw SceneError(path_, line, what); }

    // ---- header ----
    std::string_view next_header_line() {
        if (pos_ >= data_.size()) fail(line_, "the header has no end_header");
        size_t nl = data_.find('\n', pos_);
        if (nl == std::string::npos) nl = data_.size();
        std::string_view l(data_.data() + pos_, nl - pos_);
        pos_ = nl + 1;  // binary data starts right after end_header's newline
        ++line_;
        return l;
    }

    void parse_header() {
        if (text::trim(next_header_line()) != "ply") fail(1, "not a PLY file (missing 'ply' magic)");
        bool have_format = false;
        for (;;) {
            auto tok = text::split_ws(next_header_line());
            if (tok.empty()) continue;
            if (tok[0] == "end_header") break;
            if (tok[0] == "comment" || tok[0] == "obj_info") continue;
            if (tok[0] == "format") {
                if (tok.size() < 2) fail(line_, "'format' needs a value");
                if (tok[1] == "ascii")
                    format_ = Format::Ascii;
                else if (tok[1] == "binary_little_endian")
                    format_ = Format::BinaryLE;
                else if (tok[1] == "binary_big_endian")
                    format_ = Format::BinaryBE;
                else
                    fail(line_, "unsupported PLY format '" + std::string(tok[1]) + "'");
                have_format = true;
            } else if (tok[0] == "element") {
                auto n = tok.size() == 3 ? text::to_int(tok[2]) : std::nullopt;
                if (!n || *n < 0) fail(line_, "malformed 'element' line");
                refuse_repeated(tok[1]);
                elements_.push_back({std::string(tok[1]), static_cast<size_t>(*n), {}, line_});
            } else if (tok[0] == "property") {
                if (elements_.empty()) fail(line_, "'property' before any 'element'");
                Property p;
                if (tok.size() == 5 && tok[1] == "list") {
                    auto ct = type_from_name(tok[2]), it = type_from_name(tok[3]);
                    if (!ct || !it || !is_integer(*ct)) fail(line_, "unsupported list property types");
                    p = {std::string(tok[4]), *it, true, *ct};
                } else if (tok.size() == 3) {
                    auto t = type_from_name(tok[1]);
                    if (!t) fail(line_, "unknown property type '" + std::string(tok[1]) + "'");
                    p = {std::string(tok[2]), *t, false, Type::U8};
                } else {
                    fail(line_, "malformed 'property' line");
                }
                elements_.back().props.push_back(p);
            } else {
                fail(line_, "unexpected header keyword '" + std::string(tok[0]) + "'");
            }
        }
        if (!have_format) fail(line_, "the header has no 'format' line");
        ++line_;  // ascii data starts on the line after end_header
    }

    // A second 'vertex' or 'face' element would have to be merged with the
    // first (and its normals or uvs with the first's); no exporter writes one.
    void refuse_repeated(std::string_view name) {
        for (const Element& e : elements_)
            if (e.name == name && (name == "vertex" || name == "face"))
                fail(line_, "a second element '" + std::string(name) + "' (the first is at line " +
                                std::to_string(e.line) + "); a PLY mesh has one of each");
    }

    // The least bytes one value takes: its size in binary; in ascii one
    // character and a separator.
    size_t min_value_bytes(Type t) const { return format_ == Format::Ascii ? 2 : type_size(t); }

    // A count is refused when its records cannot fit in the bytes left, so
    // a hostile count neither allocates nor loops (an element without
    // properties takes no bytes: it is still held to one per record).
    void check_count(const Element& e) const {
        size_t record = 0;
        for (const Property& p : e.props) record += min_value_bytes(p.is_list ? p.count_type : p.type);
        check_fits(e.count, std::max<size_t>(record, 1), e, "records");
    }

    void check_fits(size_t count, size_t each, const Element& e, const char* what) const {
        // +1: the last value of an ascii file needs no separator after it.
        const size_t left = data_.size() - std::min(pos_, data_.size());
        if (count > (left + 1) / each)
            fail(format_ == Format::Ascii ? line_ : 0,
                 std::string(format_ == Format::Ascii ? "unexpected end of file" : "unexpected end of binary data") +
                     ": element '" + e.name + "' (declared at line " + std::to_string(e.line) + ") holds " +
                     std::to_string(count) + " " + what + ", more than the " + std::to_string(left) +
                     " bytes left in the file can hold (a truncated file or a corrupt count)");
    }

    // ---- values ----
    double value(Type t, const Element& e) {
        if (format_ == Format::Ascii) return ascii_value(t, e);
        size_t n = type_size(t);
        if (pos_ + n > data_.size())
            fail(0, "unexpected end of binary data in element '" + e.name + "' (declared at line " +
                        std::to_string(e.line) + ")");
        unsigned char b[8];
        std::memcpy(b, data_.data() + pos_, n);
        pos_ += n;
        bool file_le = format_ == Format::BinaryLE;
        if (file_le != (std::endian::native == std::endian::little))
            for (size_t i = 0; i < n / 2; ++i) std::swap(b[i], b[n - 1 - i]);
        switch (t) {
            case Type::I8: {
                int8_t v;
                std::memcpy(&v, b, 1);
                return v;
            }
            case Type::U8:
                return b[0];
            case Type::I16: {
                int16_t v;
                std::memcpy(&v, b, 2);
                return v;
            }
            case Type::U16: {
                uint16_t v;
                std::memcpy(&v, b, 2);
                return v;
            }
            case Type::I32: {
                int32_t v;
                std::memcpy(&v, b, 4);
                return v;
            }
            case Type::U32: {
                uint32_t v;
                std::memcpy(&v, b, 4);
                return v;
            }
            case Type::F32: {
                float v;
                std::memcpy(&v, b, 4);
                return v;
            }
            case Type::F64: {
                double v;
                std::memcpy(&v, b, 8);
                return v;
            }
        }
        return 0.0;
    }

    double ascii_value(Type t, const Element& e) {
        while (pos_ < data_.size() && std::isspace(static_cast<unsigned char>(data_[pos_]))) {
            if (data_[pos_] == '\n') ++line_;
            ++pos_;
        }
        if (pos_ >= data_.size())
            fail(line_, "unexpected end of file in element '" + e.name + "' (declared at line " +
                            std::to_string(e.line) + ")");
        size_t start = pos_;
        while (pos_ < data_.size() && !std::isspace(static_cast<unsigned char>(data_[pos_]))) ++pos_;
        std::string_view tok(data_.data() + start, pos_ - start);
        std::string why;
        auto v = text::to_finite_float(tok, why);
        if (!v) fail(line_, why);
        if (is_integer(t) && *v != std::floor(*v)) fail(line_, "expected an integer, got '" + std::string(tok) + "'");
        return *v;
    }

    size_t list_count(const Property& p, const Element& e) {
        double n = value(p.count_type, e);
        if (n < 0) fail(format_ == Format::Ascii ? line_ : 0, "negative list length in element '" + e.name + "'");
        check_fits(static_cast<size_t>(n), min_value_bytes(p.type), e, "list values");
        return static_cast<size_t>(n);
    }

    void skip_element(const Element& e) {
        for (size_t i = 0; i < e.count; ++i)
            for (const auto& p : e.props) {
                size_t n = p.is_list ? list_count(p, e) : 1;
                for (size_t k = 0; k < n; ++k) value(p.type, e);
            }
    }

    static int find(const Element& e, std::initializer_list<const char*> names) {
        for (const char* n : names)
            for (size_t i = 0; i < e.props.size(); ++i)
                if (!e.props[i].is_list && e.props[i].name == n) return static_cast<int>(i);
        return -1;
    }

    void read_vertices(const Element& e) {
        int x = find(e, {"x"}), y = find(e, {"y"}), z = find(e, {"z"});
        if (x < 0 || y < 0 || z < 0) fail(e.line, "element 'vertex' lacks x, y or z");
        int nx = find(e, {"nx"}), ny = find(e, {"ny"}), nz = find(e, {"nz"});
        int u = find(e, {"u", "s", "texture_u", "texture_s"}), v = find(e, {"v", "t", "texture_v", "texture_t"});
        has_normals_ = nx >= 0 && ny >= 0 && nz >= 0;
        has_uvs_ = u >= 0 && v >= 0;
        size_t cap = std::min(e.count, data_.size());  // a lying count must not exhaust memory
        positions_.reserve(cap);
        std::vector<double> vals(e.props.size());
        for (size_t i = 0; i < e.count; ++i) {
            for (size_t k = 0; k < e.props.size(); ++k) {
                const auto& p = e.props[k];
                if (p.is_list) {
                    size_t n = list_count(p, e);
                    for (size_t j = 0; j < n; ++j) value(p.type, e);
                } else {
                    vals[k] = value(p.type, e);
                }
            }
            glm::vec3 pos(vals[x], vals[y], vals[z]);
            if (!std::isfinite(pos.x) || !std::isfinite(pos.y) || !std::isfinite(pos.z))
                fail(format_ == Format::Ascii ? line_ : 0, "non-finite position of vertex " + std::to_string(i));
            positions_.push_back(pos);
            if (has_normals_) normals_.push_back(glm::vec3(vals[nx], vals[ny], vals[nz]));
            if (has_uvs_) uvs_.push_back(glm::vec2(vals[u], vals[v]));
            if (has_uvs_ && !(std::isfinite(uvs_.back().x) && std::isfinite(uvs_.back().y)))
                fail(format_ == Format::Ascii ? line_ : 0,
                     "non-finite texture coordinate of vertex " + std::to_string(i));
        }
    }

    void read_faces(const Element& e) {
        int idx = -1;
        for (size_t i = 0; i < e.props.size(); ++i)
            if (e.props[i].is_list && (e.props[i].name == "vertex_indices" || e.props[i].name == "vertex_index"))
                idx = static_cast<int>(i);
        if (idx < 0) fail(e.line, "element 'face' has no 'vertex_indices' list");
        have_faces_ = true;
        std::vector<uint32_t> poly;
        for (size_t i = 0; i < e.count; ++i) {
            for (size_t k = 0; k < e.props.size(); ++k) {
                const auto& p = e.props[k];
                size_t n = p.is_list ? list_count(p, e) : 1;
                if (static_cast<int>(k) != idx) {
                    for (size_t j = 0; j < n; ++j) value(p.type, e);
                    continue;
                }
                int line = format_ == Format::Ascii ? line_ : 0;  // after the count: this face's line
                if (n < 3) fail(line, "face " + std::to_string(i) + " has fewer than 3 vertices");
                poly.clear();
                for (size_t j = 0; j < n; ++j) poly.push_back(vertex_index(value(p.type, e), i, line));
                if (indices_.size() + poly.size() - 2 > max_triangles_)
                    fail(line, triangle_limit_message(max_triangles_, "the mesh"));
                for (size_t j = 1; j + 1 < poly.size(); ++j) indices_.push_back({poly[0], poly[j], poly[j + 1]});
            }
        }
    }

    // An index read as a double (lists may be of floats): only a whole
    // number in range names a vertex; NaN would pass a range test.
    uint32_t vertex_index(double vi, size_t face, int line) const {
        if (!(std::isfinite(vi) && vi == std::floor(vi) && vi >= 0 && vi < static_cast<double>(positions_.size()))) {
            std::ostringstream s;
            s << "face " << face << " refers to vertex " << vi << ", which is not a vertex index (the mesh has "
              << positions_.size() << " vertices)";
            fail(line, s.str());
        }
        return static_cast<uint32_t>(vi);
    }

    Mesh build() {
        if (!have_faces_) fail(0, "the PLY file has no 'face' element (point clouds are not shapes)");
        Mesh m;
        m.kind = ShapeKind::Mesh;
        m.positions = std::move(positions_);
        if (has_normals_) m.normals = std::move(normals_);
        if (has_uvs_) m.uvs = std::move(uvs_);
        m.indices = std::move(indices_);
        remove_degenerate_triangles(m);
        repair_normals(m);
        return m;
    }

    std::string path_;
    size_t max_triangles_;
    std::string data_;
    size_t pos_ = 0;
    int line_ = 0;
    Format format_ = Format::Ascii;
    std::vector<Element> elements_;
    std::vector<glm::vec3> positions_, normals_;
    std::vector<glm::vec2> uvs_;
    std::vector<glm::uvec3> indices_;
    bool has_normals_ = false, has_uvs_ = false, have_faces_ = false;
};

}  // namespace

Mesh load_ply(const std::string& path, size_t max_triangles) { return PlyReader(path, max_triangles).read(); }

}  // namespace vkmech
