// Healing shared by every reader: welding within a tolerance relative to the model's size,
// ear-clipping triangulation (Eberly, "Triangulation by Ear Clipping" 2002), removal of
// degenerate and duplicate triangles, consistent winding within each connected surface, and
// a report of coplanar overlapping faces (z-fighting). Every change is counted and noted.
//
// Numeric assumptions: welding snaps a vertex onto the first earlier vertex within the weld
// distance (grid hash of cell = weld distance, so the 27 neighbouring cells hold every
// candidate); representatives keep their exact coordinates, so survey coordinates lose
// nothing. Triangulation works in double precision in the polygon's Newell plane; its
// orientation tests are not exact predicates, so polygons that defeat them (self-
// intersecting, collinear runs) fall back to clipping the most convex corner, which always
// yields n - 2 triangles; zero-area ones are dropped and counted. Coplanarity for the overlap
// report uses a plane tolerance of the weld distance and a normal tolerance of 1e-6 rad²;
// planes are bucketed by quantised normal and offset, so two coplanar faces whose normals
// straddle a bucket boundary (differing by < 1e-6) can go unreported.

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <glm/vec2.hpp>
#include <limits>
#include <map>
#include <numeric>
#include <unordered_map>
#include <utility>

#include "abrad/hash.h"
#include "polygon_cdt.h"
#include "raw_model.h"

namespace abrad::convert::detail {

namespace {

constexpr double kDegenerateAreaFactor = 1e-12;  ///< × bbox diagonal², m²
constexpr double kNonPlanarTolerance = 1e-4;     ///< × polygon extent, before a note
constexpr double kOverlapAreaFraction = 1e-6;    ///< of the smaller triangle, to count
/// Polygons with more corners are triangulated by a constrained Delaunay triangulation.
constexpr std::size_t kEarClippingCorners = 256;
/// Most corners ear clipping takes (quadratic in them, cubic on self-intersecting polygons:
/// about a second at this size in the sanitizer build): the fallback for larger polygons that
/// the constrained triangulation refuses (self-intersecting, touching themselves) ends here.
constexpr std::size_t kMaxEarClippingCorners = 2048;

std::string format_general(double x) {
    std::array<char, 32> buf{};
    std::snprintf(buf.data(), buf.size(), "%.3g", x);
    return buf.data();
}

/// "where: message" for a place of the raw model.
std::string at(const RawModel& raw, std::size_t place, std::string_view message) {
    std::string s = raw.where ? raw.where(place) : raw.file;
    s += ": ";
    s += message;
    return s;
}

/// An ImportError at a place of the raw model (a line of an OBJ, a mesh face of an Assimp
/// file; raw.where names both, led by the file).
ImportError error_at(const RawModel& raw, std::size_t place, const std::string& message) {
    if (raw.source.format == "obj") return {raw.file, place, message};
    std::string where = raw.where ? raw.where(place) : raw.file;
    if (where.starts_with(raw.file)) where.erase(0, raw.file.size());
    while (!where.empty() && (where.front() == ':' || where.front() == ' ')) where.erase(0, 1);
    return {raw.file, 0, where.empty() ? message : where + ": " + message};
}

/// Exact position key for welding: bit patterns with -0 folded onto +0.
struct PositionKey {
    std::array<std::uint64_t, 3> bits;
    bool operator==(const PositionKey&) const = default;
};

PositionKey position_key(const glm::dvec3& p) {
    const auto bits = [](double x) { return std::bit_cast<std::uint64_t>(x == 0.0 ? 0.0 : x); };
    return {{bits(p.x), bits(p.y), bits(p.z)}};
}

struct PositionKeyHash {
    std::size_t operator()(const PositionKey& k) const {
        return static_cast<std::size_t>(
            mix_bits(k.bits[0] ^ mix_bits(k.bits[1] ^ mix_bits(k.bits[2]))));
    }
};

struct CellHash {
    std::size_t operator()(const std::array<std::int64_t, 3>& c) const {
        return static_cast<std::size_t>(
            mix_bits(static_cast<std::uint64_t>(c[0]) ^
                     mix_bits(static_cast<std::uint64_t>(c[1]) ^
                              mix_bits(static_cast<std::uint64_t>(c[2])))));
    }
};

struct TriangleKeyHash {
    std::size_t operator()(const std::array<std::uint32_t, 3>& k) const {
        return static_cast<std::size_t>(
            mix_bits((std::uint64_t{k[0]} << 32 | k[1]) ^
                     mix_bits(std::uint64_t{k[2]} + 0x9e3779b97f4a7c15ULL)));
    }
};

double triangle_area(const std::vector<glm::dvec3>& p, const glm::u32vec3& t) {
    return visdb::triangle_area(p[t.x], p[t.y], p[t.z]);
}

double orient(const glm::dvec2& a, const glm::dvec2& b, const glm::dvec2& c) {
    return (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
}

/// What triangulate() did with one polygon.
struct Triangulated {
    double off_plane = 0.0;  ///< farthest corner from the best-fit plane / polygon extent
    bool done = true;        ///< false: too large for ear clipping and not a proper polygon
};

/// Triangulates one polygon (welded vertex ids, no two cyclically consecutive ids equal, at
/// least 3) in its Newell plane: a constrained Delaunay triangulation when it has more than
/// kEarClippingCorners corners and is proper (polygon_cdt.h), else ear clipping, up to
/// kMaxEarClippingCorners. Appends exactly ids.size() - 2 triangles in the polygon's winding,
/// or none when `done` is false. Returns how far the farthest corner lies from the best-fit
/// plane relative to the polygon's extent (0 for triangles).
Triangulated triangulate(const std::vector<glm::dvec3>& positions,
                         const std::vector<std::uint32_t>& ids, std::vector<glm::u32vec3>& out) {
    const std::size_t n = ids.size();
    if (n == 3) {
        out.emplace_back(ids[0], ids[1], ids[2]);
        return {};
    }
    // Compute the centroid _c_ and the Newell normal _normal_ (twice the vector area)
    glm::dvec3 c{0.0};
    for (const std::uint32_t id : ids) c += positions[id];
    c /= static_cast<double>(n);
    glm::dvec3 normal{0.0};
    for (std::size_t i = 0; i < n; ++i) {
        normal += glm::cross(positions[ids[i]] - c, positions[ids[(i + 1) % n]] - c);
    }
    const double length = glm::length(normal);
    if (!(length > 0.0) || !std::isfinite(length)) {
        // No plane (all corners on a line): a fan; the caller drops the zero-area triangles
        for (std::size_t i = 1; i + 1 < n; ++i) out.emplace_back(ids[0], ids[i], ids[i + 1]);
        return {};
    }
    const glm::dvec3 w = normal / length;

    // Project onto the plane basis _u_, _v_ (u × v = w: the polygon turns counter-clockwise)
    const auto [u, v] = visdb::orthonormal_basis(w);
    std::vector<glm::dvec2> q(n);
    glm::dvec3 lo{std::numeric_limits<double>::max()};
    glm::dvec3 hi{std::numeric_limits<double>::lowest()};
    double off_plane = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
        const glm::dvec3 d = positions[ids[i]] - c;
        q[i] = {glm::dot(d, u), glm::dot(d, v)};
        off_plane = std::max(off_plane, std::abs(glm::dot(d, w)));
        lo = glm::min(lo, positions[ids[i]]);
        hi = glm::max(hi, positions[ids[i]]);
    }
    const double extent = glm::length(hi - lo);
    const double off = extent > 0.0 ? off_plane / extent : 0.0;

    // Triangulate a large polygon in O(n log n); ear clip it only when it is not proper
    if (n > kEarClippingCorners) {
        if (triangulate_polygon_cdt(q, ids, out)) return {off, true};
        if (n > kMaxEarClippingCorners) return {off, false};
    }

    // Clip ears from a doubly linked ring of corners
    std::vector<std::size_t> prev(n);
    std::vector<std::size_t> next(n);
    for (std::size_t i = 0; i < n; ++i) {
        prev[i] = (i + n - 1) % n;
        next[i] = (i + 1) % n;
    }
    // Does a corner other than a, b, c lie in triangle abc (closed if `inclusive`)? Corners at
    // the same vertex as a, b or c (the two ends of a bridge to a hole) do not count.
    const auto blocked = [&](std::size_t a, std::size_t b, std::size_t cc, bool inclusive) {
        for (std::size_t r = next[cc]; r != a; r = next[r]) {
            if (ids[r] == ids[a] || ids[r] == ids[b] || ids[r] == ids[cc]) continue;
            const double o1 = orient(q[a], q[b], q[r]);
            const double o2 = orient(q[b], q[cc], q[r]);
            const double o3 = orient(q[cc], q[a], q[r]);
            const bool inside = inclusive ? (o1 >= 0.0 && o2 >= 0.0 && o3 >= 0.0)
                                          : (o1 > 0.0 && o2 > 0.0 && o3 > 0.0);
            if (inside) return true;
        }
        return false;
    };
    const auto clip = [&](std::size_t b) {
        out.emplace_back(ids[prev[b]], ids[b], ids[next[b]]);
        next[prev[b]] = next[b];
        prev[next[b]] = prev[b];
    };
    std::size_t remaining = n;
    std::size_t cur = 0;
    std::size_t misses = 0;
    while (remaining > 3) {
        const std::size_t a = prev[cur];
        const std::size_t b = cur;
        const std::size_t cc = next[cur];
        if (orient(q[a], q[b], q[cc]) > 0.0 && !blocked(a, b, cc, true)) {
            clip(b);
            --remaining;
            cur = cc;
            misses = 0;
            continue;
        }
        cur = cc;
        if (++misses < remaining) continue;
        // No clean ear in a whole turn (self-intersection, collinear runs, rounding): clip a
        // convex-or-flat corner with no corner strictly inside, else the most convex corner
        std::size_t pick = n;
        std::size_t most_convex = cur;
        double best = std::numeric_limits<double>::lowest();
        std::size_t r = cur;
        for (std::size_t k = 0; k < remaining; ++k, r = next[r]) {
            const double o = orient(q[prev[r]], q[r], q[next[r]]);
            if (o > best) {
                best = o;
                most_convex = r;
            }
            if (pick == n && o >= 0.0 && !blocked(prev[r], r, next[r], false)) pick = r;
        }
        if (pick == n) pick = most_convex;
        cur = next[pick];
        clip(pick);
        --remaining;
        misses = 0;
    }
    out.emplace_back(ids[prev[cur]], ids[cur], ids[next[cur]]);
    return {off, true};
}

// ---------------------------------------------------------------------------------------------
// Welding

/// Maps every raw vertex to a welded one: first bit-identical positions, then (when
/// `distance` > 0) positions within `distance` of an earlier representative. Returns the
/// representatives; counts the near (not identical) merges in `near`.
std::vector<glm::dvec3> weld(const std::vector<glm::dvec3>& positions,
                             const std::vector<bool>& used, double distance,
                             std::vector<std::uint32_t>& weld_of, std::size_t& near) {
    std::vector<glm::dvec3> welded;
    weld_of.assign(positions.size(), 0);
    std::unordered_map<PositionKey, std::uint32_t, PositionKeyHash> exact;
    exact.reserve(positions.size());
    std::unordered_map<std::array<std::int64_t, 3>, std::vector<std::uint32_t>, CellHash> cells;
    const bool tolerant = distance > 0.0;
    const auto cell_of = [distance](const glm::dvec3& p) {
        return std::array<std::int64_t, 3>{static_cast<std::int64_t>(std::floor(p.x / distance)),
                                           static_cast<std::int64_t>(std::floor(p.y / distance)),
                                           static_cast<std::int64_t>(std::floor(p.z / distance))};
    };
    const double distance2 = distance * distance;
    near = 0;
    for (std::size_t i = 0; i < positions.size(); ++i) {
        const glm::dvec3& p = positions[i];
        const auto [it, inserted] =
            exact.try_emplace(position_key(p), static_cast<std::uint32_t>(welded.size()));
        if (!inserted) {
            weld_of[i] = it->second;
            continue;
        }
        if (tolerant && used[i]) {
            // Snap onto the nearest representative within the weld distance
            const auto c = cell_of(p);
            std::uint32_t best = std::numeric_limits<std::uint32_t>::max();
            double best_d2 = distance2;
            for (std::int64_t dx = -1; dx <= 1; ++dx)
                for (std::int64_t dy = -1; dy <= 1; ++dy)
                    for (std::int64_t dz = -1; dz <= 1; ++dz) {
                        const auto found = cells.find({c[0] + dx, c[1] + dy, c[2] + dz});
                        if (found == cells.end()) continue;
                        for (const std::uint32_t r : found->second) {
                            const glm::dvec3 d = welded[r] - p;
                            const double d2 = glm::dot(d, d);
                            if (d2 <= best_d2) {
                                best_d2 = d2;
                                best = r;
                            }
                        }
                    }
            if (best != std::numeric_limits<std::uint32_t>::max()) {
                it->second = best;
                weld_of[i] = best;
                ++near;
                continue;
            }
            cells[c].push_back(static_cast<std::uint32_t>(welded.size()));
        }
        weld_of[i] = static_cast<std::uint32_t>(welded.size());
        welded.push_back(p);
    }
    return welded;
}

// ---------------------------------------------------------------------------------------------
// Winding

struct EdgeUse {
    std::uint32_t triangle;
    bool forward;  ///< the triangle runs the edge from its smaller to its larger vertex id
};

/// Flips the minority (by area) of each connected, orientable piece of `tris` so that every
/// manifold edge (exactly two triangles) is run in opposite directions. Returns the number of
/// triangles flipped.
std::size_t make_winding_consistent(const std::vector<glm::dvec3>& positions,
                                    std::vector<glm::u32vec3>& tris) {
    if (tris.size() < 2) return 0;
    std::unordered_map<std::uint64_t, std::vector<EdgeUse>> edges;
    edges.reserve(tris.size() * 2);
    for (std::uint32_t t = 0; t < tris.size(); ++t) {
        for (int k = 0; k < 3; ++k) {
            const std::uint32_t a = tris[t][k];
            const std::uint32_t b = tris[t][(k + 1) % 3];
            const std::uint64_t key = std::uint64_t{std::min(a, b)} << 32 | std::max(a, b);
            edges[key].push_back({t, a < b});
        }
    }
    // Orientation relative to the piece's seed: flip[t] = true means t disagrees with it
    std::vector<int> state(tris.size(), -1);  // -1 unvisited, 0 keep, 1 flip
    std::vector<std::uint32_t> stack;
    std::size_t flipped = 0;
    for (std::uint32_t seed = 0; seed < tris.size(); ++seed) {
        if (state[seed] >= 0) continue;
        std::vector<std::uint32_t> piece;
        bool orientable = true;
        state[seed] = 0;
        stack.push_back(seed);
        while (!stack.empty()) {
            const std::uint32_t t = stack.back();
            stack.pop_back();
            piece.push_back(t);
            for (int k = 0; k < 3; ++k) {
                const std::uint32_t a = tris[t][k];
                const std::uint32_t b = tris[t][(k + 1) % 3];
                const auto& uses = edges[std::uint64_t{std::min(a, b)} << 32 | std::max(a, b)];
                if (uses.size() != 2) continue;  // boundary or non-manifold: no constraint
                const EdgeUse& mine = uses[0].triangle == t ? uses[0] : uses[1];
                const EdgeUse& other = uses[0].triangle == t ? uses[1] : uses[0];
                if (other.triangle == t) continue;
                // Consistent neighbours run the shared edge in opposite directions
                const bool my_dir = mine.forward != (state[t] == 1);
                const int want = (other.forward == my_dir) ? 1 : 0;
                if (state[other.triangle] < 0) {
                    state[other.triangle] = want;
                    stack.push_back(other.triangle);
                } else if (state[other.triangle] != want) {
                    orientable = false;  // a Möbius-like piece: leave it as it is
                }
            }
        }
        if (!orientable) {
            for (const std::uint32_t t : piece) state[t] = 0;
            continue;
        }
        double keep_area = 0.0;
        double flip_area = 0.0;
        for (const std::uint32_t t : piece)
            (state[t] == 1 ? flip_area : keep_area) += triangle_area(positions, tris[t]);
        const int minority = flip_area <= keep_area ? 1 : 0;
        for (const std::uint32_t t : piece) {
            if (state[t] != minority) continue;
            std::swap(tris[t].y, tris[t].z);
            ++flipped;
        }
    }
    return flipped;
}

// ---------------------------------------------------------------------------------------------
// Coplanar overlaps

/// Area of the intersection of two triangles given in the same 2D frame (convex clipping).
double overlap_area(std::array<glm::dvec2, 3> a, std::array<glm::dvec2, 3> b) {
    const auto ccw = [](std::array<glm::dvec2, 3>& t) {
        if (orient(t[0], t[1], t[2]) < 0.0) std::swap(t[1], t[2]);
    };
    ccw(a);
    ccw(b);
    std::vector<glm::dvec2> poly(a.begin(), a.end());
    std::vector<glm::dvec2> next;
    for (int e = 0; e < 3 && !poly.empty(); ++e) {
        const glm::dvec2 p = b[e];
        const glm::dvec2 q = b[(e + 1) % 3];
        next.clear();
        for (std::size_t i = 0; i < poly.size(); ++i) {
            const glm::dvec2 s = poly[i];
            const glm::dvec2 t = poly[(i + 1) % poly.size()];
            const double ds = orient(p, q, s);
            const double dt = orient(p, q, t);
            if (ds >= 0.0) next.push_back(s);
            if ((ds >= 0.0) != (dt >= 0.0)) next.push_back(s + (t - s) * (ds / (ds - dt)));
        }
        poly.swap(next);
    }
    double area = 0.0;
    for (std::size_t i = 0; i < poly.size(); ++i) {
        const glm::dvec2& s = poly[i];
        const glm::dvec2& t = poly[(i + 1) % poly.size()];
        area += s.x * t.y - s.y * t.x;
    }
    return 0.5 * std::abs(area);
}

struct FlatTriangle {
    std::uint32_t slot;
    glm::u32vec3 ids;
    glm::dvec3 normal;  ///< unit, the front
    double area;
    std::uint32_t face;  ///< the face (polygon) it was triangulated from
};

struct OverlapTally {
    std::size_t pairs = 0;
    double area = 0.0;
};

/// A triangle of find_overlaps' plane group in the plane's frame.
struct OverlapItem {
    std::uint32_t index = 0;  ///< into the FlatTriangles
    bool own = false;         ///< in the group's own offset cell (not the next one)
    std::array<glm::dvec2, 3> q{};
    glm::dvec2 lo{0.0}, hi{0.0};  ///< box of q
};

/// The box of a face's triangles in the plane's frame, and those triangles (OverlapItems).
struct FaceBox {
    glm::dvec2 lo{std::numeric_limits<double>::max()};
    glm::dvec2 hi{std::numeric_limits<double>::lowest()};
    std::vector<std::uint32_t> items;
};

/// Adds the overlapping pairs of one group of nearly coplanar triangles (`group`, indices into
/// `tris`; the first `own` in the group's own offset cell) to `tally`.
void tally_group(const std::vector<glm::dvec3>& positions, const std::vector<FlatTriangle>& tris,
                 const std::vector<std::uint32_t>& group, std::size_t own, double tolerance,
                 std::map<std::pair<std::uint32_t, std::uint32_t>, OverlapTally>& tally) {
    const glm::dvec3 w = tris[group[0]].normal;
    const auto [u, v] = visdb::orthonormal_basis(w);
    // The triangles in the plane's (u, v) frame, and their faces' boxes
    std::vector<OverlapItem> items(group.size());
    std::map<std::uint32_t, FaceBox> faces;
    for (std::size_t g = 0; g < group.size(); ++g) {
        const FlatTriangle& t = tris[group[g]];
        OverlapItem& item = items[g];
        item.index = group[g];
        item.own = g < own;
        for (int k = 0; k < 3; ++k) {
            const glm::dvec3& p = positions[t.ids[k]];
            item.q[k] = {glm::dot(p, u), glm::dot(p, v)};
        }
        item.lo = glm::min(item.q[0], glm::min(item.q[1], item.q[2]));
        item.hi = glm::max(item.q[0], glm::max(item.q[1], item.q[2]));
        FaceBox& box = faces[t.face];
        for (const glm::dvec2& q : item.q) {
            box.lo = glm::min(box.lo, q);
            box.hi = glm::max(box.hi, q);
        }
        box.items.push_back(static_cast<std::uint32_t>(g));
    }
    // Sweep the faces along u: the triangles of one large polygon (long fans across it)
    // are compared with other faces' only, never with each other's thousands
    std::vector<const FaceBox*> order;
    order.reserve(faces.size());
    for (const auto& [face, box] : faces) order.push_back(&box);
    std::sort(order.begin(), order.end(),
              [](const FaceBox* a, const FaceBox* b) { return a->lo.x < b->lo.x; });
    const auto compare = [&](const OverlapItem& a, const OverlapItem& b) {
        if (!a.own && !b.own) return;  // both in the next cell: counted there
        if (a.hi.x <= b.lo.x || b.hi.x <= a.lo.x || a.hi.y <= b.lo.y || b.hi.y <= a.lo.y) return;
        const FlatTriangle& ta = tris[a.index];
        const FlatTriangle& tb = tris[b.index];
        if (glm::dot(ta.normal, tb.normal) < 1.0 - 1e-6) return;
        for (int k = 0; k < 3; ++k)
            if (std::abs(glm::dot(ta.normal, positions[tb.ids[k]] - positions[ta.ids.x])) >
                tolerance)
                return;
        const double area = overlap_area(a.q, b.q);
        if (area <= kOverlapAreaFraction * std::min(ta.area, tb.area)) return;
        OverlapTally& t = tally[{std::min(ta.slot, tb.slot), std::max(ta.slot, tb.slot)}];
        ++t.pairs;
        t.area += area;
    };
    for (std::size_t i = 0; i < order.size(); ++i) {
        const FaceBox& a = *order[i];
        // Within a face: only a small one's triangles (ear clipping of a polygon that is
        // not proper can fold them over each other; a constrained triangulation cannot;
        // the ear-clipped fallback of 257 to 2,048 corners is not compared with itself)
        if (a.items.size() <= kEarClippingCorners)
            for (std::size_t x = 0; x < a.items.size(); ++x)
                for (std::size_t y = x + 1; y < a.items.size(); ++y)
                    compare(items[a.items[x]], items[a.items[y]]);
        for (std::size_t j = i + 1; j < order.size() && order[j]->lo.x < a.hi.x; ++j) {
            const FaceBox& b = *order[j];
            if (a.hi.y <= b.lo.y || b.hi.y <= a.lo.y) continue;
            for (const std::uint32_t x : a.items)
                for (const std::uint32_t y : b.items) compare(items[x], items[y]);
        }
    }
}

/// Counts pairs of coplanar, same-facing triangles that overlap in area (z-fighting), per
/// pair of slots. `tolerance` is the distance within which points count as on a plane.
std::map<std::pair<std::uint32_t, std::uint32_t>, OverlapTally> find_overlaps(
    const std::vector<glm::dvec3>& positions, const std::vector<FlatTriangle>& tris,
    double tolerance) {
    std::map<std::pair<std::uint32_t, std::uint32_t>, OverlapTally> tally;
    if (tris.size() < 2 || !(tolerance > 0.0)) return tally;
    // Bucket by quantised normal and plane offset; a plane is looked up in its offset cell and
    // the two neighbouring ones
    constexpr double kNormalQuantum = 1e-3;
    using Key = std::array<std::int64_t, 4>;
    std::map<Key, std::vector<std::uint32_t>> buckets;
    for (std::uint32_t i = 0; i < tris.size(); ++i) {
        const glm::dvec3 n = tris[i].normal;
        const double d = glm::dot(n, positions[tris[i].ids.x]);
        buckets[{std::llround(n.x / kNormalQuantum), std::llround(n.y / kNormalQuantum),
                 std::llround(n.z / kNormalQuantum),
                 static_cast<std::int64_t>(std::floor(d / tolerance))}]
            .push_back(i);
    }
    std::vector<std::uint32_t> group;
    for (auto it = buckets.begin(); it != buckets.end(); ++it) {
        // Gather this cell and the next offset cell (each neighbouring pair of cells once)
        group = it->second;
        const std::size_t own = group.size();
        Key up = it->first;
        ++up[3];
        if (const auto n = buckets.find(up); n != buckets.end())
            group.insert(group.end(), n->second.begin(), n->second.end());
        if (group.size() < 2) continue;
        tally_group(positions, tris, group, own, tolerance, tally);
    }
    return tally;
}

}  // namespace

// ---------------------------------------------------------------------------------------------

visdb::Scene heal(const RawModel& raw, const HealOptions& options, ImportReport& report) {
    const std::string& file = raw.file;
    report.vertices_read = raw.positions.size();
    report.faces_read = raw.faces.size();
    if (raw.faces.empty()) throw ImportError(file, 0, "no faces to import");

    // Bound the used vertices: the weld distance and the degenerate area follow the model size
    std::vector<bool> used(raw.positions.size(), false);
    for (const std::uint32_t corner : raw.corners) used[corner] = true;
    report.unused_vertices = static_cast<std::size_t>(std::count(used.begin(), used.end(), false));
    glm::dvec3 lo{std::numeric_limits<double>::max()};
    glm::dvec3 hi{std::numeric_limits<double>::lowest()};
    for (std::size_t i = 0; i < used.size(); ++i) {
        if (!used[i]) continue;
        lo = glm::min(lo, raw.positions[i]);
        hi = glm::max(hi, raw.positions[i]);
    }
    const double diagonal = glm::length(hi - lo);
    const double min_area = kDegenerateAreaFactor * diagonal * diagonal;
    report.weld_distance = std::max(0.0, options.weld_tolerance) * diagonal;

    // Weld equal positions, then positions within the weld distance
    std::vector<std::uint32_t> weld_of;
    const std::vector<glm::dvec3> welded =
        weld(raw.positions, used, report.weld_distance, weld_of, report.vertices_welded_near);
    report.vertices_welded = raw.positions.size() - welded.size();

    // Triangulate each face, then drop degenerate and duplicate triangles
    CappedNotes degenerate_notes(report.notes, "faces with degenerate triangles");
    CappedNotes duplicate_notes(report.notes, "faces with duplicate triangles");
    CappedNotes planarity_notes(report.notes, "non-planar polygons triangulated");
    std::vector<std::vector<glm::u32vec3>> slot_triangles(raw.slots.size());
    std::vector<std::vector<std::uint32_t>> slot_faces(raw.slots.size());  // face of each
    std::unordered_map<std::array<std::uint32_t, 3>, std::size_t, TriangleKeyHash> seen;
    std::vector<std::uint32_t> ids;
    std::vector<glm::u32vec3> triangles;
    for (const RawFace& face : raw.faces) {
        if (face.count > 3) ++report.polygons_triangulated;
        // Drop corners repeating the previous one (each would make one zero-area triangle)
        ids.clear();
        for (std::size_t k = 0; k < face.count; ++k) {
            const std::uint32_t id = weld_of[raw.corners[face.first + k]];
            if (ids.empty() || ids.back() != id) ids.push_back(id);
        }
        while (ids.size() > 1 && ids.front() == ids.back()) ids.pop_back();
        const std::size_t corner_triangles = face.count >= 3 ? face.count - 2 : 0;
        if (ids.size() < 3) {
            report.degenerate_dropped += corner_triangles;
            degenerate_notes.add(at(raw, face.place,
                                    "face has fewer than 3 distinct vertices; " +
                                        std::to_string(corner_triangles) +
                                        " degenerate triangle(s) dropped"));
            continue;
        }
        if (ids.size() < face.count) {
            report.degenerate_dropped += face.count - ids.size();
            degenerate_notes.add(at(raw, face.place,
                                    "repeated vertex in face; " +
                                        std::to_string(face.count - ids.size()) +
                                        " degenerate triangle(s) dropped"));
        }
        triangles.clear();
        const auto [off_plane, done] = triangulate(welded, ids, triangles);
        if (!done) {
            throw error_at(raw, face.place,
                           "polygon with " + std::to_string(ids.size()) +
                               " corners whose edges cross or touch (a proper polygon may "
                               "have any number of corners; one that is not, at most " +
                               std::to_string(kMaxEarClippingCorners) +
                               "); split it into simple faces");
        }
        if (off_plane > kNonPlanarTolerance) {
            ++report.non_planar_polygons;
            planarity_notes.add(at(raw, face.place,
                                   "polygon not planar (corners " +
                                       format_general(off_plane * 100.0) +
                                       "% of its size off the best-fit plane); triangulated"));
        }
        std::size_t degenerate = 0;
        std::size_t duplicate = 0;
        std::size_t duplicate_of = 0;  // place of the first earlier face repeated
        for (const glm::u32vec3& t : triangles) {
            const bool repeated = t.x == t.y || t.y == t.z || t.x == t.z;
            const double area = repeated ? 0.0 : triangle_area(welded, t);
            if (repeated || area < min_area || area == 0.0) {
                ++degenerate;
                continue;
            }
            std::array<std::uint32_t, 3> key{t.x, t.y, t.z};
            std::sort(key.begin(), key.end());
            const auto [it, inserted] = seen.try_emplace(key, face.place);
            if (!inserted) {
                if (duplicate++ == 0) duplicate_of = it->second;
                continue;
            }
            slot_triangles[face.slot].push_back(t);
            slot_faces[face.slot].push_back(static_cast<std::uint32_t>(&face - raw.faces.data()));
        }
        if (degenerate > 0) {
            report.degenerate_dropped += degenerate;
            degenerate_notes.add(
                at(raw, face.place,
                   std::to_string(degenerate) + " degenerate (zero-area) triangle(s) dropped"));
        }
        if (duplicate > 0) {
            report.duplicates_dropped += duplicate;
            const std::string of = raw.where ? raw.where(duplicate_of) : file;
            duplicate_notes.add(at(raw, face.place,
                                   std::to_string(duplicate) +
                                       " triangle(s) repeating the face at " + of + " dropped"));
        }
    }
    degenerate_notes.finish(file);
    duplicate_notes.finish(file);
    planarity_notes.finish(file);

    // Make winding consistent within each connected piece of every surface
    CappedNotes winding_notes(report.notes, "surfaces with flipped triangles");
    for (std::size_t s = 0; s < raw.slots.size(); ++s) {
        const std::size_t flipped = make_winding_consistent(welded, slot_triangles[s]);
        if (flipped == 0) continue;
        report.triangles_flipped += flipped;
        ++report.surfaces_flipped;
        winding_notes.add(at(raw, raw.slots[s].place,
                             "surface " + quote(raw.slots[s].name) + ": " +
                                 std::to_string(flipped) + " of " +
                                 std::to_string(slot_triangles[s].size()) +
                                 " triangles flipped to agree with their neighbours"));
    }
    winding_notes.finish(file);

    // Report coplanar overlapping faces (z-fighting)
    {
        std::vector<FlatTriangle> flat;
        for (std::size_t s = 0; s < raw.slots.size(); ++s) {
            for (std::size_t k = 0; k < slot_triangles[s].size(); ++k) {
                const glm::u32vec3& t = slot_triangles[s][k];
                const glm::dvec3 n =
                    glm::cross(welded[t.y] - welded[t.x], welded[t.z] - welded[t.x]);
                const double length = glm::length(n);
                flat.push_back(
                    {static_cast<std::uint32_t>(s), t, n / length, 0.5 * length, slot_faces[s][k]});
            }
        }
        const double tolerance = std::max(report.weld_distance, 1e-9 * diagonal);
        CappedNotes overlap_notes(report.notes, "pairs of surfaces with coplanar overlaps");
        for (const auto& [slots, tally] : find_overlaps(welded, flat, tolerance)) {
            report.overlapping_pairs += tally.pairs;
            const RawSlot& a = raw.slots[slots.first];
            const RawSlot& b = raw.slots[slots.second];
            const std::string what =
                slots.first == slots.second
                    ? "surface " + quote(a.name) + " overlaps itself"
                    : "surfaces " + quote(a.name) + " and " + quote(b.name) + " overlap";
            overlap_notes.add(at(raw, b.place,
                                 what + " coplanar, facing the same way (z-fighting): " +
                                     std::to_string(tally.pairs) + " triangle pair(s), " +
                                     format_general(tally.area) + " m²"));
        }
        overlap_notes.finish(file);
    }

    // Assemble surfaces with compact vertex arrays, and the materials they use
    visdb::Scene scene;
    std::unordered_map<std::string, std::uint32_t> defined;
    for (std::size_t m = 0; m < raw.materials.size(); ++m)
        defined.try_emplace(raw.materials[m].name, static_cast<std::uint32_t>(m));
    std::unordered_map<std::string, std::uint32_t> material_index;
    std::vector<std::uint32_t> local(welded.size(), std::numeric_limits<std::uint32_t>::max());
    for (std::size_t s = 0; s < raw.slots.size(); ++s) {
        const RawSlot& slot = raw.slots[s];
        std::vector<glm::u32vec3>& tris = slot_triangles[s];
        if (tris.empty()) {
            report.notes.push_back(at(raw, slot.place,
                                      "surface " + quote(slot.name) + " with material " +
                                          quote(slot.material) +
                                          " has no triangles left; omitted"));
            continue;
        }
        const auto [mit, added] = material_index.try_emplace(
            slot.material, static_cast<std::uint32_t>(scene.materials.size()));
        if (added) {
            const auto d = defined.find(slot.material);
            visdb::Material m = d != defined.end() ? raw.materials[d->second] : visdb::Material{};
            m.name = slot.material;
            scene.materials.push_back(std::move(m));
        }
        visdb::Surface surface;
        surface.name = slot.name;
        surface.layer = slot.layer;
        surface.material = mit->second;
        surface.source = 0;
        std::vector<std::uint32_t> touched;
        for (glm::u32vec3& t : tris) {
            for (int k = 0; k < 3; ++k) {
                std::uint32_t& l = local[t[k]];
                if (l == std::numeric_limits<std::uint32_t>::max()) {
                    l = static_cast<std::uint32_t>(surface.mesh.positions.size());
                    surface.mesh.positions.push_back(welded[t[k]]);
                    touched.push_back(t[k]);
                }
                t[k] = l;
            }
        }
        for (const std::uint32_t id : touched)
            local[id] = std::numeric_limits<std::uint32_t>::max();
        surface.mesh.triangles = std::move(tris);
        report.triangles += surface.mesh.triangles.size();
        if (scene.materials[surface.material].is_emitter()) {
            report.emitter_triangles += surface.mesh.triangles.size();
        }
        scene.surfaces.push_back(std::move(surface));
    }
    if (report.triangles == 0) {
        throw ImportError(file, 0,
                          "no triangles left after healing (" +
                              std::to_string(report.degenerate_dropped) + " degenerate, " +
                              std::to_string(report.duplicates_dropped) + " duplicate)");
    }
    scene.cameras = raw.cameras;
    return scene;
}

}  // namespace abrad::convert::detail
