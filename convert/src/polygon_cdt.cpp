// Large-polygon triangulation by constrained Delaunay triangulation (see polygon_cdt.h).
//
// Numeric assumptions: CGAL's filtered predicates (orientation, in-circle) are exact on the
// double coordinates given; with No_constraint_intersection_tag no point is ever constructed,
// so every output vertex is an input corner and a constraint crossing, overlapping or passing
// through a corner throws instead of being rounded. Inside and outside follow from the exact
// topology (the nesting level of a face: how many boundary edges separate it from the
// infinite face), never from coordinates.

#include "polygon_cdt.h"

#include <CGAL/Constrained_Delaunay_triangulation_2.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Spatial_sort_traits_adapter_2.h>
#include <CGAL/Triangulation_face_base_with_info_2.h>
#include <CGAL/Triangulation_vertex_base_with_info_2.h>
#include <CGAL/property_map.h>
#include <CGAL/spatial_sort.h>

#include <algorithm>
#include <limits>
#include <unordered_map>
#include <utility>

namespace abrad::convert::detail {
namespace {

constexpr std::uint32_t kNoId = std::numeric_limits<std::uint32_t>::max();
constexpr int kNotReached = -1;

/// The corner's vertex id; kNoId until a corner is inserted at the vertex.
struct VInfo {
    std::uint32_t id = kNoId;
};

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Vb = CGAL::Triangulation_vertex_base_with_info_2<VInfo, K>;
using Fbi = CGAL::Triangulation_face_base_with_info_2<int, K>;  // nesting level
using Fb = CGAL::Constrained_triangulation_face_base_2<K, Fbi>;
using Tds = CGAL::Triangulation_data_structure_2<Vb, Fb>;
using Cdt =
    CGAL::Constrained_Delaunay_triangulation_2<K, Tds, CGAL::No_constraint_intersection_tag>;

/// Sets every face's nesting level: 0 for the faces reached from the infinite face without
/// crossing a constraint, 1 past one constraint, and so on (CGAL's polygon-with-holes example).
void mark_nesting(Cdt& cdt) {
    for (auto f = cdt.all_faces_begin(); f != cdt.all_faces_end(); ++f) f->info() = kNotReached;
    std::vector<Cdt::Face_handle> border{cdt.infinite_face()};
    int level = 0;
    while (!border.empty()) {
        std::vector<Cdt::Face_handle> next_border;
        std::vector<Cdt::Face_handle> stack;
        for (const Cdt::Face_handle start : border) {
            if (start->info() != kNotReached) continue;
            // Flood the faces of this level; constrained edges lead to the next level
            start->info() = level;
            stack.push_back(start);
            while (!stack.empty()) {
                const Cdt::Face_handle f = stack.back();
                stack.pop_back();
                for (int i = 0; i < 3; ++i) {
                    const Cdt::Face_handle n = f->neighbor(i);
                    if (n->info() != kNotReached) continue;
                    if (cdt.is_constrained({f, i})) {
                        next_border.push_back(n);
                    } else {
                        n->info() = level;
                        stack.push_back(n);
                    }
                }
            }
        }
        border = std::move(next_border);
        ++level;
    }
}

/// Key of an undirected edge between two ids.
std::uint64_t edge_key(std::uint32_t a, std::uint32_t b) {
    if (a > b) std::swap(a, b);
    return (std::uint64_t{a} << 32) | b;
}

}  // namespace

bool triangulate_polygon_cdt(std::span<const glm::dvec2> q, std::span<const std::uint32_t> ids,
                             std::vector<glm::u32vec3>& out) {
    const std::size_t n = ids.size();
    if (n < 3 || q.size() != n) return false;
    try {
        // Insert the corners in spatial (Hilbert) order, each located from the previous one:
        // in the polygon's order a long comb's insertions each flipped most of the triangles
        // before them (quadratic; CGAL's own range insertion sorts the same way)
        Cdt cdt;
        std::vector<K::Point_2> points;
        points.reserve(n);
        for (const glm::dvec2& p : q) points.emplace_back(p.x, p.y);
        std::vector<std::size_t> order(n);
        for (std::size_t i = 0; i < n; ++i) order[i] = i;
        using Sort =
            CGAL::Spatial_sort_traits_adapter_2<K, CGAL::Pointer_property_map<K::Point_2>::type>;
        CGAL::spatial_sort(order.begin(), order.end(), Sort(CGAL::make_property_map(points)));
        std::vector<Cdt::Vertex_handle> vertex(n);
        Cdt::Face_handle hint;
        for (const std::size_t i : order) {
            const Cdt::Vertex_handle v = cdt.insert(points[i], hint);
            if (v->info().id == kNoId || v->info().id == ids[i]) {
                v->info().id = ids[i];
            } else {
                return false;  // two corners at one point of the plane
            }
            vertex[i] = v;
            hint = v->face();
        }
        // A bridge (an edge walked there and back) is not a boundary: constrain odd edges only
        std::unordered_map<std::uint64_t, std::uint32_t> walks;
        walks.reserve(n);
        for (std::size_t i = 0; i < n; ++i) ++walks[edge_key(ids[i], ids[(i + 1) % n])];
        for (std::size_t i = 0; i < n; ++i) {
            const std::size_t j = (i + 1) % n;
            if (walks[edge_key(ids[i], ids[j])] % 2 == 1)
                cdt.insert_constraint(vertex[i], vertex[j]);
        }
        mark_nesting(cdt);

        // Collect the faces at odd nesting levels
        const std::size_t first = out.size();
        for (auto f = cdt.finite_faces_begin(); f != cdt.finite_faces_end(); ++f) {
            if (f->info() % 2 != 1) continue;
            out.emplace_back(f->vertex(0)->info().id, f->vertex(1)->info().id,
                             f->vertex(2)->info().id);
        }
        if (out.size() - first != n - 2) {
            out.resize(first);
            return false;
        }
        return true;
    } catch (const Cdt::Intersection_of_constraints_exception&) {
        return false;  // edges crossing, overlapping or passing through a corner
    }
}

}  // namespace abrad::convert::detail
