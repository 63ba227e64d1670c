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
#include <glm/geometric.hpp>
#include <glm/vec2.hpp>
#include <limits>
#include <map>
#include <numeric>
#include <unordered_map>
#include <utility>

#include "raw_model.h"

namespace abrad::convert::detail {

namespace {

constexpr double kDegenerateAreaFactor = 1e-12;  ///< × bbox diagonal², m²
constexpr double kNonPlanarTolerance = 1e-4;     ///< × polygon extent, before a note
constexpr double kOverlapAreaFraction = 1e-6;    ///< of the smaller triangle, to count

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

std::uint64_t mix(std::uint64_t h) {
    // splitmix64 finaliser
    h ^= h >> 30;
    h *= 0xbf58476d1ce4e5b9ULL;
    h ^= h >> 27;
    h *= 0x94d049bb133111ebULL;
    h ^= h >> 31;
    return h;
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
        return static_cast<std::size_t>(mix(k.bits[0] ^ mix(k.bits[1] ^ mix(k.bits[2]))));
    }
};

struct CellHash {
    std::size_t operator()(const std::array<std::int64_t, 3>& c) const {
        return static_cast<std::size_t>(
            mix(static_cast<std::uint64_t>(c[0]) ^
                mix(static_cast<std::uint64_t>(c[1]) ^ mix(static_cast<std::uint64_t>(c[2])))));
    }
};

struct TriangleKeyHash {
    std::size_t operator()(const std::array<std::uint32_t, 3>& k) const {
        return static_cast<std::size_t>(mix((std::uint64_t{k[0]} << 32 | k[1]) ^
                                            mix(std::uint64_t{k[2]} + 0x9e3779b97f4a7c15ULL)));
    }
};

double triangle_area(const std::vector<glm::dvec3>& p, const glm::u32vec3& t) {
    return visdb::triangle_area(p[t.x], p[t.y], p[t.z]);
}

double orient(const glm::dvec2& a, const glm::dvec2& b, const glm::dvec2& c) {
    return (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
}

/// Triangulates one polygon (welded vertex ids, no two cyclically consecutive ids equal, at
/// least 3) by ear clipping in its Newell plane. Appends exactly ids.size() - 2 triangles in
/// the polygon's winding. Returns how far the farthest corner lies from the best-fit plane
/// relative to the polygon's extent (0 for triangles).
double triangulate(const std::vector<glm::dvec3>& positions, const std::vector<std::uint32_t>& ids,
                   std::vector<glm::u32vec3>& out) {
    const std::size_t n = ids.size();
    if (n == 3) {
        out.emplace_back(ids[0], ids[1], ids[2]);
        return 0.0;
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
        return 0.0;
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
    return extent > 0.0 ? off_plane / extent : 0.0;
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
};

struct OverlapTally {
    std::size_t pairs = 0;
    double area = 0.0;
};

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
        // Sweep along the plane's u axis; compare within the active window
        const glm::dvec3 w = tris[group[0]].normal;
        const auto [u, v] = visdb::orthonormal_basis(w);
        struct Item {
            double lo, hi, vlo, vhi;
            std::uint32_t index;
            bool own;
            std::array<glm::dvec2, 3> q;
        };
        std::vector<Item> items;
        items.reserve(group.size());
        for (std::size_t g = 0; g < group.size(); ++g) {
            const FlatTriangle& t = tris[group[g]];
            Item item{std::numeric_limits<double>::max(),
                      std::numeric_limits<double>::lowest(),
                      std::numeric_limits<double>::max(),
                      std::numeric_limits<double>::lowest(),
                      group[g],
                      g < own,
                      {}};
            for (int k = 0; k < 3; ++k) {
                const glm::dvec3& p = positions[t.ids[k]];
                item.q[k] = {glm::dot(p, u), glm::dot(p, v)};
                item.lo = std::min(item.lo, item.q[k].x);
                item.hi = std::max(item.hi, item.q[k].x);
                item.vlo = std::min(item.vlo, item.q[k].y);
                item.vhi = std::max(item.vhi, item.q[k].y);
            }
            items.push_back(item);
        }
        std::sort(items.begin(), items.end(),
                  [](const Item& a, const Item& b) { return a.lo < b.lo; });
        for (std::size_t i = 0; i < items.size(); ++i) {
            for (std::size_t j = i + 1; j < items.size() && items[j].lo < items[i].hi; ++j) {
                const Item& a = items[i];
                const Item& b = items[j];
                if (!a.own && !b.own) continue;  // both in the next cell: counted there
                if (a.vhi <= b.vlo || b.vhi <= a.vlo) continue;
                const FlatTriangle& ta = tris[a.index];
                const FlatTriangle& tb = tris[b.index];
                if (glm::dot(ta.normal, tb.normal) < 1.0 - 1e-6) continue;
                bool coplanar = true;
                for (int k = 0; k < 3 && coplanar; ++k)
                    coplanar =
                        std::abs(glm::dot(ta.normal, positions[tb.ids[k]] - positions[ta.ids.x])) <=
                        tolerance;
                if (!coplanar) continue;
                const double area = overlap_area(a.q, b.q);
                if (area <= kOverlapAreaFraction * std::min(ta.area, tb.area)) continue;
                OverlapTally& t = tally[{std::min(ta.slot, tb.slot), std::max(ta.slot, tb.slot)}];
                ++t.pairs;
                t.area += area;
            }
        }
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
        const double off_plane = triangulate(welded, ids, triangles);
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
            for (const glm::u32vec3& t : slot_triangles[s]) {
                const glm::dvec3 n =
                    glm::cross(welded[t.y] - welded[t.x], welded[t.z] - welded[t.x]);
                const double length = glm::length(n);
                flat.push_back({static_cast<std::uint32_t>(s), t, n / length, 0.5 * length});
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
