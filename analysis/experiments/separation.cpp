// Separation measures between the delta-S and glossy object families (paper
// §5 Finding 1, docs/descriptor.md §5). The rules are documented in separation.hpp.
#include "experiments/separation.hpp"

#include "accel/bvh.hpp"
#include "rng.glsl"

#include <algorithm>
#include <bit>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

namespace vkmech {

namespace {

// Uniform in [0, 1) from (seed, mesh, point, dimension): rng_init / rng_next
// of shaders/rng.glsl (pixel -> mesh, sample -> point).
double hash_uniform(uint32_t seed, uint32_t mesh, uint32_t point, uint32_t dim) {
    shader::Rng r = shader::rng_init(seed, mesh, point);
    r.dim = dim;
    return shader::rng_next(r);
}

double triangle_area(const Mesh& m, const glm::uvec3& t) {
    glm::dvec3 a(m.positions[t.x]), b(m.positions[t.y]), c(m.positions[t.z]);
    return 0.5 * glm::length(glm::cross(b - a, c - a));
}

double mesh_area(const Mesh& m) {
    double s = 0.0;
    for (const auto& t : m.indices) s += triangle_area(m, t);
    return s;
}

// Closest point on triangle abc to p (Ericson, Real-Time Collision Detection
// 5.1.5), returned as the squared distance.
double point_triangle_dist2(const glm::dvec3& p, const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c) {
    glm::dvec3 ab = b - a, ac = c - a, ap = p - a;
    double d1 = glm::dot(ab, ap), d2 = glm::dot(ac, ap);
    auto d2to = [&](const glm::dvec3& q) {
        glm::dvec3 v = p - q;
        return glm::dot(v, v);
    };
    if (d1 <= 0.0 && d2 <= 0.0) return d2to(a);
    glm::dvec3 bp = p - b;
    double d3 = glm::dot(ab, bp), d4 = glm::dot(ac, bp);
    if (d3 >= 0.0 && d4 <= d3) return d2to(b);
    double vc = d1 * d4 - d3 * d2;
    if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) return d2to(a + ab * (d1 / (d1 - d3)));
    glm::dvec3 cp = p - c;
    double d5 = glm::dot(ab, cp), d6 = glm::dot(ac, cp);
    if (d6 >= 0.0 && d5 <= d6) return d2to(c);
    double vb = d5 * d2 - d1 * d6;
    if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) return d2to(a + ac * (d2 / (d2 - d6)));
    double va = d3 * d6 - d5 * d4;
    if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0)
        return d2to(b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6))));
    double denom = va + vb + vc;
    if (!(std::abs(denom) > 0.0)) {
        // Degenerate (zero-area) triangle: the nearest of its three edges.
        auto seg = [&](const glm::dvec3& s0, const glm::dvec3& s1) {
            glm::dvec3 d = s1 - s0;
            double l2 = glm::dot(d, d);
            double t = l2 > 0.0 ? std::clamp(glm::dot(p - s0, d) / l2, 0.0, 1.0) : 0.0;
            return d2to(s0 + d * t);
        };
        return std::min({seg(a, b), seg(b, c), seg(c, a)});
    }
    double v = vb / denom, w = vc / denom;
    return d2to(a + ab * v + ac * w);
}

double point_box_dist2(const glm::dvec3& p, const glm::dvec3& lo, const glm::dvec3& hi) {
    glm::dvec3 d = glm::max(glm::max(lo - p, p - hi), glm::dvec3(0.0));
    return glm::dot(d, d);
}

double box_box_dist2(const glm::dvec3& alo, const glm::dvec3& ahi, const glm::dvec3& blo, const glm::dvec3& bhi) {
    glm::dvec3 d = glm::max(glm::max(blo - ahi, alo - bhi), glm::dvec3(0.0));
    return glm::dot(d, d);
}

// One object's geometry for the distance search: its used vertices, its
// triangles in BVH order and the BVH over them.
struct DistanceObject {
    std::vector<glm::dvec3> vertices;
    std::vector<glm::dvec3> tri;  // 3 per triangle, BVH order
    Bvh bvh;
    glm::dvec3 lo{0.0}, hi{0.0};

    explicit DistanceObject(const Mesh& m) {
        std::vector<char> used(m.positions.size(), 0);
        std::vector<glm::vec3> pos3;
        pos3.reserve(3 * m.indices.size());
        for (const auto& t : m.indices)
            for (int k = 0; k < 3; ++k) {
                used[t[k]] = 1;
                pos3.push_back(m.positions[t[k]]);
            }
        lo = glm::dvec3(std::numeric_limits<double>::max());
        hi = -lo;
        for (size_t v = 0; v < m.positions.size(); ++v)
            if (used[v]) {
                glm::dvec3 p(m.positions[v]);
                vertices.push_back(p);
                lo = glm::min(lo, p);
                hi = glm::max(hi, p);
            }
        if (pos3.empty()) return;
        bvh = build_bvh(pos3);
        tri.resize(pos3.size());
        for (size_t i = 0; i < bvh.order.size(); ++i)
            for (int k = 0; k < 3; ++k) tri[3 * i + k] = glm::dvec3(pos3[3 * bvh.order[i] + k]);
    }

    bool empty() const { return tri.empty(); }

    // Squared distance from p to the nearest triangle, if below best2;
    // otherwise best2 unchanged. Nearer child first.
    double nearest2(const glm::dvec3& p, double best2) const {
        if (bvh.nodes.empty()) return best2;
        auto box = [&](uint32_t n) {
            const auto& node = bvh.nodes[n];
            return point_box_dist2(p, glm::dvec3(node.bmin), glm::dvec3(node.bmax));
        };
        std::vector<uint32_t> stack;
        stack.reserve(64);
        if (box(0) < best2) stack.push_back(0);
        while (!stack.empty()) {
            uint32_t n = stack.back();
            stack.pop_back();
            const auto& node = bvh.nodes[n];
            if (box(n) >= best2) continue;  // best2 may have shrunk since the push
            uint32_t offset = std::bit_cast<uint32_t>(node.bmin.w), count = std::bit_cast<uint32_t>(node.bmax.w);
            if (count > 0) {
                for (uint32_t i = offset; i < offset + count; ++i)
                    best2 = std::min(best2, point_triangle_dist2(p, tri[3 * i], tri[3 * i + 1], tri[3 * i + 2]));
                continue;
            }
            uint32_t c0 = n + 1, c1 = offset;
            double d0 = box(c0), d1 = box(c1);
            if (d0 > d1) {
                std::swap(c0, c1);
                std::swap(d0, d1);
            }
            // Push the farther child first so the nearer one is visited next.
            if (d1 < best2) stack.push_back(c1);
            if (d0 < best2) stack.push_back(c0);
        }
        return best2;
    }
};

// min over a's vertices of the distance to b's triangles and vice versa,
// squared; returns best2 unchanged when nothing is nearer.
double object_distance2(const DistanceObject& a, const DistanceObject& b, double best2) {
    if (a.empty() || b.empty()) return best2;
    if (box_box_dist2(a.lo, a.hi, b.lo, b.hi) >= best2) return best2;
    for (int dir = 0; dir < 2; ++dir) {
        const DistanceObject& from = dir == 0 ? a : b;
        const DistanceObject& to = dir == 0 ? b : a;
        for (const auto& p : from.vertices) {
            if (point_box_dist2(p, to.lo, to.hi) >= best2) continue;
            best2 = to.nearest2(p, best2);
        }
    }
    return best2;
}

}  // namespace

SeparationFamily separation_family(const Scene& scene, size_t mesh_index) {
    const Mesh& m = scene.meshes.at(mesh_index);
    if (m.emitter >= 0 || m.material < 0 || static_cast<size_t>(m.material) >= scene.materials.size())
        return SeparationFamily::None;
    if (!(mesh_area(m) > 0.0)) return SeparationFamily::None;
    const Material& mat = scene.materials[m.material];
    if (mat.is_delta_only()) return SeparationFamily::Delta;
    if (mat.type == BsdfType::RoughConductor || mat.type == BsdfType::RoughDielectric) return SeparationFamily::Glossy;
    return SeparationFamily::None;
}

std::vector<glm::vec3> sample_surface_points(const Mesh& mesh, uint32_t mesh_index, uint32_t count, uint32_t seed) {
    std::vector<double> cdf;
    cdf.reserve(mesh.indices.size());
    double total = 0.0;
    for (const auto& t : mesh.indices) {
        total += triangle_area(mesh, t);
        cdf.push_back(total);
    }
    std::vector<glm::vec3> out;
    if (!(total > 0.0)) return out;
    out.reserve(count);
    for (uint32_t i = 0; i < count; ++i) {
        double u0 = hash_uniform(seed, mesh_index, i, 0) * total;
        double u1 = hash_uniform(seed, mesh_index, i, 1);
        double u2 = hash_uniform(seed, mesh_index, i, 2);
        size_t k = static_cast<size_t>(std::upper_bound(cdf.begin(), cdf.end(), u0) - cdf.begin());
        k = std::min(k, cdf.size() - 1);
        while (k > 0 && cdf[k] == cdf[k - 1]) --k;  // never a zero-area triangle
        const glm::uvec3& t = mesh.indices[k];
        glm::dvec3 a(mesh.positions[t.x]), b(mesh.positions[t.y]), c(mesh.positions[t.z]);
        double su = std::sqrt(u1);
        double b0 = 1.0 - su, b1 = u2 * su;
        out.push_back(glm::vec3(a * b0 + b * b1 + c * (1.0 - b0 - b1)));
    }
    return out;
}

double mesh_distance(const Mesh& a, const Mesh& b) {
    DistanceObject oa(a), ob(b);
    double inf = std::numeric_limits<double>::infinity();
    return std::sqrt(object_distance2(oa, ob, inf));
}

SeparationMeasures measure_separation(const Scene& scene, const SegmentVisibility& unoccluded,
                                      uint32_t points_per_object, uint32_t seed, float offset) {
    SeparationMeasures r;
    std::vector<uint32_t> delta, glossy;
    for (size_t i = 0; i < scene.meshes.size(); ++i) {
        SeparationFamily f = separation_family(scene, i);
        if (f == SeparationFamily::Delta) delta.push_back(static_cast<uint32_t>(i));
        else if (f == SeparationFamily::Glossy) glossy.push_back(static_cast<uint32_t>(i));
    }
    r.delta_objects = static_cast<int>(delta.size());
    r.glossy_objects = static_cast<int>(glossy.size());
    if (!r.defined()) return r;

    // ---- minimum surface distance: pairs nearest by bounding box first ----
    std::vector<DistanceObject> dobj_delta, dobj_glossy;
    for (uint32_t i : delta) dobj_delta.emplace_back(scene.meshes[i]);
    for (uint32_t j : glossy) dobj_glossy.emplace_back(scene.meshes[j]);
    std::vector<std::pair<double, std::pair<size_t, size_t>>> pairs;
    for (size_t i = 0; i < delta.size(); ++i)
        for (size_t j = 0; j < glossy.size(); ++j)
            pairs.push_back({box_box_dist2(dobj_delta[i].lo, dobj_delta[i].hi, dobj_glossy[j].lo, dobj_glossy[j].hi), {i, j}});
    std::sort(pairs.begin(), pairs.end());
    double best2 = std::numeric_limits<double>::infinity();
    for (const auto& [box2, ij] : pairs) {
        if (box2 >= best2) break;  // sorted: every later pair is at least as far
        best2 = object_distance2(dobj_delta[ij.first], dobj_glossy[ij.second], best2);
    }
    r.min_distance = std::sqrt(best2);

    // ---- mutual visibility: any-hit rays between sampled surface points ----
    std::vector<std::vector<glm::vec3>> pts_delta, pts_glossy;
    for (uint32_t i : delta) pts_delta.push_back(sample_surface_points(scene.meshes[i], i, points_per_object, seed));
    for (uint32_t j : glossy) pts_glossy.push_back(sample_surface_points(scene.meshes[j], j, points_per_object, seed));

    const size_t chunk = size_t(1) << 20;
    std::vector<gpu::GpuRay> rays;
    rays.reserve(chunk);
    auto flush = [&]() {
        if (rays.empty()) return;
        std::vector<uint8_t> open = unoccluded(rays);
        if (open.size() != rays.size())
            throw std::logic_error("measure_separation: the visibility function answered " + std::to_string(open.size()) +
                                   " of " + std::to_string(rays.size()) + " segments");
        for (uint8_t v : open) r.visible += v ? 1u : 0u;
        r.segments += rays.size();
        rays.clear();
    };
    const double off = offset;
    for (const auto& pa : pts_delta)
        for (const auto& pb : pts_glossy)
            for (const auto& a3 : pa)
                for (const auto& b3 : pb) {
                    glm::dvec3 a(a3), b(b3);
                    double len = glm::length(b - a);
                    if (!(len > 2.0 * off)) {  // touching: nothing can lie between
                        r.segments++;
                        r.visible++;
                        continue;
                    }
                    glm::dvec3 d = (b - a) / len;
                    glm::dvec3 o = a + d * off;
                    rays.push_back(gpu::GpuRay{glm::vec4(glm::vec3(o), 0.0f),
                                               glm::vec4(glm::vec3(d), static_cast<float>(len - 2.0 * off))});
                    if (rays.size() == chunk) flush();
                }
    flush();
    if (r.segments > 0) r.mutual_visibility = static_cast<double>(r.visible) / static_cast<double>(r.segments);
    return r;
}

}  // namespace vkmech
