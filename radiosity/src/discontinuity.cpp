// Stage 3 of the bake: discontinuity meshing. Each planar region is triangulated with the
// shadow segments as constraints (a CGAL constrained Delaunay triangulation, dm_mesh.h), then
// refined in rounds where the exact irradiance at an edge's midpoint departs from the linear
// interpolation of its ends (Heckbert 1992, Lischinski, Tampieri & Greenberg 1992).
// docs/algorithms.md#discontinuity-meshing and #illumination-driven-refinement.

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstring>
#include <initializer_list>
#include <map>
#include <memory>
#include <mutex>
#include <numeric>
#include <tuple>
#include <unordered_map>
#include <unordered_set>
#include <utility>
#include <vector>

#include "abrad/check.h"
#include "abrad/radiosity/cluster.h"
#include "abrad/radiosity/direct.h"
#include "stages.h"

namespace abrad::radiosity {

namespace {

// The refinement leaves an edge whose midpoint departs from the linear interpolation by less
// than this times the tolerance of the receivers' mean irradiance
// (docs/algorithms.md#illumination-driven-refinement).
constexpr double kFloorOfMean = 0.5;

// Where light begins, an edge from a vertex in full shadow (no direct light at all) to a lit
// one, the floor is this fraction of the above: there the field rises from zero, the
// interpolation's error is large relative to the little light there is, and halving such an
// edge halves it (the light grows about linearly from the umbra's edge), so a few splits along
// each umbra's outline buy the dim end of a penumbra its relative accuracy (CIE 171 case 5.6,
// 5 cm from the umbra: +4.0 % -> +0.7 %; the FZK-Haus default bake 133,481 -> 135,363
// triangles; docs/algorithms.md#illumination-driven-refinement).
constexpr double kOnsetFloor = 0.25;

// The refinement also tests the centroid of a triangle whose longest edge is at least this
// many shortest refined edges (0.4 m in a building): inside a large triangle the field can
// peak (a light's fall-off over a coarse floor cell) where no edge's midpoint sees it; a
// small one's field is hardly off its corners' plane
// (docs/algorithms.md#illumination-driven-refinement).
constexpr double kCentroidEdges = 8.0;

// With interreflection, edges at least this many elements long test the whole field (direct
// plus indirect), shorter ones the direct part (docs/algorithms.md,
// illumination-driven refinement: one element's length gave the FZK-Haus 165,478 triangles,
// two 154,515, the living room's work plane 0.8 % apart)
constexpr double kWholeFieldElements = 2.0;

// Exact position (and region) as a hash key.
struct PointKey {
    std::uint32_t region;
    std::array<std::uint64_t, 3> bits;
    friend bool operator==(const PointKey&, const PointKey&) = default;
};
PointKey key_of(std::uint32_t region, const glm::dvec3& p) {
    PointKey k{region, {}};
    for (int i = 0; i < 3; ++i) std::memcpy(&k.bits[i], &p[i], sizeof(double));
    return k;
}
struct PointKeyHash {
    std::size_t operator()(const PointKey& k) const {
        std::uint64_t h = 0xcbf29ce484222325ULL ^ k.region;
        for (std::uint64_t b : k.bits) h = (h ^ b) * 0x100000001b3ULL;
        return static_cast<std::size_t>(h ^ (h >> 29));
    }
};
// Exact irradiance by region and exact position, kept across rounds.
using IrradianceCache = std::unordered_map<PointKey, visdb::Rgb, PointKeyHash>;

// The shadow segments as the regions' constraints, in one order whatever order the lights
// and receivers finished in (the mesh was nondeterministic by a few triangles). Returns how
// many were given.
std::size_t add_constraints(std::vector<std::vector<ShadowSegment>>& segments, Regions& regions) {
    auto lex = [](const ShadowSegment& x, const ShadowSegment& y) {
        return lexicographically_less(x.a, y.a) || (x.a == y.a && lexicographically_less(x.b, y.b));
    };
    std::size_t constraints = 0;
    for (std::size_t t = 0; t < segments.size(); ++t) {
        std::sort(segments[t].begin(), segments[t].end(), lex);
        for (const ShadowSegment& s : segments[t]) {
            regions.planar[regions.of_triangle[t]].constraints.push_back({s.a, s.b});
            ++constraints;
        }
    }
    segments = {};
    return constraints;
}

// True when `mesh` covers the area of g's triangles to 1e-6 relative.
bool keeps_area(const BakeGeometry& g, const visdb::BakeMesh& mesh) {
    double after = 0.0;
    for (const glm::u32vec3& t : mesh.triangles)
        after +=
            visdb::triangle_area(mesh.positions[t.x], mesh.positions[t.y], mesh.positions[t.z]);
    const double before = std::accumulate(g.area.begin(), g.area.end(), 0.0);
    return std::abs(after - before) <= 1e-6 * before;
}

// The meshed regions as one bake mesh (each region's vertices its own).
void assemble(const Regions& regions, const std::vector<MeshedRegion>& meshed,
              DiscontinuityMesh& out) {
    out.mesh = {};
    out.vertex_region.clear();
    for (std::size_t r = 0; r < meshed.size(); ++r) {
        const auto base = static_cast<std::uint32_t>(out.mesh.positions.size());
        const glm::vec3 n(regions.planar[r].normal);
        for (const glm::dvec3& p : meshed[r].positions) {
            out.mesh.positions.push_back(p);
            out.mesh.normals.push_back(n);
            out.vertex_region.push_back(static_cast<std::uint32_t>(r));
        }
        for (const glm::u32vec3& t : meshed[r].triangles) {
            out.mesh.triangles.push_back(t + glm::u32vec3(base));
            out.mesh.triangle_surface.push_back(regions.surface[r]);
        }
    }
}

// Per region, the lights that reach some triangle of it (ascending, as g.lights). Coplanar
// regions whose boxes overlap (a rug on a floor) pool their lights: the hemicube's depth ties
// give such coincident faces to one of them, while both are lit.
using RegionLights = std::vector<std::vector<std::uint32_t>>;
RegionLights region_lights(const Regions& regions,
                           const std::vector<std::vector<std::uint32_t>>& lights_of_triangle,
                           double tolerance) {
    const std::size_t nr = regions.planar.size();
    RegionLights lights(nr);
    for (std::size_t t = 0; t < lights_of_triangle.size(); ++t) {
        auto& list = lights[regions.of_triangle[t]];
        list.insert(list.end(), lights_of_triangle[t].begin(), lights_of_triangle[t].end());
    }
    // Regions by plane (normal to 1e-6, offset to `tolerance`), with their boxes
    std::map<std::array<std::int64_t, 4>, std::vector<std::uint32_t>> by_plane;
    std::vector<Box> box(nr);
    for (std::size_t r = 0; r < nr; ++r) {
        const PlanarRegion& region = regions.planar[r];
        if (region.positions.empty()) continue;
        for (const glm::dvec3& p : region.positions) box[r].grow(p);
        box[r].inflate(tolerance);
        const glm::dvec3 n = region.normal;
        const double d = glm::dot(n, region.positions[0]);
        const auto q = [](double x) { return static_cast<std::int64_t>(std::llround(x)); };
        by_plane[{q(n.x * 1e6), q(n.y * 1e6), q(n.z * 1e6), q(d / tolerance)}].push_back(
            static_cast<std::uint32_t>(r));
    }
    RegionLights pooled = lights;
    for (const auto& [plane, members] : by_plane)
        for (std::size_t a = 0; a < members.size(); ++a)
            for (std::size_t b = a + 1; b < members.size(); ++b)
                if (box[members[a]].overlaps(box[members[b]])) {
                    const auto& la = lights[members[a]];
                    const auto& lb = lights[members[b]];
                    pooled[members[a]].insert(pooled[members[a]].end(), lb.begin(), lb.end());
                    pooled[members[b]].insert(pooled[members[b]].end(), la.begin(), la.end());
                }
    for (auto& list : pooled) {
        std::sort(list.begin(), list.end());
        list.erase(std::unique(list.begin(), list.end()), list.end());
    }
    return pooled;
}

// Per region, the light triangles and the luminaires that reach it.
struct RegionSources {
    RegionLights lights, luminaires;
};

// The occluder candidates of each region's light triangles, found once per tile of the
// region: the region's bounding rectangle (in its plane) is cut into square tiles of about
// `tile` metres, and a tile's candidates for a light are those of the shaft of the light and
// the tile, which holds the shaft of the light and any point of the tile. A point's candidates
// are those of its tile's whose box meets its own shaft (the test a query of that shaft makes of
// each box, in the same order: the same occluders), so that the region's many evaluations, round
// after round, filter a short list instead of each walking the BVH. A tile's lists are built on
// first use (thread safe); a region of few vertices, or a tile whose lists grow past kMaxListed
// per light, queries point by point.
class RegionShafts {
  public:
    static constexpr std::size_t kMinVertices = 8;
    static constexpr std::size_t kMaxListed = 2048;
    static constexpr int kMaxTiles = 64;  // per side

    RegionShafts(const BakeGeometry& g, const Bvh& bvh, const Regions& regions,
                 const RegionSources& sources, double reach, double tile)
        : m_g(g),
          m_bvh(bvh),
          m_occluders(regions.outlines.patches),
          m_occluder_bvh(m_occluders),
          m_regions(regions),
          m_sources(sources),
          m_reach(reach),
          m_tile(tile),
          m_coplanar(kLengthTolerance * g.size),
          m_once(std::make_unique<std::once_flag[]>(regions.planar.size())),
          m_frames(regions.planar.size()),
          m_quads(g.patches, g.emittance, g.lights) {
        ABRAD_DCHECK(g.patches.empty() || !m_occluders.empty(),
                     "the bake makes the regions' outlines before meshing");
    }

    // The exact direct light at x (unit normal n) of region r: its light triangles (their
    // occluder candidates from x's tile, or a query per point) and its luminaires. Region r
    // itself is no candidate, and an occluder whose plane passes within the length tolerance
    // of x hides nothing from it: x lies on r's mean plane, which a region planar only to the
    // bake's tolerance (bake_mesh.cpp: normals to cos 1 - 1e-9) leaves micrometres off its
    // own triangles and off the edges it shares with its neighbours, and from just behind
    // such a plane the whole light would be hidden (black patches on warped faces, black
    // edges between the facets of a cylinder).
    visdb::Rgb irradiance(std::uint32_t r, const glm::dvec3& x, const glm::dvec3& n,
                          std::vector<const Patch*>& occ) const {
        const std::span<const std::uint32_t> lights = m_sources.lights[r];
        visdb::Rgb h(0.0);
        if (const Tile* tile = tile_of(r, x)) {
            // The tile's candidates whose box meets the shaft of the light and x
            const auto candidates = [&](std::size_t k, std::vector<const Patch*>& out) {
                const Patch& lp = m_g.patches[lights[k]];
                const glm::dvec3 corners[4] = {lp.p[0], lp.p[1], lp.p[2], x};
                const Hull shaft(corners);
                for (std::uint32_t c = tile->start[k]; c < tile->start[k + 1]; ++c) {
                    const Box& b = m_occluder_bvh.box(tile->ids[c]);
                    if (b.overlaps(shaft.box()) && shaft.may_overlap(b))
                        out.push_back(&m_occluders[tile->ids[c]]);
                }
            };
            h = exact_irradiance_with(m_g.patches, m_g.emittance, lights, x, n, occ, m_reach,
                                      candidates, &m_quads, m_coplanar);
        } else {
            const auto candidates = [&](std::size_t k, std::vector<const Patch*>& out) {
                for_each_shadow_candidate(m_bvh, m_g.patches, lights[k], x, [&](std::uint32_t id) {
                    if (m_regions.of_triangle[id] != r) out.push_back(&m_g.patches[id]);
                });
            };
            h = exact_irradiance_with(m_g.patches, m_g.emittance, lights, x, n, occ, m_reach,
                                      candidates, &m_quads, m_coplanar);
        }
        for (const std::uint32_t k : m_sources.luminaires[r])
            h += luminaires_irradiance({&m_g.luminaires[k], 1}, m_g.patches, m_bvh, x, n, m_reach);
        return h;
    }

  private:
    struct Tile {
        mutable std::once_flag once;
        mutable bool built = false;
        mutable std::vector<std::uint32_t> start, ids;  // per light of the region, candidates
    };
    // A region's plane (unit normal n, offset d), its in-plane axes u and v, and its bounding
    // rectangle [u0, u0 + nu·side] × [v0, v0 + nv·side] cut into tiles
    struct Frame {
        glm::dvec3 n{0.0}, u{0.0}, v{0.0};
        double d = 0.0, u0 = 0.0, v0 = 0.0, side = 0.0;
        int nu = 0, nv = 0;
        std::unique_ptr<Tile[]> tiles;
    };

    // The tile of region r holding x, its lists built; null when the region or the tile
    // queries point by point.
    const Tile* tile_of(std::uint32_t r, const glm::dvec3& x) const {
        std::call_once(m_once[r], [&] { frame(r); });
        const Frame& f = m_frames[r];
        if (!f.tiles) return nullptr;
        const auto cell = [](double t, double t0, double side, int count) {
            return std::clamp(static_cast<int>(std::floor((t - t0) / side)), 0, count - 1);
        };
        const int i = cell(glm::dot(x, f.u), f.u0, f.side, f.nu);
        const int j = cell(glm::dot(x, f.v), f.v0, f.side, f.nv);
        const Tile& tile = f.tiles[static_cast<std::size_t>(j) * f.nu + i];
        std::call_once(tile.once, [&] { build(r, i, j, tile); });
        return tile.built ? &tile : nullptr;
    }

    void frame(std::uint32_t r) const {
        const PlanarRegion& region = m_regions.planar[r];
        if (region.positions.size() + 2 * region.constraints.size() < kMinVertices ||
            m_sources.lights[r].empty())
            return;
        Frame f;
        f.n = region.normal;
        std::tie(f.u, f.v) = visdb::orthonormal_basis(f.n);
        double u1 = -1e300, v1 = -1e300;
        f.u0 = f.v0 = 1e300;
        for (const glm::dvec3& p : region.positions) {
            f.u0 = std::min(f.u0, glm::dot(p, f.u));
            u1 = std::max(u1, glm::dot(p, f.u));
            f.v0 = std::min(f.v0, glm::dot(p, f.v));
            v1 = std::max(v1, glm::dot(p, f.v));
            f.d += glm::dot(p, f.n);
        }
        f.d /= static_cast<double>(region.positions.size());
        // Pushed out by a relative 1e-6, so that every point of the region is inside
        const double margin = 1e-6 * std::max({u1 - f.u0, v1 - f.v0, 1e-3 * m_g.size});
        f.u0 -= margin, f.v0 -= margin, u1 += margin, v1 += margin;
        f.side = std::max({m_tile, (u1 - f.u0) / kMaxTiles, (v1 - f.v0) / kMaxTiles});
        f.nu = std::max(1, static_cast<int>(std::ceil((u1 - f.u0) / f.side)));
        f.nv = std::max(1, static_cast<int>(std::ceil((v1 - f.v0) / f.side)));
        f.tiles = std::make_unique<Tile[]>(static_cast<std::size_t>(f.nu) * f.nv);
        m_frames[r] = std::move(f);
    }

    void build(std::uint32_t r, int i, int j, const Tile& tile) const {
        const Frame& f = m_frames[r];
        const std::span<const std::uint32_t> lights = m_sources.lights[r];
        const double a0 = f.u0 + i * f.side, a1 = a0 + f.side;
        const double b0 = f.v0 + j * f.side, b1 = b0 + f.side;
        const glm::dvec3 o = f.d * f.n;
        tile.start.assign(1, 0);
        for (const std::uint32_t l : lights) {
            const Patch& lp = m_g.patches[l];
            const glm::dvec3 points[7] = {lp.p[0],
                                          lp.p[1],
                                          lp.p[2],
                                          o + a0 * f.u + b0 * f.v,
                                          o + a1 * f.u + b0 * f.v,
                                          o + a1 * f.u + b1 * f.v,
                                          o + a0 * f.u + b1 * f.v};
            // (the light itself, in its own plane, hides nothing)
            m_occluder_bvh.query(Hull(points), [&](std::uint32_t id) {
                if (m_regions.outlines.region[id] != r) tile.ids.push_back(id);
            });
            if (tile.ids.size() > kMaxListed * lights.size()) {  // point by point
                tile.start = {};
                tile.ids = {};
                return;
            }
            tile.start.push_back(static_cast<std::uint32_t>(tile.ids.size()));
        }
        tile.built = true;
    }

    const BakeGeometry& m_g;
    const Bvh& m_bvh;
    // The tiles' occluder candidates: each region from its outline (Regions::outlines), the
    // same surfaces in fewer triangles, so fewer shadows to subtract from each light
    const std::span<const Patch> m_occluders;
    const Bvh m_occluder_bvh;
    const Regions& m_regions;
    const RegionSources& m_sources;
    double m_reach, m_tile, m_coplanar;
    std::unique_ptr<std::once_flag[]> m_once;
    mutable std::vector<Frame> m_frames;
    const LightQuads m_quads;  // the light triangles two by two as quadrilaterals
};

// A split point of a region, and an exact value at a point of a region (a vertex or an edge's
// midpoint), as the ranks exchange them.
struct SplitPoint {
    std::uint32_t region;
    glm::dvec3 point;
};
struct Evaluated {
    std::uint32_t region;
    PointKey key;
    visdb::Rgb irradiance;
};

// Per item of `cost`, whether this rank takes it (Cluster::share).
std::vector<char> flags_of_share(const Cluster& cluster, std::span<const double> cost) {
    std::vector<char> mine(cost.size(), 0);
    for (const std::uint32_t k : cluster.share(cost)) mine[k] = 1;
    return mine;
}

// The regions this rank evaluates and refines this round (all of them without MPI), shared
// over the ranks by cost: the region's vertices times the sources that light it (each
// evaluation asks every one of them).
std::vector<char> regions_of_rank(const Regions& regions, const RegionSources& sources,
                                  const DiscontinuityMesh& current, const Cluster& cluster) {
    const std::size_t nr = regions.planar.size();
    std::vector<double> cost(nr, 1.0);
    for (const std::uint32_t r : current.vertex_region) cost[r] += 1.0;
    for (std::size_t r = 0; r < nr; ++r)
        cost[r] *=
            1.0 + static_cast<double>(sources.lights[r].size() + sources.luminaires[r].size());
    return flags_of_share(cluster, cost);
}

// Every rank's split points and evaluated midpoints, per region, on every rank (a region's
// come from the one rank that refined it, in its order).
void exchange_refinement(Cluster& cluster, std::vector<std::vector<glm::dvec3>>& split,
                         std::vector<std::vector<std::pair<PointKey, visdb::Rgb>>>& evaluated) {
    std::vector<SplitPoint> points;
    std::vector<Evaluated> values;
    for (std::size_t r = 0; r < split.size(); ++r) {
        for (const glm::dvec3& p : split[r]) points.push_back({static_cast<std::uint32_t>(r), p});
        for (const auto& [key, h] : evaluated[r])
            values.push_back({static_cast<std::uint32_t>(r), key, h});
        split[r].clear();
        evaluated[r].clear();
    }
    for (const SplitPoint& x : values_of<SplitPoint>(cluster.all_gather(as_bytes_of(points), "dm")))
        split[x.region].push_back(x.point);
    // In one order whatever the vertex numbering the mesher gave the region's edges
    for (auto& list : split) std::sort(list.begin(), list.end(), lexicographically_less);
    for (const Evaluated& x : values_of<Evaluated>(cluster.all_gather(as_bytes_of(values), "dm")))
        evaluated[x.region].emplace_back(x.key, x.irradiance);
}

// Exact irradiance at every vertex of `out` (from the cache where known); returns the
// number of new evaluations.
std::size_t evaluate_vertices(const Regions& regions, const RegionShafts& shafts,
                              const std::vector<char>& mine, Cluster& cluster,
                              IrradianceCache& cache, DiscontinuityMesh& out,
                              ParallelProgress& progress) {
    const std::size_t n = out.mesh.positions.size();
    out.irradiance.assign(n, visdb::Rgb(0.0));
    std::vector<char> fresh(n, 0);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 64), [&](const auto& range) {
        progress.add(range.size());
        std::vector<const Patch*> occ;
        for (std::size_t v = range.begin(); v != range.end(); ++v) {
            const auto it = cache.find(key_of(out.vertex_region[v], out.mesh.positions[v]));
            if (it != cache.end()) {
                out.irradiance[v] = it->second;
                continue;
            }
            const std::uint32_t r = out.vertex_region[v];
            if (!mine[r]) continue;  // another rank's region
            const glm::dvec3& x = out.mesh.positions[v];
            const glm::dvec3& normal = regions.planar[r].normal;
            out.irradiance[v] = shafts.irradiance(r, x, normal, occ);
            fresh[v] = 1;
        }
    });
    // Every rank's new values, on every rank, by region and position: the mesher may number
    // the vertices of a region differently in another process
    std::vector<Evaluated> here;
    for (std::size_t v = 0; v < n; ++v)
        if (fresh[v]) {
            const std::uint32_t r = out.vertex_region[v];
            here.push_back({r, key_of(r, out.mesh.positions[v]), out.irradiance[v]});
        }
    const std::vector<Evaluated> all =
        values_of<Evaluated>(cluster.all_gather(as_bytes_of(here), "dm"));
    for (const Evaluated& x : all) cache.emplace(x.key, x.irradiance);
    if (cluster.size() > 1)
        for (std::size_t v = 0; v < n; ++v)
            out.irradiance[v] = cache.at(key_of(out.vertex_region[v], out.mesh.positions[v]));
    return all.size();
}

// The field the refinement tests at one region's vertices: the exact direct irradiance, and
// with interreflection the direct plus the indirect part interpolated from the elements.
struct RegionField {
    const visdb::Rgb* direct = nullptr;
    const visdb::Rgb* total = nullptr;  // null without interreflection
    const IndirectSolution* indirect = nullptr;
    // Edges (and triangles' longest edges) at least this long test the whole field; shorter
    // ones the direct part alone: the indirect part is bilinear between elements' centres, and
    // splitting a shorter edge mostly traces its kinks (two elements: docs/algorithms.md,
    // illumination-driven refinement)
    double whole_from = 0.0;
};

// The points that split region r's edges whose midpoint's irradiance departs from the
// linear interpolation of their ends, and its large triangles whose centroid's does; the points
// whose exact direct irradiance is evaluated here go to `evaluated`.
void refine_region(const Regions& regions, const RegionShafts& shafts, const MeshedRegion& m,
                   std::uint32_t r, const RegionField& f, double floor, double min_edge,
                   const BakeOptions& options, const IrradianceCache& cache,
                   std::vector<glm::dvec3>& split,
                   std::vector<std::pair<PointKey, visdb::Rgb>>& evaluated) {
    std::vector<const Patch*> occ;
    const glm::dvec3 rn = regions.planar[r].normal;
    // Splits at x when its value departs from the mean of the corners' by more than the
    // tolerance: of the whole field when the edge (or the triangle's longest) is `length` ≥
    // whole_from, else of the direct part
    const auto test = [&](const glm::dvec3& x, std::initializer_list<std::uint32_t> corners,
                          double length) {
        const bool whole = f.total && length >= f.whole_from;
        const visdb::Rgb* h = whole ? f.total : f.direct;
        visdb::Rgb linear(0.0);
        for (const std::uint32_t v : corners) linear += h[v];
        linear /= static_cast<double>(corners.size());
        const PointKey key = key_of(r, x);
        const auto hit = cache.find(key);
        visdb::Rgb exact;
        if (hit != cache.end()) {
            exact = hit->second;
        } else {
            exact = shafts.irradiance(r, x, rn, occ);
            evaluated.emplace_back(key, exact);
        }
        if (whole) exact += f.indirect->at(r, x);
        const double diff = visdb::channel_mean(glm::abs(exact - linear));
        bool dark = false, lit = false;  // a corner in full shadow, a corner with direct light
        for (const std::uint32_t v : corners) {
            if (visdb::channel_mean(f.direct[v]) == 0.0)
                dark = true;
            else
                lit = true;
        }
        if (diff > (dark && lit ? kOnsetFloor * floor : floor) &&
            diff > options.refine_tolerance *
                       std::max(visdb::channel_mean(exact), visdb::channel_mean(linear)))
            split.push_back(x);
    };
    std::vector<std::pair<std::uint32_t, std::uint32_t>> edges;
    for (const glm::u32vec3& t : m.triangles)
        for (int k = 0; k < 3; ++k)
            edges.emplace_back(std::min(t[k], t[(k + 1) % 3]), std::max(t[k], t[(k + 1) % 3]));
    std::sort(edges.begin(), edges.end());
    edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
    for (const auto& [a, b] : edges) {
        const glm::dvec3 pa = m.positions[a], pb = m.positions[b];
        const double length = glm::length(pb - pa);
        if (length < min_edge) continue;
        // Canonical midpoint: the same bits from either region sharing the edge
        const glm::dvec3 mid =
            lexicographically_less(pa, pb) ? pa + 0.5 * (pb - pa) : pb + 0.5 * (pa - pb);
        test(mid, {a, b}, length);
    }
    for (const glm::u32vec3& t : m.triangles) {
        std::array<glm::dvec3, 3> p = {m.positions[t.x], m.positions[t.y], m.positions[t.z]};
        const double longest = std::max(
            {glm::length(p[1] - p[0]), glm::length(p[2] - p[1]), glm::length(p[0] - p[2])});
        if (longest < kCentroidEdges * min_edge) continue;
        // The corners in one order, so that the centroid's bits do not depend on the
        // mesher's numbering
        std::sort(p.begin(), p.end(), lexicographically_less);
        test((p[0] + p[1] + p[2]) / 3.0, {t.x, t.y, t.z}, longest);
    }
}

// One refinement round over every non-emitting region: adds the split points to the regions;
// returns how many were added.
std::size_t refine(Regions& regions, const RegionShafts& shafts,
                   const std::vector<MeshedRegion>& meshed, const DiscontinuityMesh& current,
                   const IndirectSolution* indirect, double min_edge, const BakeOptions& options,
                   const std::vector<char>& mine, Cluster& cluster, IrradianceCache& cache,
                   std::uint64_t& evaluations, ParallelProgress& progress) {
    // The field at the vertices: exact direct, plus the indirect part where there is one
    std::vector<visdb::Rgb> field;
    if (indirect) {
        field = current.irradiance;
        tbb::parallel_for(std::size_t{0}, field.size(), [&](std::size_t v) {
            field[v] += indirect->at(current.vertex_region[v], current.mesh.positions[v]);
        });
    }
    const std::vector<visdb::Rgb>& h = indirect ? field : current.irradiance;
    double h_max = 0.0;
    for (const visdb::Rgb& x : h) h_max = std::max(h_max, visdb::channel_mean(x));
    // The field an edge's split improves: a departure under kFloorOfMean times the tolerance
    // of the receivers' mean irradiance (area-weighted) is left, so that dim places (the
    // inside of a shelf, a corner behind furniture) are not refined as finely as lit ones for a
    // gain the field, as a whole, hardly sees; and never under 1/1000 of the brightest vertex
    // (noise)
    double sum_ah = 0.0, sum_a = 0.0;
    for (const glm::u32vec3& t : current.mesh.triangles) {
        if (regions.emitter[current.vertex_region[t.x]]) continue;
        const glm::dvec3* p = current.mesh.positions.data();
        const double a = visdb::triangle_area(p[t.x], p[t.y], p[t.z]);
        sum_ah += a *
                  (visdb::channel_mean(h[t.x]) + visdb::channel_mean(h[t.y]) +
                   visdb::channel_mean(h[t.z])) /
                  3.0;
        sum_a += a;
    }
    const double h_mean = sum_a > 0.0 ? sum_ah / sum_a : 0.0;
    const double floor = std::max(1e-3 * h_max, kFloorOfMean * options.refine_tolerance * h_mean);
    std::vector<std::uint32_t> region_start(meshed.size() + 1, 0);
    for (std::size_t r = 0; r < meshed.size(); ++r)
        region_start[r + 1] =
            region_start[r] + static_cast<std::uint32_t>(meshed[r].positions.size());
    std::vector<std::vector<glm::dvec3>> split(meshed.size());
    // Midpoints and centroids evaluated this round, cached like vertices: an edge or a
    // triangle that stays unsplit keeps its point's bits, so later rounds look it up instead
    // of re-evaluating
    std::vector<std::vector<std::pair<PointKey, visdb::Rgb>>> evaluated(meshed.size());
    tbb::parallel_for(std::size_t{0}, meshed.size(), [&](std::size_t r) {
        progress.add(meshed[r].triangles.size());
        if (regions.emitter[r] || !mine[r]) return;
        const RegionField f{
            .direct = current.irradiance.data() + region_start[r],
            .total = indirect ? field.data() + region_start[r] : nullptr,
            .indirect = indirect,
            .whole_from = indirect ? kWholeFieldElements * indirect->element_size : 0.0};
        refine_region(regions, shafts, meshed[r], static_cast<std::uint32_t>(r), f, floor, min_edge,
                      options, cache, split[r], evaluated[r]);
    });
    exchange_refinement(cluster, split, evaluated);
    for (const auto& list : evaluated)
        for (const auto& [key, value] : list)
            if (cache.emplace(key, value).second) ++evaluations;
    std::size_t added = 0;
    std::unordered_set<PointKey, PointKeyHash> seen;
    for (std::size_t r = 0; r < split.size(); ++r)
        for (const glm::dvec3& p : split[r])
            if (seen.insert(key_of(0, p)).second) {
                regions.planar[r].points.push_back(p);
                ++added;
            }
    return added;
}

}  // namespace

DiscontinuityMesh mesh_discontinuities(const BakeGeometry& g, const Bvh& bvh, Regions& regions,
                                       LightShots& shots, const IndirectSolution* indirect,
                                       const BakeOptions& options, visdb::BakeStats* stats,
                                       const ProgressFn& progress) {
    std::vector<std::vector<ShadowSegment>>& segments = shots.segments;
    // Lengths relative to the model's size: a model in millimetres or kilometres meshes as the
    // same model in metres would
    const double tolerance = kLengthTolerance * g.size;
    const double min_edge = refine_min_edge(options, g.size);
    const RegionSources sources{region_lights(regions, shots.lights_of_triangle, tolerance),
                                region_lights(regions, shots.luminaires_of_triangle, tolerance)};
    // Tiles of 16 shortest refined edges (0.8 m in a building)
    const RegionShafts shafts(g, bvh, regions, sources, options.reach, 16.0 * min_edge);
    const auto t_dm = Clock::now();
    visdb::DiscontinuityStats st;
    if (stats && stats->dm) st = *stats->dm;  // the shadow edge counters of shoot_lights
    st.regions = regions.planar.size();
    st.triangles_before = g.mesh.triangles.size();
    st.segments = add_constraints(segments, regions);
    const DmOptions dm_options{.min_angle_deg = options.dm_min_angle, .merge_distance = tolerance};
    IrradianceCache cache;
    DiscontinuityMesh out;
    // The meshing and the exact evaluations are shared over the ranks by region (cluster.h);
    // the ranks exchange what makes neighbouring regions conform, and every rank gets the
    // whole mesh
    Cluster alone;
    Cluster& cluster = options.cluster ? *options.cluster : alone;
    MeshSharing sharing{
        .mine = [&](std::span<const double> cost) { return flags_of_share(cluster, cost); },
        .all_gather =
            [&](std::span<const std::byte> bytes) { return cluster.all_gather(bytes, "mesh"); },
        .seconds = {}};
    for (int round = 0;; ++round) {
        // Each step reports its own work: regions meshed, vertices evaluated, triangles refined
        const std::string of_rounds = " (round " + std::to_string(round + 1) + " of at most " +
                                      std::to_string(options.refine_rounds + 1) + ")";
        const auto tm = Clock::now();
        if (progress) progress("mesh: regions" + of_rounds, 0, regions.planar.size());
        DmStats mesher;
        const std::vector<MeshedRegion> meshed = mesh_regions(
            regions.planar, dm_options, &mesher, cluster.size() > 1 ? &sharing : nullptr);
        st.seconds_mesh += seconds_since(tm);
        if (round == 0) {
            st.constraints_dropped = mesher.constraints_dropped;
            st.points_merged = mesher.points_merged;
        }
        st.conformity_points = mesher.conformity_points;
        ++st.rounds;
        assemble(regions, meshed, out);
        const std::vector<char> mine = regions_of_rank(regions, sources, out, cluster);
        {
            ParallelProgress vertices(progress, "mesh: exact irradiance at vertices" + of_rounds,
                                      out.mesh.positions.size());
            st.exact_evaluations +=
                evaluate_vertices(regions, shafts, mine, cluster, cache, out, vertices);
        }
        if (round >= options.refine_rounds) break;
        ParallelProgress triangles(progress, "mesh: refinement, triangles" + of_rounds,
                                   out.mesh.triangles.size());
        const std::size_t added = refine(regions, shafts, meshed, out, indirect, min_edge, options,
                                         mine, cluster, cache, st.exact_evaluations, triangles);
        st.refine_points += added;
        if (added == 0) break;
    }
    st.seconds = seconds_since(t_dm);
    if (stats) stats->dm = st;
    // Re-meshing keeps every region's area (dm_mesh.h: to 1e-9 relative)
    ABRAD_DCHECK(keeps_area(g, out.mesh), "the discontinuity mesh changed the area of the scene");
    return out;
}

}  // namespace abrad::radiosity
