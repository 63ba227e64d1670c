// Luminaires through the bake (point_source.h, bake.h): the weighted hemicubes' solid angles,
// exact direct light at the bake's vertices with and without discontinuity meshing, the
// shadow outline of a cube from the point in the discontinuity mesh, patch shading with the
// flux each patch stops, and the enclosure identity for the interreflected light.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>
#include <numbers>
#include <numeric>
#include <vector>

#include "abrad/radiosity/bake.h"
#include "abrad/radiosity/direct.h"
#include "abrad/radiosity/field_error.h"
#include "abrad/radiosity/point_source.h"
#include "scenes.h"

namespace abrad::radiosity {
namespace {

constexpr double kPi = std::numbers::pi;

/// A type C web of `cd` candela in every direction (its flux 4π·cd, exactly).
visdb::PhotometricWeb uniform_web(double cd) {
    visdb::PhotometricWeb web;
    web.horizontal = {0.0};
    web.vertical = {0.0, 90.0, 180.0};
    web.candela = {cd, cd, cd};
    return web;
}

visdb::Luminaire uniform_luminaire(double cd, const glm::dvec3& position) {
    visdb::Luminaire l;
    l.name = "L";
    l.web = uniform_web(cd);
    l.position = position;
    return l;
}

/// A floor [-a, a]² at z = 0 of n × n cells (ρ 0.5) and an isotropic 1000 cd source at (0, 0, h):
/// CIE 171 case 5.2's set-up.
visdb::Scene floor_under_point(double a, int n, double h) {
    visdb::Scene scene;
    scene.emittance_unit = "lm/m2";
    scene.materials.push_back({"floor", {0.5, 0.5, 0.5}, {0, 0, 0}, 1.0});
    scene.surfaces.push_back(testing::grid("floor", 0, -a, a, -a, a, 0.0, n, true));
    scene.luminaires.push_back(uniform_luminaire(1000.0, {0.0, 0.0, h}));
    return scene;
}

/// I h / d³: the illuminance of an isotropic source of I candela at height h on the floor.
double on_floor(double intensity, const glm::dvec3& source, const glm::dvec3& x) {
    const double d = glm::length(source - x);
    return intensity * (source.z - x.z) / (d * d * d);
}

TEST(LuminaireBake, WeightedHemicubePixelsCarryTheirSolidAngle) {
    // A weight of 1 everywhere: the pixels' solid angles, which fill the hemisphere (2π)
    const Hemicube unit(50, [](const glm::dvec3&) { return 1.0; });
    const double sum = std::accumulate(unit.deltas().begin(), unit.deltas().end(), 0.0);
    EXPECT_NEAR(sum, 2.0 * kPi, 1e-12);
    // The top face's centre pixel of R = 2 is a quarter of the top face: 2π/3 sr... for the
    // whole top face [-1, 1]² at distance 1, 4·atan(1/√3) = 2π/3
    const Hemicube coarse(2, [](const glm::dvec3&) { return 1.0; });
    double top = 0.0;
    for (std::size_t p = 0; p < 4; ++p) top += coarse.delta(coarse.face_offset(kTop) + p);
    EXPECT_NEAR(top, 2.0 * kPi / 3.0, 1e-12);
    // A point source's two hemicubes carry fractions of its flux: 1 in all, ½ each for a
    // uniform web
    const auto shooters = point_shooters(uniform_luminaire(50.0, {1.0, 2.0, 3.0}), 20);
    for (const PointShooter& s : shooters) {
        EXPECT_NEAR(std::accumulate(s.hemicube.deltas().begin(), s.hemicube.deltas().end(), 0.0),
                    0.5, 1e-12);
        EXPECT_EQ(s.frame.origin, glm::dvec3(1.0, 2.0, 3.0));
    }
    EXPECT_NEAR(luminaire_power(uniform_luminaire(50.0, {})).y, 4.0 * kPi * 50.0, 1e-9);
}

TEST(LuminaireBake, DirectLightAtTheVerticesIsExactWithAndWithoutDm) {
    const visdb::Scene scene = floor_under_point(5.0, 10, 3.0);
    const glm::dvec3 source = scene.luminaires[0].position;
    for (const bool dm : {false, true}) {
        BakeOptions o;
        o.bounces = 0;
        o.dm = dm;
        const visdb::Bake b = bake(scene, o);
        EXPECT_EQ(b.unit, "lux");
        ASSERT_FALSE(b.mesh.positions.empty());
        for (std::size_t v = 0; v < b.mesh.positions.size(); ++v) {
            const double expected = on_floor(1000.0, source, b.mesh.positions[v]);
            EXPECT_NEAR(b.mesh.irradiance[v].y, expected, 1e-5 * expected) << dm << " " << v;
        }
        // The power the floor stops: 1000 cd times its solid angle from the source (a square
        // of half side a at distance h: 4 atan(a² / (h √(h² + 2a²))))
        const double omega = 4.0 * std::atan(25.0 / (3.0 * std::sqrt(9.0 + 50.0)));
        EXPECT_NEAR(b.statistics.received_power_w, 1000.0 * omega, 2e-3 * 1000.0 * omega);
        EXPECT_NEAR(b.statistics.emitted_power_w, 4000.0 * kPi, 1e-6);
    }
}

TEST(LuminaireBake, PatchShadingGivesEachPatchTheFluxItStops) {
    const visdb::Scene scene = floor_under_point(5.0, 10, 3.0);
    for (const bool dm : {false, true}) {
        BakeOptions o;
        o.bounces = 0;
        o.dm = dm;
        o.shading = Shading::Patch;
        const visdb::Bake b = bake(scene, o);
        // Σ H·A over the output triangles (each vertex the area-weighted mean of its patches)
        // is near the flux on the floor; the centre patch's value near I h / d³ there
        double power = 0.0;
        for (const glm::u32vec3& t : b.mesh.triangles) {
            const double a = visdb::triangle_area(b.mesh.positions[t.x], b.mesh.positions[t.y],
                                                  b.mesh.positions[t.z]);
            power +=
                a *
                (b.mesh.irradiance[t.x].y + b.mesh.irradiance[t.y].y + b.mesh.irradiance[t.z].y) /
                3.0;
        }
        const double omega = 4.0 * std::atan(25.0 / (3.0 * std::sqrt(9.0 + 50.0)));
        EXPECT_NEAR(power, 1000.0 * omega, 0.03 * 1000.0 * omega) << dm;
    }
}

/// The floor [-3, 3]² (ρ 0.5) with a unit cube [-0.5, 0.5]² × [0, 1] standing on it (five
/// faces, ρ 0.3) and an isotropic 500 cd source at `source`.
visdb::Scene cube_on_floor(const glm::dvec3& source) {
    visdb::Scene scene;
    scene.emittance_unit = "lm/m2";
    scene.materials.push_back({"floor", {0.5, 0.5, 0.5}, {0, 0, 0}, 1.0});
    scene.materials.push_back({"cube", {0.3, 0.3, 0.3}, {0, 0, 0}, 1.0});
    scene.surfaces.push_back(testing::grid("floor", 0, -3, 3, -3, 3, 0.0, 6, true));
    using glm::dvec3;
    scene.surfaces.push_back(
        testing::quad_grid("top", 1, {-0.5, -0.5, 1}, {1, 0, 0}, {0, 1, 0}, 1));
    scene.surfaces.push_back(testing::quad_grid("-y", 1, {-0.5, -0.5, 0}, {1, 0, 0}, {0, 0, 1}, 1));
    scene.surfaces.push_back(testing::quad_grid("+y", 1, {0.5, 0.5, 0}, {-1, 0, 0}, {0, 0, 1}, 1));
    scene.surfaces.push_back(testing::quad_grid("+x", 1, {0.5, -0.5, 0}, {0, 1, 0}, {0, 0, 1}, 1));
    scene.surfaces.push_back(testing::quad_grid("-x", 1, {-0.5, 0.5, 0}, {0, -1, 0}, {0, 0, 1}, 1));
    scene.luminaires.push_back(uniform_luminaire(500.0, source));
    return scene;
}

/// The shadow of the cube on the floor from `source` (above the cube): the convex hull of its
/// footprint and its top face projected from the point, counter-clockwise.
std::vector<glm::dvec2> shadow_outline(const glm::dvec3& source) {
    std::vector<glm::dvec2> pts;
    for (const double x : {-0.5, 0.5})
        for (const double y : {-0.5, 0.5}) {
            pts.emplace_back(x, y);
            const glm::dvec3 top{x, y, 1.0};
            const glm::dvec3 p = source + (top - source) * (source.z / (source.z - 1.0));
            pts.emplace_back(p.x, p.y);
        }
    // Andrew's monotone chain
    std::sort(pts.begin(), pts.end(), [](const glm::dvec2& a, const glm::dvec2& b) {
        return a.x < b.x || (a.x == b.x && a.y < b.y);
    });
    auto cross = [](const glm::dvec2& o, const glm::dvec2& a, const glm::dvec2& b) {
        return (a.x - o.x) * (b.y - o.y) - (a.y - o.y) * (b.x - o.x);
    };
    std::vector<glm::dvec2> hull(2 * pts.size());
    std::size_t k = 0;
    for (std::size_t i = 0; i < pts.size(); ++i) {
        while (k >= 2 && cross(hull[k - 2], hull[k - 1], pts[i]) <= 0.0) --k;
        hull[k++] = pts[i];
    }
    for (std::size_t i = pts.size() - 1, t = k + 1; i-- > 0;) {
        while (k >= t && cross(hull[k - 2], hull[k - 1], pts[i]) <= 0.0) --k;
        hull[k++] = pts[i];
    }
    hull.resize(k - 1);
    return hull;
}

/// Signed distance of `p` from the outline's edge a→b (positive outside a counter-clockwise
/// polygon).
double outside(const glm::dvec2& a, const glm::dvec2& b, const glm::dvec2& p) {
    const glm::dvec2 d = b - a;
    return (d.x * (p.y - a.y) - d.y * (p.x - a.x)) / -glm::length(d);
}

TEST(LuminaireBake, DmMeshFollowsTheShadowOutlineFromThePoint) {
    const glm::dvec3 source{0.7, 0.4, 2.5};
    const visdb::Scene scene = cube_on_floor(source);
    BakeOptions o;
    o.bounces = 0;
    o.refine_tolerance = 0.02;
    o.refine_min_edge = 0.01;
    o.refine_rounds = 8;  // fine refinement: the error left is the smooth field's
    const visdb::Bake b = bake(scene, o);
    ASSERT_GT(b.statistics.dm->shadow.edges_projected, 0u);
    const std::vector<glm::dvec2> hull = shadow_outline(source);
    // Every corner of the outline off the footprint is a vertex of the floor's mesh
    std::size_t corners = 0;
    for (const glm::dvec2& c : hull) {
        if (std::abs(c.x) <= 0.5 + 1e-9 && std::abs(c.y) <= 0.5 + 1e-9) continue;
        ++corners;
        double nearest = 1e300;
        for (std::size_t v = 0; v < b.mesh.positions.size(); ++v)
            if (b.mesh.positions[v].z == 0.0)
                nearest = std::min(nearest, glm::length(glm::dvec2(b.mesh.positions[v]) - c));
        EXPECT_LT(nearest, 1e-6) << c.x << " " << c.y;
    }
    EXPECT_GE(corners, 3u);
    // No floor triangle crosses an outline edge off the footprint: its corners lie on one side
    for (std::size_t e = 0; e < hull.size(); ++e) {
        const glm::dvec2 a = hull[e], c = hull[(e + 1) % hull.size()];
        for (const glm::u32vec3& t : b.mesh.triangles) {
            if (b.mesh.positions[t.x].z != 0.0 || b.mesh.positions[t.y].z != 0.0 ||
                b.mesh.positions[t.z].z != 0.0)
                continue;
            double lo = 0.0, hi = 0.0;
            bool along = true;  // the triangle lies beside the edge's span (not past its ends)
            for (int k = 0; k < 3; ++k) {
                const glm::dvec2 p(b.mesh.positions[t[k]]);
                const double s = outside(a, c, p);
                lo = std::min(lo, s);
                hi = std::max(hi, s);
                const double u = glm::dot(p - a, c - a) / glm::dot(c - a, c - a);
                along &= u > 0.0 && u < 1.0;
            }
            if (along) {
                EXPECT_FALSE(lo < -1e-6 && hi > 1e-6)
                    << "edge " << e << " crossed by a triangle at " << b.mesh.positions[t.x].x
                    << " " << b.mesh.positions[t.x].y;
            }
        }
    }
    // The Gouraud field against the exact field: a point source's shadow is a step, smeared
    // over the refined triangles beside the outline (refine_min_edge wide: the mesh shares its
    // vertices across the outline), so with fine refinement the floor's error is that of its
    // smooth field alone, the same floor without the cube
    auto error_of = [&](const visdb::Scene& s, const visdb::Bake& baked) {
        const DirectField exact(s);
        return field_error(
                   s, baked.mesh,
                   [&](const glm::dvec3& x, const glm::dvec3& n) { return exact.irradiance(x, n); })
            .relative_l1;
    };
    visdb::Scene bare = scene;
    bare.surfaces.resize(1);
    const double with_cube = error_of(scene, b), without = error_of(bare, bake(bare, o));
    EXPECT_LT(with_cube, 0.01);
    EXPECT_LT(with_cube, without + 0.002) << with_cube << " " << without;
}

// A large rectangular opening (1.2 x 0.8 m, 2.5 m over the floor: closer than five times its
// size, so the exact field integrates over it and the cube casts a penumbra): the shadow
// outlines cast from each of the opening's four corners are in the discontinuity mesh, as the
// outline from its centre is (the umbra and penumbra bounds); for a 0.9 m disc, those cast from
// eight points on its rim. Without the corners only the centre's outline would be.
TEST(LuminaireBake, DmMeshFollowsThePenumbraOfALargeOpening) {
    const glm::dvec3 source{0.7, 0.4, 2.5};
    // The floor vertex nearest to the point c of the floor
    const auto nearest_vertex = [](const visdb::Bake& b, const glm::dvec2& c) {
        double nearest = 1e300;
        for (std::size_t k = 0; k < b.mesh.positions.size(); ++k)
            if (b.mesh.positions[k].z == 0.0)
                nearest = std::min(nearest, glm::length(glm::dvec2(b.mesh.positions[k]) - c));
        return nearest;
    };
    // The corners of the shadow outlines from `points` off the cube's footprint
    const auto expect_outlines = [&](const visdb::Bake& b, const std::vector<glm::dvec3>& points) {
        std::size_t checked = 0;
        for (const glm::dvec3& p : points) {
            for (const glm::dvec2& c : shadow_outline(p)) {
                if (std::abs(c.x) <= 0.5 + 1e-9 && std::abs(c.y) <= 0.5 + 1e-9) continue;
                ++checked;
                EXPECT_LT(nearest_vertex(b, c), 1e-6)
                    << "from " << p.x << " " << p.y << ": " << c.x << " " << c.y;
            }
        }
        return checked;
    };
    BakeOptions o;
    o.bounces = 0;

    // A rectangle 1.2 x 0.8 m: its four corners
    visdb::Scene scene = cube_on_floor(source);
    visdb::Luminaire& l = scene.luminaires.front();
    l.opening.shape = visdb::LuminousOpening::Shape::Rectangle;
    l.opening.length = 1.2;  // along x
    l.opening.width = 0.8;   // along y
    std::vector<glm::dvec3> corners;
    for (const double u : {-0.6, 0.6})
        for (const double v : {-0.4, 0.4}) corners.push_back(source + glm::dvec3(u, v, 0.0));
    EXPECT_GE(expect_outlines(bake(scene, o), corners), 12u);

    // A disc 0.9 m across: eight points on its rim
    l.opening.shape = visdb::LuminousOpening::Shape::Disc;
    l.opening.length = l.opening.width = 0.9;
    std::vector<glm::dvec3> rim;
    for (int k = 0; k < 8; ++k) {
        const double phi = 2.0 * kPi * k / 8.0;
        rim.push_back(source + 0.45 * glm::dvec3(std::cos(phi), std::sin(phi), 0.0));
    }
    EXPECT_GE(expect_outlines(bake(scene, o), rim), 24u);
}

TEST(LuminaireBake, ClosedBoxMeetsTheEnclosureIdentity) {
    // A 4 × 3 × 2.5 m box, every face inward, ρ = 0.5, a 100 cd isotropic source inside: the
    // mean irradiance over the walls is Φ / (A (1 − ρ)) when nothing escapes
    const double rho = 0.5;
    visdb::Scene scene;
    scene.emittance_unit = "lm/m2";
    scene.materials.push_back({"wall", {rho, rho, rho}, {0, 0, 0}, 1.0});
    using glm::dvec3;
    const dvec3 lo{0, 0, 0}, hi{4, 3, 2.5}, inside = 0.5 * (lo + hi);
    auto face = [&](const std::string& name, dvec3 o, dvec3 u, dvec3 v) {
        const dvec3 c = o + 0.5 * (u + v);
        if (glm::dot(glm::cross(u, v), inside - c) < 0.0) {
            o += u;
            u = -u;
        }
        scene.surfaces.push_back(testing::quad_grid(name, 0, o, u, v, 4));
    };
    face("floor", lo, {4, 0, 0}, {0, 3, 0});
    face("ceiling", {0, 0, 2.5}, {4, 0, 0}, {0, 3, 0});
    face("south", lo, {4, 0, 0}, {0, 0, 2.5});
    face("north", {0, 3, 0}, {4, 0, 0}, {0, 0, 2.5});
    face("west", lo, {0, 3, 0}, {0, 0, 2.5});
    face("east", {4, 0, 0}, {0, 3, 0}, {0, 0, 2.5});
    scene.luminaires.push_back(uniform_luminaire(100.0, {1.3, 1.1, 1.7}));
    const double area = 2.0 * (4 * 3 + 4 * 2.5 + 3 * 2.5);
    const double flux = 4.0 * kPi * 100.0;
    const double expected = flux / (area * (1.0 - rho));

    BakeOptions o;
    o.dm = false;
    const visdb::Bake b = bake(scene, o);
    double sum = 0.0, total = 0.0;
    for (const glm::u32vec3& t : b.mesh.triangles) {
        const double a = visdb::triangle_area(b.mesh.positions[t.x], b.mesh.positions[t.y],
                                              b.mesh.positions[t.z]);
        sum += a *
               (b.mesh.irradiance[t.x].y + b.mesh.irradiance[t.y].y + b.mesh.irradiance[t.z].y) /
               3.0;
        total += a;
    }
    EXPECT_NEAR(total, area, 1e-9);
    EXPECT_NEAR(sum / total, expected, 0.02 * expected) << sum / total;
    // Energy: the luminaire's flux, all absorbed but what is still unshot
    const visdb::InterreflectionStats& i = *b.statistics.indirect;
    EXPECT_NEAR(i.energy_emitted_w, flux, 1e-9 * flux);
    EXPECT_NEAR(i.energy_absorbed_w + i.energy_escaped_w + i.energy_unshot_w, flux, 1e-4 * flux);
    EXPECT_LT(i.energy_escaped_w, 1e-3 * flux);
}

}  // namespace
}  // namespace abrad::radiosity
