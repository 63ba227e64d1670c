#include "abrad/radiosity/field_error.h"

#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <glm/geometric.hpp>
#include <stdexcept>
#include <string>

#include "abrad/radiosity/bake.h"
#include "abrad/radiosity/direct.h"
#include "scenes.h"

namespace abrad::radiosity {
namespace {

using glm::dvec3;

// A bake mesh built by hand: each triangle gets its own three vertices, with irradiance from
// `h` at the vertex positions.
struct MeshBuilder {
    visdb::BakeMesh mesh;

    template <typename H>
    void add(const dvec3& a, const dvec3& b, const dvec3& c, std::uint32_t surface, H&& h) {
        const auto base = static_cast<std::uint32_t>(mesh.positions.size());
        const glm::vec3 n(glm::normalize(glm::cross(b - a, c - a)));
        for (const dvec3& p : {a, b, c}) {
            mesh.positions.push_back(p);
            mesh.normals.push_back(n);
            mesh.irradiance.push_back(glm::vec3(h(p)));
            mesh.radiosity.push_back(glm::vec3(0.0f));
        }
        mesh.triangles.push_back({base, base + 1, base + 2});
        mesh.triangle_surface.push_back(surface);
    }
};

// Materials: 0 a grey receiver, 1 a light, 2 a black (non-reflecting) surface; one surface
// per material, with the same index.
visdb::Scene three_material_scene() {
    visdb::Scene scene;
    scene.materials.push_back({"grey", {0.5, 0.5, 0.5}, {0, 0, 0}, 1.0});
    scene.materials.push_back({"light", {0, 0, 0}, {100, 100, 100}, 1.0});
    scene.materials.push_back({"black", {0, 0, 0}, {0, 0, 0}, 1.0});
    for (std::uint32_t m = 0; m < 3; ++m) {
        visdb::Surface s;
        s.name = scene.materials[m].name;
        s.material = m;
        scene.surfaces.push_back(s);
    }
    return scene;
}

// A linear field whose values at the dyadic vertices below are exact in float.
visdb::Rgb linear(const dvec3& x) {
    return {2.0 + 3.0 * x.x - x.y + 0.5 * x.z, 1.0 + 0.25 * x.y, 4.0 - x.x + 2.0 * x.z};
}

TEST(FieldError, LinearFieldIsInterpolatedExactly) {
    MeshBuilder m;
    m.add({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, 0, linear);
    m.add({1, 0, 0}, {1.5, 2, 0.25}, {0, 1, 0}, 0, linear);
    m.add({-1, 0.5, 2}, {0.75, -1, 1}, {0.5, 0.5, -0.5}, 0, linear);  // tilted in 3-D
    for (int k : {1, 2, 3, 5}) {
        const FieldError e =
            field_error(three_material_scene(), m.mesh,
                        [](const dvec3& x, const dvec3&) { return linear(x); }, {k});
        EXPECT_LT(e.relative_l1, 1e-12) << "k " << k;
        EXPECT_LT(e.absolute_l1, 1e-12) << "k " << k;
        EXPECT_GT(e.mean_exact, 1.0);
        EXPECT_EQ(e.triangles, 3u);
        EXPECT_EQ(e.samples, 3u * static_cast<std::size_t>(k * k));
    }
}

// f = x² on the triangle (0,0), (1,0), (0,1): the interpolant is x and the error x − x² ≥ 0.
// Over the triangle, mean(x − x²) = 1/6 and mean(x²) = 1/6, so the true relative L1 is 1.
// The centroid of a sub-triangle of side h = 1/k underestimates the mean of x² on it by
// exactly h²/18 (its second central moment in x, upward or downward) and x exactly, so the
// sampled rule gives absolute 1/6 + 1/(18k²), mean exact 1/6 − 1/(18k²) and relative
// (3k² + 1)/(3k² − 1).
TEST(FieldError, QuadraticFieldMatchesClosedFormOfTheSampledRule) {
    const auto square = [](const dvec3& x) { return visdb::Rgb(x.x * x.x); };
    MeshBuilder m;
    m.add({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, 0, square);
    const auto exact = [&](const dvec3& x, const dvec3&) { return square(x); };

    // Brute force, independent of the implementation: midpoint rule on a fine grid of the
    // unit square, cells whose centre lies inside the triangle
    const int n = 2000;
    double error = 0.0, magnitude = 0.0;
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            const double x = (i + 0.5) / n, y = (j + 0.5) / n;
            if (x + y >= 1.0) continue;
            error += std::abs(x - x * x);
            magnitude += x * x;
        }
    const double brute = error / magnitude;
    EXPECT_NEAR(brute, 1.0, 1e-3);

    double previous = 1e9;
    for (int k = 1; k <= 12; ++k) {
        const FieldError e = field_error(three_material_scene(), m.mesh, exact, {k});
        const double k2 = k * k;
        EXPECT_NEAR(e.relative_l1, (3 * k2 + 1) / (3 * k2 - 1), 1e-12) << "k " << k;
        EXPECT_NEAR(e.absolute_l1, 1.0 / 6 + 1 / (18 * k2), 1e-12) << "k " << k;
        EXPECT_NEAR(e.mean_exact, 1.0 / 6 - 1 / (18 * k2), 1e-12) << "k " << k;
        EXPECT_DOUBLE_EQ(e.area_m2, 0.5);
        // Converging toward the brute-force value from above
        EXPECT_LT(std::abs(e.relative_l1 - brute), previous) << "k " << k;
        previous = std::abs(e.relative_l1 - brute);
        if (k == 3) {
            EXPECT_NEAR(e.relative_l1, brute, 0.1 * brute);
        }
    }
    EXPECT_LT(previous, 0.01);
}

// Two triangles of areas 1/2 and 2, the small one off by (2, 0, 0) W/m² in every point, the
// large one right; the exact field is 1 everywhere.
TEST(FieldError, WeightsByAreaAndAveragesChannels) {
    const auto field = [](const dvec3& x) {
        return x.x < 5.0 ? visdb::Rgb(3.0, 1.0, 1.0) : visdb::Rgb(1.0);
    };
    MeshBuilder m;
    m.add({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, 0, field);
    m.add({10, 0, 0}, {12, 0, 0}, {10, 2, 0}, 0, field);
    const FieldError e = field_error(three_material_scene(), m.mesh,
                                     [](const dvec3&, const dvec3&) { return visdb::Rgb(1.0); });
    const double error = 0.5 * 2.0 / 3.0;  // A · channel mean of |(2, 0, 0)|
    EXPECT_NEAR(e.absolute_l1, error / 2.5, 1e-12);
    EXPECT_NEAR(e.relative_l1, error / 2.5, 1e-12);
    EXPECT_NEAR(e.mean_exact, 1.0, 1e-12);
    EXPECT_NEAR(e.area_m2, 2.5, 1e-12);
    EXPECT_EQ(e.triangles, 2u);
    EXPECT_EQ(e.samples, 18u);
}

// The exact field is asked for at points of the triangle's plane, with its unit
// counter-clockwise normal, and the interpolated field of a normal-dependent one is exact.
TEST(FieldError, PassesPointsInsideAndTheUnitGeometricNormal) {
    const dvec3 a(1, 2, 3), b(2, 2, 4), c(1, 4, 3.5);
    const dvec3 normal = glm::normalize(glm::cross(b - a, c - a));
    MeshBuilder m;
    m.add(a, b, c, 0, [](const dvec3&) { return visdb::Rgb(0.0); });
    m.add(a, c, b, 0, [](const dvec3&) { return visdb::Rgb(0.0); });  // the back side
    std::atomic<int> calls{0}, wrong{0};
    const FieldError e =
        field_error(three_material_scene(), m.mesh,
                    [&](const dvec3& x, const dvec3& n) {
                        ++calls;
                        const bool front = glm::length(n - normal) < 1e-12,
                                   back = glm::length(n + normal) < 1e-12;
                        if (!(front || back) || std::abs(glm::dot(x - a, normal)) > 1e-12) ++wrong;
                        return front ? visdb::Rgb(1.0) : visdb::Rgb(3.0);
                    },
                    {4});
    EXPECT_EQ(calls.load(), 2 * 16);
    EXPECT_EQ(wrong.load(), 0);
    EXPECT_EQ(e.samples, 32u);
    EXPECT_NEAR(e.relative_l1, 1.0, 1e-12);  // |0 − 1| and |0 − 3| against 1 and 3
    EXPECT_NEAR(e.mean_exact, 2.0, 1e-12);
}

TEST(FieldError, EmittersNonReflectorsAndDegenerateTrianglesAreExcluded) {
    const auto wrong = [](const dvec3&) { return visdb::Rgb(1e6); };
    const auto exact = [](const dvec3& x, const dvec3&) { return visdb::Rgb(1.0 + x.x * x.x); };
    MeshBuilder m;
    m.add({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, 0, [](const dvec3& x) { return visdb::Rgb(1.0 + x.x); });
    const FieldError alone = field_error(three_material_scene(), m.mesh, exact);
    m.add({0, 0, 1}, {0, 1, 1}, {1, 0, 1}, 1, wrong);  // the light
    m.add({0, 0, 2}, {1, 0, 2}, {0, 1, 2}, 2, wrong);  // black
    m.add({0, 0, 3}, {1, 0, 3}, {2, 0, 3}, 0, wrong);  // a grey triangle of zero area
    const FieldError all = field_error(three_material_scene(), m.mesh, exact);
    EXPECT_GT(alone.relative_l1, 0.0);
    EXPECT_EQ(all.relative_l1, alone.relative_l1);
    EXPECT_EQ(all.absolute_l1, alone.absolute_l1);
    EXPECT_EQ(all.mean_exact, alone.mean_exact);
    EXPECT_EQ(all.area_m2, 0.5);
    EXPECT_EQ(all.triangles, 1u);
    EXPECT_EQ(all.samples, 9u);
}

TEST(FieldError, NoReceiversGivesZeros) {
    MeshBuilder m;
    m.add({0, 0, 1}, {0, 1, 1}, {1, 0, 1}, 1, [](const dvec3&) { return visdb::Rgb(5.0); });
    const FieldError e = field_error(three_material_scene(), m.mesh,
                                     [](const dvec3&, const dvec3&) { return visdb::Rgb(1.0); });
    EXPECT_EQ(e.relative_l1, 0.0);
    EXPECT_EQ(e.absolute_l1, 0.0);
    EXPECT_EQ(e.mean_exact, 0.0);
    EXPECT_EQ(e.area_m2, 0.0);
    EXPECT_EQ(e.triangles, 0u);
    EXPECT_EQ(e.samples, 0u);
}

using abrad::testing::grid;

// A 4×4 m floor under a 1×1 m light 2 m above it facing down (E = 100 W/m²).
visdb::Scene floor_scene(int floor_cells) {
    visdb::Scene scene;
    scene.materials.push_back({"floor", {0.5, 0.5, 0.5}, {0, 0, 0}, 1.0});
    scene.materials.push_back({"light", {0, 0, 0}, {100, 100, 100}, 1.0});
    scene.surfaces.push_back(grid("floor", 0, -2, 2, -2, 2, 0, floor_cells, true));
    scene.surfaces.push_back(grid("light", 1, -0.5, 0.5, -0.5, 0.5, 2, 1, false));
    return scene;
}

TEST(FieldError, FinerBakeMeshHasSmallerErrorAgainstTheDirectField) {
    FieldError error[2];
    int i = 0;
    for (int cells : {1, 20}) {
        const visdb::Scene scene = floor_scene(cells);
        BakeOptions o;
        o.dm = false;  // the scene's own mesh: the error depends on its fineness alone
        const visdb::Bake b = bake(scene, o);
        const DirectField field(scene);
        error[i] = field_error(
            scene, b.mesh, [&](const dvec3& x, const dvec3& n) { return field.irradiance(x, n); });
        EXPECT_EQ(error[i].triangles, static_cast<std::size_t>(2 * cells * cells));
        EXPECT_NEAR(error[i].area_m2, 16.0, 1e-9);
        // The mean exact irradiance is E·A_L·F(light→floor)/16 and the same for both
        EXPECT_GT(error[i].mean_exact, 1.0);
        EXPECT_LT(error[i].mean_exact, 100.0 / 16.0);
        ++i;
    }
    EXPECT_NEAR(error[0].mean_exact, error[1].mean_exact, 0.1 * error[1].mean_exact);
    EXPECT_GT(error[0].relative_l1, 0.2);
    EXPECT_LT(error[1].relative_l1, error[0].relative_l1);
    EXPECT_LT(error[1].relative_l1, 0.02);
}

TEST(FieldError, BadInputThrows) {
    const auto one = [](const dvec3&) { return visdb::Rgb(1.0); };
    const IrradianceFn exact = [](const dvec3&, const dvec3&) { return visdb::Rgb(1.0); };
    MeshBuilder good;
    good.add({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, 0, one);
    const visdb::Scene scene = three_material_scene();
    EXPECT_NO_THROW(field_error(scene, good.mesh, exact));

    auto no_irradiance = good.mesh;
    no_irradiance.irradiance.clear();
    EXPECT_THROW(field_error(scene, no_irradiance, exact), InputError);

    auto bad_surface = good.mesh;
    bad_surface.triangle_surface[0] = 3;
    EXPECT_THROW(field_error(scene, bad_surface, exact), InputError);

    auto missing_surface = good.mesh;
    missing_surface.triangle_surface.clear();
    EXPECT_THROW(field_error(scene, missing_surface, exact), InputError);

    auto bad_vertex = good.mesh;
    bad_vertex.triangles[0].z = 3;
    EXPECT_THROW(field_error(scene, bad_vertex, exact), InputError);

    visdb::Scene bad_material = scene;
    bad_material.surfaces[0].material = 7;
    try {
        field_error(bad_material, good.mesh, exact);
        ADD_FAILURE() << "no exception for a material outside the scene";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("material 7"), std::string::npos) << e.what();
    }

    EXPECT_THROW(field_error(scene, good.mesh, exact, {0}), InputError);
    EXPECT_THROW(field_error(scene, good.mesh, exact, {-2}), InputError);
    EXPECT_THROW(field_error(scene, good.mesh, IrradianceFn{}), InputError);
}

}  // namespace
}  // namespace abrad::radiosity
