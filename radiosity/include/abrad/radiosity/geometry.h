#pragma once
// The triangle every radiosity stage works on, and the few measures of it they share: one
// home for area, normal, centroid and the hemicube frame of a triangle.
//
// Numerics: plain double arithmetic, no exact predicates; a triangle with a zero or
// non-finite cross product is degenerate and is dropped where the bake mesh is built.

#include <cstdint>
#include <glm/geometric.hpp>
#include <glm/vec3.hpp>
#include <limits>

#include "abrad/visdb/model.h"

namespace abrad::radiosity {

/// A triangle seen by the hemicube: world coordinates (metres) and opacity α in [0,1].
struct Patch {
    glm::dvec3 p[3];
    double opacity = 1.0;
};

/// "No patch": an index that is no triangle.
inline constexpr std::uint32_t kNoPatch = std::numeric_limits<std::uint32_t>::max();

/// The (unnormalised) normal p1−p0 × p2−p0: twice the area, pointing to the front.
inline glm::dvec3 cross_normal(const Patch& p) {
    return glm::cross(p.p[1] - p.p[0], p.p[2] - p.p[0]);
}

/// Area in m².
inline double area(const Patch& p) { return visdb::triangle_area(p.p[0], p.p[1], p.p[2]); }

/// Unit front normal (counter-clockwise). Undefined (NaN) for a degenerate patch.
inline glm::dvec3 unit_normal(const Patch& p) { return glm::normalize(cross_normal(p)); }

/// Centroid, metres.
inline glm::dvec3 centroid(const Patch& p) { return (p.p[0] + p.p[1] + p.p[2]) / 3.0; }

/// True when a comes before b by x, then y, then z: the one order of points where an order
/// must not depend on how they were found (shadow segments, edge midpoints, a meshed region's
/// vertices).
inline bool lexicographically_less(const glm::dvec3& a, const glm::dvec3& b) {
    if (a.x != b.x) return a.x < b.x;
    if (a.y != b.y) return a.y < b.y;
    return a.z < b.z;
}

}  // namespace abrad::radiosity
