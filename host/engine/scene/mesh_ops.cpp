#include "scene/mesh_ops.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

namespace vkmech {

glm::mat3 normal_matrix(const glm::mat4& to_world) { return glm::transpose(glm::inverse(glm::mat3(to_world))); }

bool is_similarity(const glm::mat4& m, float rel_tol) {
    glm::mat3 a(m);
    glm::mat3 ata = glm::transpose(a) * a;  // s^2 * I for a similarity
    float s2 = (ata[0][0] + ata[1][1] + ata[2][2]) / 3.0f;
    if (!(s2 > 0.0f) || !std::isfinite(s2)) return false;
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
            float expect = i == j ? s2 : 0.0f;
            if (std::abs(ata[i][j] - expect) > rel_tol * s2) return false;
        }
    return true;
}

glm::vec3 triangle_cross(const Mesh& m, const glm::uvec3& t) {
    const glm::vec3& p0 = m.positions[t.x];
    return glm::cross(m.positions[t.y] - p0, m.positions[t.z] - p0);
}

void transform_mesh(Mesh& m, const glm::mat4& to_world, bool keep_facing) {
    for (auto& p : m.positions) p = glm::vec3(to_world * glm::vec4(p, 1.0f));
    glm::mat3 nm = normal_matrix(to_world);
    for (auto& n : m.normals) {
        glm::vec3 t = nm * n;
        float len = glm::length(t);
        n = len > 0.0f ? t / len : t;
    }
    // Tangents lie in the surface: they move with the linear part M. The bitangent w (n x t)
    // must stay the image M b of the old one; since (M t) x (M b) = det(M) M^-T (t x b), with
    // t x b = w n, a mirroring map (det < 0) turns w's sign.
    const float det = glm::determinant(glm::mat3(to_world));
    for (auto& t : m.tangents) {
        glm::vec3 v = glm::mat3(to_world) * glm::vec3(t);
        float len = glm::length(v);
        t = glm::vec4(len > 0.0f ? v / len : v, det < 0.0f ? -t.w : t.w);
    }
    if (keep_facing && det < 0.0f)
        for (auto& t : m.indices) std::swap(t.y, t.z);
}

void flip_orientation(Mesh& m) {
    for (auto& t : m.indices) std::swap(t.y, t.z);
    for (auto& n : m.normals) n = -n;
    for (auto& t : m.tangents) t.w = -t.w;  // the bitangent w (n x t) stays where it was
}

namespace {

// Angle-weighted normal sums (Thürmer & Wüthrich): robust to uneven fans.
std::vector<glm::vec3> angle_weighted_normals(const Mesh& m) {
    std::vector<glm::vec3> acc(m.positions.size(), glm::vec3(0.0f));
    for (const auto& t : m.indices) {
        glm::vec3 c = triangle_cross(m, t);
        float len = glm::length(c);
        if (!(len > 0.0f)) continue;
        glm::vec3 n = c / len;
        for (int k = 0; k < 3; ++k) {
            glm::vec3 e1 = m.positions[t[(k + 1) % 3]] - m.positions[t[k]];
            glm::vec3 e2 = m.positions[t[(k + 2) % 3]] - m.positions[t[k]];
            float l1 = glm::length(e1), l2 = glm::length(e2);
            if (!(l1 > 0.0f) || !(l2 > 0.0f)) continue;
            float angle = std::acos(std::clamp(glm::dot(e1, e2) / (l1 * l2), -1.0f, 1.0f));
            acc[t[k]] += angle * n;
        }
    }
    for (auto& n : acc) {
        float len = glm::length(n);
        n = len > 0.0f ? n / len : glm::vec3(0.0f, 0.0f, 1.0f);  // unreferenced vertex
    }
    return acc;
}

bool usable(const glm::vec3& n) {
    float len = glm::length(n);
    return std::isfinite(len) && len > 1e-20f;
}

}  // namespace

void compute_vertex_normals(Mesh& m) { m.normals = angle_weighted_normals(m); }

void repair_normals(Mesh& m) {
    if (m.normals.empty()) return;
    bool all_ok = std::all_of(m.normals.begin(), m.normals.end(), usable);
    std::vector<glm::vec3> fallback;
    if (!all_ok) fallback = angle_weighted_normals(m);
    for (size_t i = 0; i < m.normals.size(); ++i)
        m.normals[i] = usable(m.normals[i]) ? glm::normalize(m.normals[i]) : fallback[i];
}

size_t remove_degenerate_triangles(Mesh& m) {
    size_t before = m.indices.size();
    std::erase_if(m.indices, [&](const glm::uvec3& t) {
        if (t.x == t.y || t.y == t.z || t.x == t.z) return true;
        // In double: a tiny but valid triangle must not underflow to zero.
        glm::dvec3 p0(m.positions[t.x]), p1(m.positions[t.y]), p2(m.positions[t.z]);
        double len = glm::length(glm::cross(p1 - p0, p2 - p0));
        return !(len > 0.0);  // zero area, or non-finite positions
    });
    return before - m.indices.size();
}

double surface_area(const Mesh& m) {
    double a = 0.0;
    for (const auto& t : m.indices) a += 0.5 * static_cast<double>(glm::length(triangle_cross(m, t)));
    return a;
}

}  // namespace vkmech

namespace vkmech {

namespace {

void check_attribute_count(const Mesh& m, size_t n, const char* what, const std::string& file) {
    if (n != 0 && n != m.positions.size())
        throw SceneError(file, 0,
                         "mesh '" + m.name + "' has " + std::to_string(n) + " " + what + " for " +
                             std::to_string(m.positions.size()) +
                             " positions (each vertex needs one, or none at all): a corrupt mesh file");
}

bool finite(const glm::vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }
bool finite(const glm::vec2& v) { return std::isfinite(v.x) && std::isfinite(v.y); }

}  // namespace

void check_mesh(const Mesh& m, const std::string& file) {
    check_attribute_count(m, m.normals.size(), "normals", file);
    check_attribute_count(m, m.uvs.size(), "uvs", file);
    check_attribute_count(m, m.tangents.size(), "tangents", file);
    auto fail = [&](const std::string& what) { throw SceneError(file, 0, "mesh '" + m.name + "': " + what); };
    for (size_t i = 0; i < m.positions.size(); ++i)
        if (!finite(m.positions[i])) fail("vertex " + std::to_string(i) + " has a non-finite position");
    for (size_t i = 0; i < m.uvs.size(); ++i)
        if (!finite(m.uvs[i])) fail("vertex " + std::to_string(i) + " has a non-finite texture coordinate");
    if (!m.tangents.empty() && m.normals.empty()) fail("it has tangents but no normals");
    for (size_t i = 0; i < m.tangents.size(); ++i)
        if (!finite(glm::vec3(m.tangents[i])) || std::abs(m.tangents[i].w) != 1.0f)
            fail("vertex " + std::to_string(i) + " has a non-finite tangent or a handedness other than +-1");
    for (size_t t = 0; t < m.indices.size(); ++t)
        for (int k = 0; k < 3; ++k)
            if (m.indices[t][k] >= m.positions.size())
                fail("triangle " + std::to_string(t) + " refers to vertex " + std::to_string(m.indices[t][k]) + " of " +
                     std::to_string(m.positions.size()));
}

}  // namespace vkmech
