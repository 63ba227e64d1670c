// Interreflection against exact answers: the uniform enclosure (Φ/(A(1−ρ))), bounce by
// bounce in a closed room, energy balance with an opening, light reflected from a floor onto
// walls and ceiling (quadrature of the closed-form floor radiosity), an obstruction.

#include "abrad/radiosity/indirect.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <numbers>
#include <vector>

#include "abrad/radiosity/bake.h"
#include "abrad/radiosity/direct.h"
#include "abrad/radiosity/form_factor.h"
#include "analytic.h"
#include "mesh_checks.h"
#include "scenes.h"

namespace abrad::radiosity {
namespace {

using abrad::testing::mean_irradiance;

using abrad::testing::quad_grid;
using testing::ff_parallel_rect;

// A quad surface whose front faces `inside`.
visdb::Surface facing(const std::string& name, std::uint32_t material, glm::dvec3 o, glm::dvec3 u,
                      glm::dvec3 v, int n, glm::dvec3 inside) {
    const glm::dvec3 c = o + 0.5 * (u + v);
    if (glm::dot(glm::cross(u, v), inside - c) < 0.0) {
        o += u;
        u = -u;
    }
    return quad_grid(name, material, o, u, v, n);
}

struct RoomSpec {
    double floor = 0.5, walls = 0.5, ceiling = 0.5, light = 0.0;  // reflectances
    bool open_floor = false;
    int cells = 8;  // floor cells per side
};

// The 4×4×3 m room (x, y in [−2, 2], z in [0, 3]) with a 1×1 m light of E = 10 W/m² set into
// the ceiling's centre (the ceiling has a hole exactly where the light is: closed).
visdb::Scene room(const RoomSpec& spec) {
    visdb::Scene s;
    auto grey = [](double r) { return visdb::Rgb(r); };
    s.materials.push_back({"floor", grey(spec.floor), {0, 0, 0}, 1.0});
    s.materials.push_back({"walls", grey(spec.walls), {0, 0, 0}, 1.0});
    s.materials.push_back({"ceiling", grey(spec.ceiling), {0, 0, 0}, 1.0});
    s.materials.push_back({"light", grey(spec.light), {10, 10, 10}, 1.0});
    const glm::dvec3 mid(0, 0, 1.5);
    if (!spec.open_floor)
        s.surfaces.push_back(
            facing("floor", 0, {-2, -2, 0}, {4, 0, 0}, {0, 4, 0}, spec.cells, mid));
    s.surfaces.push_back(facing("wall -y", 1, {-2, -2, 0}, {4, 0, 0}, {0, 0, 3}, 6, mid));
    s.surfaces.push_back(facing("wall +y", 1, {-2, 2, 0}, {4, 0, 0}, {0, 0, 3}, 6, mid));
    s.surfaces.push_back(facing("wall -x", 1, {-2, -2, 0}, {0, 4, 0}, {0, 0, 3}, 6, mid));
    s.surfaces.push_back(facing("wall +x", 1, {2, -2, 0}, {0, 4, 0}, {0, 0, 3}, 6, mid));
    // Ceiling: 0.5 m cells but the four around the centre, which the light fills
    visdb::Surface ceiling;
    ceiling.name = "ceiling";
    ceiling.material = 2;
    for (int j = 0; j < 8; ++j)
        for (int i = 0; i < 8; ++i) {
            if ((i == 3 || i == 4) && (j == 3 || j == 4)) continue;
            const auto base = static_cast<std::uint32_t>(ceiling.mesh.positions.size());
            const double x = -2 + 0.5 * i, y = -2 + 0.5 * j;
            ceiling.mesh.positions.insert(
                ceiling.mesh.positions.end(),
                {{x, y, 3}, {x + 0.5, y, 3}, {x + 0.5, y + 0.5, 3}, {x, y + 0.5, 3}});
            ceiling.mesh.triangles.push_back({base, base + 2, base + 1});  // facing down
            ceiling.mesh.triangles.push_back({base, base + 3, base + 2});
        }
    s.surfaces.push_back(ceiling);
    s.surfaces.push_back(facing("light", 3, {-0.5, -0.5, 3}, {1, 0, 0}, {0, 1, 0}, 1, mid));
    return s;
}

BakeOptions quick(int bounces) {
    BakeOptions o;
    o.dm = false;
    o.bounces = bounces;
    return o;
}

void expect_energy_balance(const visdb::Bake& b) {
    const double emitted = b.statistics.indirect.value().energy_emitted_w;
    EXPECT_NEAR(emitted, 10.0, 1e-9);
    EXPECT_NEAR(b.statistics.indirect.value().energy_absorbed_w +
                    b.statistics.indirect.value().energy_escaped_w +
                    b.statistics.indirect.value().energy_unshot_w,
                emitted, 1e-3 * emitted);
}

TEST(Interreflection, UniformEnclosureMeanIrradianceIsPhiOverAOneMinusRho) {
    for (const double rho : {0.5, 0.8, 0.95}) {
        const visdb::Bake b = bake(room({rho, rho, rho, rho}), quick(-1));
        double area = 0.0;
        const double mean = mean_irradiance(b, &area);
        ASSERT_NEAR(area, 80.0, 1e-9);
        const double expected = 10.0 / (area * (1.0 - rho));
        EXPECT_NEAR(mean, expected, 0.01 * expected) << "rho " << rho;
        expect_energy_balance(b);
        // Closed: what the hemicubes miss is rounding, not a leak
        EXPECT_LT(b.statistics.indirect.value().energy_escaped_w, 1e-3 * 10.0) << "rho " << rho;
        EXPECT_LT(b.statistics.indirect.value().unshot_fraction, 0.005);
    }
}

// Issue 14's accuracy target: in a closed room of uniform ρ the converged reflected part
// (with the ambient term) is Φρ/(A(1 − ρ)) within 0.5 %, up to ρ = 0.95. The direct part's
// coarse-mesh interpolation error is taken out as in the bounce-by-bounce test below.
TEST(Interreflection, ConvergedReflectedPartOfAClosedRoomWithinHalfAPercent) {
    const double direct = 10.0 / 80.0;
    // Irradiance: the direct part does not depend on ρ
    const double direct_mean = mean_irradiance(bake(room({0.5, 0.5, 0.5, 0.5}), quick(0)));
    for (const double rho : {0.5, 0.9, 0.95}) {
        const visdb::Bake b = bake(room({rho, rho, rho, rho}), quick(-1));
        const double expected = direct * rho / (1.0 - rho);
        const double reflected = mean_irradiance(b) - direct_mean;
        EXPECT_NEAR(reflected, expected, 0.005 * expected) << "rho " << rho;
        std::printf("rho %.2f: reflected %.6f, closed form %.6f, error %+.3f%%\n", rho, reflected,
                    expected, 100.0 * (reflected / expected - 1.0));
    }
}

// Issue 18: with --ambient off, the converged answer is what was shot. The stop rule measures
// what is still to come against the reflected light (not against the emitted power, which at
// ρ = 0.05 left the reflected part 7 % short): within --converge of Φρ/(A(1 − ρ)) at every ρ,
// beside the rounding of the hemicubes (the direct part taken out as above).
TEST(Interreflection, AmbientOffStopsWithinConvergeOfTheClosedFormAtAnyRho) {
    const double direct = 10.0 / 80.0;
    const double direct_mean = mean_irradiance(bake(room({0.5, 0.5, 0.5, 0.5}), quick(0)));
    for (const double rho : {0.05, 0.2, 0.5, 0.95}) {
        BakeOptions o = quick(-1);
        o.ambient = false;
        const visdb::Bake b = bake(room({rho, rho, rho, rho}), o);
        const double expected = direct * rho / (1.0 - rho);
        const double reflected = mean_irradiance(b) - direct_mean;
        std::printf("ambient off, rho %.2f: reflected %.6f, closed form %.6f, error %+.3f%%\n", rho,
                    reflected, expected, 100.0 * (reflected / expected - 1.0));
        EXPECT_NEAR(reflected, expected, (o.converge + 0.003) * expected) << "rho " << rho;
    }
}

TEST(Interreflection, BounceByBounceInAClosedRoom) {
    // In a closed room of uniform ρ, bounce k carries Φρ^k: after N bounces the mean is
    // Φ/A · (1 − ρ^(N+1)) / (1 − ρ). The reflected part is compared on its own: the exported
    // direct field is the linear interpolation of exact vertex values on this coarse mesh, whose
    // mean misses Φ/A by 1.8% (the same in every bake of the room: the coarse-mesh error issue 18
    // tracks), so it is measured by a direct-only bake and taken out.
    const double rho = 0.6, direct = 10.0 / 80.0;
    const double direct_mean = mean_irradiance(bake(room({rho, rho, rho, rho}), quick(0)));
    EXPECT_NEAR(direct_mean, direct, 0.025 * direct);
    for (const int n : {1, 3}) {
        const visdb::Bake b = bake(room({rho, rho, rho, rho}), quick(n));
        const double expected = direct * ((1.0 - std::pow(rho, n + 1)) / (1.0 - rho) - 1.0);
        EXPECT_NEAR(mean_irradiance(b) - direct_mean, expected, 0.01 * expected) << n << " bounces";
        EXPECT_EQ(double(b.statistics.indirect.value().bounces), n);
        expect_energy_balance(b);
    }
}

TEST(Interreflection, OverRelaxationConvergesToTheSameLight) {
    const double rho = 0.9;
    BakeOptions o = quick(-1);
    o.converge = 1e-3;
    const visdb::Bake plain = bake(room({rho, rho, rho, rho}), o);
    o.overrelaxation = 1.5;
    const visdb::Bake over = bake(room({rho, rho, rho, rho}), o);
    EXPECT_NEAR(mean_irradiance(over), mean_irradiance(plain), 0.002 * mean_irradiance(plain));
    expect_energy_balance(over);
}

// Elements shoot in blocks of 2×2 cells where no other surface stands within half a block in
// front of them (the middle of the floor, walls and ceiling), cell by cell elsewhere: fewer
// hemicubes, the same light. (Near a wall a block's one shooting point would misplace the
// light the wall's foot gets: LightReflectedFromTheFloorOntoWallsAndCeiling checks that.)
TEST(Interreflection, ShootersGroupCellsAwayFromOtherSurfacesAndKeepTheLight) {
    const visdb::Scene scene = room({0.7, 0.7, 0.7, 0.0});
    BakeOptions o = quick(-1);
    o.shooter_cells = 1;
    const visdb::Bake alone = bake(scene, o);
    o.shooter_cells = 2;
    const visdb::Bake grouped = bake(scene, o);
    const auto& a = alone.statistics.indirect.value();
    const auto& g = grouped.statistics.indirect.value();
    EXPECT_EQ(a.shooters, a.elements);
    EXPECT_EQ(g.elements, a.elements);
    // Blocks away from the walls: the floor's, walls' and ceiling's middles
    EXPECT_LT(g.shooters, a.elements - 12);
    EXPECT_GT(g.shooters, a.elements / 2);  // the cells along the room's edges shoot alone
    EXPECT_LT(g.rows, a.rows);
    expect_energy_balance(grouped);
    EXPECT_NEAR(mean_irradiance(grouped), mean_irradiance(alone), 0.005 * mean_irradiance(alone));
}

// A closed room holding a cluster of small boxes (0.15 m, 0.1 m apart, floating at 0.5 m),
// every surface of one ρ: nothing can escape, and the mean irradiance over all the surfaces is
// Φ/(A(1 − ρ)). The boxes' faces are small faces grouped in shooters of many, and one point
// of a group sees the next box's face under a form factor far above the group's mean: the
// bound on it must hand the rest to what else the group sees, not count it as escaped.
TEST(Interreflection, SmallFacesGroupedInAClosedRoomLoseNoLight) {
    const double rho = 0.5;
    visdb::Scene scene = room({rho, rho, rho, rho});
    scene.materials.push_back({"box", visdb::Rgb(rho), {0, 0, 0}, 1.0});
    const auto box_material = static_cast<std::uint32_t>(scene.materials.size() - 1);
    const double side = 0.15, pitch = 0.25;
    for (int j = 0; j < 4; ++j)
        for (int i = 0; i < 4; ++i) {
            const glm::dvec3 o(-0.5 + pitch * i, -0.5 + pitch * j, 0.5);
            const glm::dvec3 c = o + 0.5 * glm::dvec3(side);
            const glm::dvec3 x(side, 0, 0), y(0, side, 0), z(0, 0, side);
            // Six faces, each facing out of the box (away from its centre)
            const auto out = [&](glm::dvec3 a, glm::dvec3 u, glm::dvec3 v) {
                return facing("box", box_material, a, u, v, 1, 2.0 * (a + 0.5 * (u + v)) - c);
            };
            for (const auto& face : {out(o, x, y), out(o + z, x, y), out(o, x, z), out(o + y, x, z),
                                     out(o, y, z), out(o + x, y, z)})
                scene.surfaces.push_back(face);
        }
    const visdb::Bake b = bake(scene, quick(-1));
    const auto& st = b.statistics.indirect.value();
    double area = 0.0;
    const double mean = mean_irradiance(b, &area);
    ASSERT_NEAR(area, 80.0 + 16 * 6 * side * side, 1e-9);
    // The reflected part, Φρ/(A(1 − ρ)), with the direct part's interpolation error taken out
    // as in the closed room above
    const double reflected = mean - mean_irradiance(bake(scene, quick(0)));
    const double expected = 10.0 / area * rho / (1.0 - rho);
    std::printf(
        "closed room with boxes: escaped %.5f W of 10, reflected %.6f, closed form %.6f "
        "(%+.3f%%)\n",
        st.energy_escaped_w, reflected, expected, 100.0 * (reflected / expected - 1.0));
    // What the hemicubes' rounding loses in a closed room (the bounds' excess counted as
    // escaped was 0.0135 W)
    EXPECT_LT(st.energy_escaped_w, 5e-4 * 10.0);
    EXPECT_NEAR(reflected, expected, 0.01 * expected);
    expect_energy_balance(b);
}

// The hemicubes draw each planar surface from its outline (outline_patches), so how finely a
// surface is meshed changes neither their cost nor what they see: a floor of 4 x 4 or 12 x 12
// cells is two triangles to them, and so is each wall of 6 x 6, and the two rooms' light
// agrees to the solution's own tolerance.
TEST(Interreflection, HemicubesDrawSurfacesFromTheirOutlines) {
    RoomSpec coarse{.floor = 0.5, .walls = 0.5, .ceiling = 0.5, .light = 0.0, .cells = 4};
    RoomSpec fine = coarse;
    fine.cells = 12;
    const visdb::Bake a = bake(room(coarse), quick(-1)), b = bake(room(fine), quick(-1));
    const auto &sa = a.statistics.indirect.value(), &sb = b.statistics.indirect.value();
    ASSERT_EQ(a.statistics.triangles, 2 * 16 + 4 * 72 + 120 + 2u);
    ASSERT_EQ(b.statistics.triangles, 2 * 144 + 4 * 72 + 120 + 2u);
    // The floor and each wall two triangles; the ceiling's cells, each a region of its own
    // (they share no vertex), and the light keep theirs
    EXPECT_EQ(sa.visibility_triangles, 2 + 4 * 2 + 120 + 2u);
    EXPECT_EQ(sb.visibility_triangles, sa.visibility_triangles);
    EXPECT_EQ(sa.elements, sb.elements);
    EXPECT_NEAR(sa.energy_absorbed_w, sb.energy_absorbed_w, 1e-3 * 10.0);
    // The ambient term is what is left unshot when the solution stops: one shot more or less
    // (the two rooms stop at 993 and 994 shots) moves it by 0.4 %
    EXPECT_NEAR(sa.ambient, sb.ambient, 0.01 * sa.ambient);
    EXPECT_LT(sb.energy_escaped_w, 1e-4 * 10.0);
    expect_energy_balance(b);
}

// Small faces are grouped in cubes that shoot from one member's point, and a member that
// point cannot see must not have its light shot from there: a partition closes a dark
// compartment off the lit room, and a small face on each side of it lies in one cube (the
// dark one the larger, so that the cube's point is on it). Nothing may reach the compartment.
TEST(Interreflection, SmallFacesAreNotShotFromBehindAWall) {
    visdb::Scene scene = room({0.5, 0.5, 0.5, 0.0});
    scene.materials.push_back({"grey", visdb::Rgb(0.5), {0, 0, 0}, 1.0});
    const auto grey = static_cast<std::uint32_t>(scene.materials.size() - 1);
    const glm::dvec3 lit(0, 0, 1.5), dark(1.8, 0, 1.5);
    scene.surfaces.push_back(
        facing("partition", grey, {1.45, -2, 0}, {0, 4, 0}, {0, 0, 3}, 4, lit));
    scene.surfaces.push_back(
        facing("partition, dark side", grey, {1.55, -2, 0}, {0, 4, 0}, {0, 0, 3}, 4, dark));
    scene.surfaces.push_back(
        facing("lit face", grey, {1.1, 0.1, 1}, {0.2, 0, 0}, {0, 0.2, 0}, 1, {1.2, 0.2, 2}));
    scene.surfaces.push_back(
        facing("dark face", grey, {1.65, 0.1, 1}, {0.25, 0, 0}, {0, 0.3, 0}, 1, {1.8, 0.2, 2}));
    const auto first = static_cast<std::uint32_t>(scene.surfaces.size() - 4);
    BakeOptions o = quick(-1);
    o.ambient = false;  // the ambient term is spread everywhere, the compartment too
    const visdb::Bake b = bake(scene, o);
    double lit_face = 0.0, dark_side = 0.0;
    for (std::size_t t = 0; t < b.mesh.triangles.size(); ++t) {
        const std::uint32_t surface = b.mesh.triangle_surface[t];
        for (int k = 0; k < 3; ++k) {
            const glm::vec3 h = b.mesh.irradiance[b.mesh.triangles[t][k]];
            if (surface == first + 2) lit_face = std::max(lit_face, double(h.y));
            if (surface == first + 1 || surface == first + 3)
                dark_side = std::max({dark_side, double(h.x), double(h.y), double(h.z)});
        }
    }
    EXPECT_GT(lit_face, 0.01);
    EXPECT_EQ(dark_side, 0.0);
}

TEST(Interreflection, EnergyBalanceWithAnOpening) {
    // Black room, open floor: the light's power escapes as F(centroid → floor opening)
    {
        const visdb::Bake b =
            bake(room({.floor = 0, .walls = 0, .ceiling = 0, .open_floor = true}), quick(-1));
        const double escaped = b.statistics.indirect.value().energy_escaped_w;
        // The hemicube (R = 50, 8×8 masks) gives the walls' edges along the opening a little
        // too much coverage: 3.547 W escape against 3.577 W (−0.8%)
        const double expected = 10.0 * ff_parallel_rect(-2, 2, -2, 2, 3);
        EXPECT_NEAR(escaped, expected, 0.012 * expected);
        expect_energy_balance(b);
    }
    // Reflecting walls and ceiling: more escapes, and the books still balance
    {
        BakeOptions o = quick(-1);
        o.converge = 1e-4;
        const visdb::Bake b = bake(room({.walls = 0.7, .ceiling = 0.8, .open_floor = true}), o);
        EXPECT_GT(b.statistics.indirect.value().energy_escaped_w,
                  10.0 * ff_parallel_rect(-2, 2, -2, 2, 3));
        EXPECT_NEAR(b.statistics.indirect.value().energy_absorbed_w +
                        b.statistics.indirect.value().energy_escaped_w,
                    10.0, 1e-3 * 10.0);
    }
}

// Radiosity of a floor point of reflectance ρ under the 1×1 m light (E = 10) at height 3.
double floor_radiosity(double x, double y, double rho) {
    return rho * 10.0 * ff_parallel_rect(-0.5 - x, 0.5 - x, -0.5 - y, 0.5 - y, 3.0);
}

// Irradiance at x (normal n) from the floor's radiosity, by midpoint quadrature over the floor.
double reflected_from_floor(const glm::dvec3& x, const glm::dvec3& n, double rho) {
    const int m = 400;
    const double h = 4.0 / m;
    double sum = 0.0;
    for (int j = 0; j < m; ++j)
        for (int i = 0; i < m; ++i) {
            const glm::dvec3 y(-2 + (i + 0.5) * h, -2 + (j + 0.5) * h, 0.0);
            const glm::dvec3 d = y - x;
            const double r2 = glm::dot(d, d);
            const double cx = glm::dot(n, d), cy = -d.z;
            if (cx <= 0.0 || cy <= 0.0) continue;
            sum += floor_radiosity(y.x, y.y, rho) * cx * cy / (std::numbers::pi * r2 * r2) * h * h;
        }
    return sum;
}

TEST(Interreflection, LightReflectedFromTheFloorOntoWallsAndCeiling) {
    // Only the floor reflects (ρ = 0.5); walls, ceiling and light are black, so the indirect
    // light anywhere is one reflection off the floor, known by quadrature of the closed form.
    const double rho = 0.5;
    const visdb::Scene scene = room({.floor = rho, .walls = 0, .ceiling = 0, .cells = 32});
    const visdb::Bake b = bake(scene, quick(-1));
    const PointIrradiance probe(scene, &b);
    ASSERT_TRUE(probe.has_indirect());
    const DirectField direct(scene);
    const std::vector<ProbePoint> points = {
        {{0.0, -2.0, 0.5}, {0, 1, 0}}, {{0.0, -2.0, 1.5}, {0, 1, 0}},
        {{1.2, -2.0, 2.5}, {0, 1, 0}}, {{2.0, 0.7, 1.0}, {-1, 0, 0}},
        {{1.0, 1.0, 3.0}, {0, 0, -1}}, {{-1.5, 0.25, 3.0}, {0, 0, -1}},
        {{0.0, 0.0, 1.5}, {0, 0, -1}},  // in the air, looking down (a grid point facing down)
    };
    const std::vector<visdb::Rgb> h = probe.at(points);
    for (std::size_t i = 0; i < points.size(); ++i) {
        const double expected = reflected_from_floor(points[i].x, points[i].n, rho);
        const double indirect = h[i].y - direct.irradiance(points[i].x, points[i].n).y;
        EXPECT_NEAR(indirect, expected, 0.02 * expected)
            << "at " << points[i].x.x << "," << points[i].x.y << "," << points[i].x.z;
    }
    // The baked vertices carry the element solution, interpolated: coarser, within 10%
    for (std::size_t v = 0; v < b.mesh.positions.size(); ++v) {
        const glm::dvec3 x = b.mesh.positions[v], n = glm::dvec3(b.mesh.normals[v]);
        if (std::abs(x.y + 2.0) > 1e-9 || x.z < 0.49 || x.z > 2.51 || std::abs(x.x) > 1.51)
            continue;
        const double expected = reflected_from_floor(x, n, rho);
        const double indirect = b.mesh.irradiance[v].y - direct.irradiance(x, n).y;
        EXPECT_NEAR(indirect, expected, 0.1 * expected) << "vertex at " << x.x << "," << x.z;
    }
}

TEST(Interreflection, BlackRoomLightAndObstructionAgainstTheClosedForm) {
    // 1×1 m source in the ceiling of a black 4×4×3 m room: floor and wall points get the
    // closed form; a black plate at 1.5 m over x < 0 hides the light in part, or whole.
    for (const bool plate : {false, true}) {
        visdb::Scene scene = room({.floor = 0, .walls = 0, .ceiling = 0});
        if (plate) {
            scene.materials.push_back({"plate", visdb::Rgb(0.0), {0, 0, 0}, 1.0});
            scene.surfaces.push_back(
                abrad::testing::grid("plate", 4, -1.9, 0.0, -1.9, 1.9, 1.5, 2, true));
        }
        const visdb::Bake b = bake(scene, quick(-1));
        const PointIrradiance probe(scene, &b);
        struct Case {
            ProbePoint p;
            double expected;
        };
        std::vector<Case> cases;
        for (const double x0 : {-1.0, 0.2, 1.0, 1.7}) {
            // From (x0, 0, 0) the plate edge x = 0 at half height projects to x = −x0 on the light
            const double lo = plate ? std::max(-0.5, -x0) : -0.5;
            const double f = lo < 0.5 ? ff_parallel_rect(lo - x0, 0.5 - x0, -0.5, 0.5, 3.0) : 0.0;
            cases.push_back({{{x0, 0.0, 0.0}, {0, 0, 1}}, 10.0 * f});
        }
        if (!plate)
            for (const double z : {0.5, 1.5, 2.5}) {
                // Wall y = −2 at (0.3, −2, z), facing +y. In the point's frame (normal = +y) the
                // light lies in the plane at distance 3 − z, spanning x − 0.3 in [−0.8, 0.2] and
                // 1.5..2.5 m along the normal
                const double d = 3.0 - z;
                const double f = testing::ff_perpendicular_rect(-0.8, 0.2, 2.5, d) -
                                 testing::ff_perpendicular_rect(-0.8, 0.2, 1.5, d);
                cases.push_back({{{0.3, -2.0, z}, {0, 1, 0}}, 10.0 * f});
            }
        std::vector<ProbePoint> points;
        for (const Case& c : cases) points.push_back(c.p);
        const std::vector<visdb::Rgb> h = probe.at(points);
        for (std::size_t i = 0; i < cases.size(); ++i)
            EXPECT_NEAR(h[i].y, cases[i].expected, 0.02 * cases[i].expected + 1e-9)
                << "plate " << plate << " at x " << cases[i].p.x.x;
    }
}

// Planar quads as solve_indirect's input, each quad a region of its own.
struct QuadScene {
    std::vector<Patch> patches;
    std::vector<visdb::Rgb> reflectance, emittance;
    std::vector<std::uint32_t> region;
    std::vector<glm::dvec3> normal;  // per region
    // a b c counter-clockwise from the front; the fourth corner is a + c − b
    void quad(glm::dvec3 a, glm::dvec3 b, glm::dvec3 c, double r, double e) {
        const glm::dvec3 d = a + c - b;
        patches.push_back({{a, b, c}});
        patches.push_back({{a, c, d}});
        for (int k = 0; k < 2; ++k) {
            reflectance.emplace_back(r);
            emittance.emplace_back(e);
            region.push_back(static_cast<std::uint32_t>(normal.size()));
        }
        normal.push_back(glm::normalize(glm::cross(b - a, c - a)));
    }
    IndirectInput input() const {
        return {.patches = patches,
                .reflectance = reflectance,
                .emittance = emittance,
                .region = region,
                .region_normal = normal};
    }
};

// A box standing on a lit floor (no bottom face: the floor under it is closed in) covers the
// centres of four floor cells. Those elements receive on the part of their cell the box leaves
// free, and used to shoot from their centroids, inside the box, onto the backs of its faces,
// where the light was counted absorbed. Their rows are made again from points of their pieces
// that see out: nothing is left on backs.
TEST(Interreflection, AnElementWhoseCentreABoxCoversShootsFromWhatItShows) {
    QuadScene q;
    const double h = 0.3, top = 0.5;  // the box [−h, h]² × [0, top]; cell centres at ±0.25
    q.quad({-2, -2, 0}, {2, -2, 0}, {2, 2, 0}, 0.5, 0.0);              // floor, +z
    q.quad({-h, -h, top}, {h, -h, top}, {h, h, top}, 0.5, 0.0);        // box top, +z
    q.quad({-h, -h, 0}, {h, -h, 0}, {h, -h, top}, 0.5, 0.0);           // −y
    q.quad({h, h, 0}, {-h, h, 0}, {-h, h, top}, 0.5, 0.0);             // +y
    q.quad({-h, h, 0}, {-h, -h, 0}, {-h, -h, top}, 0.5, 0.0);          // −x
    q.quad({h, -h, 0}, {h, h, 0}, {h, h, top}, 0.5, 0.0);              // +x
    q.quad({-0.5, 1, 2.5}, {-0.5, 2, 2.5}, {0.5, 2, 2.5}, 0.0, 10.0);  // light, −z
    IndirectOptions o;
    o.bounces = 1;  // the floor's and the box's reflection, once
    const IndirectSolution sol = solve_indirect(q.input(), o);
    // Absorbed on fronts: Σ (1 − ρ) H A; the rest of what the energy balance counts absorbed
    // landed on backs
    double fronts = 0.0;
    int covered = 0;
    for (const IndirectSolution::Element& el : sol.elements) {
        fronts +=
            visdb::channel_mean((visdb::Rgb(1.0) - el.reflectance) * (el.direct + el.indirect)) *
            el.area;
        covered += el.region == 0 && std::abs(el.centroid.x) < h && std::abs(el.centroid.y) < h;
    }
    const double backs = sol.energy.absorbed - fronts;
    std::printf("emitted %.4f W, on backs %.5f W, %d floor elements' centroids under the box\n",
                sol.energy.emitted, backs, covered);
    ASSERT_EQ(covered, 4);
    EXPECT_LT(backs, 1e-3 * sol.energy.emitted);
}

// A floor (ρ = 0.5) under a light and one black wall rising from its edge, one bounce: per wall
// element (all 8 × 6 of 0.5 m), its indirect irradiance over what the floor elements'
// radiosity sends it through the exact area-to-area form factors (each floor element's area
// sampled, the point-to-polygon closed form to the wall element), less 1.
struct WallElementError {
    glm::dvec3 centroid;
    double error;
};
std::vector<WallElementError> wall_beside_a_lit_floor(int row_resolution) {
    const double rho = 0.5;
    QuadScene q;
    q.quad({-2, -2, 0}, {2, -2, 0}, {2, 2, 0}, rho, 0.0);        // floor, +z (region 0)
    q.quad({-2, -2, 0}, {-2, -2, 3}, {2, -2, 3}, 0.0, 0.0);      // wall y = −2, +y (1)
    q.quad({-0.5, 0, 3}, {-0.5, 1, 3}, {0.5, 1, 3}, 0.0, 10.0);  // light, −z (2)
    IndirectOptions o;
    o.bounces = 1;  // the floor's reflection, once: no ambient term
    o.row_resolution = row_resolution;
    const IndirectSolution sol = solve_indirect(q.input(), o);

    // An element's rectangle: its cell within its region's rectangle (the grids are axis
    // aligned here)
    const auto rect = [&](const IndirectSolution::Element& el) {
        const IndirectSolution::Grid& g = sol.grids[el.region];
        const glm::dvec3 a =
            g.origin + sol.element_size * (double(el.cell.x) * g.u + double(el.cell.y) * g.v);
        const glm::dvec3 b = a + sol.element_size * (g.u + g.v);
        const glm::dvec3 lo(-2, -2, 0),
            hi = el.region == 0 ? glm::dvec3(2, 2, 0) : glm::dvec3(2, -2, 3);
        return std::pair{glm::clamp(glm::min(a, b), lo, hi), glm::clamp(glm::max(a, b), lo, hi)};
    };
    std::vector<WallElementError> out;
    for (const IndirectSolution::Element& wall : sol.elements) {
        if (wall.region != 1) continue;
        const auto [wl, wh] = rect(wall);
        const std::array<glm::dvec3, 4> poly = {
            glm::dvec3(wl.x, -2, wl.z), glm::dvec3(wh.x, -2, wl.z), glm::dvec3(wh.x, -2, wh.z),
            glm::dvec3(wl.x, -2, wh.z)};
        double expected = 0.0;
        for (const IndirectSolution::Element& floor : sol.elements) {
            if (floor.region != 0) continue;
            const auto [fl, fh] = rect(floor);
            const int m = 12;  // m × m samples of the floor element
            double f = 0.0;
            for (int j = 0; j < m; ++j)
                for (int i = 0; i < m; ++i) {
                    const glm::dvec3 x(fl.x + (i + 0.5) / m * (fh.x - fl.x),
                                       fl.y + (j + 0.5) / m * (fh.y - fl.y), 0.0);
                    f += point_polygon_form_factor(x, {0, 0, 1}, poly);
                }
            f /= m * m;
            expected += rho * floor.direct.y * f * floor.area / wall.area;
        }
        out.push_back({wall.centroid, wall.indirect.y / expected - 1.0});
    }
    return out;
}

// A shooter's hemicube stands for its area by one point, and a receiver near it sees the
// area under another form factor than the point's: the wall cell beside a floor cell 5 %
// more, the one above it 21 % less. With rows of R = 256 (so that pixels are not the
// question) every wall element must receive within 3 % of the exact transfer, at the wall's
// foot too (the point's form factors gave the foot's row 4.9-6.0 % too little).
TEST(Interreflection, ElementsBesideAnEdgeReceiveThroughTheAreasFormFactor) {
    const std::vector<WallElementError> errors = wall_beside_a_lit_floor(256);
    ASSERT_EQ(errors.size(), 8u * 6u);
    double worst = 0.0;
    for (const WallElementError& e : errors) {
        if (std::abs(e.error) > std::abs(worst)) worst = e.error;
        EXPECT_LT(std::abs(e.error), 0.03)
            << "wall element at x " << e.centroid.x << ", z " << e.centroid.z;
    }
    std::printf("R = 256: worst wall element %+.2f %%\n", 100.0 * worst);
}

// The rows' default hemicube: a pixel is a few cells' worth of a far wall's height, and giving
// each pixel to the cell its centre sees did so alike for every shooter in the floor's plane:
// bands of ±10 % along the wall's rows of cells (R = 32, RMS 6.2 %, worst 11 %). Each pixel's
// share is split between the cells two of its visible samples see (one from each half), drawn
// per shooter: over the wall's elements RMS 2.3 %, worst 5.0 % with R = 32 and 8 × 8 masks;
// 1.1 % and 3.4 % with the defaults R = 40 and 4 × 4 masks (3.5 % and 9.5 % with R = 32 and
// 4 × 4: the samples drawn are coarser).
TEST(Interreflection, RowPixelsDoNotBandTheCellsOfAWall) {
    const std::vector<WallElementError> errors =
        wall_beside_a_lit_floor(BakeOptions{}.element_resolution);
    ASSERT_EQ(errors.size(), 8u * 6u);
    double sum2 = 0.0, worst = 0.0;
    for (const WallElementError& e : errors) {
        sum2 += e.error * e.error;
        worst = std::max(worst, std::abs(e.error));
    }
    const double rms = std::sqrt(sum2 / double(errors.size()));
    std::printf("R = %d: RMS %.2f %%, worst %.2f %%\n", BakeOptions{}.element_resolution,
                100.0 * rms, 100.0 * worst);
    EXPECT_LT(rms, 0.03);
    EXPECT_LT(worst, 0.08);
}

// Issue 19: an element is what its triangles' pieces cover, so a needle face (its own region,
// 2e-5 m wide) is an element of a few mm². A shooter's hemicube still gives it a whole
// sample, and dividing that share by its tiny area made its indirect irradiance hundreds of
// times too large. Its indirect part must be what a probe gathers at the same points from the
// bake (the probe's hemicube sees the room, not the needle; the element's one value over a
// needle 0.3 m from two walls is 18 % off at its end), and its total at most what the light
// and the room can deliver.
TEST(Interreflection, NeedleElementsGetWhatTheRoomDelivers) {
    visdb::Scene scene = room({0.5, 0.5, 0.5, 0.0});
    scene.materials.push_back({"needle", visdb::Rgb(0.5), {0, 0, 0}, 1.0});
    struct Needle {
        glm::dvec3 a, b, c;
        glm::dvec3 n;
    };
    const std::vector<Needle> needles = {
        {{-0.3, 0.4, 1.0}, {0.3, 0.4, 1.0}, {0.3, 0.40002, 1.0}, {0, 0, 1}},    // facing up
        {{1.2, -1.7, 0.5}, {1.9, -1.7, 0.5}, {1.9, -1.69998, 0.5}, {0, 0, 1}},  // near a wall
        {{-1.0, 1.0, 2.0}, {-1.0, 1.2, 2.0}, {-1.00002, 1.2, 2.0}, {0, 0, 1}},  // short, high
    };
    for (const Needle& n : needles) {
        visdb::Surface s;
        s.name = "needle";
        s.material = 4;
        s.mesh.positions = {n.a, n.b, n.c};
        s.mesh.triangles = {{0, 1, 2}};
        scene.surfaces.push_back(s);
    }
    const auto first_needle = static_cast<std::uint32_t>(scene.surfaces.size() - needles.size());
    const visdb::Bake b = bake(scene, quick(-1));
    const visdb::Bake direct_only = bake(scene, quick(0));
    const PointIrradiance probe(scene, &b);
    const PointIrradiance probe_direct(scene, nullptr);
    int checked = 0;
    for (std::size_t t = 0; t < b.mesh.triangles.size(); ++t) {
        const std::uint32_t surface = b.mesh.triangle_surface[t];
        if (surface < first_needle) continue;
        const Needle& n = needles[surface - first_needle];
        for (int k = 0; k < 3; ++k) {
            const std::uint32_t v = b.mesh.triangles[t][k];
            const glm::dvec3 x = b.mesh.positions[v];
            const double indirect = b.mesh.irradiance[v].y - direct_only.mesh.irradiance[v].y;
            const ProbePoint point{x + 1e-6 * n.n, n.n};
            const double total = probe.at({&point, 1})[0].y;
            const double gathered = total - probe_direct.at({&point, 1})[0].y;
            EXPECT_NEAR(indirect, gathered, 0.25 * gathered)
                << "needle " << surface - first_needle << " at " << x.x << ", " << x.y;
            EXPECT_LE(b.mesh.irradiance[v].y, 1.25 * total)
                << "needle " << surface - first_needle << " at " << x.x << ", " << x.y;
            ++checked;
        }
    }
    EXPECT_EQ(checked, 9);
}

}  // namespace
}  // namespace abrad::radiosity
