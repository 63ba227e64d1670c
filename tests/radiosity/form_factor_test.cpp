#include "abrad/radiosity/form_factor.h"

#include <gtest/gtest.h>

#include <numbers>

#include "analytic.h"

namespace abrad::radiosity {
namespace {

// Lambert's contour integral against the textbook closed form for parallel rectangles.
TEST(FormFactor, PointPolygonMatchesParallelClosedForm) {
    for (double c : {0.3, 1.0, 2.5}) {
        for (double a : {0.1, 1.0, 4.0}) {
            for (double b : {0.2, 1.5}) {
                const glm::dvec3 quad[4] = {{0, 0, c}, {a, 0, c}, {a, b, c}, {0, b, c}};
                EXPECT_NEAR(ff_parallel_rectangle_corner(a, b, c),
                            point_polygon_form_factor({0, 0, 0}, {0, 0, 1}, quad), 1e-13)
                    << "a=" << a << " b=" << b << " c=" << c;
            }
        }
    }
}

TEST(FormFactor, PointPolygonMatchesPerpendicularClosedForm) {
    for (double d : {0.2, 1.0, 3.0}) {
        for (double a : {0.5, 2.0}) {
            for (double b : {0.1, 1.0, 5.0}) {
                const glm::dvec3 quad[4] = {{0, d, 0}, {a, d, 0}, {a, d, b}, {0, d, b}};
                EXPECT_NEAR(ff_perpendicular_rectangle(a, b, d),
                            point_polygon_form_factor({0, 0, 0}, {0, 0, 1}, quad), 1e-13);
            }
        }
    }
}

// Limits known without any formula: an infinite plane above fills the hemisphere (F = 1), an
// infinite wall covers half of its projected disc (F = 1/2).
TEST(FormFactor, ClosedFormsHaveTheKnownLimits) {
    EXPECT_NEAR(4.0 * ff_parallel_rectangle_corner(1e7, 1e7, 1.0), 1.0, 1e-6);
    EXPECT_NEAR(2.0 * ff_perpendicular_rectangle(1e7, 1e7, 1.0), 0.5, 1e-6);
    // A disc-like check: small rectangle straight above at distance c: F ≈ A/(π c²)
    const double a = 1e-3, c = 2.0;
    EXPECT_NEAR(4.0 * ff_parallel_rectangle_corner(a, a, c), 4 * a * a / (std::numbers::pi * c * c),
                1e-12);
}

}  // namespace
}  // namespace abrad::radiosity
