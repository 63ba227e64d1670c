// Stage 4 of the bake: interreflection on the scene's triangles, clustered into elements per
// planar region, solved by progressive refinement (indirect.h states the method and papers;
// docs/algorithms.md#interreflection).

#include <algorithm>
#include <array>
#include <cmath>
#include <glm/common.hpp>
#include <glm/vec2.hpp>
#include <limits>
#include <map>
#include <string>
#include <tuple>
#include <vector>

#include "abrad/check.h"
#include "stages.h"

namespace abrad::radiosity {

IndirectOptions solver_options(const BakeOptions& options) {
    return {.bounces = std::max(options.bounces, 0),
            .converge = options.converge,
            .element_size = options.element_size,
            .shooter_cells = options.shooter_cells,
            .overrelaxation = options.overrelaxation,
            .ambient = options.ambient,
            .method = options.method,
            .resolution = options.resolution,
            .row_resolution = options.element_resolution,
            .subpixels = options.subpixels,
            .row_subpixels = options.element_subpixels,
            .cluster = options.cluster};
}

namespace {

// The solver's input from the bake's geometry (spans into `g`, `regions` and `region_normal`)
IndirectInput solver_input(const BakeGeometry& g, const Regions& regions,
                           const std::vector<glm::dvec3>& region_normal) {
    return {.patches = g.patches,
            .reflectance = g.reflectance,
            .emittance = g.emittance,
            .region = regions.of_triangle,
            .region_normal = region_normal,
            .luminaires = g.luminaires,
            .outlines = regions.outlines.patches.empty() ? nullptr : &regions.outlines};
}

// A region's outline: the edges of its visibility triangles that no other of them shares.
struct Segment {
    glm::dvec3 a, b;
};
std::vector<std::vector<Segment>> outline_edges(const Outlines& outlines,
                                                const std::vector<std::uint32_t>& elements) {
    std::vector<std::vector<Segment>> out(elements.size());
    using Key = std::array<double, 6>;
    std::map<std::uint32_t, std::map<Key, int>> count;  // per region: edge → uses
    for (std::size_t t = 0; t < outlines.patches.size(); ++t) {
        const std::uint32_t r = outlines.region[t];
        if (r >= elements.size() || elements[r] < kGatherMinElements) continue;
        const Patch& p = outlines.patches[t];
        for (int k = 0; k < 3; ++k) {
            glm::dvec3 a = p.p[k], b = p.p[(k + 1) % 3];
            if (std::tie(b.x, b.y, b.z) < std::tie(a.x, a.y, a.z)) std::swap(a, b);
            ++count[r][{a.x, a.y, a.z, b.x, b.y, b.z}];
        }
    }
    for (const auto& [r, edges] : count)
        for (const auto& [k, uses] : edges)
            if (uses == 1) out[r].push_back({{k[0], k[1], k[2]}, {k[3], k[4], k[5]}});
    return out;
}

// Whether x lies within `d` of one of `edges`
bool within(const std::vector<Segment>& edges, const glm::dvec3& x, double d) {
    for (const Segment& s : edges) {
        const glm::dvec3 ab = s.b - s.a;
        const double len2 = glm::dot(ab, ab);
        const double t = len2 > 0.0 ? std::clamp(glm::dot(x - s.a, ab) / len2, 0.0, 1.0) : 0.0;
        if (glm::distance(s.a + t * ab, x) < d) return true;
    }
    return false;
}

}  // namespace

IndirectSolution interreflect(const BakeGeometry& g, const Regions& regions,
                              const BakeOptions& options, visdb::BakeStats* stats,
                              const ProgressFn& progress) {
    const std::vector<glm::dvec3> region_normal = region_normals(regions);
    const IndirectInput input = solver_input(g, regions, region_normal);
    const IndirectOptions io = solver_options(options);
    IndirectSolution s = solve_indirect(input, io, progress);
    if (options.convergence) *options.convergence = s.curve;
    // Every watt emitted is absorbed, escaped or still unshot (an identity of the shots)
    ABRAD_DCHECK(
        std::abs(s.energy.emitted - s.energy.absorbed - s.energy.escaped - s.energy.unshot) <=
            1e-4 * s.energy.emitted,
        "energy balance: emitted " + std::to_string(s.energy.emitted) + " W, absorbed " +
            std::to_string(s.energy.absorbed) + " + escaped " + std::to_string(s.energy.escaped) +
            " + unshot " + std::to_string(s.energy.unshot));
    if (stats) {
        visdb::InterreflectionStats& i = stats->indirect.emplace();
        i.elements = s.elements.size();
        i.pieces = s.pieces;
        i.visibility_triangles = s.visibility_triangles;
        i.shooters = s.shooters;
        i.shots = s.shots;
        i.rows = s.rows_computed;
        i.bounces = static_cast<std::uint64_t>(s.bounces_done);
        i.unshot_fraction = s.curve.empty() ? 0.0 : s.curve.back().unshot_fraction;
        i.ambient = visdb::channel_mean(s.ambient_irradiance);
        i.energy_emitted_w = s.energy.emitted;
        i.energy_absorbed_w = s.energy.absorbed;
        i.energy_escaped_w = s.energy.escaped;
        i.energy_unshot_w = s.energy.unshot;
        i.seconds = s.seconds;
    }
    return s;
}

VertexGather gather_near_boundaries(const BakeGeometry& sources, const Regions& regions,
                                    const BakeOptions& options, const IndirectSolution& solution,
                                    const BakeGeometry& target,
                                    const std::vector<visdb::Rgb>& direct,
                                    const std::vector<std::uint32_t>& vertex_region,
                                    const ProgressFn& progress) {
    VertexGather out;
    const visdb::BakeMesh& mesh = target.mesh;
    const std::vector<glm::dvec3> region_normal = region_normals(regions);
    // Regions of fewer elements (furniture's faces, reveals, frames) keep their elements'
    // values
    std::vector<std::uint32_t> elements(solution.grids.size(), 0);
    for (const IndirectSolution::Element& e : solution.elements) ++elements[e.region];
    const std::vector<std::vector<Segment>> edges = outline_edges(regions.outlines, elements);
    std::vector<ProbePoint> points;
    for (std::size_t v = 0; v < mesh.positions.size(); ++v) {
        const std::uint32_t r = vertex_region[v];
        if (r >= solution.grids.size() || elements[r] < kGatherMinElements ||
            solution.interpolates(r, mesh.positions[v]) ||
            !within(edges[r], mesh.positions[v], kGatherBand))
            continue;
        // The point a hair inside the vertex's triangles and in front of them, so that a
        // neighbouring surface meeting it at an edge lies wholly in front of the hemicube
        const glm::dvec3 x = mesh.positions[v];
        glm::dvec3 inward(0.0);
        double area = 0.0;
        for (std::uint32_t k = target.incident_start[v]; k < target.incident_start[v + 1]; ++k) {
            const std::uint32_t t = target.incident[k];
            const Patch& p = target.patches[t];
            inward += target.area[t] * ((p.p[0] + p.p[1] + p.p[2]) / 3.0 - x);
            area += target.area[t];
        }
        if (!(area > 0.0)) continue;
        inward /= area;
        const double step = std::min(kGatherInset, kGatherInsetFraction * glm::length(inward));
        const glm::dvec3 in_plane =
            glm::length(inward) > 0.0 ? glm::normalize(inward) : glm::dvec3(0.0);
        const glm::dvec3 n = region_normal[r];
        points.push_back({x + step * in_plane + kGatherLift * n, n});
        out.vertices.push_back(static_cast<std::uint32_t>(v));
    }
    // The direct part where the gathers look: the exact values at target's vertices,
    // interpolated over its triangles (found through the element cells their boxes meet)
    std::vector<std::pair<std::uint64_t, std::uint32_t>> cell_triangle;
    const double size = solution.element_size;
    const auto plane = [&](std::uint32_t r, const glm::dvec3& x) {
        const IndirectSolution::Grid& g = solution.grids[r];
        return glm::dvec2(glm::dot(x - g.origin, g.u), glm::dot(x - g.origin, g.v)) / size;
    };
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
        const std::uint32_t r = vertex_region[mesh.triangles[t].x];
        if (r >= solution.grids.size()) continue;
        glm::dvec2 lo(std::numeric_limits<double>::max()), hi(-lo);
        for (int k = 0; k < 3; ++k) {
            const glm::dvec2 q = plane(r, mesh.positions[mesh.triangles[t][k]]);
            lo = glm::min(lo, q);
            hi = glm::max(hi, q);
        }
        for (int j = int(std::floor(lo.y)); j <= int(std::floor(hi.y)); ++j)
            for (int i = int(std::floor(lo.x)); i <= int(std::floor(hi.x)); ++i)
                cell_triangle.push_back(
                    {IndirectSolution::cell_key(r, i, j), static_cast<std::uint32_t>(t)});
    }
    std::sort(cell_triangle.begin(), cell_triangle.end());
    // Target's Gouraud field of per-vertex values at point x of element e's region
    const auto gouraud = [&](const std::vector<visdb::Rgb>& values, std::uint32_t e,
                             const glm::dvec3& x) -> std::optional<visdb::Rgb> {
        const std::uint32_t r = solution.elements[e].region;
        const glm::dvec2 q = plane(r, x);
        const std::uint64_t key =
            IndirectSolution::cell_key(r, int(std::floor(q.x)), int(std::floor(q.y)));
        auto it = std::lower_bound(cell_triangle.begin(), cell_triangle.end(),
                                   std::pair<std::uint64_t, std::uint32_t>{key, 0});
        for (; it != cell_triangle.end() && it->first == key; ++it) {
            const glm::u32vec3 tri = mesh.triangles[it->second];
            const glm::dvec2 a = plane(r, mesh.positions[tri.x]);
            const glm::dvec2 b = plane(r, mesh.positions[tri.y]);
            const glm::dvec2 c = plane(r, mesh.positions[tri.z]);
            const double det = (b.x - a.x) * (c.y - a.y) - (c.x - a.x) * (b.y - a.y);
            if (det == 0.0) continue;
            const double wb = ((q.x - a.x) * (c.y - a.y) - (c.x - a.x) * (q.y - a.y)) / det;
            const double wc = ((b.x - a.x) * (q.y - a.y) - (q.x - a.x) * (b.y - a.y)) / det;
            const double wa = 1.0 - wb - wc;
            constexpr double kSlack = -1e-9;
            if (wa < kSlack || wb < kSlack || wc < kSlack) continue;
            return wa * values[tri.x] + wb * values[tri.y] + wc * values[tri.z];
        }
        return std::nullopt;
    };
    const FieldAt direct_at = [&](std::uint32_t e, const glm::dvec3& x) {
        return gouraud(direct, e, x);
    };
    const IndirectInput input = solver_input(sources, regions, region_normal);
    const IndirectOptions io = solver_options(options);
    // The first sweep sees the elements' indirect part interpolated over their cells; each
    // next one the export's as it stands (these vertices' last gathers, the interpolated
    // elements elsewhere, scaled as conservative_indirect scales them). The hemicubes are the
    // same every sweep: shot once.
    const IndirectGather gather(input, solution, io, points, progress);
    std::vector<visdb::Rgb> exported;
    const FieldAt indirect_at = [&](std::uint32_t e, const glm::dvec3& x) {
        return gouraud(exported, e, x);
    };
    for (int sweep = 0; sweep < kGatherSweeps; ++sweep) {
        if (sweep > 0) exported = conservative_indirect(target, solution, vertex_region, &out);
        out.values = gather.values(direct_at, sweep > 0 ? indirect_at : FieldAt{});
    }
    return out;
}

}  // namespace abrad::radiosity
