// Tests of the light-mesh simplification (export/src/simplify.cpp): fields with known answers
// on finely meshed planes, against an evaluation of the simplified mesh written here.

#include "abrad/export/simplify.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <glm/geometric.hpp>
#include <limits>
#include <mutex>
#include <optional>
#include <set>
#include <tuple>
#include <utility>
#include <vector>

#include "abrad/export/writers.h"

namespace abrad::exporter {
namespace {

using Field = std::function<double(double x, double y)>;

// The unit square in z = 0 as an n × n grid of cells, two triangles each (front +z), of
// surface `surface`, with irradiance `h` at every vertex (all three channels) and radiosity
// half of it.
visdb::BakeMesh grid(int n, const Field& h, std::uint32_t surface = 0) {
    visdb::BakeMesh m;
    const auto at = [n](int i, int j) { return static_cast<std::uint32_t>(j * (n + 1) + i); };
    for (int j = 0; j <= n; ++j)
        for (int i = 0; i <= n; ++i) {
            const double x = double(i) / n;
            const double y = double(j) / n;
            m.positions.emplace_back(x, y, 0.0);
            m.normals.emplace_back(0.0f, 0.0f, 1.0f);
            const auto v = static_cast<float>(h(x, y));
            m.irradiance.emplace_back(v);
            m.radiosity.emplace_back(0.5f * v);
        }
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            m.triangles.emplace_back(at(i, j), at(i + 1, j), at(i + 1, j + 1));
            m.triangles.emplace_back(at(i, j), at(i + 1, j + 1), at(i, j + 1));
            m.triangle_surface.insert(m.triangle_surface.end(), 2, surface);
        }
    return m;
}

// The Gouraud-interpolated irradiance (red) of `m` at (x, y) in z = 0, or nothing outside.
std::optional<double> interpolate(const visdb::BakeMesh& m, double x, double y) {
    for (const glm::u32vec3& t : m.triangles) {
        const glm::dvec3 a = m.positions[t.x], b = m.positions[t.y], c = m.positions[t.z];
        const double d = (b.x - a.x) * (c.y - a.y) - (c.x - a.x) * (b.y - a.y);
        const double u = ((b.x - x) * (c.y - y) - (c.x - x) * (b.y - y)) / d;
        const double v = ((c.x - x) * (a.y - y) - (a.x - x) * (c.y - y)) / d;
        const double w = 1.0 - u - v;
        if (std::min({u, v, w}) < -1e-9) continue;
        return u * m.irradiance[t.x].x + v * m.irradiance[t.y].x + w * m.irradiance[t.z].x;
    }
    return std::nullopt;
}

double area(const visdb::BakeMesh& m) {
    double sum = 0.0;
    for (const glm::u32vec3& t : m.triangles) {
        const glm::dvec3 a = m.positions[t.x], b = m.positions[t.y], c = m.positions[t.z];
        const double z = (b.x - a.x) * (c.y - a.y) - (c.x - a.x) * (b.y - a.y);
        EXPECT_GT(z, 0.0) << "a triangle turned its back";
        sum += 0.5 * z;
    }
    return sum;
}

TEST(Simplify, LinearFieldCollapsesToFewTrianglesExactly) {
    const Field linear = [](double x, double y) { return 10.0 + 4.0 * x - 3.0 * y; };
    const visdb::BakeMesh in = grid(16, linear);
    SimplifyStats stats;
    const visdb::BakeMesh out = simplify(in, {.error = 0.001}, &stats);
    EXPECT_EQ(stats.triangles_before, 512u);
    EXPECT_EQ(stats.triangles_after, out.triangles.size());
    EXPECT_LE(out.triangles.size(), 4u);  // the square's 2, and room for a stuck collapse
    EXPECT_NEAR(area(out), 1.0, 1e-12);   // the outline is kept
    // The field is linear, so the simplified mesh reproduces it everywhere
    for (int j = 0; j <= 40; ++j)
        for (int i = 0; i <= 40; ++i) {
            const double x = i / 40.0, y = j / 40.0;
            const std::optional<double> h = interpolate(out, x, y);
            ASSERT_TRUE(h) << "(" << x << ", " << y << ") is no longer covered";
            EXPECT_NEAR(*h, linear(x, y), 1e-5 * linear(x, y));
        }
    // Kept vertices carry the bake's exact values
    for (std::size_t v = 0; v < out.positions.size(); ++v) {
        const glm::dvec3 p = out.positions[v];
        EXPECT_FLOAT_EQ(out.irradiance[v].y, static_cast<float>(linear(p.x, p.y)));
        EXPECT_FLOAT_EQ(out.radiosity[v].z, 0.5f * static_cast<float>(linear(p.x, p.y)));
        EXPECT_EQ(out.normals[v], glm::vec3(0.0f, 0.0f, 1.0f));
    }
}

// An L-shaped surface (the unit square without its top right quarter) keeps its outline,
// the reflex corner included, where a linear field would let every vertex go.
TEST(Simplify, KeepsTheOutline) {
    const Field linear = [](double x, double y) { return 2.0 + x + y; };
    visdb::BakeMesh in = grid(8, linear);
    visdb::BakeMesh l = in;
    l.triangles.clear();
    l.triangle_surface.clear();
    for (std::size_t t = 0; t < in.triangles.size(); ++t) {
        const glm::u32vec3 tri = in.triangles[t];
        const glm::dvec3 c =
            (in.positions[tri.x] + in.positions[tri.y] + in.positions[tri.z]) / 3.0;
        if (c.x > 0.5 && c.y > 0.5) continue;
        l.triangles.push_back(tri);
        l.triangle_surface.push_back(0);
    }
    const visdb::BakeMesh out = simplify(l, {.error = 0.01});
    EXPECT_LE(out.triangles.size(), 8u);
    EXPECT_NEAR(area(out), 0.75, 1e-12);
    const auto has_vertex = [&](double x, double y) {
        return std::any_of(out.positions.begin(), out.positions.end(),
                           [&](const glm::dvec3& p) { return p.x == x && p.y == y; });
    };
    for (const auto& [x, y] :
         {std::pair{0.0, 0.0}, {1.0, 0.0}, {1.0, 0.5}, {0.5, 0.5}, {0.5, 1.0}, {0.0, 1.0}})
        EXPECT_TRUE(has_vertex(x, y)) << "corner (" << x << ", " << y << ") lost";
}

// A wall as an IFC model gives it: 10 × 3 m, turned 30° about z, several metres from the
// mesh's centre (a second wall opposite), meshed 40 × 12 cells, its coordinates rounded to
// float. Under a field linear along the wall, every vertex but the four corners goes: the
// quadric of a point on its planes, which round-off makes -1e-13 as often as +1e-13, once
// refused half the in-plane collapses, and outline vertices that float rounding put 1e-6 m
// off their line (a sine up to 1e-5 on 0.25 m cells) were not taken for straight.
TEST(Simplify, RealCoordinatesLeaveOnlyTheCorners) {
    visdb::BakeMesh in;
    constexpr int kU = 40, kV = 12;
    const double angle = std::acos(-1.0) / 6.0;
    const glm::dvec3 u(std::cos(angle), std::sin(angle), 0.0), v(0.0, 0.0, 1.0);
    for (int wall = 0; wall < 2; ++wall) {
        const glm::dvec3 corner =
            wall == 0 ? glm::dvec3(7.3, 4.1, 0.2)
                      : glm::dvec3(7.3, 4.1, 0.2) + 6.0 * glm::dvec3(-u.y, u.x, 0.0);
        const glm::vec3 normal(glm::cross(wall == 0 ? u : -u, v));
        const auto base = static_cast<std::uint32_t>(in.positions.size());
        const auto at = [&](int i, int j) {
            return base + static_cast<std::uint32_t>(j * (kU + 1) + i);
        };
        for (int j = 0; j <= kV; ++j)
            for (int i = 0; i <= kU; ++i) {
                const glm::dvec3 p = corner + (10.0 * i / kU) * u + (3.0 * j / kV) * v;
                in.positions.emplace_back(glm::vec3(p));  // float, as Assimp reads an IFC
                in.normals.push_back(normal);
                const auto h = static_cast<float>(50.0 + 4.0 * i / kU);
                in.irradiance.emplace_back(h);
                in.radiosity.emplace_back(0.7f * h);
            }
        for (int j = 0; j < kV; ++j)
            for (int i = 0; i < kU; ++i) {
                const glm::u32vec3 a(at(i, j), at(i + 1, j), at(i + 1, j + 1));
                const glm::u32vec3 b(at(i, j), at(i + 1, j + 1), at(i, j + 1));
                in.triangles.push_back(wall == 0 ? a : glm::u32vec3(a.x, a.z, a.y));
                in.triangles.push_back(wall == 0 ? b : glm::u32vec3(b.x, b.z, b.y));
                in.triangle_surface.insert(in.triangle_surface.end(), 2, std::uint32_t(wall));
            }
    }
    SimplifyStats stats;
    const visdb::BakeMesh out = simplify(in, {.error = 0.001}, &stats);
    EXPECT_EQ(stats.triangles_before, 2u * 2u * kU * kV);
    EXPECT_EQ(out.triangles.size(), 4u) << to_string(stats);
    EXPECT_EQ(out.positions.size(), 8u);
    // The corners stay exactly where the bake had them
    for (const glm::dvec3& p : out.positions)
        EXPECT_TRUE(std::find(in.positions.begin(), in.positions.end(), p) != in.positions.end());
    const auto total_area = [](const visdb::BakeMesh& m) {
        double sum = 0.0;
        for (const glm::u32vec3& t : m.triangles)
            sum += visdb::triangle_area(m.positions[t.x], m.positions[t.y], m.positions[t.z]);
        return sum;
    };
    EXPECT_NEAR(total_area(out), total_area(in), 1e-9 * total_area(in));
}

// A shadow boundary: full light left of x = 0.5, a tenth of it right of x = 0.5 + 1/n (a
// penumbra one cell wide). Its edges must stay within the bound at every vertex of the bake.
TEST(Simplify, StepFieldKeepsItsEdgeWithinTheBound) {
    constexpr int kCells = 20;
    const Field step = [](double x, double) {
        const double t = std::clamp((x - 0.5) * kCells, 0.0, 1.0);
        return 100.0 * (1.0 - t) + 10.0 * t;
    };
    const visdb::BakeMesh in = grid(kCells, step);
    constexpr double kError = 0.02;
    const visdb::BakeMesh out = simplify(in, {.error = kError, .floor = 0.0});
    EXPECT_LT(out.triangles.size(), in.triangles.size() / 8);
    EXPECT_NEAR(area(out), 1.0, 1e-12);
    for (const glm::dvec3& p : in.positions) {
        const std::optional<double> h = interpolate(out, p.x, p.y);
        ASSERT_TRUE(h);
        const double baked = static_cast<float>(step(p.x, p.y));
        EXPECT_LE(std::abs(*h - baked), kError * baked * (1.0 + 1e-6))
            << "at (" << p.x << ", " << p.y << ")";
    }
    // The two kinks of the penumbra are still lines of vertices
    std::set<double> kink_vertices;
    for (const glm::dvec3& p : out.positions)
        if (p.x == 0.5 || p.x == 0.5 + 1.0 / kCells) kink_vertices.insert(p.x);
    EXPECT_EQ(kink_vertices.size(), 2u);
}

// A rough field leaves little to remove: pseudo-random values in [1, 2) keep nearly every
// vertex at a 1 % bound (a few fit their neighbours by chance), and every vertex of the bake,
// kept or not, stays within the bound. (The bound is checked at the bake's vertices only: a
// checkerboard, constant along the grid's diagonals, would lose vertices along them.)
TEST(Simplify, RoughFieldKeepsItsVerticesWithinTheBound) {
    const Field noise = [](double x, double y) {
        const double s = std::sin(x * 8 * 12.9898 + y * 8 * 78.233) * 43758.5453;
        return 1.0 + (s - std::floor(s));
    };
    const visdb::BakeMesh in = grid(8, noise);
    constexpr double kError = 0.01;
    const visdb::BakeMesh out = simplify(in, {.error = kError});
    EXPECT_GE(out.positions.size(), in.positions.size() * 9 / 10);
    for (std::size_t v = 0; v < in.positions.size(); ++v) {
        const std::optional<double> h = interpolate(out, in.positions[v].x, in.positions[v].y);
        ASSERT_TRUE(h);
        const double baked = in.irradiance[v].x;
        EXPECT_LE(std::abs(*h - baked), kError * baked * (1.0 + 1e-6));
    }
}

// Two surfaces side by side with vertices of their own: their shared border stays, and each
// face keeps its surface.
// Two n × n unit squares side by side, [0, 1]² of surface 0 and [1, 2] × [0, 1] of surface 1,
// each with vertices of its own along x = 1, with the field h at every vertex's position.
visdb::BakeMesh side_by_side(int n, const Field& h) {
    visdb::BakeMesh a = grid(n, h, 0);
    const visdb::BakeMesh b = grid(
        n, [&](double x, double y) { return h(x + 1.0, y); }, 1);
    const auto offset = static_cast<std::uint32_t>(a.positions.size());
    for (std::size_t v = 0; v < b.positions.size(); ++v) {
        a.positions.push_back(b.positions[v] + glm::dvec3(1.0, 0.0, 0.0));
        a.normals.push_back(b.normals[v]);
        a.irradiance.push_back(b.irradiance[v]);
        a.radiosity.push_back(b.radiosity[v]);
    }
    for (std::size_t t = 0; t < b.triangles.size(); ++t) {
        a.triangles.push_back(b.triangles[t] + glm::u32vec3(offset));
        a.triangle_surface.push_back(1);
    }
    return a;
}

TEST(Simplify, KeepsSurfacesApart) {
    const visdb::BakeMesh a = side_by_side(6, [](double, double) { return 5.0; });
    const visdb::BakeMesh out = simplify(a, {.error = 0.01});
    EXPECT_LE(out.triangles.size(), 8u);
    std::set<std::uint32_t> surfaces(out.triangle_surface.begin(), out.triangle_surface.end());
    EXPECT_EQ(surfaces, (std::set<std::uint32_t>{0, 1}));
    for (std::size_t t = 0; t < out.triangles.size(); ++t) {
        const glm::u32vec3 tri = out.triangles[t];
        const double cx =
            (out.positions[tri.x].x + out.positions[tri.y].x + out.positions[tri.z].x) / 3.0;
        EXPECT_EQ(out.triangle_surface[t], cx < 1.0 ? 0u : 1u);
    }
}

// The triangle of `m` that holds (x, y) in z = 0 and the point's barycentric coordinates
// in it, or nothing outside.
std::optional<std::pair<std::size_t, std::array<double, 3>>> locate(const visdb::BakeMesh& m,
                                                                    double x, double y) {
    for (std::size_t i = 0; i < m.triangles.size(); ++i) {
        const glm::u32vec3 t = m.triangles[i];
        const glm::dvec3 a = m.positions[t.x], b = m.positions[t.y], c = m.positions[t.z];
        const double d = (b.x - a.x) * (c.y - a.y) - (c.x - a.x) * (b.y - a.y);
        const double u = ((b.x - x) * (c.y - y) - (c.x - x) * (b.y - y)) / d;
        const double v = ((c.x - x) * (a.y - y) - (a.x - x) * (c.y - y)) / d;
        const double w = 1.0 - u - v;
        if (std::min({u, v, w}) >= -1e-9) return std::make_pair(i, std::array<double, 3>{u, v, w});
    }
    return std::nullopt;
}

// Each vertex's share of the grid's area: a third of its triangles' area.
std::vector<double> vertex_areas(const visdb::BakeMesh& m) {
    std::vector<double> w(m.positions.size(), 0.0);
    for (const glm::u32vec3& t : m.triangles) {
        const glm::dvec3 a = m.positions[t.x], b = m.positions[t.y], c = m.positions[t.z];
        const double third = std::abs((b.x - a.x) * (c.y - a.y) - (c.x - a.x) * (b.y - a.y)) / 6;
        for (int k = 0; k < 3; ++k) w[t[k]] += third;
    }
    return w;
}

// With refit, the kept vertices' values are the least-squares fit of the bake's vertices
// (weighted by their area): the gradient of the weighted squared error with respect to
// every kept value is zero, the fit beats the same mesh with the baked values, and the
// radiosity (half the irradiance here) is refitted with it.
TEST(Simplify, RefitIsTheLeastSquaresFitOfTheBakesVertices) {
    const Field bowl = [](double x, double y) {
        return 1.0 + 4.0 * ((x - 0.5) * (x - 0.5) + (y - 0.3) * (y - 0.3));
    };
    const visdb::BakeMesh in = grid(16, bowl);
    SimplifyStats stats;
    const visdb::BakeMesh out = simplify(in, {.error = 0.05, .refit = true}, &stats);
    ASSERT_LT(out.triangles.size(), in.triangles.size() / 4);
    const std::vector<double> w = vertex_areas(in);
    std::vector<double> gradient(out.positions.size(), 0.0);
    std::vector<double> scale(out.positions.size(), 0.0);
    double fitted = 0.0;  // weighted squared error of the fit
    double baked = 0.0;   // ... of the same mesh with the field's values at its vertices
    for (std::size_t s = 0; s < in.positions.size(); ++s) {
        const auto at = locate(out, in.positions[s].x, in.positions[s].y);
        ASSERT_TRUE(at);
        const glm::u32vec3 t = out.triangles[at->first];
        const std::array<double, 3>& b = at->second;
        double h = 0.0;
        double h_baked = 0.0;
        for (int k = 0; k < 3; ++k) {
            h += b[k] * out.irradiance[t[k]].x;
            h_baked += b[k] * bowl(out.positions[t[k]].x, out.positions[t[k]].y);
        }
        const double y = in.irradiance[s].x;
        for (int k = 0; k < 3; ++k) {
            gradient[t[k]] += w[s] * b[k] * (h - y);
            scale[t[k]] += w[s] * b[k] * y;
        }
        fitted += w[s] * (h - y) * (h - y);
        baked += w[s] * (h_baked - y) * (h_baked - y);
    }
    for (std::size_t v = 0; v < out.positions.size(); ++v) {
        EXPECT_LE(std::abs(gradient[v]), 1e-5 * scale[v]) << "vertex " << v;
        EXPECT_NEAR(out.radiosity[v].z, 0.5f * out.irradiance[v].x, 1e-5 * out.irradiance[v].x);
    }
    EXPECT_LT(fitted, 0.5 * baked);
}

// The budget bounds the area-weighted mean change of irradiance at the bake's vertices (the
// last collapse of a first run goes past it at 0.016, so this checks the second run too),
// the statistics report what it spent, and a larger budget removes more.
TEST(Simplify, BudgetBoundsTheAreaWeightedChange) {
    const Field wave = [](double x, double y) { return 2.0 + std::sin(6.0 * x) * y * y + 0.5 * x; };
    const visdb::BakeMesh in = grid(24, wave);
    const std::vector<double> w = vertex_areas(in);
    const auto measured_change = [&](const visdb::BakeMesh& out) {
        double change = 0.0;
        double total = 0.0;
        for (std::size_t s = 0; s < in.positions.size(); ++s) {
            const std::optional<double> h = interpolate(out, in.positions[s].x, in.positions[s].y);
            EXPECT_TRUE(h);
            change += w[s] * std::abs(h.value_or(0.0) - in.irradiance[s].x);
            total += w[s] * in.irradiance[s].x;
        }
        return change / total;
    };
    std::size_t previous = in.triangles.size() + 1;
    for (const double budget : {0.001, 0.004, 0.016}) {
        SimplifyStats stats;
        const visdb::BakeMesh out = simplify(in, {.error = 1.0, .budget = budget}, &stats);
        const double change = measured_change(out);
        EXPECT_NEAR(change, stats.mean_change, 1e-9) << "budget " << budget;
        EXPECT_LE(change, budget * (1.0 + 1e-9)) << "budget " << budget;
        EXPECT_GT(change, budget * 0.5) << "budget " << budget;
        EXPECT_LT(out.triangles.size(), previous) << "budget " << budget;
        previous = out.triangles.size();
    }
}

// Progress while the decimation runs: with a budget, the thousandths of it spent, rising,
// then done = total; without, the vertices removed out of the mesh's, ending at the count
// that went.
TEST(Simplify, ProgressReportsTheBudgetSpentOrTheVerticesRemoved) {
    const Field wave = [](double x, double y) { return 2.0 + std::sin(6.0 * x) * y * y + 0.5 * x; };
    const visdb::BakeMesh in = grid(24, wave);
    for (const double budget : {0.016, 0.0}) {
        std::vector<std::pair<std::size_t, std::size_t>> calls;
        const SimplifyOptions options{
            .error = budget > 0.0 ? 1.0 : 0.05, .budget = budget, .exact_budget = false};
        SimplifyStats stats;
        simplify(in, options, &stats, nullptr,
                 [&](std::size_t done, std::size_t total) { calls.emplace_back(done, total); });
        ASSERT_GE(calls.size(), 3u) << "budget " << budget;  // start, some steps, end
        const std::size_t total = budget > 0.0 ? 1000 : in.positions.size();
        for (std::size_t k = 0; k < calls.size(); ++k) {
            EXPECT_EQ(calls[k].second, total);
            EXPECT_LE(calls[k].first, total);
            if (k > 0) {
                EXPECT_GE(calls[k].first, calls[k - 1].first) << "budget " << budget;
            }
            if (k + 1 < calls.size()) {
                EXPECT_LT(calls[k].first, total) << "ends only at the end";
            }
        }
        EXPECT_EQ(calls.back().first, total);
        if (budget > 0.0) {
            // The budget is spent (within a thousandth past it); the steps before the end
            // saw some of it spent (the cheapest collapses go first: here 156 thousandths
            // 64 collapses before the end)
            EXPECT_GT(stats.mean_change, 0.9 * budget);
            EXPECT_LE(stats.mean_change, 1.001 * budget);
            EXPECT_GT(calls[calls.size() - 2].first, 0u);
        } else {
            // The last step reported is within one reporting interval of the vertices removed
            const std::size_t removed = stats.vertices_before - stats.vertices_after;
            EXPECT_LE(calls[calls.size() - 2].first, removed);
            EXPECT_GT(calls[calls.size() - 2].first + 64, removed);
            EXPECT_GT(removed, 64u);
        }
    }
    // No callback: the same mesh
    const visdb::BakeMesh a = simplify(in, {.error = 1.0, .budget = 0.004});
    const visdb::BakeMesh b = simplify(in, {.error = 1.0, .budget = 0.004}, nullptr, nullptr,
                                       [](std::size_t, std::size_t) {});
    EXPECT_EQ(a.triangles, b.triangles);
}

// `kept` names each vertex's place in the input; with keep_shared, the vertices two surfaces
// both have (their shared edge, where the surfaces meet) all stay, on both sides, though
// their field is linear and the edge straight; without it the edge keeps its ends only.
TEST(Simplify, KeptNamesTheInputVertexAndSharedVerticesStay) {
    const visdb::BakeMesh a = side_by_side(6, [](double x, double y) { return 1.0 + x + 2.0 * y; });
    const auto on_shared_edge = [](const visdb::BakeMesh& m) {
        std::size_t n = 0;
        for (const glm::dvec3& p : m.positions) n += p.x == 1.0;
        return n;
    };
    for (const bool keep : {false, true}) {
        std::vector<std::uint32_t> kept;
        const visdb::BakeMesh out =
            simplify(a, {.error = 0.01, .keep_shared = keep}, nullptr, &kept);
        ASSERT_EQ(kept.size(), out.positions.size());
        for (std::size_t v = 0; v < kept.size(); ++v) {
            ASSERT_LT(kept[v], a.positions.size());
            EXPECT_EQ(out.positions[v], a.positions[kept[v]]);
            EXPECT_EQ(out.irradiance[v], a.irradiance[kept[v]]);
            EXPECT_EQ(out.radiosity[v], a.radiosity[kept[v]]);
        }
        // 7 vertices on x = 1 in each square; without keep_shared only the two corners each
        EXPECT_EQ(on_shared_edge(out), keep ? 14u : 4u) << "keep_shared " << keep;
        EXPECT_LT(out.triangles.size(), a.triangles.size() / 4) << "keep_shared " << keep;
    }
}

// Without exact_budget the decimation keeps the collapse that passed the budget when that
// passes it by at most a thousandth, and otherwise stops before it as the exact one does: at
// most one collapse (two triangles) more than the exact stop, never fewer, and within a
// thousandth of the budget.
TEST(Simplify, InexactBudgetKeepsTheOneCollapsePastIt) {
    const Field wave = [](double x, double y) { return 2.0 + std::sin(6.0 * x) * y * y + 0.5 * x; };
    const visdb::BakeMesh in = grid(24, wave);
    for (const double budget : {0.001, 0.004}) {
        SimplifyStats exact, fast;
        const visdb::BakeMesh a = simplify(in, {.error = 1.0, .budget = budget}, &exact);
        const visdb::BakeMesh b =
            simplify(in, {.error = 1.0, .budget = budget, .exact_budget = false}, &fast);
        EXPECT_LE(exact.mean_change, budget * (1.0 + 1e-9));
        EXPECT_GE(fast.mean_change, exact.mean_change);
        EXPECT_LE(fast.mean_change, budget * 1.001);
        EXPECT_LE(b.triangles.size(), a.triangles.size());
        EXPECT_GE(b.triangles.size() + 2, a.triangles.size());
    }
}

// A row of `count` unit squares (square k at x in [2k, 2k + 1], surface `count` − 1 − k, so the
// bake's surface order is not the row's), n × n cells each, with the wave field scaled by
// 10^(k mod 3 − 1): dim, middling and bright surfaces.
visdb::BakeMesh row_of_squares(int count, int n) {
    visdb::BakeMesh m;
    for (int k = 0; k < count; ++k) {
        const double scale = std::pow(10.0, k % 3 - 1);
        const visdb::BakeMesh g = grid(
            n,
            [&](double x, double y) {
                return scale * (2.0 + std::sin(6.0 * x + k) * y * y + 0.5 * x);
            },
            static_cast<std::uint32_t>(count - 1 - k));
        const auto offset = static_cast<std::uint32_t>(m.positions.size());
        for (std::size_t v = 0; v < g.positions.size(); ++v) {
            m.positions.push_back(g.positions[v] + glm::dvec3(2.0 * k, 0.0, 0.0));
            m.normals.push_back(g.normals[v]);
            m.irradiance.push_back(g.irradiance[v]);
            m.radiosity.push_back(g.radiosity[v]);
        }
        for (std::size_t t = 0; t < g.triangles.size(); ++t) {
            m.triangles.push_back(g.triangles[t] + glm::u32vec3(offset));
            m.triangle_surface.push_back(g.triangle_surface[t]);
        }
    }
    return m;
}

// The decimation runs in parts side by side (whole surfaces, at most 16 parts), each within
// the budget's share of its own irradiance: the whole keeps the budget, spends most of it, and
// comes out the same at one thread and at two, its triangles by surface; the progress rises
// to the end from the parts' threads.
TEST(Simplify, PartsSideBySideKeepTheBudgetAndDoNotDependOnThreads) {
    const visdb::BakeMesh in = row_of_squares(20, 10);  // more surfaces than parts
    const std::vector<double> w = vertex_areas(in);
    const SimplifyOptions options{.error = 1.0, .budget = 0.004};
    SimplifyStats stats;
    std::vector<std::size_t> reported;
    std::mutex reports;
    const visdb::BakeMesh out =
        simplify(in, options, &stats, nullptr, [&](std::size_t done, std::size_t total) {
            const std::lock_guard lock(reports);
            EXPECT_EQ(total, 1000u);
            reported.push_back(done);
        });
    double change = 0.0, total = 0.0;
    for (std::size_t s = 0; s < in.positions.size(); ++s) {
        const std::optional<double> h = interpolate(out, in.positions[s].x, in.positions[s].y);
        ASSERT_TRUE(h) << "vertex " << s << " is outside the simplified mesh";
        change += w[s] * std::abs(*h - in.irradiance[s].x);
        total += w[s] * in.irradiance[s].x;
    }
    EXPECT_NEAR(change / total, stats.mean_change, 1e-9);
    EXPECT_LE(change / total, options.budget * (1.0 + 1e-9));
    EXPECT_GT(change / total, options.budget * 0.5);
    EXPECT_LT(out.triangles.size(), in.triangles.size() / 4);
    EXPECT_TRUE(std::is_sorted(out.triangle_surface.begin(), out.triangle_surface.end()));
    ASSERT_GE(reported.size(), 3u);
    EXPECT_EQ(reported.front(), 0u);
    EXPECT_EQ(reported.back(), 1000u);
    EXPECT_TRUE(std::is_sorted(reported.begin(), reported.end()));
    // One thread: the same mesh
    visdb::BakeMesh alone;
    {
        const tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
        alone = simplify(in, options);
    }
    EXPECT_EQ(alone.positions, out.positions);
    EXPECT_EQ(alone.triangles, out.triangles);
    EXPECT_EQ(alone.triangle_surface, out.triangle_surface);
    EXPECT_EQ(alone.irradiance, out.irradiance);
    // Without exact_budget: the parts' last collapses pass the whole by a thousandth at most
    SimplifyStats fast;
    simplify(in, {.error = 1.0, .budget = options.budget, .exact_budget = false}, &fast);
    EXPECT_LE(fast.mean_change, options.budget * 1.001);
    EXPECT_GE(fast.mean_change, stats.mean_change);
}

TEST(Simplify, RefusesBadOptionsAndMeshes) {
    const visdb::BakeMesh in = grid(2, [](double, double) { return 1.0; });
    EXPECT_THROW(simplify(in, {.error = 0.0}), ExportError);
    EXPECT_THROW(simplify(in, {.error = 1.5}), ExportError);
    EXPECT_THROW(simplify(in, {.error = std::numeric_limits<double>::quiet_NaN()}), ExportError);
    EXPECT_THROW(simplify(in, {.error = 0.1, .floor = -1.0}), ExportError);
    EXPECT_THROW(simplify(in, {.error = 0.1, .budget = -0.1}), ExportError);
    EXPECT_THROW(simplify(in, {.error = 0.1, .budget = 2.0}), ExportError);
    visdb::BakeMesh broken = in;
    broken.triangles[0].z = 99;
    EXPECT_THROW(simplify(broken, {}), ExportError);
    broken = in;
    broken.irradiance.clear();
    EXPECT_THROW(simplify(broken, {}), ExportError);
}

}  // namespace
}  // namespace abrad::exporter
