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

// Without finer masks (ShootOptions::fine_masks, the elements' rows) a piece holding no
// sample takes one translucent sample of its area over the sample's. Triangles under a
// sample's size (1 cm squares at 3 m; a sample is 1.5 cm there at R = 50, 8 × 8) and squares of
// two pixels, whose edges leave sampleless slivers, against their closed forms.
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
        EXPECT_EQ(undersampled_translucent, undersampled_fine);  // the same pieces
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
        // Pieces that hold a sample are point sampled either way; the ones that hold none
        // take a's share (a/s of a sample) instead of at least one fine sample (s/4), so the
        // tiny squares' excess is smaller, and the large squares' sum as good
        if (size < 0.1) {
            EXPECT_LT(sum_translucent, sum_fine);
            EXPECT_LT(rms_translucent, rms_fine);
        } else {
            EXPECT_NEAR(sum_translucent / sum_exact, 1.0, 0.025);
            EXPECT_LE(rms_translucent, rms_fine + 0.005);
        }
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
