#include "abrad/radiosity/exact.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <glm/geometric.hpp>
#include <numbers>
#include <random>

#include "abrad/radiosity/direct.h"
#include "analytic.h"

namespace abrad::radiosity {
namespace {

using testing::add_quad;
using testing::ff_parallel_rect;

// A square light [-0.5, 0.5]² at height 2 facing down.
std::vector<Patch> light_square() {
    std::vector<Patch> l;
    add_quad(l, {-0.5, -0.5, 2}, {-0.5, 0.5, 2}, {0.5, 0.5, 2}, {0.5, -0.5, 2});
    return l;
}

double visible(const glm::dvec3& x, const glm::dvec3& n, const std::vector<Patch>& light,
               const std::vector<Patch>& occ) {
    std::vector<const Patch*> ptr;
    for (const auto& o : occ) ptr.push_back(&o);
    double f = 0.0;
    for (const auto& l : light) f += visible_form_factor(x, n, l, ptr);
    return f;
}

// Form factor from x on the floor (normal +z) to the light ∩ [sx0,sx1]×[sy0,sy1] at height 2.
double clipped(const glm::dvec3& x, double sx0, double sx1, double sy0, double sy1) {
    const double x0 = std::max(-0.5, sx0), x1 = std::min(0.5, sx1);
    const double y0 = std::max(-0.5, sy0), y1 = std::min(0.5, sy1);
    if (x0 >= x1 || y0 >= y1) return 0.0;
    return ff_parallel_rect(x0 - x.x, x1 - x.x, y0 - x.y, y1 - x.y, 2.0 - x.z);
}

TEST(ExactShading, UnoccludedMatchesClosedForm) {
    const auto light = light_square();
    for (glm::dvec3 x : {glm::dvec3(0, 0, 0), glm::dvec3(0.3, -0.2, 0), glm::dvec3(1.7, 0.9, 0),
                         glm::dvec3(0.5, 0.5, 1.0)}) {
        EXPECT_NEAR(visible(x, {0, 0, 1}, light, {}), clipped(x, -9, 9, -9, 9), 1e-12);
    }
    // Behind the light and in its plane: nothing
    EXPECT_EQ(visible({0, 0, 3}, {0, 0, -1}, light, {}), 0.0);
    EXPECT_EQ(visible({2, 0, 2}, {-1, 0, 0}, light, {}), 0.0);
}

// An occluding square at height 1 casts the shadow s ↦ 2s - x onto the light's plane.
TEST(ExactShading, OpaqueAndTranslucentOccluderMatchClosedForm) {
    const auto light = light_square();
    for (double alpha : {1.0, 0.4}) {
        std::vector<Patch> occ;
        add_quad(occ, {-0.2, -0.1, 1}, {-0.2, 0.25, 1}, {0.15, 0.25, 1}, {0.15, -0.1, 1}, alpha);
        for (glm::dvec3 x : {glm::dvec3(0, 0, 0), glm::dvec3(0.3, -0.2, 0),
                             glm::dvec3(-0.6, 0.4, 0), glm::dvec3(2.5, 0, 0)}) {
            const double full = clipped(x, -9, 9, -9, 9);
            const double shadow =
                clipped(x, 2 * -0.2 - x.x, 2 * 0.15 - x.x, 2 * -0.1 - x.y, 2 * 0.25 - x.y);
            EXPECT_NEAR(visible(x, {0, 0, 1}, light, occ), full - alpha * shadow, 1e-12)
                << "alpha=" << alpha << " x=" << x.x << "," << x.y;
        }
    }
}

// A point at the foot of a ramp that rises from it toward the light (the floor point's
// neighbour face), 20 nm behind the ramp's plane: as a discontinuity mesh vertex can lie on a
// face planar only to the bake's tolerance. In exact arithmetic the ramp hides nothing; from
// behind its plane it hides most of the light, unless the plane is taken to contain the point
// within `coplanar`.
TEST(ExactShading, AnOccluderWithinCoplanarOfThePointHidesNothing) {
    const auto light = light_square();
    std::vector<Patch> ramp;  // from the line x = 0.3 on the floor up to x = -0.2 at z = 0.5
    add_quad(ramp, {0.3, -1, 0}, {0.3, 1, 0}, {-0.2, 1, 0.5}, {-0.2, -1, 0.5});
    const glm::dvec3 behind = -glm::normalize(glm::dvec3(1, 0, 1));  // the ramp's back
    const glm::dvec3 x = glm::dvec3(0.3, 0.1, 0) + 2e-8 * behind;
    const double full = clipped(x, -9, 9, -9, 9);
    std::vector<const Patch*> ptr;
    for (const auto& o : ramp) ptr.push_back(&o);
    double as_given = 0.0, within = 0.0;
    for (const auto& l : light) {
        as_given += visible_form_factor(x, {0, 0, 1}, l, ptr);
        within += visible_form_factor(x, {0, 0, 1}, l, ptr, nullptr, 1e-6);
    }
    EXPECT_LT(as_given, 0.5 * full);  // the hazard
    EXPECT_NEAR(within, full, 1e-9 * full);
}

// A translucent occluder entirely inside an opaque one's shadow changes nothing; two disjoint
// translucent ones each take their share.
TEST(ExactShading, StackedOccluders) {
    const auto light = light_square();
    const glm::dvec3 x(0.05, 0.02, 0);
    std::vector<Patch> occ;
    add_quad(occ, {-0.2, -0.2, 1}, {-0.2, 0.2, 1}, {0.2, 0.2, 1}, {0.2, -0.2, 1});
    add_quad(occ, {-0.1, -0.1, 1.5}, {-0.1, 0.1, 1.5}, {0.1, 0.1, 1.5}, {0.1, -0.1, 1.5}, 0.5);
    const double expected =
        clipped(x, -9, 9, -9, 9) - clipped(x, -0.4 - x.x, 0.4 - x.x, -0.4 - x.y, 0.4 - x.y);
    // The smaller square at 1.5 projects to s ↦ (4/3)s - x/3 ... it lies inside the
    // big shadow: check the premise, then the value
    EXPECT_NEAR(visible(x, {0, 0, 1}, light, occ), expected, 1e-12);

    std::vector<Patch> two;
    add_quad(two, {-0.25, -0.2, 1}, {-0.25, 0.2, 1}, {-0.05, 0.2, 1}, {-0.05, -0.2, 1}, 0.5);
    add_quad(two, {0.05, -0.2, 1}, {0.05, 0.2, 1}, {0.2, 0.2, 1}, {0.2, -0.2, 1}, 0.25);
    const glm::dvec3 o(0, 0, 0);
    const double e2 = clipped(o, -9, 9, -9, 9) - 0.5 * clipped(o, -0.5, -0.1, -0.4, 0.4) -
                      0.25 * clipped(o, 0.1, 0.4, -0.4, 0.4);
    EXPECT_NEAR(visible(o, {0, 0, 1}, light, two), e2, 1e-12);
}

// Shadows are subtracted largest first, whatever the order the occluders come in: two
// overlapping translucent squares (the small one listed first) let (1 - α1)(1 - α2) through
// their common shadow, and a field of small opaque squares under a large translucent one,
// shuffled, gives the same form factor in every order.
TEST(ExactShading, OccluderOrderDoesNotMatter) {
    const auto light = light_square();
    const glm::dvec3 o(0, 0, 0);
    // From o, a square [a, b]² at height h shadows [2a/h, 2b/h]² on the light's plane (z = 2)
    std::vector<Patch> pair;
    add_quad(pair, {-0.05, -0.05, 1}, {-0.05, 0.1, 1}, {0.1, 0.1, 1}, {0.1, -0.05, 1}, 0.3);
    add_quad(pair, {-0.15, -0.15, 1}, {-0.15, 0.05, 1}, {0.05, 0.05, 1}, {0.05, -0.15, 1}, 0.6);
    const double s_small = clipped(o, -0.1, 0.2, -0.1, 0.2);
    const double s_big = clipped(o, -0.3, 0.1, -0.3, 0.1);
    const double s_both = clipped(o, -0.1, 0.1, -0.1, 0.1);
    const double expected = clipped(o, -9, 9, -9, 9) - 0.3 * s_small - 0.6 * s_big + 0.18 * s_both;
    EXPECT_NEAR(visible(o, {0, 0, 1}, light, pair), expected, 1e-12);
    std::swap(pair[0], pair[2]);
    std::swap(pair[1], pair[3]);
    EXPECT_NEAR(visible(o, {0, 0, 1}, light, pair), expected, 1e-12);

    // Forty small opaque squares (disjoint shadows) at height 1.5, then a large translucent
    // one at height 1 over half of them
    std::vector<Patch> field;
    double blocked = 0.0;
    for (int i = 0; i < 8; ++i)
        for (int j = 0; j < 5; ++j) {
            const double a = -0.35 + 0.09 * i, b = -0.3 + 0.12 * j, w = 0.04;
            add_quad(field, {a, b, 1.5}, {a, b + w, 1.5}, {a + w, b + w, 1.5}, {a + w, b, 1.5});
            const double k = 2.0 / 1.5;
            blocked += clipped(o, k * a, k * (a + w), k * b, k * (b + w));
        }
    add_quad(field, {-0.2, -0.2, 1}, {-0.2, 0.0, 1}, {0.0, 0.0, 1}, {0.0, -0.2, 1}, 0.5);
    const double reference = visible(o, {0, 0, 1}, light, field);
    EXPECT_LT(reference, clipped(o, -9, 9, -9, 9) - blocked);  // the large one takes its share
    for (unsigned seed = 1; seed <= 5; ++seed) {
        std::vector<Patch> shuffled = field;
        std::shuffle(shuffled.begin(), shuffled.end(), std::mt19937(seed));
        EXPECT_NEAR(visible(o, {0, 0, 1}, light, shuffled), reference, 1e-12) << "seed " << seed;
    }
    // Without the large one: the closed form of forty disjoint shadows
    field.resize(field.size() - 2);
    EXPECT_NEAR(visible(o, {0, 0, 1}, light, field), clipped(o, -9, 9, -9, 9) - blocked, 1e-12);
}

// Tilted receivers, including a light cut by the receiver's horizon, against midpoint
// quadrature of cosθ_x cosθ_L / (π r²) over the light (independent of Lambert's formula).
TEST(ExactShading, TiltedReceiverAgainstQuadrature) {
    const auto light = light_square();
    struct Case {
        glm::dvec3 x, n;
    };
    for (const Case& c : {Case{{-1.0, 0.0, 1.0}, {1, 0, 0}}, Case{{0.2, 0.1, 1.4}, {1, 0, 0}},
                          Case{{0.0, -1.2, 0.3}, glm::normalize(glm::dvec3(0, 1, 1))}}) {
        const int m = 1000;
        double sum = 0.0;
        const double da = 1.0 / (m * m);
        for (int i = 0; i < m; ++i)
            for (int j = 0; j < m; ++j) {
                const glm::dvec3 q(-0.5 + (i + 0.5) / m, -0.5 + (j + 0.5) / m, 2.0);
                const glm::dvec3 r = q - c.x;
                const double d2 = glm::dot(r, r);
                const double cx = glm::dot(c.n, r) / std::sqrt(d2);
                const double cl = r.z / std::sqrt(d2);  // light normal is -z
                if (cx > 0) sum += cx * cl / (std::numbers::pi * d2) * da;
            }
        EXPECT_NEAR(visible(c.x, c.n, light, {}), sum, 2e-4 * sum + 1e-7);
    }
}

// Two light triangles that make a convex quadrilateral are seen at once (LightQuads): the
// square light past an opaque and a translucent square, the translucent one across the
// square's diagonal (a candidate of both triangles, so it must be subtracted once), gives the
// closed form with and without the pairs. A dart (coplanar, sharing an edge, not convex) and a
// pair of unequal emittance stay two triangles each.
TEST(ExactShading, LightQuadsSeeTheLightOfTheirTwoTriangles) {
    std::vector<Patch> patches = light_square();
    std::vector<visdb::Rgb> emittance(2, visdb::Rgb(100.0));
    // The dart at z = 2.5, facing down: (10, 0), (10, 2), (14, 1) and across their first edge
    // (8, 3), which makes the corner (10, 2) reflex
    patches.push_back({{{10, 0, 2.5}, {10, 2, 2.5}, {14, 1, 2.5}}, 1.0});
    patches.push_back({{{10, 2, 2.5}, {10, 0, 2.5}, {8, 3, 2.5}}, 1.0});
    emittance.insert(emittance.end(), 2, visdb::Rgb(50.0));
    // A square of two emittances at z = 2.5, facing down
    add_quad(patches, {-10.5, -0.5, 2.5}, {-10.5, 0.5, 2.5}, {-9.5, 0.5, 2.5}, {-9.5, -0.5, 2.5});
    emittance.push_back(visdb::Rgb(10.0));
    emittance.push_back(visdb::Rgb(20.0));
    const std::vector<std::uint32_t> lights = {0, 1, 2, 3, 4, 5};
    const double alpha = 0.4;
    add_quad(patches, {-0.2, -0.1, 1}, {-0.2, 0.25, 1}, {0.15, 0.25, 1}, {0.15, -0.1, 1}, alpha);
    add_quad(patches, {0.3, -0.45, 1}, {0.3, -0.35, 1}, {0.4, -0.35, 1}, {0.4, -0.45, 1});
    emittance.resize(patches.size(), visdb::Rgb(0.0));

    const LightQuads quads(patches, emittance, lights);
    ASSERT_EQ(quads.size(), 1u);
    ASSERT_NE(quads.quad_of(0), nullptr);
    EXPECT_EQ(quads.quad_of(0), quads.quad_of(1));
    for (const std::uint32_t l : {2u, 3u, 4u, 5u}) EXPECT_EQ(quads.quad_of(l), nullptr) << l;

    const Bvh bvh(patches);
    std::vector<const Patch*> occ;
    for (const glm::dvec3 x : {glm::dvec3(0, 0, 0), glm::dvec3(0.3, -0.2, 0),
                               glm::dvec3(-0.6, 0.4, 0), glm::dvec3(0.1, 0.05, 0.5)}) {
        // The square's light, closed form: all of it less α of the translucent square's
        // shadow and all of the small opaque one's (disjoint from it), from height 2 − z
        const double s = (2.0 - x.z) / (1.0 - x.z);  // from x onto the light's plane
        const auto shadow = [&](double a0, double a1, double b0, double b1) {
            return clipped(x, x.x + s * (a0 - x.x), x.x + s * (a1 - x.x), x.y + s * (b0 - x.y),
                           x.y + s * (b1 - x.y));
        };
        const double ff = clipped(x, -9, 9, -9, 9) - alpha * shadow(-0.2, 0.15, -0.1, 0.25) -
                          shadow(0.3, 0.4, -0.45, -0.35);
        const visdb::Rgb pairs =
            exact_irradiance(patches, emittance, lights, bvh, x, {0, 0, 1}, occ, 0.0, &quads);
        const visdb::Rgb alone =
            exact_irradiance(patches, emittance, lights, bvh, x, {0, 0, 1}, occ);
        // The other lights' part (the same either way: they are not paired)
        const std::vector<std::uint32_t> others = {2, 3, 4, 5};
        const visdb::Rgb rest =
            exact_irradiance(patches, emittance, others, bvh, x, {0, 0, 1}, occ);
        EXPECT_NEAR(pairs.x - rest.x, 100.0 * ff, 1e-9) << x.x << ", " << x.y << ", " << x.z;
        EXPECT_NEAR(alone.x, pairs.x, 1e-10 * alone.x);
    }
}

}  // namespace
}  // namespace abrad::radiosity
