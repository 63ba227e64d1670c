// Luminaires as point sources in the exact direct field (direct.h): closed forms on a floor
// (a uniform web E = I h / d³, a cosine web E = I0 cos⁴θ / h²), occluders opaque and
// translucent, a turned luminaire against the same luminaire unturned in a turned scene, and
// large luminous openings (rectangle, disc) against the uniform-luminance closed forms.

#include <gtest/gtest.h>

#include <cmath>
#include <glm/geometric.hpp>
#include <numbers>
#include <vector>

#include "abrad/radiosity/direct.h"

namespace abrad::radiosity {
namespace {

constexpr double kRad = std::numbers::pi / 180.0;

/// Angles from `first` to `last` in steps of `step`.
std::vector<double> range(double first, double last, double step) {
    std::vector<double> a;
    const int n = static_cast<int>(std::lround((last - first) / step));
    for (int i = 0; i <= n; ++i) a.push_back(first + step * i);
    return a;
}

/// A rotationally symmetric type C web I(γ) on γ = 0..180 in 1° steps.
template <class F>
visdb::PhotometricWeb symmetric_web(F intensity) {
    visdb::PhotometricWeb web;
    web.horizontal = {0.0};
    web.vertical = range(0.0, 180.0, 1.0);
    for (const double g : web.vertical) web.candela.push_back(intensity(g));
    return web;
}

/// A quad [x0, x1] × [y0, y1] at height z facing +z, of opacity `alpha`.
void add_quad(visdb::Scene& scene, double x0, double y0, double x1, double y1, double z,
              double alpha) {
    visdb::Material m;
    m.name = "m" + std::to_string(scene.materials.size());
    m.opacity = alpha;
    visdb::Surface s;
    s.name = m.name;
    s.material = static_cast<std::uint32_t>(scene.materials.size());
    s.mesh.positions = {{x0, y0, z}, {x1, y0, z}, {x1, y1, z}, {x0, y1, z}};
    s.mesh.triangles = {{0, 1, 2}, {0, 2, 3}};
    scene.materials.push_back(m);
    scene.surfaces.push_back(s);
}

/// A 20 × 20 m floor and one luminaire at (0, 0, h) with `web`, hanging facing down.
visdb::Scene floor_scene(const visdb::PhotometricWeb& web, double h) {
    visdb::Scene scene;
    scene.emittance_unit = "lm/m2";
    add_quad(scene, -10.0, -10.0, 10.0, 10.0, 0.0, 1.0);
    visdb::Luminaire l;
    l.name = "L";
    l.web = web;
    l.position = {0.0, 0.0, h};
    scene.luminaires.push_back(l);
    return scene;
}

TEST(PointSource, UniformWebOnAFloorIsIhOverDCubed) {
    // CIE 171 case 5.2's source: 1000 cd at 3 m
    const DirectField field(floor_scene(symmetric_web([](double) { return 1000.0; }), 3.0));
    EXPECT_NEAR(field.irradiance({0.0, 0.0, 0.0}, {0.0, 0.0, 1.0}).y, 1000.0 / 9.0, 1e-9);
    for (const double r : {0.5, 1.0, 2.0, 3.0, 5.0, 8.0}) {
        const double d = std::sqrt(9.0 + r * r);
        const double expected = 1000.0 * 3.0 / (d * d * d);
        const visdb::Rgb e = field.irradiance({r * 0.6, r * 0.8, 0.0}, {0.0, 0.0, 1.0});
        EXPECT_NEAR(e.x, expected, 1e-9 * expected) << r;
        EXPECT_EQ(e.x, e.z);
    }
    // A point facing away sees nothing
    EXPECT_EQ(field.irradiance({1.0, 0.0, 0.0}, {0.0, 0.0, -1.0}).y, 0.0);
}

TEST(PointSource, CosineWebOnAFloorIsI0CosToTheFourthOverHSquared) {
    const double h = 2.5;
    const DirectField field(floor_scene(
        symmetric_web([](double g) { return g <= 90.0 ? 800.0 * std::cos(g * kRad) : 0.0; }), h));
    for (const double r : {0.0, 0.3, 1.0, 2.0, 4.0, 9.0}) {
        const double cos_theta = h / std::sqrt(h * h + r * r);
        const double expected = 800.0 * std::pow(cos_theta, 4) / (h * h);
        const double e = field.irradiance({0.0, r, 0.0}, {0.0, 0.0, 1.0}).y;
        EXPECT_NEAR(e, expected, 2e-4 * expected) << r;  // the web's 1° bilinear steps
    }
}

TEST(PointSource, OccludersCastTheirShadowAndTranslucentOnesAFraction) {
    visdb::Scene scene = floor_scene(symmetric_web([](double) { return 100.0; }), 3.0);
    add_quad(scene, -0.5, -0.5, 0.5, 0.5, 1.5, 1.0);  // opaque, over the origin
    // α 0.25, over (5, 0): the segment to (5, 0, 0) passes the diagonal of its two triangles
    add_quad(scene, 2.0, -0.5, 3.0, 0.5, 1.5, 0.25);
    const DirectField field(scene);
    const glm::dvec3 up{0.0, 0.0, 1.0};
    EXPECT_EQ(field.irradiance({0.0, 0.0, 0.0}, up).y, 0.0);
    EXPECT_EQ(field.irradiance({0.9, 0.0, 0.0}, up).y, 0.0);  // shadow edge at x = 1
    const double lit = 100.0 * 3.0 / std::pow(9.0 + 1.1 * 1.1, 1.5);
    EXPECT_NEAR(field.irradiance({1.1, 0.0, 0.0}, up).y, lit, 1e-12);
    const double behind = 100.0 * 3.0 / std::pow(9.0 + 25.0, 1.5);
    EXPECT_NEAR(field.irradiance({5.0, 0.0, 0.0}, up).y, 0.75 * behind, 1e-12);
    // The segment test on its own: ends excluded
    const Patch p{{{-1.0, -1.0, 1.0}, {1.0, -1.0, 1.0}, {0.0, 1.0, 1.0}}, 1.0};
    EXPECT_DOUBLE_EQ(segment_crossing(p, {0.0, 0.0, 0.0}, {0.0, 0.0, 2.0}), 0.5);
    EXPECT_EQ(segment_crossing(p, {0.0, 0.0, 1.0}, {0.0, 0.0, 2.0}), -1.0);
    EXPECT_EQ(segment_crossing(p, {0.0, 0.0, 0.0}, {0.0, 0.0, 1.0}), -1.0);
    EXPECT_EQ(segment_crossing(p, {3.0, 0.0, 0.0}, {3.0, 0.0, 2.0}), -1.0);
}

/// The form factor from a point to a parallel rectangle [0, a] × [0, b] at height h whose
/// corner lies over the point (the closed form of the configuration factor catalogues).
double corner_rectangle_factor(double a, double b, double h) {
    const double x = a / h, y = b / h;
    const double sx = std::sqrt(1.0 + x * x), sy = std::sqrt(1.0 + y * y);
    return (x / sx * std::atan(y / sx) + y / sy * std::atan(x / sy)) / (2.0 * std::numbers::pi);
}

/// The form factor from (px, py, 0), facing up, to the rectangle [x0, x1] × [y0, y1] at height
/// h facing down (the point under it): four corner rectangles.
double rectangle_factor(double px, double py, double x0, double x1, double y0, double y1,
                        double h) {
    // Inclusion-exclusion over the corners, each corner rectangle signed by its quadrant
    const auto sign = [](double v) { return v < 0.0 ? -1.0 : 1.0; };
    const double ex[2] = {x0 - px, x1 - px}, ey[2] = {y0 - py, y1 - py};
    double f = 0.0;
    for (int i = 0; i < 2; ++i)
        for (int j = 0; j < 2; ++j)
            f += (i == j ? 1.0 : -1.0) * sign(ex[i]) * sign(ey[j]) *
                 corner_rectangle_factor(std::abs(ex[i]), std::abs(ey[j]), h);
    return f;
}

TEST(PointSource, LargeRectangularOpeningGivesTheUniformLuminanceRectangle) {
    // A cosine web of I0 from a 1.2 × 0.6 m opening is a rectangle of uniform luminance
    // L = I0 / A: E = π L F, F the point-to-rectangle form factor, under it (2 m < 5 · 1.2)
    const double i0 = 900.0, length = 1.2, width = 0.6, h = 1.0;
    visdb::Scene scene = floor_scene(
        symmetric_web([&](double g) { return g <= 90.0 ? i0 * std::cos(g * kRad) : 0.0; }), h);
    visdb::Luminaire& l = scene.luminaires[0];
    l.opening = {visdb::LuminousOpening::Shape::Rectangle, width, length, 0.0};
    const double luminance = i0 / (length * width);
    const DirectField field(scene);
    for (const glm::dvec2 p : {glm::dvec2(0.0, 0.0), glm::dvec2(0.3, 0.1), glm::dvec2(0.9, -0.5),
                               glm::dvec2(2.5, 1.0)}) {
        const double expected =
            std::numbers::pi * luminance *
            rectangle_factor(p.x, p.y, -0.5 * length, 0.5 * length, -0.5 * width, 0.5 * width, h);
        const double e = field.irradiance({p.x, p.y, 0.0}, {0.0, 0.0, 1.0}).y;
        EXPECT_NEAR(e, expected, 5e-4 * expected) << p.x << " " << p.y;
        // The point source would be off by more than that close under the opening
        if (p.x == 0.0) {
            EXPECT_GT(std::abs(i0 / (h * h) - expected), 0.05 * expected);
        }
    }
    // Five sizes away and beyond: the point source, exactly
    const double far = 6.5;
    const double cos_theta = h / std::sqrt(h * h + far * far);
    EXPECT_NEAR(field.irradiance({0.0, far, 0.0}, {0.0, 0.0, 1.0}).y,
                i0 * std::pow(cos_theta, 4) / (h * h), 2e-4 * i0 * std::pow(cos_theta, 4));
    EXPECT_TRUE(opening_samples(l, 6.0).empty());
    EXPECT_EQ(opening_samples(l, 0.5).size(), 4u * 12u * 12u);  // ceil(5 · 1.2 / 0.5) cells
}

TEST(PointSource, LargeDiscOpeningGivesTheUniformLuminanceDisc) {
    // A cosine web from a disc of radius R is a disc of uniform luminance L = I0 / (π R²): on
    // its axis at h, E = π L R² / (h² + R²) = I0 / (h² + R²)
    const double i0 = 500.0, radius = 0.4;
    for (const double h : {0.25, 0.8, 1.9}) {
        visdb::Scene scene = floor_scene(
            symmetric_web([&](double g) { return g <= 90.0 ? i0 * std::cos(g * kRad) : 0.0; }), h);
        scene.luminaires[0].opening = {visdb::LuminousOpening::Shape::Disc, 2.0 * radius,
                                       2.0 * radius, 0.0};
        const DirectField field(scene);
        const double expected = i0 / (h * h + radius * radius);
        EXPECT_NEAR(field.irradiance({0.0, 0.0, 0.0}, {0.0, 0.0, 1.0}).y, expected, 5e-4 * expected)
            << h;
    }
    // An occluder under half the disc: the penumbra (the point source would give all or none)
    visdb::Scene scene = floor_scene(
        symmetric_web([&](double g) { return g <= 90.0 ? i0 * std::cos(g * kRad) : 0.0; }), 1.0);
    scene.luminaires[0].opening = {visdb::LuminousOpening::Shape::Disc, 2.0 * radius, 2.0 * radius,
                                   0.0};
    add_quad(scene, 0.0, -1.0, 1.0, 1.0, 0.99, 1.0);  // just under the half x > 0
    const DirectField shaded(scene);
    const double full = i0 / (1.0 + radius * radius);
    const double e = shaded.irradiance({0.0, 0.0, 0.0}, {0.0, 0.0, 1.0}).y;
    EXPECT_NEAR(e, 0.5 * full, 0.01 * full);
}

/// `v` turned by R = Rz(c) Ry(b) Rx(a), degrees.
glm::dvec3 turn(const glm::dvec3& v, double a, double b, double c) {
    a *= kRad;
    b *= kRad;
    c *= kRad;
    glm::dvec3 r{v.x, std::cos(a) * v.y - std::sin(a) * v.z, std::sin(a) * v.y + std::cos(a) * v.z};
    r = {std::cos(b) * r.x + std::sin(b) * r.z, r.y, -std::sin(b) * r.x + std::cos(b) * r.z};
    return {std::cos(c) * r.x - std::sin(c) * r.y, std::sin(c) * r.x + std::cos(c) * r.y, r.z};
}

TEST(PointSource, TurnedLuminaireAgreesWithTurnedScene) {
    // An asymmetric web: depends on C and γ
    visdb::PhotometricWeb web;
    web.horizontal = range(0.0, 360.0, 30.0);
    web.vertical = range(0.0, 180.0, 15.0);
    for (const double c : web.horizontal) {
        for (const double g : web.vertical) {
            web.candela.push_back(100.0 + 50.0 * std::cos(c * kRad) * std::sin(g * kRad) +
                                  20.0 * g / 180.0);
        }
    }
    const double a = 30.0, b = -20.0, c = 45.0;
    visdb::Scene turned = floor_scene(web, 3.0);
    visdb::Luminaire& l = turned.luminaires[0];
    l.axis_x = turn({1, 0, 0}, a, b, c);
    l.axis_y = turn({0, 1, 0}, a, b, c);
    l.axis_z = turn({0, 0, 1}, a, b, c);
    const DirectField turned_field(turned);
    // The same luminaire unturned at the origin; receivers turned back by R⁻¹ around it
    visdb::Scene plain = floor_scene(web, 0.0);
    for (glm::dvec3& p : plain.surfaces[0].mesh.positions) p.z = 50.0;  // out of every path
    const DirectField plain_field(plain);
    const glm::dvec3 source{0.0, 0.0, 3.0};
    for (const glm::dvec3 x : {glm::dvec3(0.0, 0.0, 0.0), glm::dvec3(1.5, -2.0, 0.0),
                               glm::dvec3(-4.0, 0.5, 0.0), glm::dvec3(2.0, 3.0, 0.0)}) {
        const glm::dvec3 n{0.0, 0.0, 1.0};
        // R⁻¹ v = (v·x', v·y', v·z') for the turned axes
        const auto back = [&](const glm::dvec3& v) {
            return glm::dvec3(glm::dot(v, l.axis_x), glm::dot(v, l.axis_y), glm::dot(v, l.axis_z));
        };
        const glm::dvec3 x_plain = back(x - source);
        const glm::dvec3 n_plain = back(n);
        const double e_turned = turned_field.irradiance(x, n).y;
        const double e_plain = plain_field.irradiance(x_plain, n_plain).y;
        EXPECT_GT(e_turned, 0.0);
        EXPECT_NEAR(e_turned, e_plain, 1e-9 * e_turned) << x.x << " " << x.y;
    }
}

}  // namespace
}  // namespace abrad::radiosity
