// Discontinuity meshing after Lischinski, Tampieri, Greenberg, "Discontinuity Meshing for
// Accurate Radiosity" (1992): constrained Delaunay triangulation with Ruppert/Chew refinement
// (Shewchuk, "Delaunay refinement algorithms for triangular mesh generation", 2002; CGAL Mesh_2).
//
// Numeric assumptions:
// - All 2D orientation / in-circle predicates are exact (filtered predicates).
// - Where shadow edges cross, the crossing is constructed exactly (Epeck, lazy exact) in the
//   first CDT and rounded to double only when read back; with Epick the rounded crossings of
//   a real model's many near-collinear shadow edges corrupted Constrained_triangulation_plus_2
//   (a crash on the FZK-Haus). The refinement CDT works on the rounded points (Epick).
// - Every "is this point on that edge / next to that point" decision is made once, with
//   merge_distance, and then carried as topology (vertex ids, polylines through shared
//   vertices), never re-decided from rounded coordinates.
// - Input vertices keep their exact 3D position; a vertex shared by several regions (a point
//   on a shared boundary) carries one exact 3D position everywhere. Only vertices created here
//   (crossings, snapped points, refinement) get origin + x u + y v.

#include "abrad/radiosity/dm_mesh.h"

#include <CGAL/Constrained_Delaunay_triangulation_2.h>
#include <CGAL/Constrained_triangulation_plus_2.h>
#include <CGAL/Delaunay_mesh_face_base_2.h>
#include <CGAL/Delaunay_mesh_vertex_base_2.h>
#include <CGAL/Delaunay_mesher_2.h>
#include <CGAL/Exact_predicates_exact_constructions_kernel.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Triangulation_face_base_with_info_2.h>
#include <CGAL/Triangulation_vertex_base_with_info_2.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <glm/geometric.hpp>
#include <map>
#include <numeric>
#include <set>
#include <stdexcept>
#include <string>
#include <tuple>
#include <unordered_map>
#include <unordered_set>
#include <utility>

#include "abrad/radiosity/bvh.h"
#include "abrad/visdb/model.h"

namespace abrad::radiosity {
namespace {

constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();
constexpr std::size_t kMaxRounds = 8;
/// Rounds (0-based) in which refinement runs; later re-meshes keep the refined vertex set but
/// insert no Steiner points, so the conformity loop terminates.
constexpr std::size_t kRefineRounds = 4;
/// Quality refinement leaves triangles whose shortest edge is under this fraction of their
/// region's size (its first CDT's bounding box diagonal) as they are.
constexpr double kQualityFloor = 1e-2;

// ---------------------------------------------------------------------------------------------
// CGAL types

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
/// Exact constructions for the CDT with crossing shadow edges: with Epick, the rounded
/// crossing points of many near-collinear edges (a real house's shadows) corrupted
/// Constrained_triangulation_plus_2 and crashed it.
using KE = CGAL::Exact_predicates_exact_constructions_kernel;
using Point2 = KE::Point_2;

/// Id of the vertex in the region's RegionState, kNone for vertices CGAL created.
struct VInfo {
    std::uint32_t id = kNone;
};
/// Flood-fill parity: -1 not reached, 0 outside, 1 inside.
struct FInfo {
    int parity = -1;
};

/// A vertex or face base with a CGAL time stamp: CGAL then orders and hashes the handles by
/// creation instead of by address. CGAL's plain bases stamp no time (nor does
/// Delaunay_mesh_vertex_base_2 outside a debugging build), and the exact-crossings
/// triangulation's constraint hierarchy and the mesher's clusters keep maps keyed by vertex
/// handles: ordered by address, the order of their work, and with co-circular points the
/// triangulation made, followed the heap (an FZK-Haus region came out in one of two
/// triangulations from run to run).
template <class Base>
class TimeStamped : public Base {
  public:
    using Base::Base;
    template <typename Tds>
    struct Rebind_TDS {
        using Other = TimeStamped<typename Base::template Rebind_TDS<Tds>::Other>;
    };
    using Has_timestamp = CGAL::Tag_true;
    std::size_t time_stamp() const { return m_time_stamp; }
    void set_time_stamp(const std::size_t& ts) { m_time_stamp = ts; }

  private:
    std::size_t m_time_stamp = std::size_t(-1);
};

// Triangulation that inserts the constraints: exact crossings, input constraints kept.
using Vb1 =
    CGAL::Triangulation_vertex_base_with_info_2<VInfo, KE,
                                                TimeStamped<CGAL::Triangulation_vertex_base_2<KE>>>;
using Fb1i =
    CGAL::Triangulation_face_base_with_info_2<FInfo, KE,
                                              TimeStamped<CGAL::Triangulation_face_base_2<KE>>>;
using Fb1 = CGAL::Constrained_triangulation_face_base_2<KE, Fb1i>;
using Tds1 = CGAL::Triangulation_data_structure_2<Vb1, Fb1>;
using Cdt1Base =
    CGAL::Constrained_Delaunay_triangulation_2<KE, Tds1, CGAL::Exact_intersections_tag>;
using Cdt1 = CGAL::Constrained_triangulation_plus_2<Cdt1Base>;

// Triangulation that is refined: its constraints no longer cross (they are the edges of a Cdt1).
using Vb2 =
    CGAL::Triangulation_vertex_base_with_info_2<VInfo, K,
                                                TimeStamped<CGAL::Delaunay_mesh_vertex_base_2<K>>>;
using Fb2 = CGAL::Delaunay_mesh_face_base_2<K>;
using Tds2 = CGAL::Triangulation_data_structure_2<Vb2, Fb2>;
using Cdt2 = CGAL::Constrained_Delaunay_triangulation_2<K, Tds2, CGAL::Exact_predicates_tag>;
/// The minimum-angle criterion (quality = sin² of the smallest angle) with a floor: a
/// triangle whose shortest edge is under `min_edge` is never bad. Refinement near an input
/// angle smaller than the bound, or near a feature far smaller than the region, would
/// otherwise add triangles down to the feature's size (the furnished room: 358k triangles
/// instead of 6.5k without the floor).
class Criteria {
  public:
    using Quality = double;
    Criteria(double sin2_min_angle, double min_edge)
        : m_bound(sin2_min_angle), m_min_edge2(min_edge * min_edge) {}

    class Is_bad {
      public:
        Is_bad(double bound, double min_edge2) : m_bound(bound), m_min_edge2(min_edge2) {}
        CGAL::Mesh_2::Face_badness operator()(Quality q) const {
            return q < m_bound ? CGAL::Mesh_2::BAD : CGAL::Mesh_2::NOT_BAD;
        }
        CGAL::Mesh_2::Face_badness operator()(const Cdt2::Face_handle& f, Quality& q) const {
            const K::Point_2 &a = f->vertex(0)->point(), &b = f->vertex(1)->point(),
                             &c = f->vertex(2)->point();
            const double ab = CGAL::squared_distance(a, b), bc = CGAL::squared_distance(b, c),
                         ca = CGAL::squared_distance(c, a);
            const double shortest = std::min({ab, bc, ca});
            if (shortest < m_min_edge2) {
                q = 1.0;
                return CGAL::Mesh_2::NOT_BAD;
            }
            // sin² of the smallest angle: (2 area)² / (product of the two longer sides²)
            const double area2 = CGAL::area(a, b, c) * 2.0;
            q = area2 * area2 / (ab * bc * ca / shortest);
            return operator()(q);
        }

      private:
        double m_bound, m_min_edge2;
    };
    Is_bad is_bad_object() const { return Is_bad(m_bound, m_min_edge2); }

  private:
    double m_bound, m_min_edge2;
};
using Mesher = CGAL::Delaunay_mesher_2<Cdt2, Criteria>;

// Triangulation of a region's outline alone (outline_triangulation): no crossings allowed,
// so no point is constructed; a crossing throws and the region keeps its triangles.
using VbO = CGAL::Triangulation_vertex_base_with_info_2<std::uint32_t, K>;
using FbOi = CGAL::Triangulation_face_base_with_info_2<FInfo, K>;
using FbO = CGAL::Constrained_triangulation_face_base_2<K, FbOi>;
using TdsO = CGAL::Triangulation_data_structure_2<VbO, FbO>;
using CdtO = CGAL::Constrained_Delaunay_triangulation_2<
    K, TdsO, CGAL::No_constraint_intersection_requiring_constructions_tag>;

// ---------------------------------------------------------------------------------------------
// Small geometry helpers

struct Vec2 {
    double x = 0.0, y = 0.0;
};
inline Vec2 operator-(Vec2 a, Vec2 b) { return {a.x - b.x, a.y - b.y}; }
inline Vec2 operator+(Vec2 a, Vec2 b) { return {a.x + b.x, a.y + b.y}; }
inline Vec2 operator*(double s, Vec2 a) { return {s * a.x, s * a.y}; }
inline double dot2(Vec2 a, Vec2 b) { return a.x * b.x + a.y * b.y; }
inline double cross2(Vec2 a, Vec2 b) { return a.x * b.y - a.y * b.x; }
inline double len2(Vec2 a) { return std::sqrt(dot2(a, a)); }

/// Exact key of a 3D position (-0 and +0 are the same point).
struct PosKey {
    std::uint64_t x, y, z;
    bool operator==(const PosKey&) const = default;
};
PosKey key_of(const glm::dvec3& p) {
    return {std::bit_cast<std::uint64_t>(p.x + 0.0), std::bit_cast<std::uint64_t>(p.y + 0.0),
            std::bit_cast<std::uint64_t>(p.z + 0.0)};
}
struct PosKeyHash {
    std::size_t operator()(const PosKey& k) const {
        std::uint64_t h = k.x * 0x9E3779B97F4A7C15ull;
        h ^= k.y + 0x7F4A7C159E3779B9ull + (h << 6) + (h >> 2);
        h ^= k.z + 0x94D049BB133111EBull + (h << 6) + (h >> 2);
        return static_cast<std::size_t>(h);
    }
};
using PosSet = std::unordered_set<PosKey, PosKeyHash>;

/// Parameter of the closest point of segment [a, b] to p, and the squared distance to it.
std::pair<double, double> closest_on_segment(const glm::dvec3& p, const glm::dvec3& a,
                                             const glm::dvec3& b) {
    const glm::dvec3 d = b - a;
    const double dd = glm::dot(d, d);
    double t = dd > 0.0 ? glm::dot(p - a, d) / dd : 0.0;
    t = std::clamp(t, 0.0, 1.0);
    const glm::dvec3 q = a + t * d;
    return {t, glm::dot(p - q, p - q)};
}

// ---------------------------------------------------------------------------------------------
// Per-region data

/// Orthonormal frame of a region's plane; (u, v, n) is right-handed.
struct Frame {
    glm::dvec3 o{0.0}, u{0.0}, v{0.0}, n{0.0};
    Vec2 project(const glm::dvec3& p) const { return {glm::dot(p - o, u), glm::dot(p - o, v)}; }
    glm::dvec3 lift(double x, double y) const { return o + x * u + y * v; }
};

Frame make_frame(const glm::dvec3& normal, const glm::dvec3& origin) {
    Frame f;
    f.n = glm::normalize(normal);
    // The axis least aligned with n gives a well-conditioned cross product
    std::tie(f.u, f.v) = visdb::orthonormal_basis(f.n);
    f.o = origin;
    return f;
}

/// A vertex of a region's meshing input: 2D position in the frame, exact 3D position, source.
struct Vtx {
    Vec2 p;
    glm::dvec3 pos{0.0};
    std::uint32_t source = kNewVertex;
};

/// What a region is meshed from. Round 0 builds it from the input; later rounds from the
/// previous output (whose constraints no longer cross), plus split points from neighbours.
struct RegionState {
    std::vector<Vtx> verts;
    std::vector<std::uint32_t> input_id;                  ///< input vertex -> verts index
    std::vector<std::array<std::uint32_t, 2>> segments;   ///< non-boundary constraints
    std::vector<std::vector<std::uint32_t>> edge_splits;  ///< per boundary edge: verts on it
};

struct RegionSetup {
    Frame frame;
    std::vector<std::array<std::uint32_t, 2>>
        boundary;  ///< input vertex pairs used an odd number of times
};

struct LocalStats {
    std::size_t dropped = 0, merged = 0;
};

struct MeshRun {
    MeshedRegion out;
    RegionState next;
};

// ---------------------------------------------------------------------------------------------
// Triangulation

/// Spatially coherent insertion order (Morton order of quantised coordinates).
std::vector<std::uint32_t> insertion_order_of(const std::vector<Vec2>& pts) {
    Box b;
    for (const Vec2& p : pts) b.grow(glm::dvec3(p.x, p.y, 0.0));
    const double ex = std::max(b.hi.x - b.lo.x, b.hi.y - b.lo.y);
    const double s = ex > 0.0 ? 65535.0 / ex : 0.0;
    auto spread = [](std::uint32_t x) {
        x &= 0xFFFFu;
        x = (x | (x << 8)) & 0x00FF00FFu;
        x = (x | (x << 4)) & 0x0F0F0F0Fu;
        x = (x | (x << 2)) & 0x33333333u;
        x = (x | (x << 1)) & 0x55555555u;
        return x;
    };
    std::vector<std::pair<std::uint32_t, std::uint32_t>> keyed(pts.size());
    for (std::size_t i = 0; i < pts.size(); ++i) {
        const auto qx =
            static_cast<std::uint32_t>(std::clamp((pts[i].x - b.lo.x) * s, 0.0, 65535.0));
        const auto qy =
            static_cast<std::uint32_t>(std::clamp((pts[i].y - b.lo.y) * s, 0.0, 65535.0));
        keyed[i] = {spread(qx) | (spread(qy) << 1), static_cast<std::uint32_t>(i)};
    }
    std::sort(keyed.begin(), keyed.end());
    std::vector<std::uint32_t> order(pts.size());
    for (std::size_t i = 0; i < keyed.size(); ++i) order[i] = keyed[i].second;
    return order;
}

/// insertion_order_of the vertices' 2D positions.
std::vector<std::uint32_t> insertion_order(const std::vector<Vtx>& verts) {
    std::vector<Vec2> pts(verts.size());
    for (std::size_t i = 0; i < verts.size(); ++i) pts[i] = verts[i].p;
    return insertion_order_of(pts);
}

/// Builds the output and the next state from a triangulation whose inside faces are known.
/// chains[e] = vertex chain of boundary edge e from its first to its last endpoint.
template <class Cdt, class InDomain, class IsSegment>
MeshRun collect(const Cdt& cdt, const Frame& frame, const RegionState& in,
                const std::vector<typename Cdt::Vertex_handle>& vh,
                const std::vector<std::vector<typename Cdt::Vertex_handle>>& chains,
                InDomain in_domain, IsSegment is_segment) {
    using Vh = typename Cdt::Vertex_handle;
    MeshRun run;
    std::unordered_map<Vh, std::uint32_t> new_id;
    auto id_of = [&](Vh v) {
        auto [it, fresh] = new_id.try_emplace(v, static_cast<std::uint32_t>(run.next.verts.size()));
        if (fresh) {
            Vtx x;
            x.p = {CGAL::to_double(v->point().x()), CGAL::to_double(v->point().y())};
            if (v->info().id != kNone) {
                x.pos = in.verts[v->info().id].pos;
                x.source = in.verts[v->info().id].source;
            } else {
                x.pos = frame.lift(x.p.x, x.p.y);
            }
            run.next.verts.push_back(x);
        }
        return it->second;
    };

    // Inside faces, counter-clockwise in the frame = counter-clockwise seen from the normal
    for (auto f = cdt.finite_faces_begin(); f != cdt.finite_faces_end(); ++f) {
        if (!in_domain(f)) continue;
        run.out.triangles.push_back(
            glm::u32vec3(id_of(f->vertex(0)), id_of(f->vertex(1)), id_of(f->vertex(2))));
    }
    // Every input vertex is kept, even one no inside face uses
    run.next.input_id.resize(in.input_id.size());
    for (std::size_t i = 0; i < in.input_id.size(); ++i)
        run.next.input_id[i] = id_of(vh[in.input_id[i]]);

    // Constraints that are not part of the boundary, between kept vertices
    for (auto e = cdt.finite_edges_begin(); e != cdt.finite_edges_end(); ++e) {
        if (!cdt.is_constrained(*e) || !is_segment(*e)) continue;
        const Vh a = e->first->vertex(cdt.cw(e->second)), b = e->first->vertex(cdt.ccw(e->second));
        auto ia = new_id.find(a), ib = new_id.find(b);
        if (ia != new_id.end() && ib != new_id.end())
            run.next.segments.push_back({ia->second, ib->second});
    }
    run.next.edge_splits.resize(chains.size());
    for (std::size_t e = 0; e < chains.size(); ++e) {
        for (std::size_t k = 1; k + 1 < chains[e].size(); ++k)
            run.next.edge_splits[e].push_back(id_of(chains[e][k]));
    }

    run.out.positions.reserve(run.next.verts.size());
    run.out.source_vertex.reserve(run.next.verts.size());
    for (const Vtx& x : run.next.verts) {
        run.out.positions.push_back(x.pos);
        run.out.source_vertex.push_back(x.source);
    }
    return run;
}

/// Walks the constrained edges of cdt from a to b (along the straight segment a-b).
std::vector<Cdt2::Vertex_handle> walk_constrained(const Cdt2& cdt, Cdt2::Vertex_handle a,
                                                  Cdt2::Vertex_handle b) {
    std::vector<Cdt2::Vertex_handle> path{a};
    const Vec2 pa{CGAL::to_double(a->point().x()), CGAL::to_double(a->point().y())},
        pb{CGAL::to_double(b->point().x()), CGAL::to_double(b->point().y())};
    const Vec2 d = pb - pa;
    const double dd = dot2(d, d);
    Cdt2::Vertex_handle cur = a;
    double t_cur = 0.0;
    for (std::size_t guard = 0; cur != b && guard < 1000000; ++guard) {
        Cdt2::Vertex_handle best;
        double best_sin = std::numeric_limits<double>::infinity(), best_t = 0.0;
        auto ec = cdt.incident_edges(cur), done = ec;
        do {
            if (cdt.is_infinite(*ec) || !cdt.is_constrained(*ec)) continue;
            Cdt2::Vertex_handle w = ec->first->vertex(cdt.cw(ec->second));
            if (w == cur) w = ec->first->vertex(cdt.ccw(ec->second));
            if (w == b) {
                best = b;
                break;
            }
            const Vec2 pw{CGAL::to_double(w->point().x()), CGAL::to_double(w->point().y())};
            const double t = dot2(pw - pa, d) / dd;
            if (t <= t_cur || t >= 1.0) continue;
            const Vec2 step =
                pw - Vec2{CGAL::to_double(cur->point().x()), CGAL::to_double(cur->point().y())};
            const double s = std::abs(cross2(step, d)) / (len2(step) * std::sqrt(dd));
            if (s < best_sin) {
                best_sin = s;
                best = w;
                best_t = t;
            }
        } while (++ec != done);
        if (best == Cdt2::Vertex_handle()) break;  // should not happen: constraints are kept
        path.push_back(best);
        cur = best;
        t_cur = best_t;
    }
    if (path.back() != b) path = {a, b};
    return path;
}

/// Uniform grid hash over 2D points, cell = merge distance.
class PointGrid {
  public:
    explicit PointGrid(double cell) : m_inv(1.0 / cell) {}
    void add(Vec2 p, std::uint32_t id) { m_cells[key(cell_of(p.x), cell_of(p.y))].push_back(id); }
    template <class F>
    void near(Vec2 p, F&& f) const {
        const std::int64_t cx = cell_of(p.x), cy = cell_of(p.y);
        for (std::int64_t dx = -1; dx <= 1; ++dx)
            for (std::int64_t dy = -1; dy <= 1; ++dy) {
                auto it = m_cells.find(key(cx + dx, cy + dy));
                if (it != m_cells.end())
                    for (std::uint32_t id : it->second) f(id);
            }
    }

  private:
    std::int64_t cell_of(double x) const {
        return static_cast<std::int64_t>(std::floor(x * m_inv));
    }
    static std::uint64_t key(std::int64_t x, std::int64_t y) {
        return static_cast<std::uint64_t>(x) * 0x9E3779B97F4A7C15ull ^
               static_cast<std::uint64_t>(y);
    }
    double m_inv;
    std::unordered_map<std::uint64_t, std::vector<std::uint32_t>> m_cells;
};

/// Box around the segment [a, b] grown by r.
Box box_around(Vec2 a, Vec2 b, double r) {
    Box q;
    q.grow(glm::dvec3(a.x, a.y, 0.0));
    q.grow(glm::dvec3(b.x, b.y, 0.0));
    q.inflate(r);
    return q;
}

/// Routes each segment (indices into `pts`) through the points within `eps` of its interior,
/// in order along it, so that no point lies on or next to a constraint it is not a vertex of.
/// `scale` is the points' extent (long segments are searched in pieces of about scale / 64).
/// With `source`, every piece is kept and source[k] is the segment piece k came from; without,
/// repeated pieces are dropped.
std::vector<std::array<std::uint32_t, 2>> route_segments(
    const std::vector<Vec2>& pts, const std::vector<std::array<std::uint32_t, 2>>& segments,
    double eps, double scale, std::vector<std::uint32_t>* source = nullptr) {
    std::vector<Box> boxes(pts.size());
    for (std::size_t i = 0; i < pts.size(); ++i) boxes[i].grow(glm::dvec3(pts[i].x, pts[i].y, 0.0));
    const Bvh bvh(std::move(boxes));
    std::vector<std::array<std::uint32_t, 2>> routed;
    std::set<std::pair<std::uint32_t, std::uint32_t>> seen;
    std::uint32_t current = 0;
    auto add_piece = [&](std::uint32_t v0, std::uint32_t v1) {
        if (v0 == v1) return;
        if (source) {
            source->push_back(current);
        } else if (!seen.insert({std::min(v0, v1), std::max(v0, v1)}).second) {
            return;
        }
        routed.push_back({v0, v1});
    };
    for (; current < segments.size(); ++current) {
        // Plain variables, not a structured binding: clang 14 (clang-tidy) cannot capture
        // structured bindings in the lambda below
        const std::uint32_t v0 = segments[current][0], v1 = segments[current][1];
        const Vec2 a = pts[v0], d = pts[v1] - a;
        const double dd = dot2(d, d);
        const int chunks = static_cast<int>(std::clamp(std::sqrt(dd) / scale * 64.0, 1.0, 256.0));
        std::vector<std::pair<double, std::uint32_t>> on;
        for (int c = 0; c < chunks; ++c) {
            const Vec2 c0 = a + (double(c) / chunks) * d, c1 = a + (double(c + 1) / chunks) * d;
            bvh.query(box_around(c0, c1, eps), [&](std::uint32_t id) {
                if (id == v0 || id == v1) return;
                const double t = dot2(pts[id] - a, d) / dd;
                if (t > 0.0 && t < 1.0 && len2(a + t * d - pts[id]) <= eps) on.push_back({t, id});
            });
        }
        std::sort(on.begin(), on.end());
        std::uint32_t prev = v0;
        for (const auto& [t, id] : on) {
            if (id == prev) continue;
            add_piece(prev, id);
            prev = id;
        }
        add_piece(prev, v1);
    }
    return routed;
}

/// Copies the first CDT's vertices and constrained edges into `cdt2` for refinement, and
/// which of its edges toggle inside/outside (`toggles` on the first CDT's edges). The exact
/// crossings of nearly concurrent shadow edges round to points 1e-16 m apart, or onto a
/// constraint they are not on; the mesher then split such an edge until its midpoint was an
/// endpoint and crashed (issue 19). So vertices closer than eps = max(h, 1e-10 x the region's
/// size) become one (represented by an input vertex, else a boundary vertex: two input
/// vertices are never merged, the boundary does not move), and a constrained edge passing
/// within eps of a vertex is routed through it. `to2` maps every first-CDT vertex. Returns the
/// region's size (the diagonal of its vertices' bounding box).
template <class Toggles>
double copy_for_refinement(
    const Cdt1& cdt, const RegionState& in,
    const std::vector<std::vector<Cdt1::Vertex_handle>>& chains, double h, Toggles&& toggles,
    Cdt2& cdt2, std::unordered_map<Cdt1::Vertex_handle, Cdt2::Vertex_handle>& to2,
    std::set<std::pair<Cdt2::Vertex_handle, Cdt2::Vertex_handle>>& toggle_edges) {
    // The vertices, rounded, input vertices first, then boundary vertices
    std::unordered_set<Cdt1::Vertex_handle> on_boundary;
    for (const auto& chain : chains) on_boundary.insert(chain.begin(), chain.end());
    std::vector<Cdt1::Vertex_handle> v1;
    std::vector<Vec2> at;  // v1's positions, rounded
    std::vector<int> rank;
    Box bounds;
    for (auto v = cdt.finite_vertices_begin(); v != cdt.finite_vertices_end(); ++v) {
        const std::uint32_t id = v->info().id;
        v1.push_back(v);
        at.push_back({CGAL::to_double(v->point().x()), CGAL::to_double(v->point().y())});
        rank.push_back(id != kNone && in.verts[id].source != kNewVertex ? 0
                       : on_boundary.count(v) != 0                      ? 1
                                                                        : 2);
        bounds.grow(glm::dvec3(at.back().x, at.back().y, 0.0));
    }
    std::vector<std::uint32_t> order(v1.size());
    for (std::uint32_t i = 0; i < order.size(); ++i) order[i] = i;
    // Input vertices first, then boundary vertices, each by position, not in the first CDT's
    // container order (which followed the heap before its handles carried time stamps)
    std::stable_sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
        return std::tuple(rank[a], at[a].x, at[a].y) < std::tuple(rank[b], at[b].x, at[b].y);
    });
    const double scale = std::max(1e-300, glm::length(bounds.hi - bounds.lo));
    const double eps = std::max(h, 1e-10 * scale);

    // Merge each vertex into a representative within eps (never an input vertex into another)
    std::vector<Vec2> reps;
    std::vector<std::uint32_t> rep_of(v1.size());
    std::vector<Cdt1::Vertex_handle> rep_vertex;
    PointGrid grid(eps);
    for (const std::uint32_t i : order) {
        const Vec2 p = at[i];
        std::uint32_t best = kNone;
        double best_d = eps;
        if (rank[i] > 0) {
            grid.near(p, [&](std::uint32_t r) {
                const double d = len2(reps[r] - p);
                if (d <= best_d) {
                    best_d = d;
                    best = r;
                }
            });
        }
        if (best == kNone) {
            best = static_cast<std::uint32_t>(reps.size());
            reps.push_back(p);
            rep_vertex.push_back(v1[i]);
            grid.add(p, best);
        }
        rep_of[i] = best;
    }
    std::vector<Cdt2::Vertex_handle> handle(reps.size());
    Cdt2::Face_handle hint;
    for (std::uint32_t r : insertion_order_of(reps)) {
        handle[r] = cdt2.insert(K::Point_2(reps[r].x, reps[r].y), hint);
        handle[r]->info() = rep_vertex[r]->info();
        hint = handle[r]->face();
    }
    std::unordered_map<Cdt1::Vertex_handle, std::uint32_t> index;
    for (std::uint32_t i = 0; i < v1.size(); ++i) {
        index.emplace(v1[i], rep_of[i]);
        to2.emplace(v1[i], handle[rep_of[i]]);
    }

    // Constrained edges between representatives, routed through the ones within eps; an
    // edge toggles when an odd number of toggling first-CDT edges lie along it. The edges go
    // in sorted, not in the first CDT's face order: the mesher's result depends on the order
    // the constraints go in, and that order followed the heap (the first CDT's constraint
    // hierarchy ordered vertex handles by address before they carried time stamps)
    std::vector<std::tuple<std::uint32_t, std::uint32_t, char>> found;  // a, b, toggling
    for (auto e = cdt.finite_edges_begin(); e != cdt.finite_edges_end(); ++e) {
        if (!cdt.is_constrained(*e)) continue;
        const std::uint32_t a = index.at(e->first->vertex(cdt.cw(e->second))),
                            b = index.at(e->first->vertex(cdt.ccw(e->second)));
        if (a == b) continue;
        found.emplace_back(std::min(a, b), std::max(a, b), toggles(e->first, e->second) ? 1 : 0);
    }
    std::sort(found.begin(), found.end());
    std::vector<std::array<std::uint32_t, 2>> edges;
    std::vector<char> toggling;
    for (const auto& [a, b, t] : found) {
        edges.push_back({a, b});
        toggling.push_back(t);
    }
    std::map<std::pair<std::uint32_t, std::uint32_t>, int> toggle_count;
    std::vector<std::uint32_t> source;
    const auto pieces = route_segments(reps, edges, eps, scale, &source);
    for (std::size_t k = 0; k < pieces.size(); ++k) {
        const auto& piece = pieces[k];
        cdt2.insert_constraint(handle[piece[0]], handle[piece[1]]);
        if (toggling[source[k]] != 0)
            ++toggle_count[{std::min(piece[0], piece[1]), std::max(piece[0], piece[1])}];
    }
    for (const auto& [key, count] : toggle_count) {
        if (count % 2 == 0) continue;
        const Cdt2::Vertex_handle a = handle[key.first], b = handle[key.second];
        toggle_edges.insert(a < b ? std::pair(a, b) : std::pair(b, a));
    }
    return scale;
}

/// Nesting parity of every face (FInfo::parity, -1 before): 0 for the infinite faces, flipped
/// across each edge where `toggles(face, i)`. The triangulation must be two-dimensional.
template <typename Cdt, typename Toggles>
void flood_parity(Cdt& cdt, Toggles&& toggles) {
    std::vector<typename Cdt::Face_handle> queue;
    auto fc = cdt.incident_faces(cdt.infinite_vertex()), done = fc;
    do {
        fc->info().parity = 0;
        queue.push_back(fc);
    } while (++fc != done);
    while (!queue.empty()) {
        const typename Cdt::Face_handle f = queue.back();
        queue.pop_back();
        for (int i = 0; i < 3; ++i) {
            const typename Cdt::Face_handle g = f->neighbor(i);
            if (g->info().parity >= 0) continue;
            g->info().parity = f->info().parity ^ (toggles(f, i) ? 1 : 0);
            queue.push_back(g);
        }
    }
}

/// Triangulates one region from its state; refines when min_angle_deg > 0.
MeshRun triangulate(const RegionSetup& setup, const RegionState& in, double min_angle_deg,
                    double h) {
    const Frame& frame = setup.frame;
    Cdt1 cdt;

    // Insert the vertices (all input vertices stay vertices)
    std::vector<Cdt1::Vertex_handle> vh(in.verts.size());
    Cdt1::Face_handle hint;
    for (std::uint32_t i : insertion_order(in.verts)) {
        vh[i] = cdt.insert(Point2(in.verts[i].p.x, in.verts[i].p.y), hint);
        hint = vh[i]->face();
        // A duplicate 2D point keeps the first id, preferring an input vertex
        if (vh[i]->info().id == kNone ||
            (in.verts[vh[i]->info().id].source == kNewVertex && in.verts[i].source != kNewVertex))
            vh[i]->info().id = i;
    }

    // Insert the boundary as polylines through their split points; remember the constraint ids
    std::unordered_set<const void*> boundary_ids;
    std::vector<std::vector<Cdt1::Constraint_id>> pieces(setup.boundary.size());
    for (std::size_t e = 0; e < setup.boundary.size(); ++e) {
        const std::uint32_t a = in.input_id[setup.boundary[e][0]],
                            b = in.input_id[setup.boundary[e][1]];
        const Vec2 pa = in.verts[a].p, d = in.verts[b].p - pa;
        std::vector<std::pair<double, std::uint32_t>> line;
        for (std::uint32_t s : in.edge_splits[e]) line.push_back({dot2(in.verts[s].p - pa, d), s});
        std::sort(line.begin(), line.end());
        Cdt1::Vertex_handle prev = vh[a];
        auto add_piece = [&](Cdt1::Vertex_handle next) {
            if (next == prev) return;
            const Cdt1::Constraint_id cid = cdt.insert_constraint(prev, next);
            boundary_ids.insert(cid.vl_ptr());
            pieces[e].push_back(cid);
            prev = next;
        };
        for (const auto& [t, s] : line) add_piece(vh[s]);
        add_piece(vh[b]);
    }
    // Insert the shadow edges (they may cross each other: exact intersections)
    for (const auto& s : in.segments)
        if (vh[s[0]] != vh[s[1]]) cdt.insert_constraint(vh[s[0]], vh[s[1]]);

    // Count boundary constraints enclosing an edge: odd = the edge separates inside from outside
    auto toggles = [&](Cdt1::Face_handle f, int i) {
        if (!f->is_constrained(i)) return false;
        const auto va = f->vertex(cdt.cw(i)), vb = f->vertex(cdt.ccw(i));
        std::size_t n = 0;
        for (auto c = cdt.contexts_begin(va, vb); c != cdt.contexts_end(va, vb); ++c)
            n += boundary_ids.count(c->id().vl_ptr());
        return n % 2 == 1;
    };
    auto is_segment = [&](const Cdt1::Edge& e) {
        const auto va = e.first->vertex(cdt.cw(e.second)), vb = e.first->vertex(cdt.ccw(e.second));
        for (auto c = cdt.contexts_begin(va, vb); c != cdt.contexts_end(va, vb); ++c)
            if (boundary_ids.count(c->id().vl_ptr()) == 0) return true;
        return false;
    };

    // Flood-fill parity from the infinite faces
    if (cdt.dimension() == 2) flood_parity(cdt, toggles);

    // Boundary chains (vertices along each boundary edge, crossings included)
    std::vector<std::vector<Cdt1::Vertex_handle>> chains(setup.boundary.size());
    for (std::size_t e = 0; e < setup.boundary.size(); ++e) {
        chains[e].push_back(vh[in.input_id[setup.boundary[e][0]]]);
        for (const auto& cid : pieces[e])
            for (auto v : cdt.vertices_in_constraint(cid))
                if (v != chains[e].back()) chains[e].push_back(v);
    }

    if (!(min_angle_deg > 0.0) || cdt.dimension() < 2) {
        return collect(
            cdt, frame, in, vh, chains, [](Cdt1::Face_handle f) { return f->info().parity == 1; },
            is_segment);
    }

    // Refinement: copy vertices and constrained edges into a CDT the mesher accepts, without
    // the features below merge_distance that rounding the exact crossings leaves
    Cdt2 cdt2;
    std::unordered_map<Cdt1::Vertex_handle, Cdt2::Vertex_handle> to2;
    std::set<std::pair<Cdt2::Vertex_handle, Cdt2::Vertex_handle>> toggle_edges;
    const double region_size =
        copy_for_refinement(cdt, in, chains, h, toggles, cdt2, to2, toggle_edges);
    auto edge_key = [](Cdt2::Vertex_handle a, Cdt2::Vertex_handle b) {
        return a < b ? std::pair(a, b) : std::pair(b, a);
    };
    // Mark the inside faces by the same parity rule
    for (auto f = cdt2.all_faces_begin(); f != cdt2.all_faces_end(); ++f) f->set_in_domain(false);
    {
        std::vector<std::pair<Cdt2::Face_handle, bool>> queue;
        std::unordered_set<Cdt2::Face_handle> seen;
        auto fc = cdt2.incident_faces(cdt2.infinite_vertex()), done = fc;
        do {
            seen.insert(fc);
            queue.push_back({fc, false});
        } while (++fc != done);
        while (!queue.empty()) {
            const auto [f, inside] = queue.back();
            queue.pop_back();
            f->set_in_domain(inside);
            for (int i = 0; i < 3; ++i) {
                const Cdt2::Face_handle g = f->neighbor(i);
                if (!seen.insert(g).second) continue;
                bool t = false;
                if (f->is_constrained(i))
                    t = toggle_edges.count(
                            edge_key(f->vertex(cdt2.cw(i)), f->vertex(cdt2.ccw(i)))) > 0;
                queue.push_back({g, inside != t});
            }
        }
    }
    const double s = std::sin(min_angle_deg * 3.14159265358979323846 / 180.0);
    Mesher mesher(cdt2, Criteria(s * s, kQualityFloor * region_size));
    mesher.init(true);
    mesher.refine_mesh();

    // Boundary chains in the refined triangulation (refinement splits constrained edges)
    std::vector<std::vector<Cdt2::Vertex_handle>> chains2(chains.size());
    std::set<std::pair<Cdt2::Vertex_handle, Cdt2::Vertex_handle>> boundary_edges;
    for (std::size_t e = 0; e < chains.size(); ++e) {
        chains2[e].push_back(to2.at(chains[e].front()));
        for (std::size_t k = 1; k < chains[e].size(); ++k) {
            const auto path =
                walk_constrained(cdt2, to2.at(chains[e][k - 1]), to2.at(chains[e][k]));
            for (std::size_t j = 1; j < path.size(); ++j) {
                boundary_edges.insert(edge_key(path[j - 1], path[j]));
                chains2[e].push_back(path[j]);
            }
        }
    }
    std::vector<Cdt2::Vertex_handle> vh2(vh.size());
    for (std::size_t i = 0; i < vh.size(); ++i) vh2[i] = to2.at(vh[i]);
    return collect(
        cdt2, frame, in, vh2, chains2, [](Cdt2::Face_handle f) { return f->is_in_domain(); },
        [&](const Cdt2::Edge& e) {
            return boundary_edges.count(edge_key(e.first->vertex(cdt2.cw(e.second)),
                                                 e.first->vertex(cdt2.ccw(e.second)))) == 0;
        });
}

// ---------------------------------------------------------------------------------------------
// Round 0: the meshing input of a region from the PlanarRegion

/// A split point found on a boundary edge of a region by the global search.
struct SplitHit {
    std::uint32_t edge;
    glm::dvec3 pos;
};

RegionState build_initial(const PlanarRegion& region, const RegionSetup& setup,
                          const std::vector<SplitHit>& hits, double h, LocalStats& stats,
                          PosSet& announced) {
    const Frame& frame = setup.frame;
    RegionState st;
    st.edge_splits.resize(setup.boundary.size());
    std::unordered_map<PosKey, std::uint32_t, PosKeyHash> by_pos;

    // Input vertices
    Box bounds;
    for (std::size_t i = 0; i < region.positions.size(); ++i) {
        Vtx x{frame.project(region.positions[i]), region.positions[i],
              static_cast<std::uint32_t>(i)};
        st.input_id.push_back(static_cast<std::uint32_t>(st.verts.size()));
        by_pos.try_emplace(key_of(x.pos), static_cast<std::uint32_t>(st.verts.size()));
        bounds.grow(glm::dvec3(x.p.x, x.p.y, 0.0));
        st.verts.push_back(x);
    }
    const double scale = std::max(1e-300, glm::length(bounds.hi - bounds.lo));
    const double cell = std::max(h, 1e-12 * scale);

    // Split points from vertices of any region that lie on the boundary edges
    auto add_split = [&](std::uint32_t e, std::uint32_t id) {
        auto& s = st.edge_splits[e];
        if (std::find(s.begin(), s.end(), id) == s.end()) s.push_back(id);
    };
    for (const SplitHit& hit : hits) {
        auto [it, fresh] =
            by_pos.try_emplace(key_of(hit.pos), static_cast<std::uint32_t>(st.verts.size()));
        if (fresh) st.verts.push_back({frame.project(hit.pos), hit.pos, kNewVertex});
        add_split(hit.edge, it->second);
    }
    for (const Vtx& x : st.verts) announced.insert(key_of(x.pos));

    PointGrid grid(cell);
    for (std::size_t i = 0; i < st.verts.size(); ++i)
        grid.add(st.verts[i].p, static_cast<std::uint32_t>(i));

    // 2D boundary edges and triangles, for snapping and clipping
    std::vector<Box> edge_boxes, tri_boxes;
    for (const auto& e : setup.boundary) {
        Box b;
        for (std::uint32_t k : e)
            b.grow(glm::dvec3(st.verts[st.input_id[k]].p.x, st.verts[st.input_id[k]].p.y, 0.0));
        b.inflate(h);
        edge_boxes.push_back(b);
    }
    for (const auto& t : region.triangles) {
        Box b;
        for (int k = 0; k < 3; ++k) b.grow(glm::dvec3(st.verts[t[k]].p.x, st.verts[t[k]].p.y, 0.0));
        b.inflate(h);
        tri_boxes.push_back(b);
    }
    const Bvh edge_bvh(std::move(edge_boxes)), tri_bvh(std::move(tri_boxes));

    // Snap a 2D point to a vertex, else onto boundary edges, else make a free vertex
    auto snap = [&](Vec2 p) -> std::uint32_t {
        std::uint32_t best = kNone;
        double best_d = h;
        grid.near(p, [&](std::uint32_t id) {
            const double d = len2(st.verts[id].p - p);
            if (d <= best_d) {
                best_d = d;
                best = id;
            }
        });
        if (best != kNone) {
            ++stats.merged;
            return best;
        }
        std::vector<std::uint32_t> on_edges;
        std::uint32_t nearest = kNone;
        double nearest_d = h, nearest_t = 0.0;
        edge_bvh.query(box_around(p, p, 0.0), [&](std::uint32_t e) {
            const Vec2 a = st.verts[st.input_id[setup.boundary[e][0]]].p;
            const Vec2 d = st.verts[st.input_id[setup.boundary[e][1]]].p - a;
            const double dd = dot2(d, d);
            if (!(dd > 0.0)) return;
            const double t = std::clamp(dot2(p - a, d) / dd, 0.0, 1.0);
            const double dist = len2(a + t * d - p);
            if (dist > h) return;
            on_edges.push_back(e);
            if (dist <= nearest_d) {
                nearest_d = dist;
                nearest = e;
                nearest_t = t;
            }
        });
        const auto id = static_cast<std::uint32_t>(st.verts.size());
        if (nearest != kNone) {
            const std::uint32_t ia = st.input_id[setup.boundary[nearest][0]];
            const std::uint32_t ib = st.input_id[setup.boundary[nearest][1]];
            const Vec2 q = st.verts[ia].p + nearest_t * (st.verts[ib].p - st.verts[ia].p);
            const glm::dvec3 pos =
                st.verts[ia].pos + nearest_t * (st.verts[ib].pos - st.verts[ia].pos);
            st.verts.push_back({q, pos, kNewVertex});
            for (std::uint32_t e : on_edges) add_split(e, id);
            ++stats.merged;
        } else {
            st.verts.push_back({p, frame.lift(p.x, p.y), kNewVertex});
        }
        grid.add(st.verts.back().p, id);
        return id;
    };

    // Edge functions of a 2D input triangle, counter-clockwise, widened by h
    auto tri_corners = [&](std::size_t t, Vec2(&c)[3]) {
        for (int k = 0; k < 3; ++k) c[k] = st.verts[region.triangles[t][k]].p;
        const double area = cross2(c[1] - c[0], c[2] - c[0]);
        if (area < 0.0) std::swap(c[1], c[2]);
        return area != 0.0;
    };

    // Shadow edges: clip to the union of the input triangles, snap the ends
    std::set<std::pair<std::uint32_t, std::uint32_t>> seen_segments;
    for (const auto& seg : region.constraints) {
        const Vec2 a = frame.project(seg[0]), b = frame.project(seg[1]);
        const Vec2 d = b - a;
        const double len = len2(d);
        bool kept = false;
        if (std::isfinite(len) && len > h) {
            std::vector<std::pair<double, double>> spans;
            tri_bvh.query(box_around(a, b, h), [&](std::uint32_t t) {
                Vec2 c[3];
                if (!tri_corners(t, c)) return;
                double t0 = 0.0, t1 = 1.0;
                for (int k = 0; k < 3 && t0 < t1; ++k) {
                    const Vec2 edge = c[(k + 1) % 3] - c[k];
                    const double f0 = cross2(edge, a - c[k]) + h * len2(edge);
                    const double f1 = cross2(edge, d);
                    if (f1 == 0.0) {
                        if (f0 < 0.0) t1 = -1.0;
                    } else if (f1 > 0.0) {
                        t0 = std::max(t0, -f0 / f1);
                    } else {
                        t1 = std::min(t1, -f0 / f1);
                    }
                }
                if (t0 < t1) spans.push_back({t0, t1});
            });
            std::sort(spans.begin(), spans.end());
            const double gap = h / len;
            std::vector<std::pair<double, double>> merged_spans;
            for (const auto& s : spans) {
                if (!merged_spans.empty() && s.first <= merged_spans.back().second + gap)
                    merged_spans.back().second = std::max(merged_spans.back().second, s.second);
                else
                    merged_spans.push_back(s);
            }
            for (const auto& [t0, t1] : merged_spans) {
                if ((t1 - t0) * len <= h) continue;
                const std::uint32_t v0 = snap(a + t0 * d), v1 = snap(a + t1 * d);
                if (v0 == v1 || len2(st.verts[v1].p - st.verts[v0].p) < h) continue;
                if (!seen_segments.insert({std::min(v0, v1), std::max(v0, v1)}).second) {
                    kept = true;
                    continue;
                }
                st.segments.push_back({v0, v1});
                kept = true;
            }
        }
        if (!kept) ++stats.dropped;
    }

    // Points: kept if inside an input triangle (within h)
    for (const glm::dvec3& p3 : region.points) {
        const Vec2 p = frame.project(p3);
        if (!std::isfinite(p.x) || !std::isfinite(p.y)) continue;
        bool inside = false;
        tri_bvh.query(box_around(p, p, 0.0), [&](std::uint32_t t) {
            Vec2 c[3];
            if (inside || !tri_corners(t, c)) return;
            bool in = true;
            for (int k = 0; k < 3 && in; ++k) {
                const Vec2 edge = c[(k + 1) % 3] - c[k];
                in = cross2(edge, p - c[k]) >= -h * len2(edge);
            }
            inside = in;
        });
        if (inside) snap(p);
    }

    // Route each segment through the vertices within h of its interior: a constraint passing a
    // vertex at 1e-17 would otherwise leave a zero-area sliver with that vertex on its edge
    std::vector<Vec2> points(st.verts.size());
    for (std::size_t i = 0; i < st.verts.size(); ++i) points[i] = st.verts[i].p;
    st.segments = route_segments(points, st.segments, h, scale);
    return st;
}

// A meshed region in an order that depends on its mesh alone: its vertices by position
// (lexicographic), its triangles by their vertices (each starting at its smallest, orientation
// kept). CGAL's triangulation numbers vertices by their memory addresses, so without this two
// runs of the same bake, or two MPI ranks, wrote the same triangles in different orders.
void canonical_order(MeshedRegion& m) {
    std::vector<std::uint32_t> order(m.positions.size());
    std::iota(order.begin(), order.end(), 0u);
    std::sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
        return lexicographically_less(m.positions[a], m.positions[b]);
    });
    std::vector<std::uint32_t> rank(order.size());
    MeshedRegion sorted;
    sorted.positions.reserve(order.size());
    for (std::uint32_t k = 0; k < order.size(); ++k) {
        rank[order[k]] = k;
        sorted.positions.push_back(m.positions[order[k]]);
        if (!m.source_vertex.empty()) sorted.source_vertex.push_back(m.source_vertex[order[k]]);
    }
    sorted.triangles.reserve(m.triangles.size());
    for (const glm::u32vec3& t : m.triangles) {
        glm::u32vec3 u(rank[t.x], rank[t.y], rank[t.z]);
        while (u.x > u.y || u.x > u.z) u = glm::u32vec3(u.y, u.z, u.x);
        sorted.triangles.push_back(u);
    }
    std::sort(sorted.triangles.begin(), sorted.triangles.end(),
              [](const glm::u32vec3& a, const glm::u32vec3& b) {
                  return std::tie(a.x, a.y, a.z) < std::tie(b.x, b.y, b.z);
              });
    m = std::move(sorted);
}

// Bytes for MeshSharing::all_gather: trivially copyable values and vectors of them, appended
// and read back in the same order.
class Bytes {
  public:
    template <typename T>
    void put(const T& value) {
        const auto* p = reinterpret_cast<const std::byte*>(&value);
        m_bytes.insert(m_bytes.end(), p, p + sizeof(T));
    }
    template <typename T>
    void put_all(const std::vector<T>& values) {
        put(static_cast<std::uint64_t>(values.size()));
        const auto* p = reinterpret_cast<const std::byte*>(values.data());
        m_bytes.insert(m_bytes.end(), p, p + values.size() * sizeof(T));
    }
    std::span<const std::byte> view() const { return m_bytes; }

  private:
    std::vector<std::byte> m_bytes;
};

class Reader {
  public:
    explicit Reader(std::span<const std::byte> bytes) : m_bytes(bytes) {}
    bool done() const { return m_at == m_bytes.size(); }
    template <typename T>
    T get() {
        T value;
        take(&value, sizeof(T));
        return value;
    }
    template <typename T>
    std::vector<T> get_all() {
        std::vector<T> values(get<std::uint64_t>());
        take(values.data(), values.size() * sizeof(T));
        return values;
    }

  private:
    void take(void* to, std::size_t n) {
        if (n > m_bytes.size() - m_at)
            throw std::logic_error("mesh_regions: a process's exchange ended early");
        if (n > 0) std::memcpy(to, m_bytes.data() + m_at, n);
        m_at += n;
    }
    std::span<const std::byte> m_bytes;
    std::size_t m_at = 0;
};

}  // namespace

std::vector<MeshedRegion> mesh_regions(std::span<const PlanarRegion> regions,
                                       const DmOptions& options, DmStats* stats,
                                       MeshSharing* sharing) {
    // Check the options and the regions
    if (!(options.min_angle_deg >= 0.0 && options.min_angle_deg <= 20.7))
        throw std::invalid_argument("mesh_regions: min_angle_deg " +
                                    std::to_string(options.min_angle_deg) +
                                    " is outside [0, 20.7]");
    if (!(options.merge_distance >= 0.0) || !std::isfinite(options.merge_distance))
        throw std::invalid_argument("mesh_regions: merge_distance " +
                                    std::to_string(options.merge_distance) +
                                    " must be finite and >= 0");
    const double h = options.merge_distance;
    DmStats total;
    const std::size_t n = regions.size();
    std::vector<RegionSetup> setups(n);
    for (std::size_t r = 0; r < n; ++r) {
        const PlanarRegion& region = regions[r];
        const std::string where = "mesh_regions: region " + std::to_string(r);
        const double nl = glm::length(region.normal);
        if (!std::isfinite(nl) || !(nl > 0.0))
            throw std::invalid_argument(where + ": zero or non-finite normal");
        for (const glm::dvec3& p : region.positions)
            if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
                throw std::invalid_argument(where + ": non-finite vertex position");
        for (const glm::u32vec3& t : region.triangles)
            for (int k = 0; k < 3; ++k)
                if (t[k] >= region.positions.size())
                    throw std::invalid_argument(
                        where + ": triangle index " + std::to_string(t[k]) + " out of range (" +
                        std::to_string(region.positions.size()) + " positions)");
        total.triangles_in += region.triangles.size();
        total.constraints_in += region.constraints.size();
        if (region.triangles.empty()) continue;
        setups[r].frame = make_frame(region.normal, region.positions[region.triangles[0][0]]);

        // Boundary edges: triangle edges used an odd number of times
        std::unordered_map<std::uint64_t, std::uint32_t> count;
        for (const glm::u32vec3& t : region.triangles)
            for (int k = 0; k < 3; ++k) {
                const std::uint32_t a = t[k], b = t[(k + 1) % 3];
                if (a == b) continue;
                ++count[(std::uint64_t{std::min(a, b)} << 32) | std::max(a, b)];
            }
        for (const auto& [key, c] : count)
            if (c % 2 == 1)
                setups[r].boundary.push_back({static_cast<std::uint32_t>(key >> 32),
                                              static_cast<std::uint32_t>(key & 0xFFFFFFFFu)});
        std::sort(setups[r].boundary.begin(), setups[r].boundary.end());
    }

    // All boundary edges in 3D, for the point-on-another-region's-edge tests
    struct EdgeRef {
        std::uint32_t region, edge;
    };
    std::vector<EdgeRef> edges;
    std::vector<Box> edge_boxes;
    for (std::size_t r = 0; r < n; ++r)
        for (std::size_t e = 0; e < setups[r].boundary.size(); ++e) {
            Box b;
            for (std::uint32_t k : setups[r].boundary[e]) b.grow(regions[r].positions[k]);
            b.inflate(h);
            edges.push_back({static_cast<std::uint32_t>(r), static_cast<std::uint32_t>(e)});
            edge_boxes.push_back(b);
        }
    const Bvh edge_bvh(std::move(edge_boxes));
    // Calls f(region, edge) for every boundary edge p lies on (within h, away from its ends)
    auto edges_through = [&](const glm::dvec3& p, auto&& f) {
        Box q;
        q.grow(p);
        edge_bvh.query(q, [&](std::uint32_t k) {
            const EdgeRef ref = edges[k];
            const auto& be = setups[ref.region].boundary[ref.edge];
            const glm::dvec3& a = regions[ref.region].positions[be[0]];
            const glm::dvec3& b = regions[ref.region].positions[be[1]];
            if (glm::distance(p, a) <= h || glm::distance(p, b) <= h || p == a || p == b) return;
            if (closest_on_segment(p, a, b).second > h * h) return;
            f(ref.region, ref.edge);
        });
    };

    // Round 0 split points: input vertices (of any region) on boundary edges
    std::vector<std::vector<SplitHit>> hits(n);
    for (std::size_t s = 0; s < n; ++s) {
        if (regions[s].triangles.empty()) continue;
        for (const glm::dvec3& p : regions[s].positions)
            edges_through(p, [&](std::uint32_t r, std::uint32_t e) { hits[r].push_back({e, p}); });
    }

    // Which regions this process meshes: all of them alone; shared, by the last call's
    // measured seconds or, at first, by size
    std::vector<char> mine(n, 1);
    if (sharing) {
        std::vector<double> cost(n, 0.0);
        for (std::size_t r = 0; r < n; ++r)
            cost[r] = sharing->seconds.size() == n
                          ? sharing->seconds[r] + 1e-6
                          : 1.0 + double(regions[r].triangles.size()) +
                                4.0 * double(regions[r].constraints.size()) +
                                double(regions[r].points.size());
        mine = sharing->mine(cost);
    }
    const auto all_gather = [&](const Bytes& bytes) {
        return sharing ? sharing->all_gather(bytes.view())
                       : std::vector<std::byte>(bytes.view().begin(), bytes.view().end());
    };

    std::vector<RegionState> states(n);
    std::vector<MeshedRegion> outputs(n);
    std::vector<PosSet> announced(n);
    std::vector<LocalStats> local(n);
    std::vector<double> seconds(n, 0.0);
    // Every region's boundary vertices, per boundary edge, on every process (from the process
    // that meshes it), for the conformity test below
    std::vector<std::vector<PosSet>> on_edge(n);
    std::vector<std::size_t> dirty;
    for (std::size_t r = 0; r < n; ++r)
        if (!regions[r].triangles.empty()) dirty.push_back(r);
    std::vector<std::vector<SplitHit>> pending(n);
    std::size_t round = 0;
    for (; round < kMaxRounds && !dirty.empty(); ++round) {
        const double angle = round < kRefineRounds ? options.min_angle_deg : 0.0;
        // What this process's regions announce: their boundary vertices not announced before
        std::vector<std::vector<SplitHit>> announce(n);
        tbb::parallel_for(std::size_t{0}, dirty.size(), [&](std::size_t k) {
            const std::size_t r = dirty[k];
            if (!mine[r]) {
                pending[r].clear();
                return;
            }
            const auto t0 = std::chrono::steady_clock::now();
            if (round == 0) {
                states[r] =
                    build_initial(regions[r], setups[r], hits[r], h, local[r], announced[r]);
            } else {
                // Add the neighbours' boundary vertices as split points
                RegionState& st = states[r];
                std::unordered_map<PosKey, std::uint32_t, PosKeyHash> by_pos;
                for (std::size_t i = 0; i < st.verts.size(); ++i)
                    by_pos.try_emplace(key_of(st.verts[i].pos), static_cast<std::uint32_t>(i));
                for (const SplitHit& hit : pending[r]) {
                    auto [it, fresh] = by_pos.try_emplace(
                        key_of(hit.pos), static_cast<std::uint32_t>(st.verts.size()));
                    if (fresh)
                        st.verts.push_back({setups[r].frame.project(hit.pos), hit.pos, kNewVertex});
                    const std::uint32_t id = it->second;
                    auto& s = st.edge_splits[hit.edge];
                    if (std::find(s.begin(), s.end(), id) == s.end()) s.push_back(id);
                    announced[r].insert(key_of(hit.pos));
                }
                pending[r].clear();
            }
            MeshRun run = triangulate(setups[r], states[r], angle, h);
            states[r] = std::move(run.next);
            outputs[r] = std::move(run.out);
            const RegionState& st = states[r];
            for (std::size_t e = 0; e < st.edge_splits.size(); ++e)
                for (std::uint32_t id : st.edge_splits[e])
                    if (announced[r].insert(key_of(st.verts[id].pos)).second)
                        announce[r].push_back({static_cast<std::uint32_t>(e), st.verts[id].pos});
            seconds[r] +=
                std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        });

        // Each meshed region's boundary vertices and announcements, to every process
        Bytes sent;
        for (const std::size_t r : dirty) {
            if (!mine[r]) continue;
            const RegionState& st = states[r];
            sent.put(static_cast<std::uint32_t>(r));
            sent.put(static_cast<std::uint32_t>(st.edge_splits.size()));
            for (const auto& ids : st.edge_splits) {
                std::vector<glm::dvec3> at;
                for (std::uint32_t id : ids) at.push_back(st.verts[id].pos);
                sent.put_all(at);
            }
            sent.put_all(announce[r]);
        }
        const std::vector<std::byte> received = all_gather(sent);
        for (Reader in(received); !in.done();) {
            const auto r = in.get<std::uint32_t>();
            on_edge[r].assign(in.get<std::uint32_t>(), {});
            for (PosSet& keys : on_edge[r])
                for (const glm::dvec3& p : in.get_all<glm::dvec3>()) keys.insert(key_of(p));
            announce[r] = in.get_all<SplitHit>();
        }

        // Announce new boundary vertices to every boundary edge they lie on
        std::vector<std::size_t> next_dirty;
        std::vector<char> is_dirty(n, 0);
        for (std::size_t r : dirty)
            for (const SplitHit& hit : announce[r])
                edges_through(hit.pos, [&](std::uint32_t r2, std::uint32_t e2) {
                    if (r2 == r && e2 == hit.edge) return;
                    if (on_edge[r2][e2].count(key_of(hit.pos))) return;
                    pending[r2].push_back({e2, hit.pos});
                    ++total.conformity_points;
                    if (!is_dirty[r2]) {
                        is_dirty[r2] = 1;
                        next_dirty.push_back(r2);
                    }
                });
        dirty = std::move(next_dirty);
    }
    total.rounds = round;

    // Every region's mesh, counters and seconds from the process that meshed it
    tbb::parallel_for(std::size_t{0}, n, [&](std::size_t r) {
        if (mine[r]) canonical_order(outputs[r]);
    });
    if (sharing) {
        Bytes sent;
        for (std::size_t r = 0; r < n; ++r) {
            if (!mine[r] || regions[r].triangles.empty()) continue;
            sent.put(static_cast<std::uint32_t>(r));
            sent.put_all(outputs[r].positions);
            sent.put_all(outputs[r].triangles);
            sent.put_all(outputs[r].source_vertex);
            sent.put(local[r]);
            sent.put(seconds[r]);
        }
        const std::vector<std::byte> received = sharing->all_gather(sent.view());
        for (Reader in(received); !in.done();) {
            const auto r = in.get<std::uint32_t>();
            outputs[r].positions = in.get_all<glm::dvec3>();
            outputs[r].triangles = in.get_all<glm::u32vec3>();
            outputs[r].source_vertex = in.get_all<std::uint32_t>();
            local[r] = in.get<LocalStats>();
            seconds[r] = in.get<double>();
        }
        sharing->seconds = seconds;
    }
    for (std::size_t r = 0; r < n; ++r) {
        total.triangles_out += outputs[r].triangles.size();
        total.constraints_dropped += local[r].dropped;
        total.points_merged += local[r].merged;
        // Round-0 split points that came from other regions' vertices are conformity points
        PosSet own;
        for (const glm::dvec3& p : regions[r].positions) own.insert(key_of(p));
        for (const SplitHit& hit : hits[r])
            total.conformity_points += own.count(key_of(hit.pos)) == 0 ? 1 : 0;
    }
    if (stats) *stats = total;
    return outputs;
}

// ---------------------------------------------------------------------------------------------
// Outlines

namespace {

/// Distance from q to the segment [a, b] (2D).
double distance_to_segment(Vec2 q, Vec2 a, Vec2 b) {
    const Vec2 d = b - a;
    const double dd = dot2(d, d);
    const double t = dd > 0.0 ? std::clamp(dot2(q - a, d) / dd, 0.0, 1.0) : 0.0;
    return len2(q - (a + t * d));
}

/// The outline's edges: chains of boundary vertices between vertices where the boundary
/// branches (or, around a loop without one, from its sharpest corner), each chain cut into the
/// fewest straight runs within `tolerance` of their chord, greedily.
std::vector<std::array<std::uint32_t, 2>> outline_edges(
    const std::vector<std::array<std::uint32_t, 2>>& boundary, const std::vector<Vec2>& p,
    double tolerance) {
    std::unordered_map<std::uint32_t, std::vector<std::uint32_t>> around;  // vertex -> edges
    for (std::uint32_t e = 0; e < boundary.size(); ++e)
        for (const std::uint32_t v : boundary[e]) around[v].push_back(e);
    std::vector<char> used(boundary.size(), 0);
    std::vector<std::array<std::uint32_t, 2>> out;
    const auto other = [&](std::uint32_t e, std::uint32_t v) {
        return boundary[e][0] == v ? boundary[e][1] : boundary[e][0];
    };
    // Walks from anchor `a` along edge `e` to the next anchor (or back to `a`)
    const auto walk = [&](std::uint32_t a, std::uint32_t e) {
        std::vector<std::uint32_t> chain{a};
        std::uint32_t v = a;
        for (;;) {
            used[e] = 1;
            v = other(e, v);
            chain.push_back(v);
            const std::vector<std::uint32_t>& es = around[v];
            if (v == a || es.size() != 2) break;
            e = es[0] == e ? es[1] : es[0];
            if (used[e]) break;
        }
        // The fewest runs, greedily: each as long as its vertices stay near its chord (and at
        // most kMaxRun vertices long: the test is quadratic in a run's length)
        constexpr std::size_t kMaxRun = 512;
        std::size_t i = 0;
        while (i + 1 < chain.size()) {
            std::size_t j = i + 1;
            while (j + 1 < chain.size() && j - i < kMaxRun) {
                bool straight = true;
                for (std::size_t q = i + 1; q <= j && straight; ++q)
                    straight =
                        distance_to_segment(p[chain[q]], p[chain[i]], p[chain[j + 1]]) <= tolerance;
                if (!straight) break;
                ++j;
            }
            out.push_back({chain[i], chain[j]});
            i = j;
        }
    };
    for (const auto& [v, es] : around)
        if (es.size() != 2)
            for (const std::uint32_t e : es)
                if (!used[e]) walk(v, e);
    // Loops of two-edge vertices only: from the sharpest corner
    for (std::uint32_t e0 = 0; e0 < boundary.size(); ++e0) {
        if (used[e0]) continue;
        std::uint32_t best = boundary[e0][0], v = best, e = e0;
        double sharpest = -1.0;
        for (std::size_t guard = 0; guard <= boundary.size(); ++guard) {
            const std::uint32_t w = other(e, v);
            const std::vector<std::uint32_t>& es = around[w];
            const std::uint32_t f = es[0] == e ? es[1] : es[0];
            const Vec2 in = p[w] - p[v], out_dir = p[other(f, w)] - p[w];
            const double n = len2(in) * len2(out_dir);
            const double turn = n > 0.0 ? std::abs(cross2(in, out_dir)) / n : 0.0;
            if (turn > sharpest) {
                sharpest = turn;
                best = w;
            }
            v = w;
            e = f;
            if (e == e0) break;
        }
        const std::vector<std::uint32_t>& es = around[best];
        walk(best, used[es[0]] ? es[1] : es[0]);
    }
    return out;
}

}  // namespace

MeshedRegion outline_triangulation(const PlanarRegion& region, double tolerance) {
    const std::size_t nv = region.positions.size();
    if (region.triangles.size() < 3 || !(glm::length(region.normal) > 0.0)) return {};
    for (const glm::u32vec3& t : region.triangles)
        if (t.x >= nv || t.y >= nv || t.z >= nv) return {};
    const Frame frame = make_frame(region.normal, region.positions[region.triangles[0][0]]);
    std::vector<Vec2> p(nv);
    for (std::size_t i = 0; i < nv; ++i) p[i] = frame.project(region.positions[i]);

    // The boundary: edges of an odd number of triangles; the area the triangles cover
    std::unordered_map<std::uint64_t, int> uses;
    double area = 0.0;
    for (const glm::u32vec3& t : region.triangles) {
        area += 0.5 * std::abs(cross2(p[t.y] - p[t.x], p[t.z] - p[t.x]));
        for (int k = 0; k < 3; ++k) {
            const std::uint32_t a = t[k], b = t[(k + 1) % 3];
            ++uses[(std::uint64_t{std::min(a, b)} << 32) | std::max(a, b)];
        }
    }
    std::vector<std::array<std::uint32_t, 2>> boundary;
    for (const auto& [key, n] : uses)
        if (n % 2 == 1)
            boundary.push_back({static_cast<std::uint32_t>(key >> 32),
                                static_cast<std::uint32_t>(key & 0xFFFFFFFFu)});
    std::sort(boundary.begin(), boundary.end());  // the same outline whatever the hash order
    if (boundary.size() < 3 || !(area > 0.0)) return {};
    const std::vector<std::array<std::uint32_t, 2>> edges = outline_edges(boundary, p, tolerance);
    if (edges.size() < 3) return {};

    CdtO cdt;
    std::unordered_map<std::uint32_t, CdtO::Vertex_handle> vh;
    try {
        for (const auto& e : edges)
            for (const std::uint32_t v : e)
                if (!vh.count(v)) {
                    const CdtO::Vertex_handle h = cdt.insert(K::Point_2(p[v].x, p[v].y));
                    h->info() = v;
                    vh[v] = h;
                }
        for (const auto& e : edges)
            if (vh.at(e[0]) != vh.at(e[1])) cdt.insert_constraint(vh.at(e[0]), vh.at(e[1]));
    } catch (const std::exception&) {
        return {};  // outlines that cross: keep the triangles
    }
    if (cdt.dimension() < 2) return {};

    // Inside: an odd number of outline edges crossed from the infinite faces
    flood_parity(cdt, [](CdtO::Face_handle f, int i) { return f->is_constrained(i); });

    MeshedRegion out;
    std::unordered_map<std::uint32_t, std::uint32_t> local;
    double covered = 0.0;
    for (auto f = cdt.finite_faces_begin(); f != cdt.finite_faces_end(); ++f) {
        if (f->info().parity != 1) continue;
        glm::u32vec3 t;
        for (int k = 0; k < 3; ++k) {
            const std::uint32_t v = f->vertex(k)->info();
            const auto [it, added] = local.try_emplace(v, static_cast<std::uint32_t>(nv));
            if (added) {
                it->second = static_cast<std::uint32_t>(out.positions.size());
                out.positions.push_back(region.positions[v]);
                out.source_vertex.push_back(v);
            }
            t[k] = it->second;
        }
        covered += 0.5 * cross2(p[f->vertex(1)->info()] - p[f->vertex(0)->info()],
                                p[f->vertex(2)->info()] - p[f->vertex(0)->info()]);
        out.triangles.push_back(t);
    }
    if (out.triangles.size() >= region.triangles.size() ||
        !(std::abs(covered - area) <= 1e-6 * area))
        return {};
    return out;
}

}  // namespace abrad::radiosity
