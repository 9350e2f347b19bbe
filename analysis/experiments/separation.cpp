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

using glm::dvec3;

// Uniform in [0, 1) from (seed, mesh, point, dimension): rng_init / rng_next
// of shaders/rng.glsl (pixel -> mesh, sample -> point).
double hash_uniform(uint32_t seed, uint32_t mesh, uint32_t point, uint32_t dim) {
    shader::Rng r = shader::rng_init(seed, mesh, point);
    r.dim = dim;
    return shader::rng_next(r);
}

double triangle_area(const Mesh& m, const glm::uvec3& t) {
    dvec3 a(m.positions[t.x]), b(m.positions[t.y]), c(m.positions[t.z]);
    return 0.5 * glm::length(glm::cross(b - a, c - a));
}

double mesh_area(const Mesh& m) {
    double s = 0.0;
    for (const auto& t : m.indices) s += triangle_area(m, t);
    return s;
}

double length2(const dvec3& v) { return glm::dot(v, v); }

// ---- exact orientation ----
//
// orient3d(a, b, c, d) = (a - d) . ((b - d) x (c - d)): six times the signed
// volume of the tetrahedron abcd, zero iff the four points are coplanar. Its
// sign is decided exactly: the double evaluation when it clears a
// conservative rounding bound, otherwise an exact evaluation with
// floating-point expansions (a value held as a sum of doubles, each
// operation error-free: two_sum, and two_prod through fma).

void two_sum(double a, double b, double& x, double& y) {
    x = a + b;
    double bv = x - a, av = x - bv;
    y = (a - av) + (b - bv);
}

void two_prod(double a, double b, double& x, double& y) {
    x = a * b;
    y = std::fma(a, b, -x);
}

// A nonoverlapping expansion: components in increasing magnitude, no zero
// component, so the sign of the value is the sign of the last component.
// add() is exact: it threads the new double through every component with
// two_sum and keeps the non-zero remainders (growing an expansion by one
// double keeps it nonoverlapping and ordered).
struct Expansion {
    std::vector<double> c;

    void add(double b) {
        std::vector<double> out;
        out.reserve(c.size() + 1);
        double q = b;
        for (double e : c) {
            double x, y;
            two_sum(q, e, x, y);
            if (y != 0.0) out.push_back(y);
            q = x;
        }
        if (q != 0.0) out.push_back(q);
        c = std::move(out);
    }
    // += s * e, exactly (s: a sum of doubles, e.g. an exact difference).
    void add_product(const std::vector<double>& s, const Expansion& e) {
        for (double a : s)
            for (double b : e.c) {
                double x, y;
                two_prod(a, b, x, y);
                add(y);
                add(x);
            }
    }
    int sign() const { return c.empty() ? 0 : (c.back() > 0.0 ? 1 : -1); }
};

// a - b exactly, as two doubles.
std::vector<double> exact_diff(double a, double b) {
    double x, y;
    two_sum(a, -b, x, y);
    return {y, x};
}

// The 2 x 2 minor p_i q_j - p_j q_i of two exact differences, exactly.
Expansion exact_minor(const std::vector<double>& pi, const std::vector<double>& pj, const std::vector<double>& qi,
                      const std::vector<double>& qj) {
    Expansion m;
    for (double a : pi)
        for (double b : qj) {
            double x, y;
            two_prod(a, b, x, y);
            m.add(y);
            m.add(x);
        }
    for (double a : pj)
        for (double b : qi) {
            double x, y;
            two_prod(a, b, x, y);
            m.add(-y);
            m.add(-x);
        }
    return m;
}

int orient3d_exact(const dvec3& a, const dvec3& b, const dvec3& c, const dvec3& d) {
    std::vector<double> u[3], v[3], w[3];
    for (int i = 0; i < 3; ++i) {
        u[i] = exact_diff(a[i], d[i]);
        v[i] = exact_diff(b[i], d[i]);
        w[i] = exact_diff(c[i], d[i]);
    }
    // u . (v x w) = u_x (v_y w_z - v_z w_y) + u_y (v_z w_x - v_x w_z) + u_z (v_x w_y - v_y w_x)
    Expansion det;
    det.add_product(u[0], exact_minor(v[1], v[2], w[1], w[2]));
    det.add_product(u[1], exact_minor(v[2], v[0], w[2], w[0]));
    det.add_product(u[2], exact_minor(v[0], v[1], w[0], w[1]));
    return det.sign();
}

// Sign of orient3d(a, b, c, d): +1, -1 or 0, exact.
int orient3d(const dvec3& a, const dvec3& b, const dvec3& c, const dvec3& d) {
    dvec3 u = a - d, v = b - d, w = c - d;
    double m0 = v.y * w.z - v.z * w.y, m1 = v.z * w.x - v.x * w.z, m2 = v.x * w.y - v.y * w.x;
    double det = u.x * m0 + u.y * m1 + u.z * m2;
    double perm = std::abs(u.x) * (std::abs(v.y * w.z) + std::abs(v.z * w.y)) +
                  std::abs(u.y) * (std::abs(v.z * w.x) + std::abs(v.x * w.z)) +
                  std::abs(u.z) * (std::abs(v.x * w.y) + std::abs(v.y * w.x));
    // The double evaluation errs by less than about 8 ulp of the permanent
    // (rounded differences, products and sums); 1e-14 leaves a wide margin.
    double bound = 1e-14 * perm;
    if (det > bound) return 1;
    if (det < -bound) return -1;
    return orient3d_exact(a, b, c, d);
}

// ---- triangle-triangle intersection (closed triangles) ----

bool boxes_overlap(const Triangle3& a, const Triangle3& b) {
    for (int k = 0; k < 3; ++k) {
        double alo = std::min({a[0][k], a[1][k], a[2][k]}), ahi = std::max({a[0][k], a[1][k], a[2][k]});
        double blo = std::min({b[0][k], b[1][k], b[2][k]}), bhi = std::max({b[0][k], b[1][k], b[2][k]});
        if (ahi < blo || bhi < alo) return false;
    }
    return true;
}

// A point off the plane of t, or false when t is degenerate (its vertices
// are collinear or coincide). Candidates: t's vertex plus its computed normal,
// then plus each axis; a non-degenerate triangle cannot contain all four
// directions, and each candidate is checked with the exact orient3d.
bool off_plane_point(const Triangle3& t, dvec3& o) {
    dvec3 e1 = t[1] - t[0], e2 = t[2] - t[0];
    double scale =
        std::max({std::abs(e1.x), std::abs(e1.y), std::abs(e1.z), std::abs(e2.x), std::abs(e2.y), std::abs(e2.z), 1.0});
    dvec3 cand[4] = {t[0] + glm::cross(e1, e2), t[0] + dvec3(scale, 0, 0), t[0] + dvec3(0, scale, 0),
                     t[0] + dvec3(0, 0, scale)};
    for (const dvec3& c : cand)
        if (orient3d(t[0], t[1], t[2], c) != 0) {
            o = c;
            return true;
        }
    return false;
}

// r on the segment pq, given that p, q, r are collinear: inside pq's box.
bool on_collinear_segment(const dvec3& p, const dvec3& q, const dvec3& r) {
    for (int k = 0; k < 3; ++k)
        if (r[k] < std::min(p[k], q[k]) || r[k] > std::max(p[k], q[k])) return false;
    return true;
}

// Closed segments pq and uv, both in the plane of which o is off: do they meet?
// orient3d(x, y, z, o) is the in-plane orientation of xyz, up to one sign.
bool coplanar_segments_meet(const dvec3& p, const dvec3& q, const dvec3& u, const dvec3& v, const dvec3& o) {
    int o1 = orient3d(p, q, u, o), o2 = orient3d(p, q, v, o);
    int o3 = orient3d(u, v, p, o), o4 = orient3d(u, v, q, o);
    if (o1 * o2 < 0 && o3 * o4 < 0) return true;
    if (o1 == 0 && on_collinear_segment(p, q, u)) return true;
    if (o2 == 0 && on_collinear_segment(p, q, v)) return true;
    if (o3 == 0 && on_collinear_segment(u, v, p)) return true;
    if (o4 == 0 && on_collinear_segment(u, v, q)) return true;
    return false;
}

// Does the closed segment pq meet the closed triangle t? sp, sq: orient3d of
// p and q against t's plane (precomputed).
bool segment_meets_triangle(const dvec3& p, const dvec3& q, int sp, int sq, const Triangle3& t) {
    const dvec3 &a = t[0], &b = t[1], &c = t[2];
    if (sp * sq > 0) return false;  // both strictly on one side
    if (sp != 0 || sq != 0) {
        // pq meets t's plane in one point; it lies in the closed triangle iff
        // the line pq passes no edge on the outside: the three orientations
        // are not of mixed strict signs.
        int s1 = orient3d(p, q, a, b), s2 = orient3d(p, q, b, c), s3 = orient3d(p, q, c, a);
        bool pos = s1 > 0 || s2 > 0 || s3 > 0, neg = s1 < 0 || s2 < 0 || s3 < 0;
        return !(pos && neg);
    }
    // pq lies in t's plane (or t is degenerate).
    dvec3 o;
    if (!off_plane_point(t, o)) return false;  // degenerate t: its own edges are tested against the other triangle
    int abc = orient3d(a, b, c, o);
    auto inside = [&](const dvec3& x) {
        int s1 = orient3d(a, b, x, o) * abc, s2 = orient3d(b, c, x, o) * abc, s3 = orient3d(c, a, x, o) * abc;
        return s1 >= 0 && s2 >= 0 && s3 >= 0;
    };
    if (inside(p) || inside(q)) return true;
    return coplanar_segments_meet(p, q, a, b, o) || coplanar_segments_meet(p, q, b, c, o) ||
           coplanar_segments_meet(p, q, c, a, o);
}

// ---- distances ----

double point_segment_dist2(const dvec3& p, const dvec3& a, const dvec3& b) {
    dvec3 d = b - a;
    double l2 = glm::dot(d, d);
    double t = l2 > 0.0 ? std::clamp(glm::dot(p - a, d) / l2, 0.0, 1.0) : 0.0;
    return length2(p - (a + d * t));
}

// Closest point on triangle abc to p (Ericson, Real-Time Collision Detection
// 5.1.5), returned as the squared distance.
double point_triangle_dist2(const dvec3& p, const dvec3& a, const dvec3& b, const dvec3& c) {
    dvec3 ab = b - a, ac = c - a, ap = p - a;
    double d1 = glm::dot(ab, ap), d2 = glm::dot(ac, ap);
    auto d2to = [&](const dvec3& q) { return length2(p - q); };
    if (d1 <= 0.0 && d2 <= 0.0) return d2to(a);
    dvec3 bp = p - b;
    double d3 = glm::dot(ab, bp), d4 = glm::dot(ac, bp);
    if (d3 >= 0.0 && d4 <= d3) return d2to(b);
    double vc = d1 * d4 - d3 * d2;
    if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) return d2to(a + ab * (d1 / (d1 - d3)));
    dvec3 cp = p - c;
    double d5 = glm::dot(ab, cp), d6 = glm::dot(ac, cp);
    if (d6 >= 0.0 && d5 <= d6) return d2to(c);
    double vb = d5 * d2 - d1 * d6;
    if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) return d2to(a + ac * (d2 / (d2 - d6)));
    double va = d3 * d6 - d5 * d4;
    if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0)
        return d2to(b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6))));
    double denom = va + vb + vc;
    if (!(std::abs(denom) > 0.0))  // degenerate (zero-area) triangle: the nearest of its three edges
        return std::min({point_segment_dist2(p, a, b), point_segment_dist2(p, b, c), point_segment_dist2(p, c, a)});
    double v = vb / denom, w = vc / denom;
    return d2to(a + ab * v + ac * w);
}

// Squared distance between the closed segments p0p1 and q0q1. The minimum of
// the (convex) squared distance over the parameter square lies either at an
// interior critical point or on the square's boundary, where one parameter is
// 0 or 1: an endpoint against the other segment. Both are evaluated; the
// interior candidate only when the segments are not parallel (den > 0), and
// always as the distance between two actual points of the segments, so
// rounding in the parameters can never produce a value below the true
// minimum. Parallel and zero-length segments are thereby the endpoint cases.
double segment_segment_dist2(const dvec3& p0, const dvec3& p1, const dvec3& q0, const dvec3& q1) {
    double best = std::min({point_segment_dist2(p0, q0, q1), point_segment_dist2(p1, q0, q1),
                            point_segment_dist2(q0, p0, p1), point_segment_dist2(q1, p0, p1)});
    dvec3 u = p1 - p0, v = q1 - q0, w = p0 - q0;
    double a = glm::dot(u, u), b = glm::dot(u, v), c = glm::dot(v, v), d = glm::dot(u, w), e = glm::dot(v, w);
    double den = a * c - b * b;  // |u x v|^2 up to rounding
    if (den > 0.0) {
        double s = (b * e - c * d) / den, t = (a * e - b * d) / den;
        if (s > 0.0 && s < 1.0 && t > 0.0 && t < 1.0) best = std::min(best, length2((p0 + u * s) - (q0 + v * t)));
    }
    return best;
}

// Lexicographic order of triangles (by vertex coordinates), so that the
// distance of a pair is computed the same way whichever comes first.
bool triangle_less(const Triangle3& a, const Triangle3& b) {
    for (int i = 0; i < 3; ++i)
        for (int k = 0; k < 3; ++k)
            if (a[i][k] != b[i][k]) return a[i][k] < b[i][k];
    return false;
}

double triangle_dist2_ordered(const Triangle3& a, const Triangle3& b) {
    if (triangles_intersect(a, b)) return 0.0;
    double best = std::numeric_limits<double>::infinity();
    for (int i = 0; i < 3; ++i) {
        best = std::min(best, point_triangle_dist2(a[i], b[0], b[1], b[2]));
        best = std::min(best, point_triangle_dist2(b[i], a[0], a[1], a[2]));
    }
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            best = std::min(best, segment_segment_dist2(a[i], a[(i + 1) % 3], b[j], b[(j + 1) % 3]));
    return best;
}

double triangle_dist2(const Triangle3& a, const Triangle3& b) {
    return triangle_less(b, a) ? triangle_dist2_ordered(b, a) : triangle_dist2_ordered(a, b);
}

double box_box_dist2(const dvec3& alo, const dvec3& ahi, const dvec3& blo, const dvec3& bhi) {
    dvec3 d = glm::max(glm::max(blo - ahi, alo - bhi), dvec3(0.0));
    return glm::dot(d, d);
}

// One object's geometry for the distance search: its triangles in BVH order,
// their bounding boxes, and the BVH over them.
struct DistanceObject {
    std::vector<Triangle3> tri;  // BVH order
    std::vector<dvec3> tri_lo, tri_hi;
    Bvh bvh;
    dvec3 lo{0.0}, hi{0.0};

    explicit DistanceObject(const Mesh& m) {
        std::vector<glm::vec3> pos3;
        pos3.reserve(3 * m.indices.size());
        for (const auto& t : m.indices)
            for (int k = 0; k < 3; ++k) pos3.push_back(m.positions[t[k]]);
        if (pos3.empty()) return;
        bvh = build_bvh(pos3);
        tri.resize(bvh.order.size());
        tri_lo.resize(tri.size());
        tri_hi.resize(tri.size());
        lo = dvec3(std::numeric_limits<double>::max());
        hi = -lo;
        for (size_t i = 0; i < bvh.order.size(); ++i) {
            for (int k = 0; k < 3; ++k) tri[i][k] = dvec3(pos3[3 * bvh.order[i] + k]);
            tri_lo[i] = glm::min(glm::min(tri[i][0], tri[i][1]), tri[i][2]);
            tri_hi[i] = glm::max(glm::max(tri[i][0], tri[i][1]), tri[i][2]);
            lo = glm::min(lo, tri_lo[i]);
            hi = glm::max(hi, tri_hi[i]);
        }
    }

    bool empty() const { return tri.empty(); }
    dvec3 node_lo(uint32_t n) const { return dvec3(bvh.nodes[n].bmin); }
    dvec3 node_hi(uint32_t n) const { return dvec3(bvh.nodes[n].bmax); }
    uint32_t node_count(uint32_t n) const { return std::bit_cast<uint32_t>(bvh.nodes[n].bmax.w); }
    uint32_t node_offset(uint32_t n) const { return std::bit_cast<uint32_t>(bvh.nodes[n].bmin.w); }
    double node_extent(uint32_t n) const { return glm::length(node_hi(n) - node_lo(n)); }
};

// The exact distance between two objects, squared: a simultaneous descent of
// both BVHs, nearer node pairs first, skipping every pair of nodes (and of
// triangles) whose bounding boxes are at least best2 apart; every remaining
// triangle pair gets the exact triangle-triangle distance. Returns best2
// unchanged when nothing is nearer; 0 as soon as two triangles intersect.
double object_distance2(const DistanceObject& a, const DistanceObject& b, double best2) {
    if (a.empty() || b.empty()) return best2;
    if (box_box_dist2(a.lo, a.hi, b.lo, b.hi) >= best2) return best2;
    struct Item {
        uint32_t na, nb;
        double box2;
    };
    auto pair_box2 = [&](uint32_t na, uint32_t nb) {
        return box_box_dist2(a.node_lo(na), a.node_hi(na), b.node_lo(nb), b.node_hi(nb));
    };
    std::vector<Item> stack;
    stack.reserve(128);
    stack.push_back({0, 0, pair_box2(0, 0)});
    while (!stack.empty()) {
        Item it = stack.back();
        stack.pop_back();
        if (it.box2 >= best2) continue;  // best2 may have shrunk since the push
        uint32_t ca = a.node_count(it.na), cb = b.node_count(it.nb);
        if (ca > 0 && cb > 0) {  // two leaves
            uint32_t oa = a.node_offset(it.na), ob = b.node_offset(it.nb);
            for (uint32_t i = oa; i < oa + ca; ++i)
                for (uint32_t j = ob; j < ob + cb; ++j) {
                    if (box_box_dist2(a.tri_lo[i], a.tri_hi[i], b.tri_lo[j], b.tri_hi[j]) >= best2) continue;
                    best2 = std::min(best2, triangle_dist2(a.tri[i], b.tri[j]));
                    if (best2 == 0.0) return 0.0;
                }
            continue;
        }
        // Open the inner node (the larger one when both are inner).
        bool open_a = cb > 0 || (ca == 0 && a.node_extent(it.na) >= b.node_extent(it.nb));
        Item c0, c1;
        if (open_a) {
            c0 = {it.na + 1, it.nb, 0.0};
            c1 = {a.node_offset(it.na), it.nb, 0.0};
        } else {
            c0 = {it.na, it.nb + 1, 0.0};
            c1 = {it.na, b.node_offset(it.nb), 0.0};
        }
        c0.box2 = pair_box2(c0.na, c0.nb);
        c1.box2 = pair_box2(c1.na, c1.nb);
        if (c0.box2 > c1.box2) std::swap(c0, c1);
        // The farther pair first, so the nearer one is visited next.
        if (c1.box2 < best2) stack.push_back(c1);
        if (c0.box2 < best2) stack.push_back(c0);
    }
    return best2;
}

}  // namespace

bool triangles_intersect(const Triangle3& a, const Triangle3& b) {
    if (!boxes_overlap(a, b)) return false;
    int sb[3], sa[3];
    for (int i = 0; i < 3; ++i) sb[i] = orient3d(a[0], a[1], a[2], b[i]);
    if ((sb[0] > 0 && sb[1] > 0 && sb[2] > 0) || (sb[0] < 0 && sb[1] < 0 && sb[2] < 0)) return false;
    for (int i = 0; i < 3; ++i) sa[i] = orient3d(b[0], b[1], b[2], a[i]);
    if ((sa[0] > 0 && sa[1] > 0 && sa[2] > 0) || (sa[0] < 0 && sa[1] < 0 && sa[2] < 0)) return false;
    // Two closed triangles meet iff an edge of one meets the other: their
    // intersection is convex, and each of its extreme points lies on an
    // edge of one of them.
    for (int i = 0; i < 3; ++i) {
        int j = (i + 1) % 3;
        if (segment_meets_triangle(a[i], a[j], sa[i], sa[j], b)) return true;
        if (segment_meets_triangle(b[i], b[j], sb[i], sb[j], a)) return true;
    }
    return false;
}

double triangle_distance(const Triangle3& a, const Triangle3& b) { return std::sqrt(triangle_dist2(a, b)); }

SeparationFamily separation_family(const Scene& scene, size_t mesh_index) {
    const Mesh& m = scene.meshes.at(mesh_index);
    if (m.emitter >= 0 || m.material < 0 || static_cast<size_t>(m.material) >= scene.materials.size())
        return SeparationFamily::None;
    if (!(mesh_area(m) > 0.0)) return SeparationFamily::None;
    return separation_family_of(scene.lobe_flags(m.material));  // a blend: its components' flags
}

SeparationFamily separation_family_of(uint32_t lobe_flags) {
    if (lobe_flags & gpu::LOBE_BIT_G) return SeparationFamily::Glossy;
    if (lobe_flags & gpu::LOBE_BIT_S) return SeparationFamily::Delta;
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
        dvec3 a(mesh.positions[t.x]), b(mesh.positions[t.y]), c(mesh.positions[t.z]);
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
        if (f == SeparationFamily::Delta)
            delta.push_back(static_cast<uint32_t>(i));
        else if (f == SeparationFamily::Glossy)
            glossy.push_back(static_cast<uint32_t>(i));
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
            pairs.push_back(
                {box_box_dist2(dobj_delta[i].lo, dobj_delta[i].hi, dobj_glossy[j].lo, dobj_glossy[j].hi), {i, j}});
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
            throw std::logic_error("measure_separation: the visibility function answered " +
                                   std::to_string(open.size()) + " of " + std::to_string(rays.size()) + " segments");
        for (uint8_t v : open) r.visible += v ? 1u : 0u;
        r.segments += rays.size();
        rays.clear();
    };
    const double off = offset;
    for (const auto& pa : pts_delta)
        for (const auto& pb : pts_glossy)
            for (const auto& a3 : pa)
                for (const auto& b3 : pb) {
                    dvec3 a(a3), b(b3);
                    double len = glm::length(b - a);
                    if (!(len > 2.0 * off)) {  // touching: nothing can lie between
                        r.segments++;
                        r.visible++;
                        continue;
                    }
                    dvec3 d = (b - a) / len;
                    dvec3 o = a + d * off;
                    rays.push_back(gpu::GpuRay{glm::vec4(glm::vec3(o), 0.0f),
                                               glm::vec4(glm::vec3(d), static_cast<float>(len - 2.0 * off))});
                    if (rays.size() == chunk) flush();
                }
    flush();
    if (r.segments > 0) r.mutual_visibility = static_cast<double>(r.visible) / static_cast<double>(r.segments);
    return r;
}

}  // namespace vkmech
