#include "abrad/radiosity/bake.h"

#include <gtest/gtest.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <glm/geometric.hpp>
#include <numbers>
#include <string>
#include <vector>

#include "abrad/radiosity/direct.h"
#include "abrad/radiosity/form_factor.h"
#include "analytic.h"
#include "scenes.h"

namespace abrad::radiosity {
namespace {

// Floor 2×2 m (8×8 cells) under a 1×1 m light at 1.5 m, E = (10, 20, 5) W/m², ρ_floor = 0.5,
// with or without the 0.4 m occluder half way (scenes.h).
visdb::Scene paper_scene(bool occluder) { return abrad::testing::floor_and_light(8, occluder); }

// Form factor from floor point x to the light ∩ rectangle, both at height 1.5.
double ff_light_part(const glm::dvec3& x, double sx0, double sx1, double sy0, double sy1) {
    const double x0 = std::max(-0.5, sx0), x1 = std::min(0.5, sx1);
    const double y0 = std::max(-0.5, sy0), y1 = std::min(0.5, sy1);
    if (x0 >= x1 || y0 >= y1) return 0.0;
    return testing::ff_parallel_rect(x0 - x.x, x1 - x.x, y0 - x.y, y1 - x.y, 1.5);
}

TEST(Bake, ExactShadingMatchesClosedFormOnTheFloor) {
    for (bool occluder : {false, true}) {
        BakeOptions o;
        o.dm = false;
        const visdb::Bake b = bake(paper_scene(occluder), o);
        int floor_vertices = 0;
        for (std::size_t t = 0; t < b.mesh.triangles.size(); ++t) {
            if (b.mesh.triangle_surface[t] != 0) continue;
            for (int k = 0; k < 3; ++k) {
                const std::uint32_t v = b.mesh.triangles[t][k];
                const glm::dvec3 x = b.mesh.positions[v];
                double f = ff_light_part(x, -9, 9, -9, 9);
                // The occluder at half height projects s ↦ 2s - x onto the light's plane
                if (occluder) f -= ff_light_part(x, -0.4 - x.x, 0.4 - x.x, -0.4 - x.y, 0.4 - x.y);
                EXPECT_NEAR(b.mesh.irradiance[v].y, 20.0 * f, 1e-5 * 20.0 * f + 1e-9)
                    << "occluder " << occluder << " at " << x.x << "," << x.y;
                EXPECT_NEAR(b.mesh.radiosity[v].x, 0.5 * 10.0 * f, 1e-5 * 5.0 * f + 1e-9);
                ++floor_vertices;
            }
        }
        EXPECT_EQ(floor_vertices, 8 * 8 * 2 * 3);
    }
}

// The paper's way: vertex = area-weighted patch irradiance from the hemicube. Close to the
// exact field away from shadow edges, and conserving the power that reaches the floor.
TEST(Bake, PatchShadingConservesPowerOnTheFloor) {
    BakeOptions o;
    o.shading = Shading::Patch;
    o.dm = false;
    const visdb::Scene scene = paper_scene(false);
    const visdb::Bake b = bake(scene, o);
    const double received = b.statistics.received_power_w;
    // Power leaving the light that lands on the 2×2 floor: E · A_L · F(light→floor); with a
    // differential-area hemicube at each light triangle's centroid it is E·A·F(centroid→floor)
    const double mean_e = (10 + 20 + 5) / 3.0;
    const double ff_centroid_floor =
        (testing::ff_parallel_rect(-1 + 1.0 / 6, 1 + 1.0 / 6, -1 + 1.0 / 6, 1 + 1.0 / 6, 1.5) +
         testing::ff_parallel_rect(-1 - 1.0 / 6, 1 - 1.0 / 6, -1 - 1.0 / 6, 1 - 1.0 / 6, 1.5)) /
        2;
    EXPECT_NEAR(received, mean_e * 1.0 * ff_centroid_floor, 0.01 * received);
    // The centre vertex: the hemicube treats each light triangle as a point at its centroid
    // (±1/6, ∓1/6, 1.5) carrying half the light's area, so each floor triangle j gets
    // H_j = Σ_L E·A_L·F(c_L → j)/A_j; the vertex averages its 6 incident triangles (equal
    // areas). Near a large light this overestimates the exact value
    // (docs/algorithms.md#light-triangle-shooting).
    const double q = 0.25;
    using P = glm::dvec3;
    const P z(0, 0, 0);
    const std::vector<std::array<P, 3>> incident = {
        {P(-q, -q, 0), P(0, -q, 0), z}, {P(-q, -q, 0), z, P(-q, 0, 0)},  // cell [-q,0]²
        {z, P(q, 0, 0), P(q, q, 0)},    {z, P(q, q, 0), P(0, q, 0)},     // cell [0,q]²
        {P(-q, 0, 0), z, P(0, q, 0)},   {P(0, -q, 0), P(q, 0, 0), z}};
    double expected = 0.0;
    for (const auto& tri : incident)
        for (const glm::dvec3 c :
             {glm::dvec3(1.0 / 6, -1.0 / 6, 1.5), glm::dvec3(-1.0 / 6, 1.0 / 6, 1.5)})
            expected +=
                10.0 * 0.5 * point_polygon_form_factor(c, {0, 0, -1}, tri) / (q * q / 2) / 6;
    BakeOptions exact_options;
    exact_options.dm = false;
    const visdb::Bake e = bake(scene, exact_options);
    int checked = 0;
    for (std::size_t v = 0; v < b.mesh.positions.size(); ++v) {
        if (glm::length(b.mesh.positions[v]) < 1e-12) {
            EXPECT_NEAR(b.mesh.irradiance[v].x, expected, 0.01 * expected);
            EXPECT_GT(b.mesh.irradiance[v].x, 1.03 * e.mesh.irradiance[v].x);
            ++checked;
        }
    }
    EXPECT_EQ(checked, 1);
}

TEST(Bake, RejectsSceneWithoutLightsAndBadOptions) {
    visdb::Scene scene = paper_scene(false);
    scene.materials[1].emittance = {0, 0, 0};
    EXPECT_THROW(bake(scene, BakeOptions{}), InputError);
    BakeOptions o;
    o.resolution = 51;
    EXPECT_THROW(bake(paper_scene(false), o), InputError);
    o = {};
    o.subpixels = 5;
    EXPECT_THROW(bake(paper_scene(false), o), InputError);
}

// A setting the chosen method or mode does not use is an error naming it (pbrt-v4's
// ReportUnused); the same setting where it is used, or a setting always used, is fine.
// Workers report through ParallelProgress: never two calls at once, the first 0 of the total,
// the last the whole total, and done never above it
TEST(Progress, ParallelWorkReportsSeriallyFromZeroToTheTotal) {
    std::atomic<int> inside{0};
    std::atomic<bool> overlapped{false};
    std::vector<std::pair<std::size_t, std::size_t>> calls;
    const ProgressFn fn = [&](std::string_view stage, std::size_t done, std::size_t total) {
        if (inside.fetch_add(1) != 0) overlapped = true;
        EXPECT_EQ(stage, "work");
        calls.emplace_back(done, total);
        inside.fetch_sub(1);
    };
    constexpr std::size_t kItems = 20000;
    {
        ParallelProgress progress(fn, "work", kItems);
        tbb::parallel_for(std::size_t{0}, kItems, [&](std::size_t) {
            volatile double x = 0.0;
            for (int k = 0; k < 2000; ++k) x = x + std::sqrt(double(k));
            progress.add(1);
        });
    }
    EXPECT_FALSE(overlapped);
    ASSERT_GE(calls.size(), 2u);
    EXPECT_EQ(calls.front(), std::make_pair(std::size_t{0}, kItems));
    EXPECT_EQ(calls.back(), std::make_pair(kItems, kItems));
    for (const auto& [done, total] : calls) EXPECT_LE(done, total);
}

TEST(Bake, SettingsTheBakeDoesNotUseAreErrors) {
    const auto message_of = [](const BakeOptions& o, const std::string& given) {
        try {
            check_unused(o, std::vector<std::string>{given});
        } catch (const InputError& e) {
            return std::string(e.what());
        }
        return std::string();
    };
    BakeOptions o;  // converged interreflection, A-buffer, DM with 4 refinement rounds
    EXPECT_EQ(message_of(o, "--converge"), "");
    EXPECT_EQ(message_of(o, "--element-size"), "");
    o.bounces = 0;  // direct light only
    EXPECT_NE(message_of(o, "--converge").find("--converge"), std::string::npos);
    EXPECT_NE(message_of(o, "--converge").find("--bounces converge"), std::string::npos);
    EXPECT_NE(message_of(o, "--overrelax"), "");
    EXPECT_NE(message_of(o, "--element-size"), "");
    EXPECT_NE(message_of(o, "--element-resolution"), "");
    EXPECT_NE(message_of(o, "--element-subpixels"), "");
    EXPECT_NE(message_of(o, "--shooter-cells"), "");
    EXPECT_NE(message_of(o, "--edge-gather"), "");
    EXPECT_EQ(message_of(o, "--subpixels"), "");
    EXPECT_EQ(message_of(o, "--lights"), "");
    EXPECT_EQ(message_of(o, "--refine-tolerance"), "");
    EXPECT_EQ(message_of(o, "--resolution"), "");  // always used
    EXPECT_EQ(message_of(o, "--threads"), "");

    o.bounces = -1;  // converge
    EXPECT_EQ(message_of(o, "--converge"), "");
    EXPECT_EQ(message_of(o, "--ambient"), "");
    EXPECT_EQ(message_of(o, "--edge-gather"), "");
    o.bounces = 3;  // Jacobi sweeps: the element grid is used, the convergence threshold is not
    EXPECT_EQ(message_of(o, "--element-size"), "");
    EXPECT_NE(message_of(o, "--converge"), "");

    o = {};
    o.method = Visibility::ZBuffer;
    EXPECT_NE(message_of(o, "--subpixels").find("--method abuffer"), std::string::npos);
    EXPECT_NE(message_of(o, "--element-subpixels").find("--method abuffer"), std::string::npos);
    o = {};
    o.dm = false;
    for (const char* dm_only :
         {"--lights", "--dm-angle", "--refine-rounds", "--refine-tolerance", "--refine-min-edge"})
        EXPECT_NE(message_of(o, dm_only).find(dm_only), std::string::npos) << dm_only;
    o = {};
    o.refine_rounds = 0;  // shadow edges only: no refinement tolerance to use
    EXPECT_NE(message_of(o, "--refine-tolerance"), "");
    EXPECT_EQ(message_of(o, "--refine-rounds"), "");
}

// The thread count only changes how the work is spread (a task arena): a one-thread bake gives
// the all-core bake's field, to the float rounding of per-light sums taken in another order.
TEST(Bake, ThreadCountIsTheBakesOwn) {
    BakeOptions one;
    one.threads = 1;
    one.dm = false;
    BakeOptions all = one;
    all.threads = 0;
    const visdb::Bake a = bake(paper_scene(false), one);
    const visdb::Bake b = bake(paper_scene(false), all);
    ASSERT_EQ(a.mesh.irradiance.size(), b.mesh.irradiance.size());
    for (std::size_t v = 0; v < a.mesh.irradiance.size(); ++v)
        for (int c = 0; c < 3; ++c)
            EXPECT_NEAR(a.mesh.irradiance[v][c], b.mesh.irradiance[v][c],
                        1e-6f * std::max(1.0f, b.mesh.irradiance[v][c]));
}

// A shadow edge earns a mesh edge only where the refinement would mesh the change it marks:
// the edges a dim second light (1e-5 of the main one) casts of the occluder mark changes under
// the refinement's floor and are dropped and counted; the main light's are kept.
TEST(Bake, ShadowEdgesOnlyWhereTheRefinementWouldMeshThem) {
    BakeOptions o;
    o.bounces = 0;
    o.lights = LightModel::Centroid;  // hard edges: one line per occluder edge
    o.refine_rounds = 0;
    const auto segments = [&](const visdb::Scene& scene) {
        const visdb::Bake b = bake(scene, o);
        const visdb::DiscontinuityStats& dm = b.statistics.dm.value();
        return std::pair{dm.segments, dm.shadow.segments_weak};
    };
    const auto [base, base_weak] = segments(paper_scene(true));
    EXPECT_GT(base, 4u);  // the occluder's square shadow, cut by the floor's triangles
    EXPECT_EQ(base_weak, 0u);

    visdb::Scene dim = paper_scene(true);
    for (const double e : {1e-4, 5.0}) {
        dim.materials.push_back({"dim", {0, 0, 0}, {e, e, e}, 1.0});
        dim.surfaces.push_back(
            abrad::testing::grid("dim", static_cast<std::uint32_t>(dim.materials.size() - 1), -0.95,
                                 -0.65, -0.95, -0.65, 1.4, 1, false));
        const auto [kept, weak] = segments(dim);
        if (e < 1e-3) {  // under 1/1000 of the main light's brightest patch: dropped
            EXPECT_EQ(kept, base);
            EXPECT_GT(weak, 4u);
        } else {  // half the main light: its edges are kept where it lights the floor
            EXPECT_GT(kept, base);
        }
        dim.surfaces.pop_back();
        dim.materials.pop_back();
    }
}

// Vertices are split where faces of one surface differ in normal, never shared across surfaces.
TEST(Bake, VerticesNotSharedAcrossSurfacesOrNormals) {
    BakeOptions o;
    o.dm = false;
    const visdb::Bake b = bake(paper_scene(true), o);
    std::vector<int> surface_of(b.mesh.positions.size(), -1);
    for (std::size_t t = 0; t < b.mesh.triangles.size(); ++t)
        for (int k = 0; k < 3; ++k) {
            const auto v = b.mesh.triangles[t][k];
            const int s = static_cast<int>(b.mesh.triangle_surface[t]);
            EXPECT_TRUE(surface_of[v] == -1 || surface_of[v] == s);
            surface_of[v] = s;
        }
    EXPECT_EQ(b.mesh.positions.size(), 81u + 4u + 4u);
}

// The point evaluator (probes, grids) and the bake's exact shading agree at every vertex,
// including the penumbra of the occluder.
TEST(DirectField, AgreesWithExactBakeAtEveryVertex) {
    const visdb::Scene scene = paper_scene(true);
    BakeOptions direct;
    direct.bounces = 0;  // direct light, as the field
    const visdb::Bake b = bake(scene, direct);
    const DirectField field(scene);
    EXPECT_EQ(field.light_triangles(), 2u);
    for (std::size_t v = 0; v < b.mesh.positions.size(); ++v) {
        const visdb::Rgb h = field.irradiance(b.mesh.positions[v], glm::dvec3(b.mesh.normals[v]));
        EXPECT_NEAR(h.y, b.mesh.irradiance[v].y, 1e-5 * h.y + 1e-9) << "vertex " << v;
    }
    visdb::Scene dark = scene;
    dark.materials[1].emittance = {0, 0, 0};
    EXPECT_THROW(DirectField{dark}, InputError);
}

// Coplanar faces share their vertices on a tilted plane too, where the normal is not exactly
// representable in float (a float-rounded comparison would split them at random).
TEST(Bake, CoplanarFacesOfATiltedPlaneShareVertices) {
    visdb::Scene scene = paper_scene(false);
    visdb::Surface& floor = scene.surfaces[0];
    for (auto& p : floor.mesh.positions) p = {p.x * 0.93, p.y * 0.71, 0.3 + p.y * 0.7 + p.x * 0.45};
    BakeOptions o;
    o.dm = false;
    const visdb::Bake b = bake(scene, o);
    std::size_t floor_vertices = 0;
    std::vector<bool> seen(b.mesh.positions.size(), false);
    for (std::size_t t = 0; t < b.mesh.triangles.size(); ++t)
        if (b.mesh.triangle_surface[t] == 0)
            for (int k = 0; k < 3; ++k)
                if (!seen[b.mesh.triangles[t][k]]) {
                    seen[b.mesh.triangles[t][k]] = true;
                    ++floor_vertices;
                }
    EXPECT_EQ(floor_vertices, 81u);
}

}  // namespace
}  // namespace abrad::radiosity
