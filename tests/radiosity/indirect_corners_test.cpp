// Indirect light where surfaces meet (issue 18, item 4): the default bake's per-vertex indirect
// irradiance 5 cm and 25 cm from the edges and corners of the CIE 171 case 5.8 room (a closed
// 4 m cube of uniform reflectance, a 1×1 m source in the ceiling's centre) against a converged
// reference written out independently of abrad's solver: collocation at the centres of cells
// graded toward the edges (1 cm at the edges), with the exact differential-area-to-rectangle
// form factor for every cell pair, solved to 1e-12 and gathered at the point with the same
// closed form. The bake misses the 3 % there: a known defect, measured (with the part
// of it no interpolation of 0.5 m element means can remove) while it lasts.

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "abrad/radiosity/bake.h"
#include "abrad/radiosity/direct.h"
#include "abrad/radiosity/indirect.h"
#include "analytic.h"
#include "cie171.h"
#include "mesh_checks.h"

namespace abrad::radiosity {
namespace {

using abrad::testing::area_mean;
using abrad::testing::gouraud_at;
using abrad::testing::irradiance_at;
using glm::dvec3;
using testing::AxisRect;
using testing::ff_axis_rect;

constexpr double kHalf = 2.0;        // the room is [−2, 2]² × [0, 4]
constexpr double kExitance = 100.0;  // W/m² of the 1 m² source: Φ = 100 W
constexpr double kBound = 0.03;      // the bound at 5 cm and 25 cm from an edge
const AxisRect kSource{2, -1.0, {-0.5, -0.5, 4.0}, {0.5, 0.5, 4.0}};

// ---- The reference ----

// Breakpoints of [−2, 2] graded toward both ends: cells of `first` at the ends, growing by
// `ratio` up to `widest`.
std::vector<double> graded(double first, double ratio, double widest) {
    std::vector<double> half{0.0};  // distances from the end
    double h = first;
    while (half.back() + h < kHalf - 1e-9) {
        half.push_back(half.back() + h);
        h = std::min(h * ratio, widest);
    }
    half.push_back(kHalf);
    // The last step may be a sliver: merge it into the one before
    if (half.size() > 2 && half[half.size() - 1] - half[half.size() - 2] < 0.5 * first)
        half.erase(half.end() - 2);
    std::vector<double> b;
    b.reserve(2 * half.size() - 1);
    for (const double d : half) b.push_back(-kHalf + d);
    for (auto it = half.rbegin() + 1; it != half.rend(); ++it) b.push_back(kHalf - *it);
    return b;
}

struct Cell {
    AxisRect rect;
    dvec3 centre, normal;
};

// The six faces of the room cut at `breaks` (z: the same shifted up by 2 m), fronts inside.
std::vector<Cell> room_cells(const std::vector<double>& breaks) {
    std::vector<Cell> cells;
    // Face: axis, the plane's coordinate, the direction its front faces
    const std::array<std::pair<int, double>, 6> faces = {
        {{2, 0.0}, {2, 4.0}, {0, -kHalf}, {0, kHalf}, {1, -kHalf}, {1, kHalf}}};
    for (const auto& [axis, plane] : faces) {
        const int i = (axis + 1) % 3, j = (axis + 2) % 3;
        const double facing = plane == (axis == 2 ? 0.0 : -kHalf) ? 1.0 : -1.0;
        const double shift_i = i == 2 ? kHalf : 0.0, shift_j = j == 2 ? kHalf : 0.0;
        for (std::size_t b = 0; b + 1 < breaks.size(); ++b)
            for (std::size_t a = 0; a + 1 < breaks.size(); ++a) {
                dvec3 lo(plane), hi(plane);
                lo[i] = breaks[a] + shift_i;
                hi[i] = breaks[a + 1] + shift_i;
                lo[j] = breaks[b] + shift_j;
                hi[j] = breaks[b + 1] + shift_j;
                dvec3 n(0.0);
                n[axis] = facing;
                cells.push_back({{axis, facing, lo, hi}, 0.5 * (lo + hi), n});
            }
    }
    return cells;
}

// The room's symmetry (the D4 of the vertical axis): a cell's image in the wedge
// 0 ≤ x ≤ y, as a key.
std::array<long long, 6> canonical(const Cell& c) {
    dvec3 x = c.centre, n = c.normal;
    if (x.x < 0) x.x = -x.x, n.x = -n.x;
    if (x.y < 0) x.y = -x.y, n.y = -n.y;
    if (x.x > x.y) std::swap(x.x, x.y), std::swap(n.x, n.y);
    auto q = [](double v) { return std::llround(v * 1e7); };
    return {q(x.x), q(x.y), q(x.z), q(n.x), q(n.y), q(n.z)};
}

// Reflected radiosity of the room's cells: B_i = ρ (D_i + Σ_j F_ij B_j), D the source's exact
// irradiance at the cell's centre, F_ij the exact form factor from that centre to cell j.
class RoomReference {
  public:
    RoomReference(double rho, const std::vector<double>& breaks)
        : m_cells(room_cells(breaks)), m_b(m_cells.size(), 0.0) {
        // One row per orbit of the symmetry
        std::map<std::array<long long, 6>, std::size_t> orbit_of;
        std::vector<std::size_t> orbit(m_cells.size()), first;
        for (std::size_t k = 0; k < m_cells.size(); ++k) {
            const auto [it, inserted] = orbit_of.try_emplace(canonical(m_cells[k]), first.size());
            if (inserted) first.push_back(k);
            orbit[k] = it->second;
        }
        const std::size_t n = m_cells.size(), no = first.size();
        std::vector<float> f(no * n);  // float: 4 bytes a pair
        std::vector<double> direct(no);
        for (std::size_t o = 0; o < no; ++o) {
            const Cell& c = m_cells[first[o]];
            direct[o] = kExitance * ff_axis_rect(c.centre, c.normal, kSource);
            for (std::size_t k = 0; k < n; ++k)
                f[o * n + k] =
                    static_cast<float>(ff_axis_rect(c.centre, c.normal, m_cells[k].rect));
        }
        // Gauss-Seidel over the orbits to 1e-12 of the largest radiosity
        std::vector<double> b(no, 0.0);
        for (int sweep = 0; sweep < 10000; ++sweep) {
            double change = 0.0, largest = 0.0;
            for (std::size_t o = 0; o < no; ++o) {
                double gathered = 0.0;
                for (std::size_t k = 0; k < n; ++k) gathered += f[o * n + k] * b[orbit[k]];
                const double next = rho * (direct[o] + gathered);
                change = std::max(change, std::abs(next - b[o]));
                largest = std::max(largest, next);
                b[o] = next;
            }
            if (change <= 1e-12 * largest) break;
        }
        for (std::size_t k = 0; k < n; ++k) m_b[k] = b[orbit[k]];
        m_cells_count = n;
    }

    /// Indirect irradiance at x (unit axis normal n): the cells' radiosity gathered exactly.
    double indirect(const dvec3& x, const dvec3& n) const {
        double sum = 0.0;
        for (std::size_t k = 0; k < m_cells.size(); ++k)
            sum += m_b[k] * ff_axis_rect(x, n, m_cells[k].rect);
        return sum;
    }

    std::size_t cells() const { return m_cells_count; }

    /// Area-weighted mean of the indirect irradiance over the cells `keep` accepts (by centre
    /// and normal): each cell's B/ρ less its direct part.
    template <class Keep>
    double mean_indirect(double rho, Keep keep) const {
        double sum = 0.0, area = 0.0;
        for (std::size_t k = 0; k < m_cells.size(); ++k) {
            const Cell& c = m_cells[k];
            if (!keep(c.centre, c.normal)) continue;
            const dvec3 e = c.rect.hi - c.rect.lo;
            const int axis = c.rect.axis;
            const double a = e[(axis + 1) % 3] * e[(axis + 2) % 3];
            sum += a * (m_b[k] / rho - kExitance * ff_axis_rect(c.centre, c.normal, kSource));
            area += a;
        }
        return sum / area;
    }

  private:
    std::vector<Cell> m_cells;
    std::vector<double> m_b;
    std::size_t m_cells_count = 0;
};

// ---- The bake ----

// Breakpoints of the scene's surfaces: 5 cm and 25 cm from every edge, the source's edges.
const std::vector<double> kMeshBreaks = {-2.0, -1.95, -1.75, -1.0, -0.5, 0.5, 1.0, 1.75, 1.95, 2.0};

// The rectangle lo + [breaks]·u + [breaks]·v (breaks in [−2, 2], cell by cell) facing
// `inside`, without the cells whose centre `skip` accepts.
template <class Skip>
visdb::Surface grid_surface(const std::string& name, std::uint32_t material, const dvec3& centre,
                            const dvec3& u, const dvec3& v, const dvec3& inside, Skip skip,
                            const std::vector<double>& breaks = kMeshBreaks) {
    visdb::Surface s;
    s.name = name;
    s.material = material;
    const bool flip = glm::dot(glm::cross(u, v), inside - centre) < 0.0;
    const std::size_t m = breaks.size();
    for (std::size_t j = 0; j < m; ++j)
        for (std::size_t i = 0; i < m; ++i)
            s.mesh.positions.push_back(centre + breaks[i] * u + breaks[j] * v);
    auto id = [m](std::size_t i, std::size_t j) { return static_cast<std::uint32_t>(j * m + i); };
    for (std::size_t j = 0; j + 1 < m; ++j)
        for (std::size_t i = 0; i + 1 < m; ++i) {
            if (skip(0.5 * (breaks[i] + breaks[i + 1]), 0.5 * (breaks[j] + breaks[j + 1])))
                continue;
            const std::uint32_t a = id(i, j), b = id(i + 1, j), c = id(i + 1, j + 1),
                                d = id(i, j + 1);
            if (flip) {
                s.mesh.triangles.push_back({a, c, b});
                s.mesh.triangles.push_back({a, d, c});
            } else {
                s.mesh.triangles.push_back({a, b, c});
                s.mesh.triangles.push_back({a, c, d});
            }
        }
    return s;
}

// Case 5.8's room (cie171_test.cpp's cube_room) with vertices at `breaks` on every face (by
// default 5 cm and 25 cm from every edge).
visdb::Scene room_scene(double rho, const std::vector<double>& breaks = kMeshBreaks) {
    visdb::Scene s;
    const auto surface = cie171::add_material(s, "surface", rho);
    const auto light = cie171::add_material(s, "source", rho, kExitance);
    const dvec3 mid(0, 0, 2);
    auto none = [](double, double) { return false; };
    const dvec3 x(1, 0, 0), y(0, 1, 0), z(0, 0, 1);
    s.surfaces.push_back(grid_surface("floor", surface, {0, 0, 0}, x, y, mid, none, breaks));
    s.surfaces.push_back(grid_surface(
        "ceiling", surface, {0, 0, 4}, x, y, mid,
        [](double a, double b) { return std::abs(a) < 0.5 && std::abs(b) < 0.5; }, breaks));
    s.surfaces.push_back(grid_surface("wall -y", surface, {0, -2, 2}, x, z, mid, none, breaks));
    s.surfaces.push_back(grid_surface("wall +y", surface, {0, 2, 2}, x, z, mid, none, breaks));
    s.surfaces.push_back(grid_surface("wall -x", surface, {-2, 0, 2}, y, z, mid, none, breaks));
    s.surfaces.push_back(grid_surface("wall +x", surface, {2, 0, 2}, y, z, mid, none, breaks));
    s.surfaces.push_back(cie171::facing("source", light, {-0.5, -0.5, 4}, x, y, 1, mid));
    return s;
}

// Distance of x from the nearest edge of the room face it lies on (normal n).
double edge_distance(const dvec3& x, const dvec3& n) {
    double d = std::numeric_limits<double>::max();
    for (int k = 0; k < 3; ++k) {
        if (n[k] != 0.0) continue;
        const double lo = k == 2 ? 0.0 : -kHalf, hi = k == 2 ? 4.0 : kHalf;
        d = std::min({d, x[k] - lo, hi - x[k]});
    }
    return d;
}

struct Worst {
    double error = 0.0;  // relative, signed
    dvec3 at{0.0};
    int count = 0;
    void add(double e, const dvec3& x) {
        ++count;
        if (std::abs(e) > std::abs(error)) error = e, at = x;
    }
};

// The graded reference's breakpoints: 1 cm at the edges, growing by 1.4 up to 20 cm.
const std::vector<double> kReferenceBreaks = graded(0.01, 1.4, 0.2);

TEST(IndirectCorners, ReferenceIsConverged) {
    // The reference at points near edges moves by less than 0.3 % when its cells halve
    const std::vector<double> fine = graded(0.005, 1.4, 0.1);
    // (ρ = 0.7, where the interreflections carry the most: 0.05 moves by less)
    for (const double rho : {0.7}) {
        const RoomReference coarse(rho, kReferenceBreaks), finer(rho, fine);
        for (const dvec3& x : {dvec3(1.95, 1.95, 0.0), dvec3(-1.95, 1.0, 0.0),
                               dvec3(1.75, 1.75, 0.0), dvec3(1.95, -2.0, 0.05)}) {
            const dvec3 n = x.z == 0.0 ? dvec3(0, 0, 1) : dvec3(0, 1, 0);
            const double a = coarse.indirect(x, n), b = finer.indirect(x, n);
            std::printf("rho %.2f at (%.2f, %.2f, %.2f): %.6f (%zu cells), %.6f (%zu): %+.3f %%\n",
                        rho, x.x, x.y, x.z, a, coarse.cells(), b, finer.cells(),
                        100.0 * (a / b - 1.0));
            EXPECT_NEAR(a, b, 0.003 * b) << "rho " << rho;
        }
    }
}

// The ceiling around the source receives no direct light (the source lies in its plane), only
// what the room reflects. Modelled as 16 large triangles, it used to be exported with those
// triangles' 16 vertices, at the corners and around the source, each the value of its nearest
// element: the refinement looked at the direct light alone (mean −1.78 %, and 0.75 m or more
// from the walls RMS 4.8 %, worst 10 %). Now it refines the whole field, and the exported
// ceiling carries what the elements hold (73 vertices; −0.56 %, RMS 2.5 %, worst 5.8 %):
// its mean within 1 % of the reference's (the Gouraud field integrated over the triangles),
// RMS under 3 % and every point within 6 %.
TEST(IndirectCorners, ACeilingLitOnlyByReflectionIsExportedWithItsLight) {
    const double rho = 0.5;
    const visdb::Scene scene = room_scene(rho, {-2.0, -0.5, 0.5, 2.0});
    const visdb::Bake b = bake(scene, BakeOptions{});
    const visdb::BakeMesh& m = b.mesh;
    // The ceiling's triangles, the source's left out; no direct light: all of it reflected
    const auto ceiling = [&](std::size_t t) {
        const glm::u32vec3 tri = m.triangles[t];
        const dvec3 p[3] = {m.positions[tri.x], m.positions[tri.y], m.positions[tri.z]};
        const dvec3 c = (p[0] + p[1] + p[2]) / 3.0;
        return p[0].z == 4.0 && p[1].z == 4.0 && p[2].z == 4.0 &&
               !(std::abs(c.x) < 0.5 && std::abs(c.y) < 0.5);
    };
    double area = 0.0;
    const double mean = area_mean(
        m, [&](std::uint32_t v) { return irradiance_at(m, v); }, ceiling, &area);
    std::vector<bool> seen(m.positions.size(), false);
    std::size_t vertices = 0;
    for (std::size_t t = 0; t < m.triangles.size(); ++t)
        if (ceiling(t))
            for (int k = 0; k < 3; ++k)
                if (!seen[m.triangles[t][k]]) seen[m.triangles[t][k]] = true, ++vertices;
    ASSERT_NEAR(area, 15.0, 1e-9);
    const RoomReference reference(rho, kReferenceBreaks);
    const double expected = reference.mean_indirect(rho, [](const dvec3& x, const dvec3& n) {
        return n.z < 0.0 && (std::abs(x.x) > 0.5 || std::abs(x.y) > 0.5);
    });
    // And point by point, 0.75 m and more from the walls (nearer, the corners' own defect,
    // KnownDefectExactElementMeansNearEdges): the Gouraud field at every 5 cm against the
    // reference
    double worst = 0.0, squares = 0.0;
    int points = 0;
    for (double py = -1.25; py <= 1.25 + 1e-9; py += 0.05)
        for (double px = -1.25; px <= 1.25 + 1e-9; px += 0.05) {
            if (std::abs(px) < 0.55 && std::abs(py) < 0.55) continue;  // the source and its rim
            const dvec3 x(px, py, 4.0);
            const std::optional<double> value = gouraud_at(m, x, {0, 0, -1});
            ASSERT_TRUE(value) << "no ceiling triangle at " << px << ", " << py;
            const double error = *value / reference.indirect(x, {0, 0, -1}) - 1.0;
            worst = std::max(worst, std::abs(error));
            squares += error * error;
            ++points;
        }
    const double rms = std::sqrt(squares / points);
    std::printf(
        "ceiling: %zu vertices, exported mean %.5f W/m2, reference %.5f: %+.2f %%; "
        "%d points: RMS %.2f %%, worst %.2f %%\n",
        vertices, mean, expected, 100.0 * (mean / expected - 1.0), points, 100.0 * rms,
        100.0 * worst);
    EXPECT_NEAR(mean, expected, 0.01 * expected);
    EXPECT_LT(rms, 0.03);
    EXPECT_LT(worst, 0.06);
}

// The export carries the solution's reflected flux on every face, whatever its mesh: the
// room's faces as 3 × 3 large cells each (no discontinuity mesh). Read at those vertices
// alone, the interpolated field's Gouraud means were 0.4-0.6 % low on the floor and walls and
// 1.8 % on the ceiling (its field peaks between the vertices); scaled to the elements' flux,
// 0.6 % at most. Each face's exported mean indirect irradiance (Gouraud, the vertices'
// irradiance less their exact direct part) within 1 % of the reference's mean over the face.
TEST(IndirectCorners, EveryFaceExportsTheFluxTheRoomReflectsOntoIt) {
    const double rho = 0.5;
    const visdb::Scene scene = room_scene(rho, {-2.0, -0.5, 0.5, 2.0});
    BakeOptions options;
    options.dm = false;
    const visdb::Bake b = bake(scene, options);
    const visdb::BakeMesh& m = b.mesh;
    const DirectField direct(scene);
    const RoomReference reference(rho, kReferenceBreaks);
    const std::array<dvec3, 6> normals = {dvec3(0, 0, 1),  dvec3(0, 0, -1), dvec3(1, 0, 0),
                                          dvec3(-1, 0, 0), dvec3(0, 1, 0),  dvec3(0, -1, 0)};
    for (const dvec3& n : normals) {
        // The face's triangles (the source's left out: it is not a reflecting room face here)
        const auto on_face = [&](std::size_t t) {
            const glm::u32vec3 tri = m.triangles[t];
            const dvec3 p[3] = {m.positions[tri.x], m.positions[tri.y], m.positions[tri.z]};
            const dvec3 c = (p[0] + p[1] + p[2]) / 3.0;
            if (glm::dot(glm::normalize(glm::cross(p[1] - p[0], p[2] - p[0])), n) < 0.99)
                return false;
            return !(c.z == 4.0 && std::abs(c.x) < 0.5 && std::abs(c.y) < 0.5);
        };
        const double exported = area_mean(
            m,
            [&](std::uint32_t v) {
                return irradiance_at(m, v) - direct.irradiance(m.positions[v], n).y;
            },
            on_face);
        const double expected = reference.mean_indirect(rho, [&](const dvec3& x, const dvec3& c) {
            return c == n && !(x.z == 4.0 && std::abs(x.x) < 0.5 && std::abs(x.y) < 0.5);
        });
        std::printf(
            "face n (%+.0f, %+.0f, %+.0f): exported mean indirect %.4f, reference %.4f: "
            "%+.2f %%\n",
            n.x, n.y, n.z, exported, expected, 100.0 * (exported / expected - 1.0));
        EXPECT_NEAR(exported, expected, 0.01 * expected) << "face n " << n.x << n.y << n.z;
    }
}

// The bake's worst errors 5 cm and 25 cm from an edge, per ρ, against the reference; returns
// the points outside `bound` (at 5 cm, and at 25 cm too unless `near_only`). `worst5` gets the
// worst 5 cm error.
int measure_near_edges(std::string& table, const BakeOptions& options = {}, double bound = kBound,
                       bool near_only = false, double* worst5 = nullptr) {
    table = "| rho | 5 cm: worst export | at | 25 cm: worst export | at | probe at 5 cm |\n";
    int misses = 0;
    for (const double rho : {0.05, 0.3, 0.7}) {
        const visdb::Scene scene = room_scene(rho);
        const visdb::Bake b = bake(scene, options);
        const RoomReference reference(rho, kReferenceBreaks);
        const DirectField direct(scene);
        const PointIrradiance probe(scene, &b);
        Worst near, far, gathered;
        for (std::size_t v = 0; v < b.mesh.positions.size(); ++v) {
            const dvec3 x = b.mesh.positions[v], n = glm::round(dvec3(b.mesh.normals[v]));
            if (x.z == 4.0 && std::abs(x.x) <= 0.5 && std::abs(x.y) <= 0.5) continue;  // source
            const double d = edge_distance(x, n);
            const bool at5 = std::abs(d - 0.05) < 1e-9, at25 = std::abs(d - 0.25) < 1e-9;
            if (!at5 && !at25) continue;
            const double expected = reference.indirect(x, n);
            const double indirect = b.mesh.irradiance[v].y - direct.irradiance(x, n).y;
            const double error = indirect / expected - 1.0;
            (at5 ? near : far).add(error, x);
            misses += (at5 || !near_only) && std::abs(error) > bound;
            if (at5) {
                const ProbePoint p{x + 1e-6 * n, n};
                const double g = probe.at({&p, 1})[0].y - direct.irradiance(x, n).y;
                gathered.add(g / expected - 1.0, x);
            }
        }
        char row[256];
        std::snprintf(row, sizeof row,
                      "| %.2f | %+.1f %% (of %d) | (%.2f, %.2f, %.2f) | %+.1f %% (of %d) | "
                      "(%.2f, %.2f, %.2f) | %+.1f %% |\n",
                      rho, 100.0 * near.error, near.count, near.at.x, near.at.y, near.at.z,
                      100.0 * far.error, far.count, far.at.x, far.at.y, far.at.z,
                      100.0 * gathered.error);
        table += row;
        EXPECT_GT(near.count, 100);  // the scene's vertices survive the discontinuity mesh
        EXPECT_GT(far.count, 100);
        if (worst5 && std::abs(near.error) > std::abs(*worst5)) *worst5 = near.error;
    }
    return misses;
}

// Issue 18's bound with --edge-gather: the vertices within 0.15 m of the faces' edges take
// two hemicube gathers (each element's light interpolated over its cell, the direct part the
// bake's exact vertex values; the second seeing the first's values near the edges) instead of
// the nearest element centres' values, and keep them through the flux scale. Every 5 cm point
// within 3 % of the reference at ρ 0.05, 0.3 and 0.7 (measured −1.1 / −1.2 / +1.4 %; without
// the option +50 / +58 / +27 %, with one gather −1.2 / +4.0 / +4.9 %).
TEST(IndirectCorners, EdgeGatherWithin3PercentOfTheReferenceNearEdges) {
    BakeOptions options;
    options.edge_gather = true;
    std::string table;
    double worst = 0.0;
    const int misses = measure_near_edges(table, options, kBound, true, &worst);
    std::printf("%s", table.c_str());
    EXPECT_EQ(misses, 0) << table;
    EXPECT_LT(std::abs(worst), kBound);
}

// Known defect (docs/validation.md, "Indirect light where surfaces meet"): the indirect part
// of the default bake misses 3 % near edges and corners. Three causes, measured there: the
// vertex takes the nearest element centre's value within half a cell of a boundary; 0.5 m
// element means cannot follow the field's bend near a concave edge whatever the interpolation
// (KnownDefectExactElementMeansNearEdges); at ρ = 0.05 the default stop (unshot power under
// 0.5 % of the emitted, about 10 % of the reflected light at that ρ) leaves the corner
// elements short, the ambient term spreading the rest evenly. Skipped with the measured errors
// while the defect lasts; fails once every point is within 3 % (then the mark goes). With
// --edge-gather on the 5 cm points are within 3 %
// (EdgeGatherWithin3PercentOfTheReferenceNearEdges); the option is not the default for its cost.
TEST(IndirectCorners, KnownDefectDefaultBakeWithin3PercentOfTheReferenceNearEdges) {
    std::string table;
    const int misses = measure_near_edges(table);
    std::printf("%s", table.c_str());
    if (misses > 0)
        GTEST_SKIP() << misses << " points miss 3 % (known defect, docs/validation.md)\n" << table;
    ADD_FAILURE() << "every point within 3 %: the defect is fixed, drop the mark";
}

// What the interpolation can reach: one face of the room (floor, ceiling, or wall y = −2)
// whose 8 × 8 elements hold the reference's exact means over their cells (4 × 4 samples),
// interpolated 5 cm and 25 cm from its edges (corners included, and 1 m and 2 m along them)
// against the reference there. Returns the worst relative errors at 5 cm and at 25 cm.
std::pair<double, double> exact_means_near_edges(const RoomReference& reference, int face) {
    const dvec3 n = face == 0 ? dvec3(0, 0, 1) : face == 1 ? dvec3(0, 0, -1) : dvec3(0, 1, 0);
    auto at = [face](double a, double b) {  // a, b in [0, 4] along the face
        return face == 2 ? dvec3(a - 2, -2, b) : dvec3(a - 2, b - 2, face == 0 ? 0.0 : 4.0);
    };
    IndirectSolution sol;
    sol.element_size = 0.5;
    sol.grids.push_back({dvec3(0.0), dvec3(1, 0, 0), dvec3(0, 1, 0)});
    const int q = 4;
    for (int j = 0; j < 8; ++j)
        for (int i = 0; i < 8; ++i) {
            double sum = 0.0;
            for (int b = 0; b < q; ++b)
                for (int a = 0; a < q; ++a)
                    sum += reference.indirect(
                        at(0.5 * (i + (a + 0.5) / q), 0.5 * (j + (b + 0.5) / q)), n);
            IndirectSolution::Element e;
            e.cell = {i, j};
            e.centroid = dvec3(0.5 * i + 0.25, 0.5 * j + 0.25, 0.0);
            e.area = 0.25;
            e.indirect = visdb::Rgb(sum / (q * q));
            sol.cell_element[IndirectSolution::cell_key(0, i, j)] =
                static_cast<std::uint32_t>(sol.elements.size());
            sol.elements.push_back(e);
        }
    sol.index_cells();
    double worst5 = 0.0, worst25 = 0.0;
    for (const double a : {0.05, 0.25, 1.0, 2.0})
        for (const double b : {0.05, 0.25, 1.0, 2.0}) {
            const double d = std::min(a, b);
            if (d > 0.3) continue;
            const double error =
                sol.at(0, dvec3(a, b, 0.0)).y / reference.indirect(at(a, b), n) - 1.0;
            double& worst = d < 0.1 ? worst5 : worst25;
            if (std::abs(error) > std::abs(worst)) worst = error;
        }
    return {worst5, worst25};
}

// Known defect, the part the interpolation can reach: one face's elements holding the
// reference's exact means still miss 3 % at 5 cm from its edges (the field bends within the
// outer half cell, most on the ceiling, whose field falls toward the walls' unlit tops).
// Skipped with the measured errors while the defect lasts; fails once within 3 %.
TEST(IndirectCorners, KnownDefectExactElementMeansNearEdges) {
    const RoomReference reference(0.3, kReferenceBreaks);
    const char* names[] = {"floor", "ceiling", "wall"};
    std::string table = "| rho 0.3, face | 5 cm: worst | 25 cm: worst |\n";
    bool missed = false;
    for (int face = 0; face < 3; ++face) {
        const auto [at5, at25] = exact_means_near_edges(reference, face);
        char row[96];
        std::snprintf(row, sizeof row, "| %s | %+.1f %% | %+.1f %% |\n", names[face], 100.0 * at5,
                      100.0 * at25);
        table += row;
        missed = missed || std::abs(at5) > kBound || std::abs(at25) > kBound;
    }
    std::printf("%s", table.c_str());
    if (missed) GTEST_SKIP() << "exact element means miss 3 % near edges (known defect)\n" << table;
    ADD_FAILURE() << "exact element means within 3 %: the defect is fixed, drop the mark";
}

}  // namespace
}  // namespace abrad::radiosity
