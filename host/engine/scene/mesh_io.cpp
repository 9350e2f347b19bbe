// OBJ reader and the mesh-file dispatch; the PLY reader is in ply_io.cpp.
#include "scene/mesh_io.hpp"

#include "scene/file_read.hpp"
#include "scene/mesh_ops.hpp"
#include "scene/text_parse.hpp"
#include "scene/triangle_budget.hpp"

#include <cmath>
#include <filesystem>
#include <unordered_map>

namespace vkmech {

namespace {

struct Corner {
    long long v = -1, vt = -1, vn = -1;
    bool operator==(const Corner&) const = default;
};

struct CornerHash {
    size_t operator()(const Corner& c) const {
        size_t h = std::hash<long long>()(c.v);
        h = h * 1000003u ^ std::hash<long long>()(c.vt);
        h = h * 1000003u ^ std::hash<long long>()(c.vn);
        return h;
    }
};

class ObjReader {
public:
    ObjReader(std::string path, size_t max_triangles) : path_(std::move(path)), max_triangles_(max_triangles) {}

    Mesh read() {
        std::string data = read_whole_file(path_);
        std::string_view rest(data);
        while (!rest.empty()) {
            size_t nl = rest.find('\n');
            std::string_view line = rest.substr(0, nl);
            rest = nl == std::string_view::npos ? std::string_view() : rest.substr(nl + 1);
            ++line_;
            if (size_t hash = line.find('#'); hash != std::string_view::npos) line = line.substr(0, hash);
            parse_line(line);
        }
        return build();
    }

private:
    [[noreturn]] void fail(const std::string& what) const { throw SceneError(path_, line_, what); }

    float number(std::string_view tok) const {
        std::string why;
        auto v = text::to_finite_float(tok, why);
        if (!v) fail(why);
        return static_cast<float>(*v);
    }

    void parse_line(std::string_view line) {
        auto tok = text::split_ws(line);
        if (tok.empty()) return;
        const std::string_view key = tok[0];
        if (key == "v") {
            if (tok.size() < 4) fail("'v' needs 3 coordinates");
            pos_.push_back({number(tok[1]), number(tok[2]), number(tok[3])});
        } else if (key == "vt") {
            if (tok.size() < 2) fail("'vt' needs at least 1 coordinate");
            uv_.push_back({number(tok[1]), tok.size() > 2 ? number(tok[2]) : 0.0f});
        } else if (key == "vn") {
            if (tok.size() < 4) fail("'vn' needs 3 coordinates");
            nrm_.push_back({number(tok[1]), number(tok[2]), number(tok[3])});
        } else if (key == "f") {
            if (tok.size() < 4) fail("a face needs at least 3 vertices");
            std::vector<uint32_t> poly;
            for (size_t i = 1; i < tok.size(); ++i) poly.push_back(vertex(tok[i]));
            if (tris_.size() + poly.size() - 2 > max_triangles_)
                fail(triangle_limit_message(max_triangles_, "the mesh"));
            for (size_t i = 1; i + 1 < poly.size(); ++i) tris_.push_back({poly[0], poly[i], poly[i + 1]});
        }
        // Everything else (o, g, s, usemtl, mtllib, l, p, ...) is irrelevant
        // to the geometry and ignored on purpose.
    }

    // Resolves one OBJ index (1-based, or negative = relative to the end).
    long long resolve(std::string_view s, size_t count, const char* what) const {
        auto i = text::to_int(s);
        if (!i) fail(std::string("cannot parse ") + what + " index '" + std::string(s) + "'");
        long long n = static_cast<long long>(count);
        long long r = *i > 0 ? *i - 1 : n + *i;
        if (*i == 0 || r < 0 || r >= n)
            fail(std::string(what) + " index " + std::to_string(*i) + " out of range (" + std::to_string(n) +
                 " defined so far)");
        return r;
    }

    uint32_t vertex(std::string_view tok) {
        Corner c;
        size_t s1 = tok.find('/');
        c.v = resolve(tok.substr(0, s1), pos_.size(), "vertex");
        if (s1 != std::string_view::npos) {
            std::string_view rest = tok.substr(s1 + 1);
            size_t s2 = rest.find('/');
            std::string_view t = rest.substr(0, s2);
            if (!t.empty()) c.vt = resolve(t, uv_.size(), "texture coordinate");
            if (s2 != std::string_view::npos) {
                std::string_view n = rest.substr(s2 + 1);
                if (!n.empty()) c.vn = resolve(n, nrm_.size(), "normal");
            }
        }
        auto [it, inserted] = index_.try_emplace(c, static_cast<uint32_t>(corners_.size()));
        if (inserted) corners_.push_back(c);
        return it->second;
    }

    Mesh build() {
        Mesh m;
        m.kind = ShapeKind::Mesh;
        bool all_n = !corners_.empty(), any_uv = false;
        for (const auto& c : corners_) {
            all_n = all_n && c.vn >= 0;
            any_uv = any_uv || c.vt >= 0;
        }
        for (const auto& c : corners_) {
            m.positions.push_back(pos_[c.v]);
            // A normal only where every corner has one; otherwise the caller
            // derives them (a partial field would be inconsistent).
            if (all_n) m.normals.push_back(nrm_[c.vn]);
            if (any_uv) m.uvs.push_back(c.vt >= 0 ? uv_[c.vt] : glm::vec2(0.0f));
        }
        m.indices = std::move(tris_);
        if (m.indices.empty()) throw SceneError(path_, 0, "the mesh has no faces");
        remove_degenerate_triangles(m);
        repair_normals(m);
        return m;
    }

    std::string path_;
    size_t max_triangles_;
    int line_ = 0;
    std::vector<glm::vec3> pos_, nrm_;
    std::vector<glm::vec2> uv_;
    std::vector<Corner> corners_;
    std::unordered_map<Corner, uint32_t, CornerHash> index_;
    std::vector<glm::uvec3> tris_;
};

}  // namespace

Mesh load_obj(const std::string& path, size_t max_triangles) { return ObjReader(path, max_triangles).read(); }

Mesh load_mesh_file(const std::string& path, size_t max_triangles) {
    std::string ext = text::lower(std::filesystem::path(path).extension().string());
    if (ext == ".obj") return load_obj(path, max_triangles);
    if (ext == ".ply") return load_ply(path, max_triangles);
    throw SceneError(path, 0, "unsupported mesh format '" + ext + "' (expected .obj or .ply)");
}

std::string read_whole_file(const std::string& path) { return read_regular_file(path, "mesh file"); }

}  // namespace vkmech
