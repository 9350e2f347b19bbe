#include "scene/primitives.hpp"

#include "io/invariant.hpp"
#include "scene/mesh_ops.hpp"

#include <cmath>
#include <numbers>

namespace vkmech {

namespace {

constexpr float kPi = std::numbers::pi_v<float>;

// Shared tail of every maker: world space, facing, optional flip, and the
// guarantee that no degenerate triangle leaves this file.
Mesh finish(Mesh m, const glm::mat4& to_world, bool flip_normals) {
    transform_mesh(m, to_world, /*keep_facing=*/true);
    if (flip_normals) flip_orientation(m);
    m.flip_normals = flip_normals;
    m.center = glm::vec3(to_world * glm::vec4(m.center, 1.0f));
    remove_degenerate_triangles(m);
    return m;
}

// An orthonormal basis around n (Duff et al. 2017, branchless).
void onb(const glm::vec3& n, glm::vec3& b1, glm::vec3& b2) {
    float sign = std::copysign(1.0f, n.z);
    float a = -1.0f / (sign + n.z);
    float b = n.x * n.y * a;
    b1 = glm::vec3(1.0f + sign * n.x * n.x * a, sign * b, -sign * n.x);
    b2 = glm::vec3(b, sign + n.y * n.y * a, -n.y);
}

}  // namespace

Mesh make_rectangle(const glm::mat4& to_world, bool flip_normals) {
    Mesh m;
    m.kind = ShapeKind::Rectangle;
    m.positions = {{-1, -1, 0}, {1, -1, 0}, {1, 1, 0}, {-1, 1, 0}};
    m.uvs = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    m.indices = {{0, 1, 2}, {0, 2, 3}};
    return finish(std::move(m), to_world, flip_normals);
}

Mesh make_cube(const glm::mat4& to_world, bool flip_normals) {
    Mesh m;
    m.kind = ShapeKind::Cube;
    // Each face: outward normal n and two in-plane axes u, v with
    // cross(u, v) = n, so (c-u-v, c+u-v, c+u+v, c-u+v) winds CCW about n.
    const glm::vec3 normals[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    for (const glm::vec3& n : normals) {
        glm::vec3 u = std::abs(n.z) > 0.5f ? glm::vec3(std::copysign(1.0f, n.z), 0, 0) : glm::vec3(0, 0, 1);
        if (std::abs(n.y) > 0.5f) u = glm::vec3(0, 0, n.y);
        if (std::abs(n.x) > 0.5f) u = glm::vec3(0, n.x, 0);
        glm::vec3 v = glm::cross(n, u);
        uint32_t base = static_cast<uint32_t>(m.positions.size());
        m.positions.push_back(n - u - v);
        m.positions.push_back(n + u - v);
        m.positions.push_back(n + u + v);
        m.positions.push_back(n - u + v);
        m.uvs.insert(m.uvs.end(), {{0, 0}, {1, 0}, {1, 1}, {0, 1}});
        m.indices.push_back({base, base + 1, base + 2});
        m.indices.push_back({base, base + 2, base + 3});
    }
    return finish(std::move(m), to_world, flip_normals);
}

Mesh make_sphere(const glm::vec3& center, float radius, const glm::mat4& to_world, bool flip_normals,
                 SphereTessellation tess) {
    VKM_ASSERT(radius > 0.0f, "make_sphere: radius must be positive (the loaders refuse others)");
    const int nb = tess.bands < 2 ? 2 : tess.bands;
    const int ns = tess.segments < 3 ? 3 : tess.segments;
    Mesh m;
    m.kind = ShapeKind::Sphere;
    // Rings j = 0..nb (theta from the +z pole), each with ns + 1 vertices so
    // the uv seam is not shared. The pole rings hold ns copies of the pole
    // (one per segment, for uv), used only by non-degenerate triangles.
    for (int j = 0; j <= nb; ++j) {
        float theta = kPi * static_cast<float>(j) / static_cast<float>(nb);
        for (int i = 0; i <= ns; ++i) {
            float u = static_cast<float>(i) / static_cast<float>(ns);
            if (j == 0 || j == nb) u = (static_cast<float>(i) + 0.5f) / static_cast<float>(ns);
            float phi = 2.0f * kPi * u;
            glm::vec3 d(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta));
            if (j == 0) d = glm::vec3(0, 0, 1);  // exact poles: cos(pi) is not exactly -1 in float
            if (j == nb) d = glm::vec3(0, 0, -1);
            m.positions.push_back(center + radius * d);
            m.normals.push_back(d);
            m.uvs.push_back({u, static_cast<float>(j) / static_cast<float>(nb)});
        }
    }
    auto vid = [&](int j, int i) { return static_cast<uint32_t>(j * (ns + 1) + i); };
    // With a = (j,i), b = (j+1,i), c = (j+1,i+1), d = (j,i+1), the edges
    // a->b (increasing theta) and a->d (increasing phi) give an outward
    // cross product. At the poles one of the two triangles collapses and is
    // not emitted.
    for (int j = 0; j < nb; ++j)
        for (int i = 0; i < ns; ++i) {
            uint32_t a = vid(j, i), b = vid(j + 1, i), c = vid(j + 1, i + 1), d = vid(j, i + 1);
            if (j != nb - 1) m.indices.push_back({a, b, c});
            if (j != 0) m.indices.push_back({a, c, d});
        }
    m.center = center;
    Mesh out = finish(std::move(m), to_world, flip_normals);
    if (is_similarity(to_world)) {
        // World radius: the uniform scale of a similarity (cube root of |det|).
        out.radius = radius * std::cbrt(std::abs(glm::determinant(glm::mat3(to_world))));
    } else {
        // A non-uniform scale makes an ellipsoid (the inverse-transpose
        // normals are still exact). It is no longer an analytic sphere, so
        // it must not be sampled or measured as one.
        out.kind = ShapeKind::Mesh;
        out.radius = 0.0f;
    }
    return out;
}

Mesh make_disk(const glm::mat4& to_world, bool flip_normals, int segments) {
    const int ns = segments < 3 ? 3 : segments;
    Mesh m;
    m.kind = ShapeKind::Disk;
    // ns centre copies (polar uv has no single value at r = 0), then ns + 1
    // rim vertices (seam duplicated).
    for (int i = 0; i < ns; ++i) {
        m.positions.push_back({0, 0, 0});
        m.uvs.push_back({0.0f, (static_cast<float>(i) + 0.5f) / static_cast<float>(ns)});
    }
    for (int i = 0; i <= ns; ++i) {
        float v = static_cast<float>(i) / static_cast<float>(ns);
        float phi = 2.0f * kPi * v;
        m.positions.push_back({std::cos(phi), std::sin(phi), 0.0f});
        m.uvs.push_back({1.0f, v});
    }
    // phi increasing is counter-clockwise seen from +z.
    for (int i = 0; i < ns; ++i) {
        uint32_t c = static_cast<uint32_t>(i);
        uint32_t r0 = static_cast<uint32_t>(ns + i), r1 = r0 + 1;
        m.indices.push_back({c, r0, r1});
    }
    return finish(std::move(m), to_world, flip_normals);
}

Mesh make_cylinder(const glm::vec3& p0, const glm::vec3& p1, float radius, const glm::mat4& to_world, bool flip_normals,
                   int segments) {
    const int ns = segments < 3 ? 3 : segments;
    Mesh m;
    m.kind = ShapeKind::Cylinder;
    // Unit tube (radius 1, z in [0,1]) placed by Mitsuba's frame:
    // to_world * translate(p0) * frame(p1 - p0) * scale(r, r, |p1 - p0|).
    glm::vec3 axis = p1 - p0;
    float length = glm::length(axis);
    VKM_ASSERT(radius > 0.0f && length > 0.0f,
               "make_cylinder: radius and length must be positive (the loaders refuse others)");
    glm::vec3 w = axis / length, u, v;
    onb(w, u, v);
    glm::mat4 local(1.0f);
    local[0] = glm::vec4(u * radius, 0.0f);
    local[1] = glm::vec4(v * radius, 0.0f);
    local[2] = glm::vec4(w * length, 0.0f);
    local[3] = glm::vec4(p0, 1.0f);
    for (int k = 0; k <= 1; ++k)
        for (int i = 0; i <= ns; ++i) {
            float s = static_cast<float>(i) / static_cast<float>(ns);
            float phi = 2.0f * kPi * s;
            glm::vec3 d(std::cos(phi), std::sin(phi), 0.0f);
            m.positions.push_back(d + glm::vec3(0, 0, static_cast<float>(k)));
            m.normals.push_back(d);
            m.uvs.push_back({s, static_cast<float>(k)});
        }
    // a = (bottom, i), b = (bottom, i+1), c = (top, i+1), d = (top, i):
    // cross(b - a, c - a) points outward.
    for (int i = 0; i < ns; ++i) {
        uint32_t a = static_cast<uint32_t>(i), b = a + 1;
        uint32_t c = static_cast<uint32_t>(ns + 1 + i + 1), d = c - 1;
        m.indices.push_back({a, b, c});
        m.indices.push_back({a, c, d});
    }
    m.center = glm::vec3(0.0f, 0.0f, 0.5f);  // object centre: the axis midpoint
    return finish(std::move(m), to_world * local, flip_normals);
}

}  // namespace vkmech
