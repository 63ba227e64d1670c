#pragma once
// Triangulation of large polygons in O(n log n): a constrained Delaunay triangulation of the
// polygon's corners with its edges as constraints, faces inside marked by nesting (Chew,
// "Constrained Delaunay triangulations", 1989; CGAL's Constrained_Delaunay_triangulation_2).
// Internal to convert/: heal() calls it for polygons too large for ear clipping. CGAL stays in
// polygon_cdt.cpp, its own library (built with -O2 and CGAL_NDEBUG, as the mesher).

#include <cstdint>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <span>
#include <vector>

namespace abrad::convert::detail {

/// Triangulates the polygon whose corners, in order, are at `q` (2D, the polygon's plane,
/// counter-clockwise) with vertex ids `ids` (same length, at least 3). An id may repeat (the
/// two ends of a bridge to a hole, a corner touched twice): equal ids must have equal points,
/// and an edge walked an even number of times (a bridge) is not a boundary. Appends the
/// triangles inside the polygon, counter-clockwise in `q`'s frame, and returns true, when the
/// polygon is a proper one: its edges meet only at shared corners (no crossing, no corner on
/// another edge, no two ids at one point) and the triangulation has exactly ids.size() - 2
/// triangles. Returns false and appends nothing otherwise (the caller falls back). Predicates
/// are exact (filtered); nothing is constructed.
bool triangulate_polygon_cdt(std::span<const glm::dvec2> q, std::span<const std::uint32_t> ids,
                             std::vector<glm::u32vec3>& out);

}  // namespace abrad::convert::detail
