// CIE 171:2006 analytic test cases (docs/validation.md): 5.2 point source (and a cosine web's
// cos⁴ law), 5.3 area source, 5.4 flux balance of a
// black room, 5.6 obstruction, 5.7 diffuse reflection with an obstruction, 5.8 interreflections
// in a closed room. Each case is a scene testing what the report's case tests (the report's own
// geometry where it is public, 5.8's; docs/validation.md states every geometry), and its
// reference is computed from closed forms written out in cie171.h and here (Lambert's
// point-to-polygon form factor, Howell's corner form factor as its check, the enclosure
// relation Φ/(A(1−ρ)), a quadrature of the closed-form floor radiosity for 5.7), never from
// abrad. Each point is checked on the probe (PointIrradiance, what `abrad probe` prints) and on
// the default bake's exported field (the Gouraud value at the point), with the 5 % tolerance
// published validations use and abrad's own 2 % target (kTarget), or tighter where it reaches
// that. The tests print their tables:
// `build/test/tests/radiosity/cie171_test` reproduces docs/validation.md.

#include "cie171.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <glm/geometric.hpp>
#include <numbers>
#include <optional>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "abrad/convert/photometry.h"
#include "abrad/radiosity/bake.h"
#include "abrad/radiosity/direct.h"
#include "abrad/radiosity/indirect.h"
#include "mesh_checks.h"
#include "scenes.h"

namespace abrad::radiosity {
namespace {

using abrad::testing::mean_irradiance;

using namespace cie171;  // NOLINT(google-build-using-namespace): the cases' shared parts

// ---- Reading a bake ----

// The exported field at p (mesh_checks.h).
std::optional<double> gouraud_at(const visdb::Bake& b, const dvec3& p, const dvec3& n) {
    return abrad::testing::gouraud_at(b.mesh, p, n);
}

// ---- One row of a case's table ----

struct Row {
    const Point* point;
    double probe, exported;
};

// Probes and reads the exported field at every point; prints the case's table.
std::vector<Row> measure(const char* title, const visdb::Scene& scene, const visdb::Bake& b,
                         const std::vector<Point>& points) {
    std::vector<ProbePoint> ps;
    ps.reserve(points.size());
    for (const Point& p : points) ps.push_back(p.p);
    const std::vector<visdb::Rgb> h = PointIrradiance(scene, &b).at(ps);
    std::vector<Row> rows;
    rows.reserve(points.size());
    std::printf("%s\n| point | reference | probe | error | export | error |\n", title);
    for (std::size_t i = 0; i < points.size(); ++i) {
        const Point& p = points[i];
        const double probe = (h[i].x + h[i].y + h[i].z) / 3.0;
        const double exported = gouraud_at(b, p.p.x, p.p.n).value_or(std::nan(""));
        rows.push_back({&p, probe, exported});
        std::printf("| %s | %.4f | %.4f | %+.5f %% | %.4f | %+.3f %% |\n", p.name.c_str(),
                    p.reference, probe, 100.0 * rel_error(probe, p.reference), exported,
                    100.0 * rel_error(exported, p.reference));
    }
    return rows;
}

// The checks of a case: every probe value within its tolerance; every exported value (off
// the mesh: none) within the published 5 % and within kTarget or its own tighter tolerance.
void check(const std::vector<Row>& rows) {
    for (const Row& r : rows) {
        const Point& p = *r.point;
        EXPECT_NEAR(r.probe, p.reference, p.probe_tolerance * p.reference) << p.name;
        if (std::isnan(r.exported)) continue;
        EXPECT_NEAR(r.exported, p.reference, kPublished * p.reference) << p.name;
        const double tight = p.export_tight > 0.0 ? p.export_tight : kTarget;
        EXPECT_NEAR(r.exported, p.reference, tight * p.reference) << p.name;
    }
}

// ---- The references' own check ----

TEST(Cie171, LambertFormFactorAgreesWithHowellsCornerFormula) {
    // Two independent closed forms: the references below rest on the first
    for (const auto& [a, b, c] : {std::array{1.0, 2.0, 3.0}, std::array{0.3, 0.1, 2.5},
                                  std::array{4.0, 4.0, 0.5}, std::array{1.0, 1.0, 1.0}}) {
        const double f = lambert_ff({0, 0, 0}, {0, 0, 1}, rect_z(0, a, 0, b, c));
        EXPECT_NEAR(f, howell_corner(a, b, c), 1e-12) << a << " " << b << " " << c;
    }
}

// ---- 5.3: a rectangular Lambertian area source ----

// The 2 × 1 m emitter [-1,1]×[-0.5,0.5] at 3 m facing down, exitance M (kM), over a black
// 6 × 6 m floor and a black wall at x = 3 facing the emitter.
visdb::Scene area_source_scene() {
    visdb::Scene s;
    const auto black = add_material(s, "black", 0.0);
    const auto light = add_material(s, "emitter", 0.0, kM);
    const dvec3 mid(0, 0, 1.5);
    s.surfaces.push_back(facing("floor", black, {-3, -3, 0}, {6, 0, 0}, {0, 6, 0}, 6, mid));
    s.surfaces.push_back(facing("wall", black, {3, -3, 0}, {0, 6, 0}, {0, 0, 3}, 6, mid));
    s.surfaces.push_back(facing("emitter", light, {-1, -0.5, 3}, {2, 0, 0}, {0, 1, 0}, 1, mid));
    return s;
}

std::vector<Point> area_source_points() {
    const std::vector<dvec3> emitter = rect_z(-1, 1, -0.5, 0.5, 3);
    std::vector<Point> points;
    // Floor points (normal +z), from under the centre to far off the emitter's corner
    for (const auto& [x, y] :
         {std::array{0.0, 0.0}, std::array{0.5, 0.25}, std::array{1.0, 0.5}, std::array{1.5, 0.0},
          std::array{2.0, 1.0}, std::array{0.0, 2.0}, std::array{2.5, -2.5}}) {
        const dvec3 x0(x, y, 0.0), n(0, 0, 1);
        points.push_back({label("floor", x, y), {x0, n}, kM * lambert_ff(x0, n, emitter)});
    }
    // Wall points (normal -x), the emitter seen at a grazing angle from the wall's top;
    // the wall's field is smooth: within 1 %
    for (const auto& [y, z] :
         {std::array{0.0, 0.5}, std::array{0.0, 1.5}, std::array{0.0, 2.5}, std::array{1.5, 1.5}}) {
        const dvec3 x0(3.0, y, z), n(-1, 0, 0);
        points.push_back(
            {label("wall", y, z), {x0, n}, kM * lambert_ff(x0, n, emitter), 1e-4, 0.01});
    }
    return points;
}

// ---- 5.2: a point source over a floor ----

// A luminaire at (0, 0, h) with a rotationally symmetric type C web I(γ) (γ = 0..180° in 1°
// steps) over a black 10 × 10 m floor ([-5, 5]², 1 m cells), in lux.
visdb::Scene point_source_scene(double h, visdb::PhotometricWeb web) {
    visdb::Scene s;
    s.emittance_unit = "lm/m2";
    const auto black = add_material(s, "black", 0.0);
    s.surfaces.push_back(
        facing("floor", black, {-5, -5, 0}, {10, 0, 0}, {0, 10, 0}, 10, {0, 0, 1}));
    visdb::Luminaire l;
    l.name = "source";
    l.web = std::move(web);
    l.position = {0.0, 0.0, h};
    s.luminaires.push_back(l);
    return s;
}

template <class Web>
visdb::Scene point_source_scene(double h, Web intensity) {
    visdb::PhotometricWeb web;
    web.horizontal = {0.0};
    for (int g = 0; g <= 180; ++g) {
        web.vertical.push_back(g);
        web.candela.push_back(intensity(g * kPi / 180.0));
    }
    return point_source_scene(h, std::move(web));
}

// Floor points (x, y) from the foot of the source, facing up; E from `reference(r)`. The
// points on the floor's 1 m grid are vertices of every bake: their export is the exact value
// (1e-4: float); between vertices kTarget, the refinement's tolerance (2 % of an edge's
// midpoint) leaving up to about that much on a smooth field.
template <class Reference>
std::vector<Point> floor_points(Reference reference) {
    std::vector<Point> points;
    for (const auto& [x, y] : {std::array{0.0, 0.0}, std::array{0.5, 0.0}, std::array{1.0, 0.0},
                               std::array{2.0, 0.0}, std::array{4.0, 0.0}, std::array{0.7, 0.7},
                               std::array{1.5, -2.5}, std::array{-3.2, 3.6}}) {
        const bool vertex = x == std::round(x) && y == std::round(y);
        points.push_back({label("floor", x, y),
                          {dvec3(x, y, 0.0), dvec3(0, 0, 1)},
                          reference(std::hypot(x, y)),
                          1e-6,
                          vertex ? 1e-4 : 0.0});
    }
    return points;
}

TEST(Cie171, Case52PointSource) {
    // 1000 cd in every direction at 3 m: E = I h / d³, 111.11 lx below the source
    const visdb::Scene scene = point_source_scene(3.0, [](double) { return 1000.0; });
    const auto reference = [](double r) { return 1000.0 * 3.0 / std::pow(9.0 + r * r, 1.5); };
    check(measure("5.2 point source", scene, bake(scene, BakeOptions{}), floor_points(reference)));
}

// A cosine web I0 cos γ at height h over a floor point r from its foot: E = I0 cos⁴θ / h².
double cos4_law(double i0, double h, double r) {
    const double c = h / std::sqrt(h * h + r * r);
    return i0 * std::pow(c, 4) / (h * h);
}

// A cosine web I0 cos γ (downward only) at 2.5 m.
visdb::Scene cosine_web_scene() {
    return point_source_scene(2.5,
                              [](double g) { return g <= kPi / 2 ? 800.0 * std::cos(g) : 0.0; });
}

std::vector<Point> cosine_web_points() {
    std::vector<Point> points = floor_points([](double r) { return cos4_law(800.0, 2.5, r); });
    for (Point& p : points) p.probe_tolerance = 2e-4;  // the web's 1° bilinear steps
    for (Point& p : points) p.export_tight = p.export_tight > 0.0 ? 2e-4 : 0.0;
    return points;
}

TEST(Cie171, CosineWebCosToTheFourth) {
    const visdb::Scene scene = cosine_web_scene();
    check(measure("cosine web", scene, bake(scene, BakeOptions{}), cosine_web_points()));
}

// The standard's own case 5.2. Its table (111.11, 105.21, 90.02, 71.11, 99.73, 85.64, 68.06,
// 74.36, 59.98, 49.39 lx) is, within 0.03 %, I0·cos⁴θ/h² with I0 = 1000 cd and h = 3 m
// at the points (0.5 i, 0.5 j) m, 0 <= j <= i <= 3, taken row by row: a source whose
// intensity is 1000·cos γ cd (a uniform 1000 cd web gives 106.64 lx, not 105.21, at 0.5 m).
// The web comes from an IES LM-63-2002 file read by abrad's reader, as a user gives it.
std::string cosine_ies_text(double i0) {
    std::string text =
        "IESNA:LM-63-2002\n[TEST] CIE 171:2006 case 5.2 source, I = I0 cos(gamma)\n"
        "TILT=NONE\n1 -1 1 181 1 1 2 0 0 0\n1 1 0\n";
    char number[32];
    for (int g = 0; g <= 180; ++g) {
        std::snprintf(number, sizeof number, "%d%s", g, g % 10 == 9 || g == 180 ? "\n" : " ");
        text += number;
    }
    text += "0\n";
    for (int g = 0; g <= 180; ++g) {
        const double c = g <= 90 ? i0 * std::cos(g * kPi / 180.0) : 0.0;
        std::snprintf(number, sizeof number, "%.9f%s", std::max(c, 0.0),
                      g % 6 == 5 || g == 180 ? "\n" : " ");
        text += number;
    }
    return text;
}

TEST(Cie171, Case52TheStandardsTable) {
    const convert::PhotometricFile file = convert::read_ies(cosine_ies_text(1000.0), "case52.ies");
    ASSERT_NEAR(file.flux(), kPi * 1000.0, 1e-3 * kPi * 1000.0);  // ∫ I0 cos γ dω = π I0
    const visdb::Scene scene = point_source_scene(3.0, file.web);
    // The standard's published values, in its table's order
    constexpr std::array<double, 10> kTable = {111.11, 105.21, 90.02, 71.11, 99.73,
                                               85.64,  68.06,  74.36, 59.98, 49.39};
    constexpr double kPublished52 = 0.005;  // the criterion asked of this case: 0.5 % each
    std::vector<Point> points;
    std::size_t k = 0;
    for (int j = 0; j <= 3; ++j) {
        for (int i = j; i <= 3; ++i, ++k) {
            const double x = 0.5 * i, y = 0.5 * j;
            const double closed = cos4_law(1000.0, 3.0, std::hypot(x, y));
            // The table is that closed form (to 0.027 % at worst: its own rounding and steps)
            ASSERT_NEAR(kTable[k], closed, 3e-4 * closed) << x << " " << y;
            points.push_back({label("floor", x, y),
                              {dvec3(x, y, 0.0), dvec3(0, 0, 1)},
                              kTable[k],
                              kPublished52,
                              i % 2 == 0 && j % 2 == 0 ? 2e-3 : 0.0});
        }
    }
    const std::vector<Row> rows =
        measure("5.2 the standard's table", scene, bake(scene, BakeOptions{}), points);
    check(rows);
    // And the probe against the closed form itself, well inside the table's rounding: the
    // web's 1° bilinear steps
    for (const Row& r : rows) {
        const dvec3 x = r.point->p.x;
        EXPECT_NEAR(r.probe, cos4_law(1000.0, 3.0, std::hypot(x.x, x.y)), 2e-4 * r.probe)
            << r.point->name;
    }
}

TEST(Cie171, Case53AreaSource) {
    const visdb::Scene scene = area_source_scene();
    const std::vector<Point> points = area_source_points();
    check(measure("5.3 area source", scene, bake(scene, BakeOptions{}), points));
}

// ---- 5.4 and 5.8: the 4 × 4 × 4 m room ----

// The closed 4 × 4 × 4 m room (x, y in [-2, 2], z in [0, 4]; total area 96 m²) with a 1 × 1 m
// source of M = 100 W/m² (Φ = 100 W) set flush into the ceiling's centre (the ceiling has
// a hole where it is). Every surface, the source's too, has reflectance rho.
constexpr double kRoomFlux = 100.0;

visdb::Scene cube_room(double rho) {
    visdb::Scene s;
    const auto surface = add_material(s, "surface", rho);
    const auto light = add_material(s, "source", rho, kRoomFlux);
    const dvec3 mid(0, 0, 2);
    s.surfaces.push_back(facing("floor", surface, {-2, -2, 0}, {4, 0, 0}, {0, 4, 0}, 4, mid));
    s.surfaces.push_back(facing("wall -y", surface, {-2, -2, 0}, {4, 0, 0}, {0, 0, 4}, 4, mid));
    s.surfaces.push_back(facing("wall +y", surface, {-2, 2, 0}, {4, 0, 0}, {0, 0, 4}, 4, mid));
    s.surfaces.push_back(facing("wall -x", surface, {-2, -2, 0}, {0, 4, 0}, {0, 0, 4}, 4, mid));
    s.surfaces.push_back(facing("wall +x", surface, {2, -2, 0}, {0, 4, 0}, {0, 0, 4}, 4, mid));
    // Ceiling: cells between -2, -1.5, -0.5, 0.5, 1.5 and 2 m on both axes (1 m inside, 0.5 m
    // along the walls) but the centre one, the source's hole
    visdb::Surface ceiling;
    ceiling.name = "ceiling";
    ceiling.material = surface;
    const double edges[] = {-2.0, -1.5, -0.5, 0.5, 1.5, 2.0};
    for (int j = 0; j < 5; ++j)
        for (int i = 0; i < 5; ++i) {
            if (i == 2 && j == 2) continue;
            const auto base = static_cast<std::uint32_t>(ceiling.mesh.positions.size());
            const double x0 = edges[i], x1 = edges[i + 1], y0 = edges[j], y1 = edges[j + 1];
            ceiling.mesh.positions.insert(ceiling.mesh.positions.end(),
                                          {{x0, y0, 4}, {x1, y0, 4}, {x1, y1, 4}, {x0, y1, 4}});
            ceiling.mesh.triangles.push_back({base, base + 2, base + 1});  // facing down
            ceiling.mesh.triangles.push_back({base, base + 3, base + 2});
        }
    s.surfaces.push_back(ceiling);
    s.surfaces.push_back(facing("source", light, {-0.5, -0.5, 4}, {1, 0, 0}, {0, 1, 0}, 1, mid));
    return s;
}

TEST(Cie171, Case54FluxBalanceOfABlackRoom) {
    // Black surfaces: every watt the source emits lands once. The exported irradiance
    // integrated over the room's surfaces (the source's own and the ceiling, in its plane,
    // receive nothing) is the emitted flux.
    const visdb::Scene scene = cube_room(0.0);
    const visdb::Bake b = bake(scene, BakeOptions{});
    double area = 0.0;
    const double flux = mean_irradiance(b, &area) * area;
    ASSERT_NEAR(area, 96.0, 1e-9);
    std::printf("5.4 flux balance: emitted %.4f W, received (export) %.4f W, error %+.3f %%\n",
                kRoomFlux, flux, 100.0 * rel_error(flux, kRoomFlux));
    // The linear interpolation of the exact vertex values over the coarse room (1 m cells,
    // refined where the field departs from linear by more than 2 %) loses half a percent
    // (2 % with the refinement at 10 %, 1.3 % at 7 %, 1.1 % at 5 %)
    EXPECT_NEAR(flux, kRoomFlux, kTarget * kRoomFlux);
    // The probe at the floor's centre and a wall's centre against the closed form
    const std::vector<dvec3> source = rect_z(-0.5, 0.5, -0.5, 0.5, 4);
    std::vector<Point> points;
    for (const auto& [name, x, n] : {std::tuple{"floor centre", dvec3(0, 0, 0), dvec3(0, 0, 1)},
                                     std::tuple{"floor corner", dvec3(1.9, 1.9, 0), dvec3(0, 0, 1)},
                                     std::tuple{"wall centre", dvec3(0, -2, 2), dvec3(0, 1, 0)}})
        points.push_back({name, {x, n}, kRoomFlux * lambert_ff(x, n, source), 1e-4, 0.01});
    check(measure("5.4 points", scene, b, points));
}

// ---- 5.6: an opaque obstruction between the source and the points ----

TEST(Cie171, Case56Obstruction) {
    const visdb::Scene scene = obstruction_scene();
    const std::vector<Point> points = obstruction_points();
    const visdb::Bake b = bake(scene, BakeOptions{});
    check(measure("5.6 obstruction", scene, b, points));
    // In the umbra: nothing
    const std::vector<ProbePoint> umbra = {{{-0.8, 0.0, 0.0}, {0, 0, 1}}};
    EXPECT_EQ(PointIrradiance(scene, &b).at(umbra)[0].y, 0.0);
    EXPECT_LT(gouraud_at(b, umbra[0].x, umbra[0].n).value_or(1.0), 1e-6 * kM);
}

// ---- 5.7: diffuse reflection with an obstruction ----

// The floor [-2,2]² (ρ = 0.5) is the diffuse source S2, lit by the 1 × 1 m emitter
// [-0.5,0.5]² at 3 m facing down (M = 1000 W/m², ρ = 0). A black partition in the plane x = 1
// (y in [-2, 2], z in [0, 1.2]) hides part of the floor from the points; a black wall at
// x = 2 faces the room; nothing else (open above). Only the floor reflects, once: its
// radiosity is B(y) = ρ M F(y → the part of the emitter the partition leaves it), a closed
// form, and a point's reflected irradiance is the integral of B over the part of the floor it
// sees through the partition (midpoint quadrature, 1 cm cells: the partition's line is a cell
// edge, the visibility edge a line of constant x). The wall points also see the emitter whole.
constexpr double kFloorRho = 0.5, kPartitionTop = 1.2;

visdb::Scene reflection_scene() {
    visdb::Scene s;
    const auto black = add_material(s, "black", 0.0);
    const auto floor = add_material(s, "floor", kFloorRho);
    const auto light = add_material(s, "emitter", 0.0, kM);
    const dvec3 mid(0, 0, 1.5);
    s.surfaces.push_back(facing("floor", floor, {-2, -2, 0}, {4, 0, 0}, {0, 4, 0}, 8, mid));
    s.surfaces.push_back(facing("partition", black, {1, -2, 0}, {0, 4, 0}, {0, 0, kPartitionTop}, 4,
                                {0, 0, 1}));  // front towards the emitter
    s.surfaces.push_back(facing("wall", black, {2, -2, 0}, {0, 4, 0}, {0, 0, 3}, 4, mid));
    s.surfaces.push_back(facing("emitter", light, {-0.5, -0.5, 3}, {1, 0, 0}, {0, 1, 0}, 1, mid));
    return s;
}

// Direct irradiance of floor point (x, y, 0) from the emitter, the partition's shadow cut out:
// behind it (x > 1) the ray to emitter point x_L crosses x = 1 at height 3(x-1)/(x-x_L),
// below the top 1.2 exactly when x_L < 2.5 - 1.5x.
double floor_direct(double x, double y) {
    double lo = -0.5;
    if (x > 1.0) lo = std::max(lo, (1.0 - (3.0 - kPartitionTop) / 3.0 * x) / (kPartitionTop / 3.0));
    if (lo >= 0.5) return 0.0;
    return kM * lambert_ff({x, y, 0.0}, {0, 0, 1}, rect_z(lo, 0.5, -0.5, 0.5, 3));
}

// Irradiance reflected from the floor onto x (normal n), x beyond the partition (x.x > 1).
double reflected_onto(const dvec3& x, const dvec3& n, const std::vector<double>& radiosity,
                      int cells) {
    const double h = 4.0 / cells;
    double sum = 0.0;
    for (int j = 0; j < cells; ++j)
        for (int i = 0; i < cells; ++i) {
            const dvec3 y(-2 + (i + 0.5) * h, -2 + (j + 0.5) * h, 0.0);
            // Hidden by the partition: the segment crosses x = 1 below its top
            if (y.x < 1.0 && (1.0 - y.x) / (x.x - y.x) * x.z <= kPartitionTop) continue;
            const dvec3 d = y - x;
            const double r2 = glm::dot(d, d), cx = glm::dot(n, d), cy = -d.z;
            if (cx <= 0.0 || cy <= 0.0) continue;
            sum += radiosity[std::size_t(j) * cells + i] * cx * cy / (kPi * r2 * r2) * h * h;
        }
    return sum;
}

TEST(Cie171, Case57DiffuseReflectionWithAnObstruction) {
    const visdb::Scene scene = reflection_scene();
    const int cells = 400;
    std::vector<double> radiosity(std::size_t(cells) * cells);
    for (int j = 0; j < cells; ++j)
        for (int i = 0; i < cells; ++i)
            radiosity[std::size_t(j) * cells + i] =
                kFloorRho *
                floor_direct(-2 + (i + 0.5) * 4.0 / cells, -2 + (j + 0.5) * 4.0 / cells);
    const std::vector<dvec3> emitter = rect_z(-0.5, 0.5, -0.5, 0.5, 3);
    std::vector<Point> points;
    // Vertical points on the wall (normal -x): emitter + floor seen past the partition
    for (const auto& [y, z] : {std::array{0.0, 0.25}, std::array{0.0, 0.75}, std::array{0.0, 1.5},
                               std::array{0.0, 2.5}, std::array{1.0, 0.75}}) {
        const dvec3 x(2.0, y, z), n(-1, 0, 0);
        // The probe's reflected part is gathered from the bake (its direct part is exact):
        // within 1 %; the export within kTarget, the top too, where the floor beyond the
        // partition comes into view
        points.push_back({label("wall", y, z),
                          {x, n},
                          kM * lambert_ff(x, n, emitter) + reflected_onto(x, n, radiosity, cells),
                          0.01});
    }
    // Horizontal points facing down, between partition and wall (in the air: probe only)
    for (const auto& [y, z] : {std::array{0.0, 0.5}, std::array{0.5, 1.0}}) {
        const dvec3 x(1.5, y, z), n(0, 0, -1);
        points.push_back({label("air, down, x = 1.5", y, z),
                          {x, n},
                          reflected_onto(x, n, radiosity, cells),
                          kPublished});
    }
    check(measure("5.7 diffuse reflection with an obstruction", scene, bake(scene, BakeOptions{}),
                  points));
}

// ---- 5.8: interreflections in a closed room ----

// The area-weighted mean over b's mesh of the exact direct irradiance at its vertices,
// interpolated as the export's (mean_irradiance's channel mean).
double mean_direct_at_vertices(const visdb::Scene& scene, const visdb::Bake& b) {
    const DirectField direct(scene);
    std::vector<double> d(b.mesh.positions.size());
    for (std::size_t v = 0; v < d.size(); ++v)
        d[v] = visdb::channel_mean(
            direct.irradiance(b.mesh.positions[v], glm::dvec3(b.mesh.normals[v])));
    return abrad::testing::area_mean(
        b.mesh, [&](std::uint32_t v) { return d[v]; }, [](std::size_t) { return true; });
}

TEST(Cie171, Case58InterreflectionsInAClosedRoom) {
    // Uniform reflectance rho everywhere: the mean irradiance over the room's 96 m² is
    // Φ/(A(1−ρ)) (every watt is received 1/(1−ρ) times on average), of which Φ/A is direct
    // and Φρ/(A(1−ρ)) reflected. The export's direct part carries its interpolation loss
    // (5.4); the reflected part, the interreflection solution's, is checked alone against its
    // closed form as well: the export less the exact direct light at the same vertices (the
    // mesh differs with ρ, as the refinement follows the reflected light too).
    std::printf(
        "5.8 interreflections (room mean)\n| rho | reference | export | error | reflected "
        "part | export | error |\n");
    for (const double rho : {0.05, 0.25, 0.5, 0.75, 0.95}) {
        const visdb::Scene scene = cube_room(rho);
        const visdb::Bake b = bake(scene, BakeOptions{});
        double area = 0.0;
        const double mean = mean_irradiance(b, &area);
        const double direct_mean = mean_direct_at_vertices(scene, b);
        ASSERT_NEAR(area, 96.0, 1e-9);
        const double expected = kRoomFlux / (area * (1.0 - rho));
        const double reflected = expected - kRoomFlux / area;
        std::printf("| %.2f | %.4f | %.4f | %+.3f %% | %.4f | %.4f | %+.3f %% |\n", rho, expected,
                    mean, 100.0 * rel_error(mean, expected), reflected, mean - direct_mean,
                    100.0 * rel_error(mean - direct_mean, reflected));
        EXPECT_NEAR(mean, expected, kTarget * expected) << "rho " << rho;
        EXPECT_NEAR(mean - direct_mean, reflected, 0.005 * reflected) << "rho " << rho;
    }
}

}  // namespace
}  // namespace abrad::radiosity
