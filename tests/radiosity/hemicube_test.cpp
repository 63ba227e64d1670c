#include "abrad/radiosity/hemicube.h"

#include <gtest/gtest.h>

#include <numeric>

#include "abrad/radiosity/shoot.h"
#include "analytic.h"

namespace abrad::radiosity {
namespace {

using testing::add_quad;

TEST(Hemicube, DeltaFormFactorsSumToOne) {
    for (int r : {2, 10, 50, 100, 400}) {
        const Hemicube hc(r);
        const double sum = std::accumulate(hc.deltas().begin(), hc.deltas().end(), 0.0);
        EXPECT_NEAR(sum, 1.0, 1e-6) << hc.to_string();
        EXPECT_EQ(hc.pixel_count(), static_cast<std::size_t>(3 * r * r));
    }
}

TEST(Hemicube, SideFacesCarryEqualShares) {
    const Hemicube hc(50);
    double face_sum[kFaceCount] = {};
    for (int f = 0; f < kFaceCount; ++f)
        for (int i = 0; i < hc.width(f) * hc.height(f); ++i)
            face_sum[f] += hc.delta(hc.face_offset(f) + static_cast<std::size_t>(i));
    for (int f = 2; f < kFaceCount; ++f) EXPECT_NEAR(face_sum[f], face_sum[1], 1e-12);
    // The top face alone: a 2×2 square at height 1 (closed form)
    EXPECT_NEAR(face_sum[kTop], testing::ff_parallel_rect(-1, 1, -1, 1, 1), 1e-12);
}

TEST(Hemicube, RejectsOddResolution) { EXPECT_THROW(Hemicube(51), std::invalid_argument); }

double shoot_ff(const std::vector<Patch>& patches, Visibility method, int r, int s = 8) {
    const Hemicube hc(r);
    ShootOptions o;
    o.method = method;
    o.subpixels = s;
    const ShootResult res = shoot(ShooterFrame::at({0, 0, 0}, {0, 0, 1}), patches, hc, o);
    return std::accumulate(res.form_factor.begin(), res.form_factor.end(), 0.0);
}

// Differential area to a parallel rectangle, off-centre, against the closed form.
TEST(Hemicube, ParallelRectangleAgainstClosedForm) {
    std::vector<Patch> p;
    const double c = 1.0;
    add_quad(p, {-0.3, 0.2, c}, {-0.3, 1.1, c}, {0.7, 1.1, c}, {0.7, 0.2, c});  // faces down
    const double exact = testing::ff_parallel_rect(-0.3, 0.7, 0.2, 1.1, c);
    EXPECT_NEAR(shoot_ff(p, Visibility::ZBuffer, 50), exact, 0.02 * exact);
    EXPECT_NEAR(shoot_ff(p, Visibility::ZBuffer, 400), exact, 0.003 * exact);
    EXPECT_NEAR(shoot_ff(p, Visibility::ABuffer, 50), exact, 0.003 * exact);
}

// A wall rising from the shooter's plane straddles the top face and a side face: it must
// be counted once, matching the closed form.
TEST(Hemicube, PerpendicularRectangleStraddlingFacesCountedOnce) {
    std::vector<Patch> p;
    const double d = 0.8, b = 2.0;
    add_quad(p, {-0.5, d, 0}, {0.9, d, 0}, {0.9, d, b}, {-0.5, d, b});
    const double exact = testing::ff_perpendicular_rect(-0.5, 0.9, b, d);
    EXPECT_NEAR(shoot_ff(p, Visibility::ABuffer, 50), exact, 0.003 * exact);
    EXPECT_NEAR(shoot_ff(p, Visibility::ZBuffer, 400), exact, 0.003 * exact);
    EXPECT_NEAR(shoot_ff(p, Visibility::ZBuffer, 50), exact, 0.03 * exact);
}

// The shooter's own surface, a hair in front of its point (the planar regions' tolerance:
// a wall's triangles and its elements' centroids agree to a micrometre), lies in its plane and
// subtends nothing. Taken as a ceiling right above the point, it covered the whole hemicube:
// in the FZK-Haus 184 wall elements' rows gave their whole power to their own backs.
TEST(Hemicube, TheShootersOwnPlaneAHairInFrontSeesNothing) {
    for (const double hair : {1e-12, 1e-9, 1e-7, 0.0, -1e-9}) {
        std::vector<Patch> p;
        add_quad(p, {-2, -2, hair}, {2, -2, hair}, {2, 2, hair}, {-2, 2, hair});  // own floor
        // A room above it: the ceiling 1 m up, 1 × 1 m around the point's vertical
        add_quad(p, {-0.5, -0.5, 1}, {-0.5, 0.5, 1}, {0.5, 0.5, 1}, {0.5, -0.5, 1});
        const Hemicube hc(50);
        ShootOptions o;
        o.method = Visibility::ABuffer;
        const ShootResult res = shoot(ShooterFrame::at({0.1, 0.2, 0}, {0, 0, 1}), p, hc, o);
        EXPECT_EQ(res.form_factor[0] + res.form_factor[1], 0.0) << "hair " << hair;
        const double exact = testing::ff_parallel_rect(-0.6, 0.4, -0.7, 0.3, 1.0);
        EXPECT_NEAR(res.form_factor[2] + res.form_factor[3], exact, 0.003 * exact)
            << "hair " << hair;
    }
}

// A closed box around the shooter receives everything: the form factors sum to 1 whatever
// the faces each triangle spans (no sample counted twice or lost).
TEST(Hemicube, EnclosureReceivesEverythingOnce) {
    std::vector<Patch> p;
    const double x0 = -0.7, x1 = 1.3, y0 = -0.4, y1 = 0.9, z0 = -0.5, z1 = 1.7;
    add_quad(p, {x0, y0, z1}, {x1, y0, z1}, {x1, y1, z1}, {x0, y1, z1});  // ceiling
    add_quad(p, {x0, y0, z0}, {x0, y1, z0}, {x1, y1, z0}, {x1, y0, z0});  // floor
    add_quad(p, {x0, y0, z0}, {x1, y0, z0}, {x1, y0, z1}, {x0, y0, z1});
    add_quad(p, {x1, y1, z0}, {x0, y1, z0}, {x0, y1, z1}, {x1, y1, z1});
    add_quad(p, {x0, y1, z0}, {x0, y0, z0}, {x0, y0, z1}, {x0, y1, z1});
    add_quad(p, {x1, y0, z0}, {x1, y1, z0}, {x1, y1, z1}, {x1, y0, z1});
    for (int s : {4, 8, 16}) EXPECT_NEAR(shoot_ff(p, Visibility::ABuffer, 50, s), 1.0, 1e-9);
    EXPECT_NEAR(shoot_ff(p, Visibility::ZBuffer, 50), 1.0, 1e-9);
    EXPECT_NEAR(shoot_ff(p, Visibility::ZBuffer, 64), 1.0, 1e-9);
}

// Receivers behind the shooter or in its plane get nothing.
TEST(Hemicube, BehindAndInPlaneReceiveNothing) {
    std::vector<Patch> p;
    add_quad(p, {-1, -1, -0.5}, {-1, 1, -0.5}, {1, 1, -0.5}, {1, -1, -0.5});
    add_quad(p, {0.1, -1, 0}, {2, -1, 0}, {2, 1, 0}, {0.1, 1, 0});
    EXPECT_EQ(shoot_ff(p, Visibility::ABuffer, 50), 0.0);
    EXPECT_EQ(shoot_ff(p, Visibility::ZBuffer, 50), 0.0);
}

}  // namespace
}  // namespace abrad::radiosity
