// Point-to-polygon form factor: Lambert's contour integral, F = 1/(2π) Σ θ_i n·γ_i.

#include "abrad/radiosity/form_factor.h"

#include <cmath>
#include <glm/geometric.hpp>
#include <numbers>

#include "abrad/radiosity/polygon.h"

namespace abrad::radiosity {

double unoccluded_triangle_form_factor(const glm::dvec3& x, const glm::dvec3& n,
                                       const glm::dvec3 (&corners)[3]) {
    Polygon3 poly;
    for (const glm::dvec3& c : corners) poly.push_back(c);
    poly = clip_polygon(poly, [&](const glm::dvec3& c) { return glm::dot(c - x, n); });
    if (poly.size() < 3) return 0.0;
    return point_polygon_form_factor(x, n, {poly.begin(), poly.end()});
}

double point_polygon_form_factor(const glm::dvec3& x, const glm::dvec3& n,
                                 std::span<const glm::dvec3> polygon) {
    const std::size_t count = polygon.size();
    if (count < 3) return 0.0;
    double sum = 0.0;
    for (std::size_t i = 0; i < count; ++i) {
        // Edge as seen from _x_: the angle it subtends and its plane normal _c_
        const glm::dvec3 r0 = polygon[i] - x;
        const glm::dvec3 r1 = polygon[(i + 1) % count] - x;
        const glm::dvec3 c = glm::cross(r0, r1);
        const double len = glm::length(c);
        if (len <= 0.0) continue;  // edge through the point or degenerate: contributes 0
        const double theta = std::atan2(len, glm::dot(r0, r1));
        sum += theta * glm::dot(n, c) / len;
    }
    return std::abs(sum) / (2.0 * std::numbers::pi);
}

double ff_parallel_rectangle_corner(double a, double b, double c) {
    const double A = a / c, B = b / c;
    const double sa = std::sqrt(1.0 + A * A), sb = std::sqrt(1.0 + B * B);
    return (A / sa * std::atan(B / sa) + B / sb * std::atan(A / sb)) / (2.0 * std::numbers::pi);
}

double ff_perpendicular_rectangle(double a, double b, double d) {
    // Contour integral over the corners (0,d,0), (a,d,0), (a,d,b), (0,d,b) seen from the
    // origin with n = +z: only the edges parallel to the element's plane contribute.
    const double h = std::sqrt(b * b + d * d);
    return (std::atan(a / d) - d / h * std::atan(a / h)) / (2.0 * std::numbers::pi);
}

}  // namespace abrad::radiosity
