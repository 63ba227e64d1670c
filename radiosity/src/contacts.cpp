// Stage 1, before the bake mesh: the parts of faces pressed against another solid's face are
// hidden, and cut away (stages.h hide_contacts).
//
// A wall's top under the slab, its foot on the floor, a cupboard's bottom: two opaque faces
// in one plane, facing each other, where neither can receive or send light. Left in the
// mesh, the slab's underside is one planar region over every room of a storey, and the
// interreflection's elements (cells of a region's grid) straddle the walls: an element lit in
// one room shoots that light from its point in the next, and its mean over the hidden strip
// darkens the field interpolated into both rooms (the FZK-Haus ceiling exported 7.6 % below
// its solution with 0.5 m elements, 1.6 % with 0.25 m). Cut away, each room's ceiling is its
// own region, and no element spans a wall. The parts of faces lying inside another closed
// surface (a slab's strip inside an outer wall that runs on through it) are hidden too, and
// cut away the same way (Cutter::subtract_solids).

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <glm/geometric.hpp>
#include <map>
#include <utility>
#include <vector>

#include "abrad/radiosity/direct.h"
#include "abrad/radiosity/polygon.h"
#include "stages.h"

namespace abrad::radiosity {

namespace {

// Two faces touch when every corner of one lies within this fraction of the model's size of
// the other's plane (1e-5 m in a 10 m building), their normals opposite to cos 1 − 1e-6.
constexpr double kContactDistance = 1e-6;
constexpr double kOpposite = 1.0 - 1e-6;
// A face has a solid behind it when a vertex of its surface lies this fraction of the model's
// size behind its plane (a wall's top: the wall's foot; a back-to-back sheet has none)
constexpr double kSolidBehind = 1e-4;
// Pieces of less than this fraction of the model's size squared are rounding, not area
constexpr double kSliver = 1e-14;
// A part of a face is inside a solid when the point this many tolerances in front of its
// centre is
constexpr double kInFront = 4.0;

// The T-junction repair: triangles whose height is under this many tolerances are left as
// they are, and an input triangle is split at most this many times (a guard: tolerances
// could otherwise cycle among near-collinear vertices)
constexpr double kNeedle = 4.0;
constexpr int kMaxSplits = 256;

using Piece = FixedPolygon<glm::dvec3, 32>;

struct ContactFace {
    std::uint32_t surface = 0, triangle = 0;
    glm::dvec3 n{0.0};  // unit
};

double area_of(const Piece& p) { return glm::length(area_vector(p)); }

// `piece` less triangle `u` (its unit normal `n`, its plane `piece`'s): the parts outside each
// of u's edges in turn, convex; `overlap` set when some of `piece` lay inside u. A piece u
// does not overlap stays whole (u's edge lines would cut it for nothing).
void subtract(const Piece& piece, const glm::dvec3 (&u)[3], const glm::dvec3& n, double sliver,
              std::vector<Piece>& out, bool& overlap) {
    Piece outside[3];
    int parts = 0;
    Piece rest = piece;  // ends as piece ∩ u
    for (int k = 0; k < 3 && !rest.empty(); ++k) {
        const glm::dvec3 a = u[k], inward = glm::cross(n, u[(k + 1) % 3] - a);
        const Piece part =
            clip_polygon(rest, [&](const glm::dvec3& x) { return -glm::dot(inward, x - a); });
        if (part.size() >= 3 && area_of(part) > sliver) outside[parts++] = part;
        rest = clip_polygon(rest, [&](const glm::dvec3& x) { return glm::dot(inward, x - a); });
    }
    if (rest.size() < 3 || !(area_of(rest) > sliver)) {
        out.push_back(piece);
        return;
    }
    overlap = true;
    out.insert(out.end(), outside, outside + parts);
}

// Splits triangles at the vertices lying inside their edges (where a cut neighbour made
// them), so that the mesh has no T-junctions.
void split_at_vertices(visdb::TriangleMesh& m, std::size_t first_new, double tol) {
    if (first_new == m.positions.size()) return;
    std::vector<Box> boxes;
    for (std::size_t v = first_new; v < m.positions.size(); ++v) {
        Box b;
        b.grow(m.positions[v]);
        b.inflate(tol);
        boxes.push_back(b);
    }
    const Bvh bvh(std::move(boxes));
    // The first vertex strictly inside an edge of t: (edge, vertex), or edge −1
    const auto on_edge = [&](const glm::u32vec3& t) -> std::pair<int, std::uint32_t> {
        for (int k = 0; k < 3; ++k) {
            const glm::dvec3 a = m.positions[t[k]], b = m.positions[t[(k + 1) % 3]];
            const double len2 = glm::dot(b - a, b - a);
            // A needle (its third corner within a few tol of the edge's line) is left as it
            // is: near-collinear vertices would split it into each other's needles
            const glm::dvec3 c = m.positions[t[(k + 2) % 3]];
            if (!(len2 > 0.0) ||
                glm::length(glm::cross(b - a, c - a)) <= kNeedle * tol * std::sqrt(len2))
                continue;
            Box q;
            q.grow(a);
            q.grow(b);
            q.inflate(tol);
            std::pair<int, std::uint32_t> found{-1, 0};
            bvh.query(q, [&](std::uint32_t i) {
                const auto v = static_cast<std::uint32_t>(first_new + i);
                if (found.first >= 0 || v == t.x || v == t.y || v == t.z) return;
                // Inside the edge, and further than tol from its ends
                const glm::dvec3 x = m.positions[v];
                const double s = glm::dot(x - a, b - a) / len2, len = std::sqrt(len2);
                if (s * len <= tol || (1.0 - s) * len <= tol) return;
                if (glm::length(a + s * (b - a) - x) <= tol) found = {k, v};
            });
            if (found.first >= 0) return found;
        }
        return {-1, 0};
    };
    // Depth first from each triangle, so that the output keeps the input's order
    std::vector<glm::u32vec3> out;
    out.reserve(m.triangles.size());
    std::vector<glm::u32vec3> stack;
    for (const glm::u32vec3& input : m.triangles) {
        stack.assign(1, input);
        for (int splits = 0; !stack.empty();) {
            const glm::u32vec3 t = stack.back();
            stack.pop_back();
            const auto [k, v] =
                splits < kMaxSplits ? on_edge(t) : std::pair<int, std::uint32_t>{-1, 0};
            ++splits;
            if (k < 0) {
                // A split's piece may be flat (its corners on one line in floating point,
                // where the input triangle was a near-needle): no area, left out
                const glm::dvec3 a = m.positions[t.x];
                if (t == input ||
                    glm::length(glm::cross(m.positions[t.y] - a, m.positions[t.z] - a)) > 0.0)
                    out.push_back(t);
                continue;
            }
            // t = (a, b, c) with v inside a–b: (a, v, c) and (v, b, c)
            const std::uint32_t a = t[k], b = t[(k + 1) % 3], c = t[(k + 2) % 3];
            stack.emplace_back(v, b, c);
            stack.emplace_back(a, v, c);
        }
    }
    m.triangles = std::move(out);
}

// A fan triangle under kNeedle tolerances high is rounding, not area.
bool needle(const Patch& p, double tol) {
    double longest = 0.0;
    for (int e = 0; e < 3; ++e)
        longest = std::max(longest, glm::distance(p.p[e], p.p[(e + 1) % 3]));
    return !(2.0 * area(p) > kNeedle * tol * longest);
}

// The scene's faces, which of them touch which, and the cuts.
class Cutter {
  public:
    Cutter(const visdb::Scene& scene, double size)
        : m_scene(scene),
          m_size(size),
          m_tol(kContactDistance * size),
          m_sliver(kSliver * size * size) {
        collect();
        if (m_faces.empty()) return;
        find_touching();
        m_solid.assign(m_faces.size(), -1);
    }

    ContactCut run() {
        ContactCut out;
        out.meshes.resize(m_scene.surfaces.size());
        // Faces are in surface order: [first, last) are surface s's
        std::size_t first = 0;
        for (std::size_t s = 0; s < m_scene.surfaces.size(); ++s) {
            std::size_t last = first;
            while (last < m_faces.size() && m_faces[last].surface == s) ++last;
            bool any = false;
            for (std::size_t i = first; i < last && !any; ++i) any = may_cut(i);
            if (any) cut_surface(static_cast<std::uint32_t>(s), first, last, out);
            first = last;
        }
        return out;
    }

  private:
    // Every face of the scene, with its patch for the BVH
    void collect() {
        for (std::size_t s = 0; s < m_scene.surfaces.size(); ++s) {
            m_first.push_back(m_faces.size());
            const visdb::TriangleMesh& m = m_scene.surfaces[s].mesh;
            for (std::size_t t = 0; t < m.triangles.size(); ++t) {
                const glm::u32vec3 tri = m.triangles[t];
                const Patch p{{m.positions.at(tri.x), m.positions.at(tri.y), m.positions.at(tri.z)},
                              1.0};
                const glm::dvec3 c = cross_normal(p);
                const double len = glm::length(c);
                if (!(len > 0.0) || !std::isfinite(len)) continue;
                m_faces.push_back(
                    {static_cast<std::uint32_t>(s), static_cast<std::uint32_t>(t), c / len});
                m_patches.push_back(p);
            }
        }
        m_first.push_back(m_faces.size());
    }

    bool opaque(const ContactFace& f) const {
        const visdb::Surface& s = m_scene.surfaces[f.surface];
        return s.material < m_scene.materials.size() &&
               m_scene.materials[s.material].opacity >= 1.0;
    }

    // Per face, the opaque faces of other surfaces lying on it and facing it
    void find_touching() {
        const Bvh bvh(m_patches);
        m_touching.resize(m_faces.size());
        m_crossing.resize(m_faces.size());
        tbb::parallel_for(std::size_t{0}, m_faces.size(), [&](std::size_t i) {
            const ContactFace& f = m_faces[i];
            const Patch& p = m_patches[i];
            Box box;
            for (const glm::dvec3& x : p.p) box.grow(x);
            box.inflate(m_tol);
            bvh.query(box, [&](std::uint32_t j) {
                const ContactFace& g = m_faces[j];
                if (g.surface == f.surface || !opaque(g)) return;
                // Per corner of g: in front of f's plane (beyond m_tol), or on it (within m_tol)
                int front = 0, on = 0;
                for (const glm::dvec3& x : m_patches[j].p) {
                    const double d = glm::dot(f.n, x - p.p[0]);
                    front += d > m_tol ? 1 : 0;
                    on += std::abs(d) <= m_tol ? 1 : 0;
                }
                if (front == 1 || front == 2) m_crossing[i].push_back(j);
                if (on == 3 && glm::dot(f.n, g.n) <= -kOpposite) m_touching[i].push_back(j);
            });
            // Ascending, and so by surface: faces are collected in surface order
            std::sort(m_touching[i].begin(), m_touching[i].end());
            std::sort(m_crossing[i].begin(), m_crossing[i].end());
        });
    }

    // True when x lies inside surface s's solid: the line through x crosses s's faces an odd
    // number of times on either side of x (a sheet, crossed at most once by a line, fails one
    // of them). The line's segment reaches past the model on both sides.
    bool inside_solid(std::uint32_t s, const glm::dvec3& x) const {
        // A direction no model edge or face is likely to hold
        const glm::dvec3 d = 2.0 * m_size * glm::normalize(glm::dvec3(0.5773, 0.6191, 0.5327));
        int forward = 0, backward = 0;
        for (std::size_t j = m_first[s]; j < m_first[s + 1]; ++j) {
            const double t = segment_crossing(m_patches[j], x - d, x + d);
            if (t >= 0.0) (t > 0.5 ? forward : backward) += 1;
        }
        return forward % 2 == 1 && backward % 2 == 1;
    }

    // Where face j crosses face i's plane, in that plane: the two points where j's edges pass
    // from in front of it (beyond m_tol) to not; false when j does not cross
    bool crossing_segment(std::size_t i, std::uint32_t j, glm::dvec3& a, glm::dvec3& b) const {
        const glm::dvec3& n = m_faces[i].n;
        const glm::dvec3& o = m_patches[i].p[0];
        const Patch& q = m_patches[j];
        double d[3];
        for (int k = 0; k < 3; ++k) d[k] = glm::dot(n, q.p[k] - o);
        glm::dvec3 points[2];
        int found = 0;
        for (int k = 0; k < 3 && found < 2; ++k) {
            const int l = (k + 1) % 3;
            if ((d[k] > m_tol) == (d[l] > m_tol)) continue;
            const double s = std::clamp(d[k] / (d[k] - d[l]), 0.0, 1.0);
            const glm::dvec3 x = q.p[k] + s * (q.p[l] - q.p[k]);
            points[found++] = x - glm::dot(n, x - o) * n;
        }
        if (found < 2 || glm::distance(points[0], points[1]) <= m_tol) return false;
        a = points[0];
        b = points[1];
        return true;
    }

    // Convex `piece` (wound about n) split by segment a–b where the segment runs through it
    void split_by(const Piece& piece, const glm::dvec3& n, const glm::dvec3& a, const glm::dvec3& b,
                  std::vector<Piece>& out) const {
        // The segment clipped to the piece: its parameter range inside every edge
        double lo = 0.0, hi = 1.0;
        for (std::size_t k = 0; k < piece.size() && lo < hi; ++k) {
            const glm::dvec3 p0 = piece[k],
                             inward = glm::cross(n, piece[(k + 1) % piece.size()] - p0);
            const double fa = glm::dot(inward, a - p0), fb = glm::dot(inward, b - p0);
            if (fa < 0.0 && fb < 0.0)
                hi = lo;
            else if (fa < 0.0)
                lo = std::max(lo, fa / (fa - fb));
            else if (fb < 0.0)
                hi = std::min(hi, fa / (fa - fb));
        }
        if (!((hi - lo) * glm::distance(a, b) > m_tol)) {
            out.push_back(piece);
            return;
        }
        const glm::dvec3 side = glm::cross(n, b - a);
        const Piece left =
            clip_polygon(piece, [&](const glm::dvec3& x) { return glm::dot(side, x - a); });
        const Piece right =
            clip_polygon(piece, [&](const glm::dvec3& x) { return -glm::dot(side, x - a); });
        if (left.size() < 3 || right.size() < 3 || !(area_of(left) > m_sliver) ||
            !(area_of(right) > m_sliver)) {
            out.push_back(piece);
            return;
        }
        out.push_back(left);
        out.push_back(right);
    }

    // `pieces` of face i less the parts lying inside other surfaces' solids (a wall running
    // through the slab whose underside the face is): split along where each solid's faces
    // cross the face's plane, and the parts just in front of which the solid lies dropped;
    // true when some part was
    bool subtract_solids(std::size_t i, std::vector<Piece>& pieces) const {
        const glm::dvec3& n = m_faces[i].n;
        const std::vector<std::uint32_t>& crossing = m_crossing[i];
        bool cut = false;
        std::vector<Piece> split, next;
        for (std::size_t k = 0; k < crossing.size();) {
            const std::uint32_t s = m_faces[crossing[k]].surface;
            split = pieces;
            for (; k < crossing.size() && m_faces[crossing[k]].surface == s; ++k) {
                glm::dvec3 a, b;
                if (!crossing_segment(i, crossing[k], a, b)) continue;
                next.clear();
                for (const Piece& q : split) split_by(q, n, a, b, next);
                split.swap(next);
            }
            next.clear();
            for (const Piece& q : split) {
                glm::dvec3 c(0.0);
                for (std::size_t v = 0; v < q.size(); ++v) c += q[v];
                c /= static_cast<double>(q.size());
                if (!inside_solid(s, c + kInFront * m_tol * n)) next.push_back(q);
            }
            // The solid's lines stay only where they bound a part it hides
            if (next.size() < split.size()) {
                pieces.swap(next);
                cut = true;
            }
        }
        return cut;
    }

    // Face i has faces of other surfaces touching it or crossing its plane: it may be cut
    bool may_cut(std::size_t i) const { return !m_touching[i].empty() || !m_crossing[i].empty(); }

    // A touching face hides only with a solid behind it (not a sheet's other side)
    bool solid_behind(std::uint32_t j) {
        if (m_solid[j] < 0) {
            const ContactFace& g = m_faces[j];
            m_solid[j] = 0;
            for (const glm::dvec3& x : m_scene.surfaces[g.surface].mesh.positions)
                if (glm::dot(g.n, x - m_patches[j].p[0]) < -kSolidBehind * m_size) {
                    m_solid[j] = 1;
                    break;
                }
        }
        return m_solid[j] == 1;
    }

    // Face i less the faces hiding it, as convex pieces; false when none overlaps it
    bool remainder(std::size_t i, std::vector<Piece>& pieces) {
        pieces.assign(1, {});
        for (const glm::dvec3& x : m_patches[i].p) pieces[0].push_back(x);
        bool overlap = false;
        std::vector<Piece> next;
        for (const std::uint32_t j : m_touching[i]) {
            if (!solid_behind(j)) continue;
            next.clear();
            bool hit = false;
            for (const Piece& q : pieces)
                subtract(q, m_patches[j].p, m_faces[j].n, m_sliver, next, hit);
            if (hit) pieces.swap(next);
            overlap = overlap || hit;
        }
        if (!m_crossing[i].empty() && subtract_solids(i, pieces)) overlap = true;
        return overlap;
    }

    // Surface s (faces [first, last)) with its hidden parts cut away
    void cut_surface(std::uint32_t s, std::size_t first, std::size_t last, ContactCut& out) {
        const visdb::TriangleMesh& m = m_scene.surfaces[s].mesh;
        visdb::TriangleMesh cut;
        cut.positions = m.positions;
        // New corners by position: the clipping makes a shared edge's points bit-identical
        std::map<std::array<double, 3>, std::uint32_t> index;
        for (std::size_t v = 0; v < m.positions.size(); ++v)
            index.try_emplace({m.positions[v].x, m.positions[v].y, m.positions[v].z},
                              static_cast<std::uint32_t>(v));
        const auto vertex = [&](const glm::dvec3& x) {
            const auto [it, added] = index.try_emplace(
                {x.x, x.y, x.z}, static_cast<std::uint32_t>(cut.positions.size()));
            if (added) cut.positions.push_back(x);
            return it->second;
        };
        std::vector<std::uint32_t> face_of(m.triangles.size(), kNoPatch);
        for (std::size_t i = first; i < last; ++i)
            face_of[m_faces[i].triangle] = static_cast<std::uint32_t>(i);
        std::vector<Piece> pieces;
        for (std::size_t t = 0; t < m.triangles.size(); ++t) {
            const std::uint32_t i = face_of[t];
            if (i == kNoPatch || !may_cut(i) || !remainder(i, pieces)) {
                cut.triangles.push_back(m.triangles[t]);
                continue;
            }
            double kept = 0.0;
            for (const Piece& q : pieces) {
                kept += area_of(q);
                // Convex: a fan from the first corner, in the face's own winding
                for (std::size_t k = 1; k + 1 < q.size(); ++k) {
                    if (needle({{q[0], q[k], q[k + 1]}, 1.0}, m_tol)) continue;
                    const std::uint32_t a = vertex(q[0]), b = vertex(q[k]), c = vertex(q[k + 1]);
                    cut.triangles.emplace_back(a, b, c);
                }
            }
            out.hidden_m2 += std::max(0.0, area(m_patches[i]) - kept);
            ++out.faces_cut;
        }
        split_at_vertices(cut, m.positions.size(), m_tol);
        out.meshes[s] = std::move(cut);
    }

    const visdb::Scene& m_scene;
    double m_size, m_tol, m_sliver;
    std::vector<ContactFace> m_faces;
    std::vector<Patch> m_patches;
    std::vector<std::vector<std::uint32_t>> m_touching;
    // Per face, the opaque faces of other surfaces crossing its plane near it, by surface
    std::vector<std::vector<std::uint32_t>> m_crossing;
    std::vector<std::size_t> m_first;  // per surface, its first face; one past the last at the end
    std::vector<signed char> m_solid;  // per face: −1 not known yet, 0 no solid behind, 1 solid
};

}  // namespace

ContactCut hide_contacts(const visdb::Scene& scene, double size) {
    return Cutter(scene, size).run();
}

}  // namespace abrad::radiosity
