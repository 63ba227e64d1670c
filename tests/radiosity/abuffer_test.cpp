// A-buffer against Z-buffer on what the paper is about: small patches, translucency,
// undersampling, and the occlusion lists kept from the fragments.

#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <random>
#include <set>

#include "abrad/radiosity/form_factor.h"
#include "abrad/radiosity/shoot.h"
#include "analytic.h"

namespace abrad::radiosity {
namespace {

using testing::add_quad;

// Small squares on a plane 3 m above the shooter, each under half a hemicube pixel at R = 50.
std::vector<Patch> small_patches(double size, std::vector<double>& exact) {
    std::vector<Patch> p;
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> jitter(0.0, 0.1);
    const double h = 3.0;
    for (int i = -8; i <= 8; ++i) {
        for (int j = -8; j <= 8; ++j) {
            const double x = i * 0.3 + jitter(rng), y = j * 0.3 + jitter(rng);
            add_quad(p, {x, y, h}, {x, y + size, h}, {x + size, y + size, h}, {x + size, y, h});
            const glm::dvec3 quad[4] = {
                {x, y, h}, {x, y + size, h}, {x + size, y + size, h}, {x + size, y, h}};
            exact.push_back(point_polygon_form_factor({0, 0, 0}, {0, 0, 1}, quad));
        }
    }
    return p;
}

// RMS relative error of the per-square form factors.
double rms_error(const std::vector<Patch>& p, const std::vector<double>& exact, Visibility method,
                 int r, int s = 8) {
    ShootOptions o;
    o.method = method;
    o.subpixels = s;
    o.occlusion = false;
    const ShootResult res = shoot(ShooterFrame::at({0, 0, 0}, {0, 0, 1}), p, Hemicube(r), o);
    double sum = 0.0;
    for (std::size_t q = 0; q < exact.size(); ++q) {
        const double f = res.form_factor[2 * q] + res.form_factor[2 * q + 1];
        sum += (f - exact[q]) * (f - exact[q]) / (exact[q] * exact[q]);
    }
    return std::sqrt(sum / static_cast<double>(exact.size()));
}

TEST(ABuffer, SmallPatchErrorFarBelowZBufferAndCloseToEightfoldZBuffer) {
    std::vector<double> exact;
    const auto p = small_patches(0.05, exact);
    const double zb50 = rms_error(p, exact, Visibility::ZBuffer, 50);
    const double zb400 = rms_error(p, exact, Visibility::ZBuffer, 400);
    const double ab50 = rms_error(p, exact, Visibility::ABuffer, 50, 8);
    const double ab50_4 = rms_error(p, exact, Visibility::ABuffer, 50, 4);
    const double ab50_16 = rms_error(p, exact, Visibility::ABuffer, 50, 16);
    std::cout << "rms relative form-factor error, 0.05 m squares at 3 m: ZB R=50 " << zb50
              << ", ZB R=400 " << zb400 << ", AB R=50 4x4 " << ab50_4 << ", 8x8 " << ab50
              << ", 16x16 " << ab50_16 << "\n";
    EXPECT_GT(zb50, 0.5);                 // point sampling cannot resolve them
    EXPECT_LT(ab50, 0.25 * zb50);         // far below the Z-buffer at the same R
    EXPECT_LT(ab50, 2.0 * zb400 + 0.02);  // and close to a Z-buffer at 8·R
    EXPECT_LT(zb400, 2.0 * ab50 + 0.02);
    EXPECT_LT(ab50_16, ab50);  // finer masks converge
}

// The pane passes 1 − α of what reaches it to the receiver behind; the pane keeps α.
TEST(ABuffer, TranslucentPanePassesOneMinusAlpha) {
    const double alpha = 0.3;
    std::vector<Patch> p;
    add_quad(p, {-0.3, -0.2, 2}, {-0.3, 0.4, 2}, {0.5, 0.4, 2}, {0.5, -0.2, 2});  // receiver
    add_quad(p, {-2, -2, 1}, {-2, 2, 1}, {2, 2, 1}, {2, -2, 1}, alpha);           // pane
    const double receiver = testing::ff_parallel_rect(-0.3, 0.5, -0.2, 0.4, 2);
    const double pane = testing::ff_parallel_rect(-2, 2, -2, 2, 1);
    ShootOptions o;
    const ShootResult res = shoot(ShooterFrame::at({0, 0, 0}, {0, 0, 1}), p, Hemicube(50), o);
    EXPECT_NEAR(res.form_factor[0] + res.form_factor[1], (1 - alpha) * receiver, 0.003 * receiver);
    EXPECT_NEAR(res.form_factor[2] + res.form_factor[3], alpha * pane, 0.003 * pane);
    // The receiver lists the pane as an occluder
    EXPECT_EQ(res.occluders_of(0).size(), 2u);
}

// A patch far smaller than a sample is still seen by the A-buffer (finer mask), never by
// a point-sampled Z-buffer that misses its pixel centre.
TEST(ABuffer, UndersampledPatchGetsFinerMask) {
    std::vector<Patch> p;
    const double s = 0.002, x = 0.0113, y = 0.0171, h = 3.0;  // off every sample centre
    add_quad(p, {x, y, h}, {x, y + s, h}, {x + s, y + s, h}, {x + s, y, h});
    ShootOptions o;
    const ShootResult ab = shoot(ShooterFrame::at({0, 0, 0}, {0, 0, 1}), p, Hemicube(50), o);
    o.method = Visibility::ZBuffer;
    const ShootResult zb = shoot(ShooterFrame::at({0, 0, 0}, {0, 0, 1}), p, Hemicube(50), o);
    const double exact = testing::ff_parallel_rect(x, x + s, y, y + s, h);
    const double f = ab.form_factor[0] + ab.form_factor[1];
    EXPECT_GT(ab.undersampled_pixels, 0u);
    EXPECT_GT(f, 0.0);
    EXPECT_LT(f, 20 * exact);  // one fine sample of a 16×16 mask at most per piece
    EXPECT_EQ(zb.form_factor[0] + zb.form_factor[1], 0.0);
}

// Per-square form factors (the two triangles of square q are patches 2q and 2q + 1) from
// the origin looking up, sparse (as the elements' rows shoot), with or without finer masks.
std::vector<double> sparse_square_ff(const std::vector<Patch>& p, std::size_t squares,
                                     bool fine_masks, std::size_t& undersampled) {
    ShootOptions o;
    o.occlusion = false;
    o.sparse = true;
    o.fine_masks = fine_masks;
    const ShootResult res = shoot(ShooterFrame::at({0, 0, 0}, {0, 0, 1}), p, Hemicube(50), o);
    std::vector<double> f(squares, 0.0);
    for (const PatchFormFactor& h : res.hits) f[h.patch / 2] += h.ff;
    undersampled = res.undersampled_pixels;
    return f;
}

// Without finer masks (ShootOptions::fine_masks, the elements' rows) a piece under a quarter
// of a sample's area is one partial sample of its area over the sample's, the sample holding
// its centroid; larger pieces are point sampled. Triangles under a sample's size (1 cm
// squares at 3 m; a sample is 1.5 cm there at R = 50, 8 × 8) and squares of two pixels, whose
// edges leave sampleless slivers, against their closed forms.
TEST(ABuffer, TranslucentSamplesKeepUndersampledPiecesFormFactors) {
    for (const double size : {0.01, 0.25}) {
        SCOPED_TRACE(size);
        std::vector<double> exact;
        const auto p = small_patches(size, exact);
        std::size_t undersampled_fine = 0, undersampled_translucent = 0;
        const std::vector<double> fine = sparse_square_ff(p, exact.size(), true, undersampled_fine);
        const std::vector<double> translucent =
            sparse_square_ff(p, exact.size(), false, undersampled_translucent);
        EXPECT_GT(undersampled_fine, 0u);
        if (size < 0.1) {
            EXPECT_GT(undersampled_translucent, 0u);  // pieces under a sample
        }
        double rms_fine = 0.0, rms_translucent = 0.0, sum_exact = 0.0, sum_translucent = 0.0,
               sum_fine = 0.0;
        for (std::size_t q = 0; q < exact.size(); ++q) {
            rms_fine += std::pow(fine[q] / exact[q] - 1.0, 2);
            rms_translucent += std::pow(translucent[q] / exact[q] - 1.0, 2);
            sum_exact += exact[q];
            sum_fine += fine[q];
            sum_translucent += translucent[q];
        }
        rms_fine = std::sqrt(rms_fine / static_cast<double>(exact.size()));
        rms_translucent = std::sqrt(rms_translucent / static_cast<double>(exact.size()));
        std::cout << size << " m squares at 3 m, rms relative form-factor error: finer masks "
                  << rms_fine << ", translucent samples " << rms_translucent << "; sums "
                  << sum_fine / sum_exact << " and " << sum_translucent / sum_exact
                  << " of exact\n";
        // The finer mask gives a piece under a sample at least one fine sample (s/4), where
        // its area (a/s of a sample) is its due: the tiny squares' excess is gone (one
        // translucent sample per pixel crossed, as the rows had before, made it 1.5 times
        // exact, rms 0.82), and the large squares' sum is as good
        if (size < 0.1) {
            EXPECT_NEAR(sum_translucent / sum_exact, 1.0, 0.1);
            EXPECT_LT(rms_translucent, 0.15);
            EXPECT_LT(rms_translucent, 0.25 * rms_fine);
        } else {
            EXPECT_NEAR(sum_translucent / sum_exact, 1.0, 0.025);
            EXPECT_LE(rms_translucent, rms_fine + 0.005);
        }
    }
}

// Thin strips (0.5 mm by 0.4 m at 3 m, every orientation in their plane; a louvre's slats, a
// frame's edge) seen by an element row's hemicube (R = 32, 8 × 8): a sample there is 2.3 cm
// wide, so a strip fills 2 % of the samples along it and the samples it happens to hold say
// nothing of its area. Without finer masks each of its triangles is one fragment of its area.
TEST(ABuffer, ThinStripsKeepTheirFormFactors) {
    std::vector<Patch> p;
    std::vector<double> exact;
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> pos(-2.5, 2.5), angle(0.0, 3.14159265358979);
    const double h = 3.0, w = 0.0005, len = 0.4;
    for (int k = 0; k < 400; ++k) {
        const glm::dvec3 c(pos(rng), pos(rng), h);
        const double a = angle(rng);
        const glm::dvec3 along(std::cos(a) * len / 2, std::sin(a) * len / 2, 0.0);
        const glm::dvec3 across(-std::sin(a) * w / 2, std::cos(a) * w / 2, 0.0);
        const glm::dvec3 q[4] = {c - along - across, c - along + across, c + along + across,
                                 c + along - across};
        add_quad(p, q[0], q[1], q[2], q[3]);
        exact.push_back(point_polygon_form_factor({0, 0, 0}, {0, 0, 1}, q));
    }
    for (const bool fine : {true, false}) {
        SCOPED_TRACE(fine ? "finer masks" : "translucent");
        ShootOptions o;
        o.occlusion = false;
        o.sparse = true;
        o.fine_masks = fine;
        const ShootResult res = shoot(ShooterFrame::at({0, 0, 0}, {0, 0, 1}), p, Hemicube(32), o);
        std::vector<double> f(exact.size(), 0.0);
        for (const PatchFormFactor& hit : res.hits) f[hit.patch / 2] += hit.ff;
        double sum = 0.0, sum_exact = 0.0, rms = 0.0;
        for (std::size_t q = 0; q < exact.size(); ++q) {
            sum += f[q];
            sum_exact += exact[q];
            rms += std::pow(f[q] / exact[q] - 1.0, 2);
        }
        rms = std::sqrt(rms / static_cast<double>(exact.size()));
        std::cout << (fine ? "finer masks" : "translucent") << ": sum " << sum / sum_exact
                  << " of exact, rms " << rms << ", " << res.fragments << " fragments\n";
        if (fine) {
            // At least one fine sample in every pixel crossed: several times the strip's area
            EXPECT_GT(sum / sum_exact, 2.0);
        } else {
            EXPECT_NEAR(sum / sum_exact, 1.0, 0.02);
            EXPECT_LT(rms, 0.05);
            EXPECT_LE(res.fragments, p.size());  // one per triangle
        }
    }
}

// Nine squares of 0.2 m at 3 m, each a mesh of tiny faces (2 and 5 mm squares of two
// triangles, a thousandth to a fiftieth of a sample each; a chair's curved seat, a fine
// tessellation): the pieces under a sample lie side by side, so their coverages add up within
// a sample. Stacked as translucent layers instead (1 − Π(1 − α)) they stopped 0.65 of the
// squares' form factor.
TEST(ABuffer, MeshesOfTinyFacesKeepTheirFormFactors) {
    for (const double cell : {0.002, 0.005}) {
        SCOPED_TRACE(cell);
        std::vector<Patch> p;
        double exact = 0.0;
        const double h = 3.0;
        const int n = static_cast<int>(std::lround(0.2 / cell));
        for (int sq = 0; sq < 9; ++sq) {
            const double x0 = -1.2 + 0.9 * (sq % 3) + 0.013 * sq;
            const double y0 = -1.2 + 0.9 * (sq / 3) + 0.007 * sq;
            for (int i = 0; i < n; ++i)
                for (int j = 0; j < n; ++j) {
                    const double x = x0 + i * cell, y = y0 + j * cell;
                    add_quad(p, {x, y, h}, {x, y + cell, h}, {x + cell, y + cell, h},
                             {x + cell, y, h});
                }
            const double s = n * cell;
            const glm::dvec3 q[4] = {
                {x0, y0, h}, {x0, y0 + s, h}, {x0 + s, y0 + s, h}, {x0 + s, y0, h}};
            exact += point_polygon_form_factor({0, 0, 0}, {0, 0, 1}, q);
        }
        ShootOptions o;
        o.occlusion = false;
        o.sparse = true;
        o.fine_masks = false;
        const ShootResult res = shoot(ShooterFrame::at({0, 0, 0}, {0, 0, 1}), p, Hemicube(32), o);
        double sum = 0.0;
        for (const PatchFormFactor& hit : res.hits) sum += hit.ff;
        std::cout << cell << " m faces: " << sum / exact << " of the squares' form factor\n";
        EXPECT_NEAR(sum / exact, 1.0, 0.03);
    }
}

// Occlusion lists (Algorithm 2) on a hand-built stack: translucent pane, opaque occluder,
// receiver, and a patch hidden entirely behind the receiver.
TEST(ABuffer, OcclusionListsOfAHandBuiltStack) {
    std::vector<Patch> p;
    add_quad(p, {-0.1, -0.1, 0.5}, {-0.1, 0.3, 0.5}, {0.3, 0.3, 0.5}, {0.3, -0.1, 0.5},
             0.5);                                                                // 0,1 pane
    add_quad(p, {-0.2, -0.2, 1}, {-0.2, 0.2, 1}, {0.2, 0.2, 1}, {0.2, -0.2, 1});  // 2,3 occluder
    add_quad(p, {-1, -1, 2}, {-1, 1, 2}, {1, 1, 2}, {1, -1, 2});                  // 4,5 receiver
    add_quad(p, {-0.1, -0.1, 3}, {-0.1, 0.1, 3}, {0.1, 0.1, 3}, {0.1, -0.1, 3});  // 6,7 hidden
    add_quad(p, {3, 3, 2}, {3, 4, 2}, {4, 4, 2}, {4, 3, 2});                      // 8,9 lit
    const ShootResult res =
        shoot(ShooterFrame::at({0, 0, 0}, {0, 0, 1}), p, Hemicube(50), ShootOptions{});
    // Occluders of a quad (both its triangles), as quads: 0 pane, 1 occluder, 2 receiver,
    // 3 hidden, 4 freely lit
    auto occluders = [&](std::uint32_t quad) {
        std::set<std::uint32_t> s;
        for (std::uint32_t t : {2 * quad, 2 * quad + 1})
            for (const auto& o : res.occluders_of(t)) s.insert(o.occluder / 2);
        return s;
    };
    // The receiver is behind the pane and the occluder
    EXPECT_EQ(occluders(2), (std::set<std::uint32_t>{0, 1}));
    // The occluder is behind the translucent pane
    EXPECT_EQ(occluders(1), (std::set<std::uint32_t>{0}));
    // The hidden patch: the occluder's ray bundle stops at the opaque receiver, so only the
    // receiver is listed (the paper's Algorithm 2)
    EXPECT_EQ(occluders(3), (std::set<std::uint32_t>{2}));
    EXPECT_EQ(res.form_factor[6] + res.form_factor[7], 0.0);
    // Nothing occludes the pane or the freely lit patch
    EXPECT_TRUE(occluders(0).empty());
    EXPECT_TRUE(occluders(4).empty());
    EXPECT_GE(res.raw_pairs, res.occlusion.size());
}

}  // namespace
}  // namespace abrad::radiosity
