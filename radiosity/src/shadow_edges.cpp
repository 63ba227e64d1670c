// Shadow edges on a receiver (Wang et al., "Using A-Buffer in Radiosity", Algorithm 3,
// ProjectShadowEdge), with VE wedges for area lights (docs/algorithms.md#shadow-edges).
//
// Method. Every event is a segment in the receiver's plane with a parameter along it, and
// every condition on it (inside the receiver, in front of the light, below the light point,
// hidden by an opaque occluder) is an affine inequality in that parameter, so the visible part
// of each event is a union of parameter intervals computed exactly (up to rounding):
//  - EV (point light L, occluder edge P(t) = p + t (q - p)): the central projection
//    x(t) = (h_L P(t) - h(t) L) / (h_L - h(t)) (h = height above the receiver plane) keeps
//    the sign of any affine function f once multiplied by h_L - h(t) > 0:
//    h_L f(P(t)) - h(t) f(L), which is affine in t. A receiver point x is hidden by an opaque
//    triangle O iff the open segment L→x crosses O: x is strictly inside the three planes
//    through L and O's edges (the same test holds for P(t), on the same ray) and strictly on
//    the other side of O's plane than L (affine in t after the same multiplication). That is
//    Algorithm 3's "split the wedge" done exactly, O clipped to the slab implicitly.
//  - VE (light edge ab, occluder vertex v): the wedge meets the receiver plane in the segment
//    x(u) = proj_a(v) + u (proj_b(v) - proj_a(v)). In the wedge plane an opaque triangle O is
//    a segment σ; the chords q(u)→x(u) (q on ab, through v) sweep the triangles (a, b, v) and
//    (v, proj_a(v), proj_b(v)), so the hidden u are the central projections from v of σ
//    clipped to those two triangles: an exact interval per occluder and triangle.
//
// Numeric assumptions: double precision, constructions not exact. Tolerances are relative to
// the scene size R (the diagonal of the light's and receiver's bounding box): kRel·R for
// lengths and heights. Hidden parts must be strictly inside an occluder's shadow volume by
// that tolerance, so occluders touching a wedge (neighbours sharing a vertex, triangles in the
// light's or the receiver's plane) do not cut it. A VE hidden interval whose end comes from a
// point of σ within about kRel·R of v is imprecise (near-touching configurations only).
// Occluder edges are clipped to heights h ≤ (1 − kNearLight) h_L before projecting.
// Beyond the minimum: a VE wedge is skipped when the opaque occluders at v surround the
// lines from the light edge through v (v is then no silhouette vertex; see fan_surrounds).
// Output: segments on a receiver edge are dropped (the mesh has that edge), collinear
// overlapping or touching segments are merged (directions within kAngleTol, lines within
// kRel·R).

#include "abrad/radiosity/shadow_edges.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <glm/geometric.hpp>
#include <glm/vec2.hpp>
#include <limits>
#include <numbers>
#include <utility>

#include "abrad/radiosity/exact.h"

namespace abrad::radiosity {

ShadowStats& ShadowStats::operator+=(const ShadowStats& o) {
    edges_projected += o.edges_projected;
    shared_edges_skipped += o.shared_edges_skipped;
    segments_split += o.segments_split;
    segments += o.segments;
    return *this;
}

std::string to_string(LightModel m) {
    return m == LightModel::Centroid ? "centroid" : m == LightModel::Vertices ? "vertices" : "area";
}

std::optional<LightModel> parse_light_model(std::string_view t) {
    if (t == "centroid") return LightModel::Centroid;
    if (t == "vertices") return LightModel::Vertices;
    if (t == "area") return LightModel::Area;
    return std::nullopt;
}

namespace {

constexpr double kRel = 1e-10;       // relative tolerance (times the scene size R)
constexpr double kNearLight = 1e-9;  // occluder points must be below (1 - kNearLight) h_L
constexpr double kOpaque = 1.0 - 1e-9;
constexpr double kAngleTol = 1e-9;  // merging: directions equal within this angle (radians)

using glm::dvec2;
using glm::dvec3;

// A closed parameter interval.
struct Span {
    double lo, hi;
};

double cross2(const dvec2& a, const dvec2& b) { return a.x * b.y - a.y * b.x; }

// Keeps the t of `s` where f(t) = f0 + t (f1 - f0) >= tol. False when nothing is left.
bool keep_where(Span& s, double f0, double f1, double tol) {
    const double df = f1 - f0;
    const double flo = f0 + s.lo * df, fhi = f0 + s.hi * df;
    const bool in_lo = flo >= tol, in_hi = fhi >= tol;
    if (in_lo && in_hi) return true;
    if (!in_lo && !in_hi) return false;
    // The ends differ, so df != 0
    const double t = std::clamp((tol - f0) / df, s.lo, s.hi);
    if (in_lo)
        s.hi = t;
    else
        s.lo = t;
    return s.lo <= s.hi;
}

// Removes `cut` from the sorted disjoint intervals `vis`; true when something was removed.
bool subtract(std::vector<Span>& vis, const Span& cut) {
    if (std::none_of(vis.begin(), vis.end(),
                     [&](const Span& s) { return cut.hi > s.lo && cut.lo < s.hi; }))
        return false;  // (without building a new list)
    bool changed = false;
    std::vector<Span> out;
    out.reserve(vis.size() + 1);
    for (const Span& s : vis) {
        if (cut.hi <= s.lo || cut.lo >= s.hi) {
            out.push_back(s);
            continue;
        }
        changed = true;
        if (cut.lo > s.lo) out.push_back({s.lo, cut.lo});
        if (cut.hi < s.hi) out.push_back({cut.hi, s.hi});
    }
    if (changed) vis = std::move(out);
    return changed;
}

// An affine function f(x) = dot(n, x) - c of space, restricted to the receiver plane.
struct Affine {
    dvec3 n;
    double c;
    double operator()(const dvec3& x) const { return glm::dot(n, x) - c; }
};

// A triangle that may hide parts of events: its plane and its vertices.
struct Cutter {
    const Patch* patch;
    dvec3 normal;  // unit
};

struct Context {
    dvec3 r0, nr;                  // receiver plane (unit normal)
    std::array<Affine, 4> region;  // >= 0 inside the receiver and in front of the light
    std::array<dvec3, 3> rv;       // receiver vertices
    double scale;                  // R
    double tol;                    // kRel R
    double min_length;
    std::vector<const Patch*> occ;       // occluders without the receiver and the light
    std::vector<Cutter> cutters;         // opaque, non-degenerate occluders
    std::vector<std::size_t> cutter_of;  // occ index of each cutter
};

double height(const Context& c, const dvec3& p) { return glm::dot(p - c.r0, c.nr); }

bool same_triangle(const Patch& a, const Patch& b) {
    std::array<dvec3, 3> x{a.p[0], a.p[1], a.p[2]}, y{b.p[0], b.p[1], b.p[2]};
    std::sort(x.begin(), x.end(), lexicographically_less);
    std::sort(y.begin(), y.end(), lexicographically_less);
    return x == y;
}

bool has_vertex(const Patch& t, const dvec3& v) {
    return t.p[0] == v || t.p[1] == v || t.p[2] == v;
}

// One occluder edge p–q, shared by `count` occluders from `first` in EdgeGroups' lists.
struct EdgeGroup {
    dvec3 p, q;
    std::uint32_t first = 0, count = 0;
};

// The occluders' edges, each once, with the occluders that share it (indices into
// Context::occ) and each one's third vertex, in two lists for all edges (a few allocations
// per receiver, not two per edge).
struct EdgeGroups {
    std::vector<EdgeGroup> groups;
    std::vector<std::size_t> tris;
    std::vector<dvec3> thirds;
    std::span<const std::size_t> tris_of(const EdgeGroup& g) const {
        return {tris.data() + g.first, g.count};
    }
    std::span<const dvec3> thirds_of(const EdgeGroup& g) const {
        return {thirds.data() + g.first, g.count};
    }
};

EdgeGroups edge_groups(const Context& c) {
    struct Rec {
        dvec3 lo, hi, third;
        std::size_t tri;
    };
    std::vector<Rec> recs;
    recs.reserve(3 * c.occ.size());
    for (std::size_t i = 0; i < c.occ.size(); ++i) {
        const Patch& t = *c.occ[i];
        for (int k = 0; k < 3; ++k) {
            dvec3 a = t.p[k], b = t.p[(k + 1) % 3];
            if (a == b) continue;
            if (lexicographically_less(b, a)) std::swap(a, b);
            recs.push_back({a, b, t.p[(k + 2) % 3], i});
        }
    }
    auto key_less = [](const Rec& x, const Rec& y) {
        if (x.lo != y.lo) return lexicographically_less(x.lo, y.lo);
        if (x.hi != y.hi) return lexicographically_less(x.hi, y.hi);
        return x.tri < y.tri;
    };
    std::sort(recs.begin(), recs.end(), key_less);
    EdgeGroups out;
    out.tris.reserve(recs.size());
    out.thirds.reserve(recs.size());
    for (std::size_t i = 0; i < recs.size();) {
        EdgeGroup g{recs[i].lo, recs[i].hi, static_cast<std::uint32_t>(out.tris.size()), 0};
        std::size_t j = i;
        for (; j < recs.size() && recs[j].lo == g.p && recs[j].hi == g.q; ++j) {
            if (g.count > 0 && out.tris.back() == recs[j].tri) continue;
            out.tris.push_back(recs[j].tri);
            out.thirds.push_back(recs[j].third);
            ++g.count;
        }
        out.groups.push_back(g);
        i = j;
    }
    return out;
}

// A cutter seen from a light point L: hidden iff all four functions are > tolerances.
struct CutterView {
    std::size_t occ_index;
    dvec3 o0, normal;
    double side;  // sign of L's side of the plane (+1 / -1)
    double dist_l;
    std::array<dvec3, 3> cone;  // inward normals of the planes through L and each edge
    std::array<double, 3> cone_tol;
};

// Cutters as seen from L: those that some segment from L to the receiver can cross.
std::vector<CutterView> cutter_views(const Context& c, const dvec3& L, double hl) {
    std::vector<CutterView> views;
    views.reserve(c.cutters.size());
    for (std::size_t k = 0; k < c.cutters.size(); ++k) {
        const Patch& o = *c.cutters[k].patch;
        const double h0 = height(c, o.p[0]), h1 = height(c, o.p[1]), h2 = height(c, o.p[2]);
        if (std::max({h0, h1, h2}) <= c.tol || std::min({h0, h1, h2}) >= hl - c.tol) continue;
        CutterView v{};
        v.occ_index = c.cutter_of[k];
        v.o0 = o.p[0];
        v.normal = c.cutters[k].normal;
        v.dist_l = glm::dot(L - v.o0, v.normal);
        if (std::abs(v.dist_l) <= c.tol) continue;  // seen edge-on from L
        v.side = v.dist_l > 0 ? 1.0 : -1.0;
        const double orient = glm::dot(glm::cross(o.p[0] - L, o.p[1] - L), o.p[2] - L);
        const double s = orient > 0 ? 1.0 : -1.0;
        for (int e = 0; e < 3; ++e) {
            v.cone[e] = s * glm::cross(o.p[e] - L, o.p[(e + 1) % 3] - L);
            v.cone_tol[e] = kRel * glm::length(v.cone[e]) * c.scale;
        }
        views.push_back(v);
    }
    return views;
}

// The occluder edge pq (heights hp, hq) seen from L (height hl), in parameter t along pq.
struct EdgeFromLight {
    dvec3 L, p, q;
    double hl, hp, hq;

    // The receiver point L casts the edge point at t onto
    dvec3 project(double t) const {
        const dvec3 pt = p + t * (q - p);
        const double h = hp + t * (hq - hp);
        return (hl * pt - h * L) / (hl - h);
    }
};

// The part `hs` of `s` that cutter v hides from L (strictly inside its shadow volume by the
// tolerance, so that touching occluders do not cut, and bounded exactly); false when none.
bool hidden_by(const Context& c, const CutterView& v, const EdgeFromLight& e, const Span& s,
               Span& hs) {
    hs = s;
    Span strict = s;
    bool inside = true;
    const double dtol = kRel * e.hl * c.scale;
    for (int k = 0; k < 4 && inside; ++k) {
        double f0, f1, tol;
        if (k == 3) {
            // Beyond the occluder's plane, seen from L
            const double dp = glm::dot(e.p - v.o0, v.normal);
            const double dq = glm::dot(e.q - v.o0, v.normal);
            f0 = -v.side * (e.hl * dp - e.hp * v.dist_l);
            f1 = -v.side * (e.hl * dq - e.hq * v.dist_l);
            tol = dtol;
        } else {
            // Inside the cone from L through the occluder
            f0 = glm::dot(v.cone[k], e.p - e.L);
            f1 = glm::dot(v.cone[k], e.q - e.L);
            tol = v.cone_tol[k];
        }
        inside = keep_where(strict, f0, f1, tol) && keep_where(hs, f0, f1, 0.0);
    }
    return inside && glm::length(e.project(strict.hi) - e.project(strict.lo)) > c.tol;
}

// The parameter span of edge e whose shadow from L falls on the lit receiver (the slab
// 0 <= h <= h_top, then the receiver region); false when empty.
bool lit_span(const Context& c, const EdgeFromLight& e, double h_top, Span& s) {
    s = Span{0.0, 1.0};
    if (!keep_where(s, e.hp, e.hq, 0.0) || !keep_where(s, h_top - e.hp, h_top - e.hq, 0.0))
        return false;
    for (const Affine& f : c.region) {
        const double fl = f(e.L);
        if (!keep_where(s, e.hl * f(e.p) - e.hp * fl, e.hl * f(e.q) - e.hq * fl, 0.0)) return false;
    }
    return true;
}

// Segments cast by the point light L (EV events).
void ev_events(const Context& c, const dvec3& L, const EdgeGroups& groups,
               std::vector<ShadowSegment>& out, ShadowStats& st) {
    const double hl = height(c, L);
    if (hl <= c.tol) return;  // L on or behind the receiver's plane
    const double h_top = hl * (1.0 - kNearLight);
    const std::vector<CutterView> views = cutter_views(c, L, hl);

    std::vector<Span> vis;
    for (const EdgeGroup& g : groups.groups) {
        const std::span<const std::size_t> tris = groups.tris_of(g);
        const std::span<const dvec3> thirds = groups.thirds_of(g);
        const dvec3 p = g.p, q = g.q;
        const double hp = height(c, p), hq = height(c, q);
        // Occluder edges in the receiver's plane cast nothing
        if (std::abs(hp) <= c.tol && std::abs(hq) <= c.tol) continue;
        if (std::max(hp, hq) <= 0.0 || std::min(hp, hq) >= h_top) continue;

        // Shared edge: no silhouette when the two faces are on opposite sides of the wedge
        if (tris.size() == 2 &&
            std::abs(c.occ[tris[0]]->opacity - c.occ[tris[1]]->opacity) <= 1e-12) {
            const dvec3 w = glm::cross(p - L, q - L);
            const double wt = kRel * glm::length(w) * c.scale;
            const double s0 = glm::dot(w, thirds[0] - L), s1 = glm::dot(w, thirds[1] - L);
            if ((s0 > wt && s1 < -wt) || (s0 < -wt && s1 > wt)) {
                ++st.shared_edges_skipped;
                continue;
            }
        }
        ++st.edges_projected;

        // Clip the edge to the slab 0 <= h <= h_top and its projection to the lit receiver
        const EdgeFromLight e{L, p, q, hl, hp, hq};
        Span s;
        if (!lit_span(c, e, h_top, s)) continue;
        const double keep_len = std::max(c.min_length, c.tol);
        if (glm::length(e.project(s.hi) - e.project(s.lo)) < keep_len) continue;

        // Remove the parts hidden from L by other opaque occluders
        vis.assign(1, s);
        for (const CutterView& v : views) {
            if (std::find(tris.begin(), tris.end(), v.occ_index) != tris.end()) continue;
            Span hs;
            if (!hidden_by(c, v, e, s, hs)) continue;
            if (subtract(vis, hs)) ++st.segments_split;
            if (vis.empty()) break;
        }
        for (const Span& piece : vis) {
            const dvec3 a = e.project(piece.lo), b = e.project(piece.hi);
            if (glm::length(b - a) >= keep_len) out.push_back({a, b});
        }
    }
}

// Contact edges: occluder edges in the receiver's plane of faces that stand out of it (a box
// standing on a floor, a wall on a slab that runs under it). A point source's light stops
// there whatever the point's place, so they bound its shadow where ev_events casts nothing.
void contact_edges(const Context& c, const EdgeGroups& groups, std::vector<ShadowSegment>& out) {
    const double keep_len = std::max(c.min_length, c.tol);
    for (const EdgeGroup& g : groups.groups) {
        if (std::abs(height(c, g.p)) > c.tol || std::abs(height(c, g.q)) > c.tol) continue;
        bool stands = false;
        for (const dvec3& third : groups.thirds_of(g)) stands |= std::abs(height(c, third)) > c.tol;
        if (!stands) continue;
        // Clip to the receiver triangle
        Span s{0.0, 1.0};
        bool inside = true;
        for (std::size_t e = 0; e < 3 && inside; ++e)
            inside = keep_where(s, c.region[e](g.p), c.region[e](g.q), 0.0);
        if (!inside) continue;
        const dvec3 a = g.p + s.lo * (g.q - g.p), b = g.p + s.hi * (g.q - g.p);
        if (glm::length(b - a) >= keep_len) out.push_back({a, b});
    }
}

// Keeps the part of the 2D segment w0-w1 at least `tol` inside the triangle `t`.
bool clip_to_triangle(dvec2& w0, dvec2& w1, const std::array<dvec2, 3>& t, double tol) {
    const double orient = cross2(t[1] - t[0], t[2] - t[0]);
    if (orient == 0.0) return false;
    const double s = orient > 0 ? 1.0 : -1.0;
    Span sp{0.0, 1.0};
    for (int e = 0; e < 3; ++e) {
        const dvec2 a = t[e], d = t[(e + 1) % 3] - a;
        const double len = std::sqrt(d.x * d.x + d.y * d.y);
        if (len == 0.0) return false;
        const double g0 = s * cross2(d, w0 - a) / len, g1 = s * cross2(d, w1 - a) / len;
        if (!keep_where(sp, g0, g1, tol)) return false;
    }
    const dvec2 d = w1 - w0;
    const dvec2 n0 = w0 + sp.lo * d, n1 = w0 + sp.hi * d;
    w0 = n0;
    w1 = n1;
    return true;
}

// An occluder vertex and one occluder incident to it.
struct VRec {
    dvec3 v;
    std::size_t tri;
};

// Occluder vertices sorted by position (each position once per incident occluder).
std::vector<VRec> occluder_vertices(const Context& c) {
    std::vector<VRec> verts;
    verts.reserve(3 * c.occ.size());
    for (std::size_t i = 0; i < c.occ.size(); ++i)
        for (const dvec3& v : c.occ[i]->p) verts.push_back({v, i});
    std::sort(verts.begin(), verts.end(), [](const VRec& x, const VRec& y) {
        return x.v != y.v ? lexicographically_less(x.v, y.v) : x.tri < y.tri;
    });
    return verts;
}

// True when the opaque occluders incident to v (verts[first, last)) surround the line through
// v along d: seen along d their corners at v cover a full turn, so the line crosses their
// surface at v (v is no silhouette vertex from that direction) and is blocked there.
bool fan_surrounds(const Context& c, const std::vector<VRec>& verts, std::size_t first,
                   std::size_t last, const dvec3& v, const dvec3& d) {
    const double twopi = 2.0 * std::numbers::pi, ang_tol = 1e-9;
    const dvec3 n = glm::normalize(d);
    const auto [e1, e2] = visdb::orthonormal_basis(n);
    std::vector<Span> arcs;
    for (std::size_t m = first; m < last; ++m) {
        const Patch& t = *c.occ[verts[m].tri];
        if (t.opacity < kOpaque) continue;
        int k = 0;
        while (k < 3 && t.p[k] != v) ++k;
        if (k == 3) continue;
        const dvec3 w1 = t.p[(k + 1) % 3] - v, w2 = t.p[(k + 2) % 3] - v;
        dvec2 u1(glm::dot(w1, e1), glm::dot(w1, e2)), u2(glm::dot(w2, e1), glm::dot(w2, e2));
        const double l1 = std::sqrt(glm::dot(u1, u1)), l2 = std::sqrt(glm::dot(u2, u2));
        if (l1 <= 1e-12 * glm::length(w1) || l2 <= 1e-12 * glm::length(w2)) continue;
        double cr = cross2(u1, u2) / (l1 * l2);
        if (std::abs(cr) <= 1e-12) continue;  // seen edge-on: no area around the line
        if (cr < 0) std::swap(u1, u2);
        double a0 = std::atan2(u1.y, u1.x), a1 = std::atan2(u2.y, u2.x);
        if (a0 < 0) a0 += twopi;
        if (a1 < a0) a1 += twopi;
        if (a1 > twopi) {
            arcs.push_back({a0, twopi});
            arcs.push_back({0.0, a1 - twopi});
        } else {
            arcs.push_back({a0, a1});
        }
    }
    std::sort(arcs.begin(), arcs.end(), [](const Span& x, const Span& y) { return x.lo < y.lo; });
    double reach = 0.0;
    for (const Span& a : arcs) {
        if (a.lo > reach + ang_tol) return false;
        reach = std::max(reach, a.hi);
    }
    return reach >= twopi - ang_tol;
}

// The plane of the wedge through the light edge ab and the occluder vertex v, with 2D
// coordinates (origin v, x along ab) and the receiver trace xa + u·e of the wedge.
struct Wedge {
    dvec3 v, nw, ex, ey;
    dvec2 xa2, e2;
    double tol;

    dvec2 to2(const dvec3& w) const { return dvec2(glm::dot(w - v, ex), glm::dot(w - v, ey)); }

    // u of the receiver point on the line from v through w
    bool u_of(const dvec2& w, double& u) const {
        const double den = cross2(e2, w);
        if (std::sqrt(w.x * w.x + w.y * w.y) <= tol || std::abs(den) <= 1e-300) return false;
        u = cross2(w, xa2) / den;
        return std::isfinite(u);
    }
};

// The trace σ = [s0, s1] of occluder o on the wedge plane, in wedge coordinates; false when o
// does not cross the plane (or lies in it: measure zero, not handled).
bool occluder_trace(const Patch& o, const Wedge& w, dvec2& s0, dvec2& s1) {
    std::array<double, 3> d{};
    for (int m = 0; m < 3; ++m) d[m] = glm::dot(o.p[m] - w.v, w.nw);
    const double tol = w.tol;
    if ((d[0] > tol && d[1] > tol && d[2] > tol) || (d[0] < -tol && d[1] < -tol && d[2] < -tol))
        return false;
    if (std::abs(d[0]) <= tol && std::abs(d[1]) <= tol && std::abs(d[2]) <= tol) return false;
    std::array<dvec3, 4> pts{};
    int np = 0;
    for (int m = 0; m < 3 && np < 4; ++m) {
        const int n = (m + 1) % 3;
        if (std::abs(d[m]) <= tol) pts[np++] = o.p[m];
        if ((d[m] > tol && d[n] < -tol) || (d[m] < -tol && d[n] > tol)) {
            if (np < 4) pts[np++] = o.p[m] + (o.p[n] - o.p[m]) * (d[m] / (d[m] - d[n]));
        }
    }
    if (np < 2) return false;
    // The two farthest points span σ
    s0 = w.to2(pts[0]);
    s1 = w.to2(pts[1]);
    double best = -1.0;
    for (int m = 0; m < np; ++m)
        for (int n = m + 1; n < np; ++n) {
            const dvec2 u = w.to2(pts[m]), x = w.to2(pts[n]);
            const double dd = glm::dot(x - u, x - u);
            if (dd > best) best = dd, s0 = u, s1 = x;
        }
    return true;
}

// Removes from `vis` (parameter spans of the wedge's receiver trace, of length elen) what the
// cutters not incident to v (verts[first, last)) hide inside the two swept triangles.
void cut_wedge(const Context& c, const Wedge& w, const std::vector<VRec>& verts, std::size_t first,
               std::size_t last, const std::array<std::array<dvec2, 3>, 2>& sweep, double elen,
               std::vector<Span>& vis, ShadowStats& st) {
    for (std::size_t k = 0; k < c.cutters.size(); ++k) {
        const Patch& o = *c.cutters[k].patch;
        bool incident = false;
        for (std::size_t m = first; m < last; ++m) incident |= verts[m].tri == c.cutter_of[k];
        if (incident || has_vertex(o, w.v)) continue;
        dvec2 s0, s1;
        if (!occluder_trace(o, w, s0, s1)) continue;
        for (const auto& tri : sweep) {
            // σ strictly inside the swept triangle by the tolerance, bounded exactly
            dvec2 w0 = s0, w1 = s1, t0 = s0, t1 = s1;
            if (!clip_to_triangle(t0, t1, tri, c.tol) || !clip_to_triangle(w0, w1, tri, 0.0))
                continue;
            const dvec2 dt = t1 - t0;
            if (std::sqrt(dt.x * dt.x + dt.y * dt.y) <= c.tol) continue;
            double u0 = 0.0, u1 = 0.0;
            if (!w.u_of(w0, u0) || !w.u_of(w1, u1)) continue;
            const Span hs{std::min(u0, u1), std::max(u0, u1)};
            if ((hs.hi - hs.lo) * elen <= c.tol) continue;
            if (subtract(vis, hs)) ++st.segments_split;
        }
        if (vis.empty()) break;
    }
}

// Segments of the wedges through the light edge ab and each occluder vertex (VE events).
void ve_events(const Context& c, const dvec3& a, const dvec3& b, const std::vector<VRec>& verts,
               std::vector<ShadowSegment>& out, ShadowStats& st) {
    const double ha = height(c, a), hb = height(c, b);
    if (ha <= c.tol || hb <= c.tol) return;
    const double h_top = std::min(ha, hb) * (1.0 - kNearLight);

    const double keep_len = std::max(c.min_length, c.tol);
    std::vector<Span> vis;
    for (std::size_t i = 0; i < verts.size();) {
        const dvec3 v = verts[i].v;
        std::size_t j = i;
        while (j < verts.size() && verts[j].v == v) ++j;
        const std::size_t first = i;
        i = j;
        const double hv = height(c, v);
        if (hv <= c.tol || hv >= h_top) continue;
        // Wedge inside the occluders at v (e.g. the corner of a closed box facing the light
        // edge): checked at both ends and the middle of ab, exact when the set of surrounded
        // directions is convex (convex corners), otherwise the wedge may be kept needlessly
        if (fan_surrounds(c, verts, first, j, v, v - a) &&
            fan_surrounds(c, verts, first, j, v, v - b) &&
            fan_surrounds(c, verts, first, j, v, v - 0.5 * (a + b)))
            continue;

        // The wedge's trace: proj_a(v) to proj_b(v), clipped to the lit receiver
        const dvec3 xa = (ha * v - hv * a) / (ha - hv), xb = (hb * v - hv * b) / (hb - hv);
        Span s{0.0, 1.0};
        bool empty = false;
        for (const Affine& f : c.region) {
            if (!keep_where(s, f(xa), f(xb), 0.0)) {
                empty = true;
                break;
            }
        }
        if (empty) continue;
        const dvec3 e = xb - xa;
        const double elen = glm::length(e);
        if (elen * (s.hi - s.lo) < keep_len) continue;
        ++st.edges_projected;

        // Wedge plane frame, origin v (none when v is on the light edge's line)
        const dvec3 wn = glm::cross(b - a, v - a);
        const double wl = glm::length(wn);
        if (!(wl > c.tol * glm::length(b - a))) continue;
        const dvec3 nw = wn / wl, ex = glm::normalize(b - a);
        Wedge w{.v = v,
                .nw = nw,
                .ex = ex,
                .ey = glm::cross(nw, ex),
                .xa2 = dvec2(0.0),
                .e2 = dvec2(0.0),
                .tol = c.tol};
        w.xa2 = w.to2(xa);
        w.e2 = w.to2(xb) - w.xa2;
        const std::array<std::array<dvec2, 3>, 2> sweep{
            {{w.to2(a), w.to2(b), dvec2(0.0)}, {dvec2(0.0), w.xa2, w.to2(xb)}}};

        vis.assign(1, s);
        cut_wedge(c, w, verts, first, j, sweep, elen, vis, st);
        for (const Span& piece : vis) {
            const dvec3 p = xa + piece.lo * e, q = xa + piece.hi * e;
            if (glm::length(q - p) >= keep_len) out.push_back({p, q});
        }
    }
}

// Drops segments on the receiver's boundary and merges collinear overlapping ones.
std::vector<ShadowSegment> merge(const Context& c, const std::vector<ShadowSegment>& in) {
    // 2D frame of the receiver plane, turned by an arbitrary angle so that axis-aligned lines
    // stay away from the direction wrap-around at angle 0 ~ π
    const dvec3 u0 = glm::normalize(c.rv[1] - c.rv[0]), v0 = glm::cross(c.nr, u0);
    const double turn = 0.3;
    const dvec3 ex = std::cos(turn) * u0 + std::sin(turn) * v0, ey = glm::cross(c.nr, ex);
    auto to2 = [&](const dvec3& w) {
        return dvec2(glm::dot(w - c.r0, ex), glm::dot(w - c.r0, ey));
    };

    struct Item {
        double angle, offset, s0, s1;
        dvec3 a, b;  // at s0 and s1
    };
    std::vector<Item> items;
    items.reserve(in.size());
    const double keep_len = std::max(c.min_length, c.tol);
    for (const ShadowSegment& seg : in) {
        // On a receiver edge: the mesh has that edge already
        bool on_boundary = false;
        for (int e = 0; e < 3 && !on_boundary; ++e) {
            const Affine& f = c.region[static_cast<std::size_t>(e)];
            on_boundary = std::abs(f(seg.a)) <= c.tol && std::abs(f(seg.b)) <= c.tol;
        }
        if (on_boundary) continue;
        const dvec2 a = to2(seg.a), b = to2(seg.b);
        dvec2 d = b - a;
        const double len = std::sqrt(d.x * d.x + d.y * d.y);
        if (!(len >= keep_len)) continue;
        d /= len;
        if (d.y < 0.0 || (d.y == 0.0 && d.x < 0.0)) d = -d;
        double angle = std::atan2(d.y, d.x);
        if (angle > std::numbers::pi - kAngleTol) {
            angle -= std::numbers::pi;
            d = -d;
        }
        Item it{angle, cross2(d, a), glm::dot(d, a), glm::dot(d, b), seg.a, seg.b};
        if (it.s1 < it.s0) {
            std::swap(it.s0, it.s1);
            std::swap(it.a, it.b);
        }
        items.push_back(it);
    }
    std::sort(items.begin(), items.end(),
              [](const Item& x, const Item& y) { return x.angle < y.angle; });

    std::vector<ShadowSegment> out;
    for (std::size_t i = 0; i < items.size();) {
        // Items of one direction
        std::size_t j = i;
        while (j < items.size() && items[j].angle - items[i].angle <= kAngleTol) ++j;
        std::sort(items.begin() + static_cast<std::ptrdiff_t>(i),
                  items.begin() + static_cast<std::ptrdiff_t>(j),
                  [](const Item& x, const Item& y) { return x.offset < y.offset; });
        for (std::size_t k = i; k < j;) {
            // Items of one line
            std::size_t m = k;
            while (m < j && items[m].offset - items[k].offset <= c.tol) ++m;
            std::sort(items.begin() + static_cast<std::ptrdiff_t>(k),
                      items.begin() + static_cast<std::ptrdiff_t>(m),
                      [](const Item& x, const Item& y) { return x.s0 < y.s0; });
            Item cur = items[k];
            for (std::size_t n = k + 1; n <= m; ++n) {
                if (n < m && items[n].s0 <= cur.s1 + c.tol) {
                    if (items[n].s1 > cur.s1) {
                        cur.s1 = items[n].s1;
                        cur.b = items[n].b;
                    }
                    continue;
                }
                out.push_back({cur.a, cur.b});
                if (n < m) cur = items[n];
            }
            k = m;
        }
        i = j;
    }
    return out;
}

// The receiver's plane and region, the scene scale and the occluders of `c`; `light` (null
// for a point source) bounds the region to the front of its plane and is no occluder. The
// box of the receiver and `points` gives the scale. False when nothing can be cast (a
// degenerate receiver or light, or no occluder).
bool make_context(Context& c, const Patch& receiver, const Patch* light,
                  std::span<const dvec3> points, std::span<const Patch* const> occluders,
                  double min_length) {
    // Receiver and light planes; scene scale R
    const dvec3 rn = glm::cross(receiver.p[1] - receiver.p[0], receiver.p[2] - receiver.p[0]);
    dvec3 lo = receiver.p[0], hi = receiver.p[0];
    for (const dvec3& p : receiver.p) {
        lo = glm::min(lo, p);
        hi = glm::max(hi, p);
    }
    for (const dvec3& p : points) {
        lo = glm::min(lo, p);
        hi = glm::max(hi, p);
    }
    c.scale = glm::length(hi - lo);
    const double rl = glm::length(rn);
    if (!(c.scale > 0.0) || !std::isfinite(c.scale) || rl <= 1e-300 ||
        rl <= 1e-24 * c.scale * c.scale)
        return false;
    c.tol = kRel * c.scale;
    c.min_length = min_length;
    c.r0 = receiver.p[0];
    c.nr = rn / rl;
    for (int e = 0; e < 3; ++e) {
        const dvec3 a = receiver.p[e], b = receiver.p[(e + 1) % 3];
        const dvec3 n = glm::normalize(glm::cross(c.nr, b - a));  // inward
        c.region[static_cast<std::size_t>(e)] = {n, glm::dot(n, a)};
        c.rv[static_cast<std::size_t>(e)] = a;
    }
    if (light) {
        const dvec3 ln = glm::cross(light->p[1] - light->p[0], light->p[2] - light->p[0]);
        const double ll = glm::length(ln);
        if (ll <= 1e-300 || ll <= 1e-24 * c.scale * c.scale) return false;
        c.region[3] = {ln / ll, glm::dot(ln / ll, light->p[0])};
    } else {
        c.region[3] = c.region[0];  // a point source lights every side: no fourth bound
    }

    // Occluders: without the receiver, the light and what lies wholly behind an area light's
    // plane (a segment from the light to the receiver runs in front of it: the other
    // triangles of a closed emitter hide nothing of it); the opaque ones also cut
    const Affine& light_plane = c.region[3];
    for (const Patch* t : occluders) {
        if (t == nullptr || same_triangle(*t, receiver) || (light && same_triangle(*t, *light)))
            continue;
        if (light &&
            std::max({light_plane(t->p[0]), light_plane(t->p[1]), light_plane(t->p[2])}) <= c.tol)
            continue;
        const std::size_t idx = c.occ.size();
        c.occ.push_back(t);
        if (t->opacity < kOpaque) continue;
        const dvec3 n = glm::cross(t->p[1] - t->p[0], t->p[2] - t->p[0]);
        const double len = glm::length(n);
        const double e = std::max({glm::length(t->p[1] - t->p[0]), glm::length(t->p[2] - t->p[1]),
                                   glm::length(t->p[0] - t->p[2])});
        if (!(len > 1e-12 * e * e)) continue;  // degenerate: covers nothing
        c.cutters.push_back({t, n / len});
        c.cutter_of.push_back(idx);
    }
    return !c.occ.empty();
}

}  // namespace

ShadowContrast shadow_contrast(std::span<const Patch* const> lights, const Patch& receiver,
                               std::span<const Patch* const> occluders,
                               const ShadowSegment& segment, double delta, double enough) {
    ShadowContrast out;
    const dvec3 rn = glm::cross(receiver.p[1] - receiver.p[0], receiver.p[2] - receiver.p[0]);
    const dvec3 d = segment.b - segment.a;
    const double rl = glm::length(rn);
    if (!(rl > 0.0) || !(glm::length(d) > 0.0) || !(delta > 0.0)) return out;
    const dvec3 n = rn / rl;
    // The unit normal of the segment in the receiver's plane, scaled to the offset δ
    const dvec3 m = delta * glm::normalize(glm::cross(n, d));
    // On the lines across the segment through its middle and its ends: F at ±δ, then how far
    // F departs from the straight line between those at 0 and ±δ/2 (the refinement's test on
    // an edge of 2δ across the segment, at three places along it)
    const auto f_at = [&](const dvec3& x) {
        double f = 0.0;
        for (const Patch* light : lights) f += visible_form_factor(x, n, *light, occluders);
        out.level = std::max(out.level, f);
        return f;
    };
    for (const double along : {0.5, 0.0, 1.0}) {
        const dvec3 x = segment.a + along * d;
        const double f0 = f_at(x - m), f1 = f_at(x + m);
        for (const double t : {0.0, -0.5, 0.5}) {
            const double linear = f0 + 0.5 * (t + 1.0) * (f1 - f0);
            out.change = std::max(out.change, std::abs(f_at(x + t * m) - linear));
            if (out.change >= enough) return out;
        }
    }
    return out;
}

std::vector<ShadowSegment> point_shadow_edges(const glm::dvec3& source, const Patch& receiver,
                                              std::span<const Patch* const> occluders,
                                              double min_length, ShadowStats* stats) {
    ShadowStats st;
    Context c{};
    std::vector<ShadowSegment> out;
    const dvec3 points[1] = {source};
    if (make_context(c, receiver, nullptr, points, occluders, min_length)) {
        // EV events from the one point: its VE wedges through the occluders' silhouette edges
        std::vector<ShadowSegment> raw;
        const EdgeGroups groups = edge_groups(c);
        ev_events(c, source, groups, raw, st);
        contact_edges(c, groups, raw);
        out = merge(c, raw);
    }
    st.segments = out.size();
    if (stats) *stats += st;
    return out;
}

std::vector<ShadowSegment> shadow_edges(const Patch& light, LightModel model, const Patch& receiver,
                                        std::span<const Patch* const> occluders, double min_length,
                                        ShadowStats* stats, const EmitterEdges& emitter) {
    ShadowStats st;
    auto finish = [&](std::vector<ShadowSegment> r) {
        st.segments = r.size();
        if (stats) *stats += st;
        return r;
    };
    Context c{};
    if (!make_context(c, receiver, &light, light.p, occluders, min_length)) return finish({});

    // EV events from each light point
    std::vector<ShadowSegment> raw;
    const EdgeGroups groups = edge_groups(c);
    if (model == LightModel::Centroid) {
        ev_events(c, (light.p[0] + light.p[1] + light.p[2]) / 3.0, groups, raw, st);
    } else {
        for (int k = 0; k < 3; ++k)
            if (!emitter.corner_inside(k)) ev_events(c, light.p[k], groups, raw, st);
    }
    // VE events along each light edge on the emitter's boundary
    if (model == LightModel::Area) {
        const std::vector<VRec> verts = occluder_vertices(c);
        for (int e = 0; e < 3; ++e)
            if (!emitter.interior[static_cast<std::size_t>(e)])
                ve_events(c, light.p[e], light.p[(e + 1) % 3], verts, raw, st);
    }
    return finish(merge(c, raw));
}

}  // namespace abrad::radiosity
