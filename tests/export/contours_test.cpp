// Isolines by marching squares and round contour levels (export/include/abrad/export/contours.h)
// against fields whose isolines are known exactly: a linear ramp, a cone (circles), a saddle.

#include "abrad/export/contours.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <vector>

namespace {

using abrad::exporter::contour_levels;
using abrad::exporter::isoline;
using abrad::exporter::IsoSegment;

TEST(Contours, LinearRampGivesAStraightLineThroughEveryRow) {
    // f(i, j) = i on 5 x 4 points: the isoline at 2.5 is the line i = 2.5, one segment per row
    const int nx = 5, ny = 4;
    std::vector<double> f;
    for (int j = 0; j < ny; ++j)
        for (int i = 0; i < nx; ++i) f.push_back(i);
    const std::vector<IsoSegment> s = isoline(f, nx, ny, 2.5);
    ASSERT_EQ(s.size(), 3U);
    double covered = 0.0;
    for (const IsoSegment& seg : s) {
        EXPECT_DOUBLE_EQ(seg.a.i, 2.5) << seg.to_string();
        EXPECT_DOUBLE_EQ(seg.b.i, 2.5) << seg.to_string();
        covered += std::abs(seg.b.j - seg.a.j);
    }
    EXPECT_DOUBLE_EQ(covered, 3.0);
    // A level outside the values crosses nothing; one at a node value stays off the node's
    // neighbours (the node counts as above)
    EXPECT_TRUE(isoline(f, nx, ny, 10.0).empty());
    EXPECT_TRUE(isoline(f, nx, ny, -1.0).empty());
    for (const IsoSegment& seg : isoline(f, nx, ny, 2.0)) EXPECT_DOUBLE_EQ(seg.a.i, 2.0);
}

TEST(Contours, ConeGivesCircles) {
    // f = distance from (20, 20) on 41 x 41 points: the isoline at r is the circle of radius r,
    // each crossing exact up to the interpolation of the distance along an edge (error below
    // h² / (8 r) for unit spacing h = 1)
    const int n = 41;
    const double c = 20.0;
    std::vector<double> f;
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) f.push_back(std::hypot(i - c, j - c));
    for (const double r : {5.0, 12.3, 18.0}) {
        const std::vector<IsoSegment> s = isoline(f, n, n, r);
        ASSERT_FALSE(s.empty());
        double length = 0.0;
        for (const IsoSegment& seg : s) {
            for (const auto& p : {seg.a, seg.b})
                EXPECT_NEAR(std::hypot(p.i - c, p.j - c), r, 1.0 / (8.0 * r)) << seg.to_string();
            length += std::hypot(seg.b.i - seg.a.i, seg.b.j - seg.a.j);
        }
        // The chords of a circle are a little shorter than it
        EXPECT_NEAR(length, 2.0 * std::numbers::pi * r, 0.01 * 2.0 * std::numbers::pi * r);
        EXPECT_LT(length, 2.0 * std::numbers::pi * r);
    }
}

TEST(Contours, SaddleFollowsTheMeanOfTheCorners) {
    // Corners (0,0) and (1,1) at 1, (1,0) and (0,1) at 0: level 0.5 crosses every edge at its
    // middle. The mean (0.5) counts as above, so the above corners connect through the centre
    // and the segments cut off the corners below: (1,0) and (0,1)
    const std::vector<double> f{1.0, 0.0, 0.0, 1.0};  // row-major: j = 0 then j = 1
    std::vector<IsoSegment> s = isoline(f, 2, 2, 0.5);
    ASSERT_EQ(s.size(), 2U);
    const auto around = [](const IsoSegment& seg, double ci, double cj) {
        const double mi = 0.5 * (seg.a.i + seg.b.i), mj = 0.5 * (seg.a.j + seg.b.j);
        return std::abs(mi - ci) < 0.3 && std::abs(mj - cj) < 0.3;
    };
    EXPECT_TRUE(around(s[0], 0.75, 0.25) || around(s[1], 0.75, 0.25))
        << s[0].to_string() << " " << s[1].to_string();
    EXPECT_TRUE(around(s[0], 0.25, 0.75) || around(s[1], 0.25, 0.75))
        << s[0].to_string() << " " << s[1].to_string();
    // At 0.6 the mean is below: the segments cut off the corners above, (0,0) and (1,1)
    s = isoline(f, 2, 2, 0.6);
    ASSERT_EQ(s.size(), 2U);
    EXPECT_TRUE(around(s[0], 0.2, 0.2) || around(s[1], 0.2, 0.2))
        << s[0].to_string() << " " << s[1].to_string();
    EXPECT_TRUE(around(s[0], 0.8, 0.8) || around(s[1], 0.8, 0.8))
        << s[0].to_string() << " " << s[1].to_string();
}

TEST(Contours, CellsWithoutDataAndBadSizes) {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    // The ramp with its middle row missing: every cell has a corner without data
    const std::vector<double> f{0.0, 1.0, nan, nan, 0.0, 1.0};
    EXPECT_TRUE(isoline(f, 2, 3, 0.5).empty());
    EXPECT_THROW(isoline(f, 2, 2, 0.5), std::invalid_argument);
    EXPECT_TRUE(isoline(std::vector<double>{1.0, 2.0}, 2, 1, 1.5).empty());
}

TEST(Contours, RoundLevels) {
    const auto expect = [](double lo, double hi, const std::vector<double>& want) {
        const std::vector<double> got = contour_levels(lo, hi, 6);
        ASSERT_EQ(got.size(), want.size()) << lo << ".." << hi;
        for (std::size_t k = 0; k < want.size(); ++k) EXPECT_NEAR(got[k], want[k], 1e-9);
    };
    expect(0.0, 523.0, {100, 200, 300, 400, 500});
    expect(12.0, 13.0, {12.2, 12.4, 12.6, 12.8});
    expect(31.7, 176.0, {50, 75, 100, 125, 150, 175});
    expect(0.0, 1.0, {0.2, 0.4, 0.6, 0.8});
    // Levels lie strictly inside the range
    expect(100.0, 500.0, {200, 300, 400});  // steps of 50 would give 7
    EXPECT_TRUE(contour_levels(5.0, 5.0).empty());
    EXPECT_TRUE(contour_levels(0.0, std::numeric_limits<double>::infinity()).empty());
    EXPECT_TRUE(contour_levels(0.0, 1.0, 0).empty());
}

}  // namespace
