#pragma once
// The CIE 171:2006 analytic cases' shared parts (docs/validation.md): closed-form references
// written out independently of abrad's code, scene builders, and case 5.6 (also run through the
// command line by the tools tests).

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <glm/geometric.hpp>
#include <numbers>
#include <string>
#include <vector>

#include "abrad/radiosity/indirect.h"
#include "abrad/visdb/model.h"
#include "scenes.h"

namespace abrad::radiosity::cie171 {

using glm::dvec3;

constexpr double kPi = std::numbers::pi;
constexpr double kPublished = 0.05;  ///< the tolerance per point of published validations
/// What abrad's default export is held to at every point (issue 18), unless a point is given a
/// tighter tolerance of its own
constexpr double kTarget = 0.02;
constexpr double kM = 1000.0;  ///< exitance of the 5.3, 5.6 and 5.7 emitters, W/m²

// ---- References: closed forms, independent of abrad's code ----

/// Lambert's form factor from a differential area at x (unit normal n) to the planar polygon
/// `poly` lying wholly in front of it: 1/(2π) Σ θ_i n·û_i over its edges, θ_i the angle the edge
/// subtends at x and û_i the unit normal of the plane through x and the edge.
inline double lambert_ff(const dvec3& x, const dvec3& n, const std::vector<dvec3>& poly) {
    double sum = 0.0;
    for (std::size_t i = 0; i < poly.size(); ++i) {
        const dvec3 a = glm::normalize(poly[i] - x);
        const dvec3 b = glm::normalize(poly[(i + 1) % poly.size()] - x);
        const dvec3 c = glm::cross(a, b);
        const double s = glm::length(c);
        if (s == 0.0) continue;
        sum += std::atan2(s, glm::dot(a, b)) * glm::dot(n, c / s);
    }
    return std::abs(sum) / (2.0 * kPi);
}

/// Howell's C-11: differential area to a parallel a × b rectangle at distance c, the area's
/// normal through one corner.
inline double howell_corner(double a, double b, double c) {
    const double x = a / c, y = b / c;
    const double sx = std::sqrt(1.0 + x * x), sy = std::sqrt(1.0 + y * y);
    return (x / sx * std::atan(y / sx) + y / sy * std::atan(x / sy)) / (2.0 * kPi);
}

/// The axis-aligned rectangle [x0,x1]×[y0,y1] at height z (a polygon).
inline std::vector<dvec3> rect_z(double x0, double x1, double y0, double y1, double z) {
    return {{x0, y0, z}, {x1, y0, z}, {x1, y1, z}, {x0, y1, z}};
}

inline double rel_error(double value, double reference) { return value / reference - 1.0; }

/// "what (a, b)", two decimals.
inline std::string label(const char* what, double a, double b) {
    char s[64];
    std::snprintf(s, sizeof s, "%s (%.2f, %.2f)", what, a, b);
    return s;
}

// ---- Scenes ----

/// A quad surface whose front faces `inside` (as in indirect_test.cpp).
inline visdb::Surface facing(const std::string& name, std::uint32_t material, dvec3 o, dvec3 u,
                             dvec3 v, int n, const dvec3& inside) {
    const dvec3 c = o + 0.5 * (u + v);
    if (glm::dot(glm::cross(u, v), inside - c) < 0.0) {
        o += u;
        u = -u;
    }
    return abrad::testing::quad_grid(name, material, o, u, v, n);
}

inline std::uint32_t add_material(visdb::Scene& s, const std::string& name, double rho,
                                  double emittance = 0.0) {
    s.materials.push_back({name, visdb::Rgb(rho), visdb::Rgb(emittance), 1.0});
    return static_cast<std::uint32_t>(s.materials.size() - 1);
}

/// A point with its reference and its tolerances (relative): the probe's, and the export's
/// tight one where abrad reaches one stably (0: kTarget).
struct Point {
    std::string name;
    ProbePoint p;
    double reference;
    double probe_tolerance = 1e-4;
    double export_tight = 0.0;
};

// ---- 5.6: an opaque obstruction between the source and the points ----

/// The 1 × 1 m source [-0.5,0.5]² at 3 m facing down (M = 1000 W/m²) over a black 4 × 4 m
/// floor, with a black opaque plate at 1.5 m (half way) over x < 0. From a floor point
/// (x0, y0, 0) the plate's edge x = 0 projects onto the source's plane at x = -x0: the point
/// sees the part x >= -x0 of the source (penumbra for |x0| < 0.5, umbra for x0 <= -0.5).
inline visdb::Scene obstruction_scene() {
    visdb::Scene s = {};
    const auto black = add_material(s, "black", 0.0);
    const auto light = add_material(s, "source", 0.0, kM);
    const dvec3 mid(0, 0, 0.75);
    s.surfaces.push_back(facing("floor", black, {-2, -2, 0}, {4, 0, 0}, {0, 4, 0}, 4, mid));
    s.surfaces.push_back(
        facing("plate", black, {-2, -2, 1.5}, {2, 0, 0}, {0, 4, 0}, 2, {0, 0, 3}));  // facing up
    s.surfaces.push_back(
        facing("source", light, {-0.5, -0.5, 3}, {1, 0, 0}, {0, 1, 0}, 1, {0, 0, 0}));
    return s;
}

/// The 5.6 points: floor points across the penumbra (y = 0 and 0.3 m) and one fully lit, with
/// their closed-form references.
inline std::vector<Point> obstruction_points() {
    std::vector<Point> points;
    for (const double y0 : {0.0, 0.3})
        for (const double x0 : {-0.45, -0.25, 0.0, 0.25, 0.45, 0.75}) {
            const dvec3 x(x0, y0, 0.0), n(0, 0, 1);
            const double lo = std::max(-0.5, -x0);
            points.push_back({label("floor", x0, y0),
                              {x, n},
                              kM * lambert_ff(x, n, rect_z(lo, 0.5, -0.5, 0.5, 3))});
        }
    return points;
}

}  // namespace abrad::radiosity::cie171
