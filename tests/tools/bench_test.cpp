// The benchmark's pieces and the generated floors, with real values: the hemicube's
// form-factor error against the closed form, the Pareto front, a tiny end-to-end run that
// writes the CSV and the summary, and the floors' geometry (areas, normals, light count).

#include "abrad/tools/bench.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <glm/geometric.hpp>
#include <map>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "abrad/tools/floor_gen.h"
#include "temp_dir.h"

namespace abrad::tools {
namespace {

namespace fs = std::filesystem;
using radiosity::Visibility;

TEST(Bench, FormFactorErrorFallsWithResolutionAndWithTheABuffer) {
    const double z50 = hemicube_ff_error(Visibility::ZBuffer, 50, 1);
    const double z400 = hemicube_ff_error(Visibility::ZBuffer, 400, 1);
    const double a50 = hemicube_ff_error(Visibility::ABuffer, 50, 8);
    EXPECT_GT(z50, 0.0);
    EXPECT_LT(z50, 0.5);  // 34.6%: point sampling at R = 50 aliases badly on 0.25 m patches
    EXPECT_LT(z400, 0.5 * z50);
    EXPECT_LT(a50, z50);  // 8x8 coverage masks at R = 50 beat point samples at R = 50
}

TEST(Bench, ParetoFrontKeepsOnlyUndominatedRuns) {
    std::vector<BenchRun> runs(5);
    const double t[5] = {1.0, 2.0, 3.0, 2.5, 0.5}, e[5] = {0.1, 0.05, 0.01, 0.2, -1.0};
    for (int i = 0; i < 5; ++i) {
        runs[i].scene = "s";
        runs[i].seconds_wall = t[i];
        runs[i].field_error = e[i];
    }
    // Run 3 is slower and worse than run 1; run 4 has no field error
    EXPECT_EQ(pareto_front(runs), (std::vector<std::size_t>{0, 1, 2}));
}

TEST(Bench, SettingsGridCoversTheIssuesGrid) {
    const auto full = settings_grid(false, 0);
    EXPECT_EQ(full.size(),
              (4u + 9u) * 4u * 2u);  // hemicubes × (DM off + 3 light models) × shadings
    EXPECT_EQ(settings_grid(true, 0).size(), 3u * 2u * 2u);
}

TEST(Bench, QuickRunWritesCsvAndSummaryWithRealValues) {
    const abrad::testing::TempDir dir("bench");
    const fs::path out = dir / "out";
    BenchOptions o;
    o.out = out;
    o.quick = true;
    o.plot = false;
    o.subdivisions = 1;
    FloorOptions room;
    room.cell = 1.0;
    room.furniture = 1;
    o.scenes.push_back({"room", generate_floor(room)});
    o.sizes = {400};
    o.scaling.dm = false;
    o.scaling.bounces = 0;
    const std::vector<BenchRun> runs = run_bench(o);
    ASSERT_EQ(runs.size(), 12u + 1u);
    for (const BenchRun& r : runs) {
        EXPECT_GT(r.seconds_wall, 0.0);
        EXPECT_GT(r.peak_rss_mb, 1.0);
        EXPECT_GT(r.triangles_out, 0u);
        EXPECT_EQ(r.light_triangles, 2u);
        EXPECT_GE(r.field_error, 0.0);
        EXPECT_LT(r.field_error, 1.0);
        // Every ray from a ceiling panel in a closed room hits something: Σ F = 1
        EXPECT_NEAR(r.statistics.mean_form_factor_sum, 1.0, 1e-6) << label(r.options);
        if (r.options.dm) {
            EXPECT_GT(r.triangles_out, r.triangles_in);
        }
    }
    // Exact shading with DM beats patch shading without it on the same hemicube
    auto find = [&](bool dm, radiosity::Shading s) {
        for (const BenchRun& r : runs)
            if (r.kind == "grid" && r.options.dm == dm && r.options.shading == s &&
                r.options.resolution == 50 && r.options.method == Visibility::ABuffer)
                return r.field_error;
        return -1.0;
    };
    EXPECT_LT(find(true, radiosity::Shading::Exact), find(false, radiosity::Shading::Patch));
    std::ifstream csv(out / "bench.csv");
    std::string line;
    int rows = 0;
    std::getline(csv, line);
    EXPECT_EQ(line.rfind("scene,kind,triangles_in", 0), 0u);
    while (std::getline(csv, line)) ++rows;
    EXPECT_EQ(rows, 12);
    std::ifstream md(out / "summary.md");
    std::stringstream text;
    text << md.rdbuf();
    EXPECT_NE(text.str().find("Pareto-best settings"), std::string::npos);
    EXPECT_NE(text.str().find("## Scaling on generated floors"), std::string::npos);
}

// The uniform baseline of the mesh trade-off: a 2 x 2 m floor of 2 x 2 cells and a light,
// split to 100 triangles. Longest-edge bisection of right isosceles triangles keeps them right
// isosceles: areas A or A/2, the floor's area and facing kept, no T-vertex (the edges with
// one triangle are the floor's outline, 8 m), the light untouched.
TEST(Bench, UniformSubdivisionReachesTheCountConformingAndEven) {
    visdb::Scene scene;
    scene.materials.push_back({"floor", {0.5, 0.5, 0.5}, {0, 0, 0}, 1.0});
    scene.materials.push_back({"light", {0, 0, 0}, {10, 10, 10}, 1.0});
    visdb::Surface floor, light;
    floor.material = 0;
    for (int j = 0; j <= 2; ++j)
        for (int i = 0; i <= 2; ++i) floor.mesh.positions.push_back({i - 1.0, j - 1.0, 0.0});
    for (std::uint32_t j = 0; j < 2; ++j)
        for (std::uint32_t i = 0; i < 2; ++i) {
            const std::uint32_t a = 3 * j + i;
            floor.mesh.triangles.push_back({a, a + 1, a + 4});
            floor.mesh.triangles.push_back({a, a + 4, a + 3});
        }
    light.material = 1;
    light.mesh.positions = {{-0.5, -0.5, 1.5}, {-0.5, 0.5, 1.5}, {0.5, 0.5, 1.5}, {0.5, -0.5, 1.5}};
    light.mesh.triangles = {{0, 1, 2}, {0, 2, 3}};
    scene.surfaces = {floor, light};

    const visdb::Scene out = subdivide_uniformly(scene, 100);
    EXPECT_GE(out.triangle_count(), 100u);
    EXPECT_LE(out.triangle_count(), 101u);  // a split adds one triangle per side of the edge
    EXPECT_EQ(out.surfaces[1].mesh.positions, light.mesh.positions);
    EXPECT_EQ(out.surfaces[1].mesh.triangles, light.mesh.triangles);
    const visdb::TriangleMesh& m = out.surfaces[0].mesh;
    double area = 0.0, lo = 1e9, hi = 0.0;
    std::map<std::pair<std::uint32_t, std::uint32_t>, int> edges;
    for (const glm::u32vec3& t : m.triangles) {
        const glm::dvec3 n =
            glm::cross(m.positions[t.y] - m.positions[t.x], m.positions[t.z] - m.positions[t.x]);
        EXPECT_GT(n.z, 0.0);
        area += 0.5 * n.z;
        lo = std::min(lo, 0.5 * n.z);
        hi = std::max(hi, 0.5 * n.z);
        for (int k = 0; k < 3; ++k) {
            const std::uint32_t a = t[k], b = t[(k + 1) % 3];
            ++edges[{std::min(a, b), std::max(a, b)}];
        }
    }
    EXPECT_NEAR(area, 4.0, 1e-12);
    EXPECT_LE(hi, 2.0 * lo * (1.0 + 1e-9));
    double outline = 0.0;
    for (const auto& [e, n] : edges) {
        EXPECT_LE(n, 2);
        if (n == 1) outline += glm::length(m.positions[e.second] - m.positions[e.first]);
    }
    EXPECT_NEAR(outline, 8.0, 1e-12);
    // Nothing to split but the light: as it was
    EXPECT_EQ(subdivide_uniformly(scene, 5).triangle_count(), scene.triangle_count());
}

// The mesh trade-off rows: the default DM bake, and the uniform mesh of its size without DM,
// both measured against the exact direct light.
TEST(Bench, MeshTradeoffPairsDmWithAUniformMeshOfItsSize) {
    const abrad::testing::TempDir dir("tradeoff");
    BenchOptions o;
    o.out = dir / "out";
    o.subdivisions = 1;
    fs::create_directories(o.out);
    FloorOptions room;
    room.cell = 1.0;
    room.furniture = 1;
    const BenchScene scene{"room", generate_floor(room)};
    const std::vector<BenchRun> runs = mesh_tradeoff(scene, radiosity::BakeOptions{}, {0.07}, o);
    ASSERT_EQ(runs.size(), 2u);
    const BenchRun &dm = runs[0], &uniform = runs[1];
    EXPECT_TRUE(dm.options.dm);
    EXPECT_FALSE(uniform.options.dm);
    EXPECT_EQ(dm.kind, "tradeoff");
    EXPECT_EQ(dm.options.bounces, 0);
    EXPECT_GT(dm.triangles_out, dm.triangles_in);
    EXPECT_GE(uniform.triangles_out, dm.triangles_out);
    EXPECT_LE(uniform.triangles_out, dm.triangles_out + 1);
    for (const BenchRun& r : runs) {
        EXPECT_GT(r.field_error, 0.0);
        EXPECT_LT(r.field_error, 0.5);
    }
    EXPECT_FALSE(fs::exists(o.out / "tradeoff.visdb"));
}

TEST(FloorGen, OneRoomHasItsAreasAndFacesInwards) {
    FloorOptions o;
    o.furniture = 0;
    o.lights = 2;
    o.cell = 0.5;
    const visdb::Scene s = generate_floor(o);
    double floor = 0.0, ceiling = 0.0, light = 0.0, walls = 0.0;
    std::size_t light_triangles = 0;
    for (const visdb::Surface& surface : s.surfaces)
        for (const auto& t : surface.mesh.triangles) {
            const glm::dvec3 a = surface.mesh.positions[t.x], b = surface.mesh.positions[t.y],
                             c = surface.mesh.positions[t.z];
            const glm::dvec3 cr = glm::cross(b - a, c - a);
            const double area = 0.5 * glm::length(cr);
            ASSERT_GT(area, 0.0);
            const std::string& m = s.materials[surface.material].name;
            if (m == "floor") {
                floor += area;
                EXPECT_GT(cr.z, 0.0);
            } else if (m == "ceiling") {
                ceiling += area;
                EXPECT_LT(cr.z, 0.0);
            } else if (m == "light") {
                light += area;
                ++light_triangles;
                EXPECT_LT(cr.z, 0.0);
            } else {
                walls += area;
            }
        }
    EXPECT_NEAR(floor, 20.0, 1e-9);
    EXPECT_NEAR(ceiling, 20.0, 1e-9);
    EXPECT_NEAR(light, 2 * 0.36, 1e-9);
    EXPECT_EQ(light_triangles, 4u);
    // Four walls, both faces (inner 5 and 4 m, outer 5.2 and 4.2 m), 3 m high, no doors
    EXPECT_NEAR(walls, 3.0 * 2 * (5.0 + 4.0 + 5.2 + 4.2), 1e-6);
}

TEST(FloorGen, DoorsOpenInnerWallsOnly) {
    FloorOptions o;
    o.rooms_x = 2;
    o.furniture = 0;
    const visdb::Scene s = generate_floor(o);
    double thresholds = 0.0;
    for (const visdb::Surface& surface : s.surfaces)
        if (surface.name == "thresholds")
            for (const auto& t : surface.mesh.triangles)
                thresholds += 0.5 * glm::length(glm::cross(
                                        surface.mesh.positions[t.y] - surface.mesh.positions[t.x],
                                        surface.mesh.positions[t.z] - surface.mesh.positions[t.x]));
    EXPECT_NEAR(thresholds, 0.9 * 0.1, 1e-12);  // one door (0.9 m) through one inner wall (0.1 m)
    EXPECT_THROW(validate(FloorOptions{.rooms_x = 0}), std::invalid_argument);
    EXPECT_THROW(validate(FloorOptions{.cell = 0.0}), std::invalid_argument);
}

TEST(FloorGen, SizesFollowTheTarget) {
    for (std::size_t target : {3000u, 30000u, 100000u}) {
        const std::size_t n = generate_floor(floor_for_triangles(target)).triangle_count();
        EXPECT_GT(double(n), double(target) / 1.5) << target;
        EXPECT_LT(double(n), double(target) * 1.5) << target;
    }
}

}  // namespace
}  // namespace abrad::tools
