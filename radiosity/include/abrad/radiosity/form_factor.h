#pragma once
// Exact form factors: the point-to-polygon form factor (Lambert 1760; Baum, Rushmeier &
// Winget 1989) and textbook closed forms used as references (Howell's catalogue, C-11/C-14).

#include <glm/vec3.hpp>
#include <span>

namespace abrad::radiosity {

/// Form factor from a differential area at `x` with unit normal `n` to the planar polygon
/// `polygon` (any winding, metres). The polygon must lie in the closed half-space in front of
/// the point (clip it first); the result is then exact up to rounding and in [0, 1].
double point_polygon_form_factor(const glm::dvec3& x, const glm::dvec3& n,
                                 std::span<const glm::dvec3> polygon);

/// Form factor from a differential area at `x` with unit normal `n` to the part of triangle
/// `corners` in front of the point's plane, without occluders: what a hemicube at `x` can give
/// the triangle at most (point_polygon_form_factor of the clipped triangle; 0 behind).
double unoccluded_triangle_form_factor(const glm::dvec3& x, const glm::dvec3& n,
                                       const glm::dvec3 (&corners)[3]);

/// A hemicube form factor this many times unoccluded_triangle_form_factor marks a receiver
/// smaller than the hemicube's sample (a needle, a sliver), which took a whole sample: the
/// patch shading and the interreflection replace it by the closed form.
inline constexpr double kUndersampledFactor = 2.0;

/// Closed form: differential area to a parallel rectangle a × b at distance c, the normal of
/// the area passing through one corner of the rectangle (Howell C-11).
double ff_parallel_rectangle_corner(double a, double b, double c);

/// Closed form: differential area to a rectangle perpendicular to its plane. The area is at
/// distance `d` from the rectangle's plane, opposite one corner; the rectangle extends `a`
/// parallel to the area's plane and `b` up from it (Howell C-14).
double ff_perpendicular_rectangle(double a, double b, double d);

}  // namespace abrad::radiosity
