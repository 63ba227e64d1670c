#pragma once
// Reference scenes with known answers, built from the closed forms in form_factor.h.

#include <cmath>
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

/// Two triangles of the quad a, b, c, d (counter-clockwise seen from its front).
inline void add_quad(std::vector<Patch>& out, glm::dvec3 a, glm::dvec3 b, glm::dvec3 c,
                     glm::dvec3 d, double opacity = 1.0) {
    out.push_back({{a, b, c}, opacity});
    out.push_back({{a, c, d}, opacity});
}

}  // namespace abrad::radiosity::testing
