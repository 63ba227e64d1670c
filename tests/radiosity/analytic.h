#pragma once
// Reference scenes with known answers, built from the closed forms in form_factor.h.

#include <algorithm>
#include <cmath>
#include <glm/vec3.hpp>
#include <utility>
#include <vector>

#include "abrad/radiosity/form_factor.h"
#include "abrad/radiosity/shoot.h"

namespace abrad::radiosity::testing {

/// Form factor from the origin (normal +z) to the rectangle [x0,x1]×[y0,y1] at height c,
/// by inclusion–exclusion of the corner closed form.
inline double ff_parallel_rect(double x0, double x1, double y0, double y1, double c) {
    auto g = [c](double x, double y) {
        if (x == 0.0 || y == 0.0) return 0.0;
        const double s = (x > 0) == (y > 0) ? 1.0 : -1.0;
        return s * ff_parallel_rectangle_corner(std::abs(x), std::abs(y), c);
    };
    return g(x1, y1) - g(x0, y1) - g(x1, y0) + g(x0, y0);
}

/// Form factor from the origin (normal +z) to the rectangle x in [x0,x1], z in [0,b] in the
/// plane y = d (d > 0).
inline double ff_perpendicular_rect(double x0, double x1, double b, double d) {
    auto p = [&](double x) {
        if (x == 0.0) return 0.0;
        return (x > 0 ? 1.0 : -1.0) * ff_perpendicular_rectangle(std::abs(x), b, d);
    };
    return p(x1) - p(x0);
}

/// An axis-aligned rectangular light: in the plane x[axis] = [lo, hi]'s common value, spanning
/// [lo, hi] on the other two axes, emitting toward `facing` (+1 or -1 along `axis`).
struct AxisRect {
    int axis;
    double facing;
    glm::dvec3 lo, hi;
};

/// Unoccluded form factor from x (unit normal n along a coordinate axis) to the light r, by
/// the parallel and perpendicular closed forms above: 0 where x is not in front of the light
/// or the light not in front of x; the part of a perpendicular light behind x's plane clipped.
inline double ff_axis_rect(const glm::dvec3& x, const glm::dvec3& n, const AxisRect& r) {
    const int a = r.axis;
    if ((x[a] - r.lo[a]) * r.facing <= 0.0) return 0.0;  // x on or behind the light's plane
    int k = 0;                                           // n's axis
    while (n[k] == 0.0) ++k;
    const double sn = n[k] > 0.0 ? 1.0 : -1.0;
    const glm::dvec3 lo = r.lo - x, hi = r.hi - x;  // the light relative to x
    if (k == a) {
        const double h = lo[a] * sn;
        if (h <= 0.0) return 0.0;
        const int i = (a + 1) % 3, j = (a + 2) % 3;
        return ff_parallel_rect(lo[i], hi[i], lo[j], hi[j], h);
    }
    // Perpendicular: distance along the light's axis, height along n, width along the third
    const int w = 3 - a - k;
    double b0 = lo[k] * sn, b1 = hi[k] * sn;
    if (b0 > b1) std::swap(b0, b1);
    b0 = std::max(b0, 0.0);
    b1 = std::max(b1, 0.0);
    const double d = std::abs(lo[a]);
    return ff_perpendicular_rect(lo[w], hi[w], b1, d) - ff_perpendicular_rect(lo[w], hi[w], b0, d);
}

/// Two triangles of the quad a, b, c, d (counter-clockwise seen from its front).
inline void add_quad(std::vector<Patch>& out, glm::dvec3 a, glm::dvec3 b, glm::dvec3 c,
                     glm::dvec3 d, double opacity = 1.0) {
    out.push_back({{a, b, c}, opacity});
    out.push_back({{a, c, d}, opacity});
}

}  // namespace abrad::radiosity::testing
