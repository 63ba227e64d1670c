// Stage 2 of the bake: one A-buffer (or Z-buffer) hemicube shot from every light-source
// triangle (Wang et al., "Using A-Buffer in Radiosity": the progressive refinement step
// restricted to the lights), with what each shot feeds: patch irradiance, exact vertex
// irradiance past the occluders of the occlusion lists (Algorithm 2), and shadow edges
// (Algorithm 3) for discontinuity meshing. docs/algorithms.md#light-triangle-shooting,
// #occlusion-lists and #shadow-edges.

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <mutex>
#include <numbers>
#include <span>
#include <type_traits>
#include <utility>
#include <vector>

#include "abrad/radiosity/cluster.h"
#include "abrad/radiosity/cull.h"
#include "abrad/radiosity/direct.h"
#include "abrad/radiosity/exact.h"
#include "abrad/radiosity/exact_sum.h"
#include "abrad/radiosity/point_source.h"
#include "stages.h"

namespace abrad::radiosity {

namespace {

// True when the corners of `c` lie on the closed back side of the plane through `on` with
// normal `n` (unit), within a relative 1e-9 of the span of c and `on` along n.
bool wholly_behind(const Patch& c, const glm::dvec3& on, const glm::dvec3& n) {
    double lo = 0.0, hi = 0.0;
    for (const glm::dvec3& p : c.p) {
        const double d = glm::dot(p - on, n);
        lo = std::min(lo, d);
        hi = std::max(hi, d);
    }
    return hi <= 1e-9 * (hi - lo) + 1e-12;
}

// False when `c` cannot hide any part of `light` from any part of `receiver`:
// - the six corners lie on one closed side of c's plane, so no segment between them crosses
//   it (a floor cannot shadow a wall standing on it; a wall cannot shadow the floor);
// - c lies wholly behind an area light's plane or the receiver's: a segment that carries light
//   runs in front of both but for its ends (the other triangles of a closed emitter, all
//   behind each of its triangles' planes, do not shadow it).
bool can_occlude(const Patch& c, const Patch& light, const Patch& receiver) {
    const glm::dvec3 cr = cross_normal(c);
    const double len = glm::length(cr);
    if (!(len > 0.0)) return false;
    // (a point source, given as a triangle of three equal corners, has no plane to be behind)
    const bool area_light = glm::length(cross_normal(light)) > 0.0;
    if ((area_light && wholly_behind(c, light.p[0], unit_normal(light))) ||
        wholly_behind(c, receiver.p[0], unit_normal(receiver)))
        return false;
    const glm::dvec3 n = cr / len;
    double lo = 0.0, hi = 0.0;
    for (const Patch* q : {&light, &receiver})
        for (const glm::dvec3& p : q->p) {
            const double d = glm::dot(p - c.p[0], n);
            lo = std::min(lo, d);
            hi = std::max(hi, d);
        }
    const double eps = 1e-9 * (hi - lo) + 1e-12;
    return lo < -eps && hi > eps;
}

// True when the light's hemicube, at its centroid, cannot see the front of receiver r (the
// centroid is on or behind r's plane) though part of the light is in front of r by more than
// a relative 1e-9 of the light's size: the shot then says nothing of r (the side of a box
// that only the far part of a ceiling panel lights). A light in r's plane (a panel flush with
// the ceiling) lights nothing of it.
bool unseen_from_centroid(const Patch& light, const Patch& r) {
    const glm::dvec3 n = unit_normal(r);
    if (glm::dot(centroid(light) - r.p[0], n) > 0.0) return false;
    const double eps =
        1e-9 * std::max({glm::length(light.p[1] - light.p[0]), glm::length(light.p[2] - light.p[1]),
                         glm::length(light.p[0] - light.p[2])});
    for (const glm::dvec3& p : light.p)
        if (glm::dot(p - r.p[0], n) > eps) return true;
    return false;
}

// True when some of light l may reach the front of receiver r: part of r in front of the
// light's plane and part of the light in front of r's.
bool may_light(const Patch& light, const Patch& r) {
    const glm::dvec3 ln = unit_normal(light), rn = unit_normal(r);
    bool in_front = false, facing = false;
    for (int k = 0; k < 3; ++k) {
        in_front |= glm::dot(r.p[k] - light.p[0], ln) > 0.0;
        facing |= glm::dot(light.p[k] - r.p[0], rn) > 0.0;
    }
    return in_front && facing;
}

// A shadow segment of light triangle l (kNoLight: a luminaire) on receiver triangle j, with
// what it may change there (W/m², means over RGB): the light's largest unoccluded irradiance
// on the receiver and the segment (the most the light can change anywhere on it), and its
// emitter's: that times the emitter's area over the light's, and so its patch irradiance on j.
constexpr std::uint32_t kNoLight = ~std::uint32_t{0};
struct LitSegment {
    std::uint32_t j, l;
    ShadowSegment segment;
    double unoccluded;
    double emitter_unoccluded;
    double emitter_patch;
};

// One light's shot and what it contributes, before it is added to the totals.
struct OneLight {
    std::vector<std::uint32_t> near;           // receivers: in reach (cull.h) or in reached regions
    std::vector<std::uint32_t> near_vertices;  // their vertices
    std::vector<std::uint32_t> corner_lit;     // lit from a corner, not from the centroid
    std::vector<visdb::Rgb> triangle;          // patch irradiance, all triangles
    std::vector<visdb::Rgb> vertex;            // exact irradiance (exact shading without DM)
    std::vector<LitSegment> segments;
    visdb::ShootStats shoot;
    visdb::ExactShadeStats exact;
    visdb::ShadowEdgeStats shadow;
};

// Adds one task's shadow segments and counters to the light's (the caller holds the lock).
void add_segments(const std::vector<LitSegment>& here, const ShadowStats& s,
                  visdb::ShadowEdgeStats counts, OneLight& out) {
    out.segments.insert(out.segments.end(), here.begin(), here.end());
    counts.edges_projected += s.edges_projected;
    counts.shared_edges_skipped += s.shared_edges_skipped;
    counts.segments_split += s.segments_split;
    out.shadow += counts;
}

// Exact vertex irradiance from light l past the occluders the fragment lists found.
// Candidates: the occlusion lists of the vertex's triangles (Algorithm 2, from the light's
// centroid), completed by a conservative bounding-volume query of the region between the
// vertex and the light: occluders that hide only part of the light (penumbra) may be
// invisible from the centroid.
void shade_vertices_exactly(const BakeGeometry& g, const Bvh& bvh, std::uint32_t l,
                            const ShootResult& shot, const std::vector<std::uint32_t>& vertices,
                            OneLight& out) {
    const Patch& light = g.patches[l];
    const glm::dvec3 normal = unit_normal(light);
    out.vertex.assign(g.mesh.positions.size(), visdb::Rgb(0.0));
    std::mutex accumulate;
    tbb::parallel_for(
        tbb::blocked_range<std::size_t>(0, vertices.size(), 64), [&](const auto& range) {
            std::vector<std::uint32_t> ids, listed, touched;
            std::vector<const Patch*> occ;
            VisibleStats vs;
            vs.touched = &touched;
            std::uint64_t missed = 0;
            for (std::size_t vi = range.begin(); vi != range.end(); ++vi) {
                const std::uint32_t v = vertices[vi];
                const glm::dvec3 x = g.mesh.positions[v];
                if (glm::dot(x - light.p[0], normal) <= 0.0) continue;  // behind the light
                listed.clear();
                for (std::uint32_t k = g.incident_start[v]; k < g.incident_start[v + 1]; ++k)
                    for (const OcclusionPair& p : shot.occluders_of(g.incident[k]))
                        if (p.occluder != l) listed.push_back(p.occluder);
                std::sort(listed.begin(), listed.end());
                listed.erase(std::unique(listed.begin(), listed.end()), listed.end());
                const glm::dvec3 n(g.mesh.normals[v]);
                // The listed occluders first: when they hide the whole light (a vertex behind
                // a wall, in another room), more occluders cannot show any of it, and the
                // shaft query, the dearer part, is not needed
                occ.clear();
                for (const std::uint32_t id : listed) occ.push_back(&g.patches[id]);
                VisibleStats listed_only;
                if (visible_form_factor(x, n, light, occ, &listed_only) <= 0.0) {
                    vs.occluders_tested += listed_only.occluders_tested;
                    vs.occluders_projected += listed_only.occluders_projected;
                    continue;  // out.vertex[v] stays 0
                }
                ids = listed;
                for_each_shadow_candidate(bvh, g.patches, l, x, [&](std::uint32_t id) {
                    if (!std::binary_search(listed.begin(), listed.end(), id)) ids.push_back(id);
                });
                for (std::size_t k = listed.size(); k < ids.size(); ++k)
                    occ.push_back(&g.patches[ids[k]]);
                touched.clear();
                const double f = visible_form_factor(x, n, light, occ, &vs);
                for (std::uint32_t t : touched) missed += t >= listed.size();
                out.vertex[v] = g.emittance[l] * f;
            }
            std::lock_guard lock(accumulate);
            out.exact.occluders_tested += vs.occluders_tested;
            out.exact.occluders_hiding_light += vs.occluders_projected;
            out.exact.occluders_missed_by_lists += missed;
        });
}

// Occluders that may cast a shadow edge of light l on receiver j: j's occlusion list,
// completed by a conservative query of the shaft of the light and the receiver (the lists
// come from the centroid only). Returns how many came from the list.
std::size_t edge_occluders(const BakeGeometry& g, const Bvh& bvh, std::uint32_t l, std::uint32_t j,
                           const ShootResult& shot, std::vector<std::uint32_t>& ids) {
    const Patch& light = g.patches[l];
    const Patch& r = g.patches[j];
    ids.clear();
    // Only occluders whose plane separates some light and receiver points
    for (const OcclusionPair& p : shot.occluders_of(j))
        if (p.occluder != l && can_occlude(g.patches[p.occluder], light, r))
            ids.push_back(p.occluder);
    const std::size_t n_listed = ids.size();
    // Shaft of light and receiver: the convex hull of their six corners
    const glm::dvec3 corners[6] = {light.p[0], light.p[1], light.p[2], r.p[0], r.p[1], r.p[2]};
    bvh.query(Hull(corners), [&](std::uint32_t id) {
        if (id != l && id != j &&
            std::find(ids.begin(), ids.begin() + n_listed, id) == ids.begin() + n_listed &&
            can_occlude(g.patches[id], light, r))
            ids.push_back(id);
    });
    return n_listed;
}

// Shadow edges (Algorithm 3) of light l on every receiver in front of the light that faces
// it.
void project_shadow_edges(const BakeGeometry& g, const Regions& regions, const Bvh& bvh,
                          std::uint32_t l, const ShootResult& shot,
                          const std::vector<std::uint32_t>& receivers, LightModel model,
                          const EmitterEdges& emitter, std::span<const std::uint32_t> siblings,
                          OneLight& out) {
    const Patch& light = g.patches[l];
    const double emittance = visdb::channel_mean(g.emittance[l]);
    // The emitter's area (the light and its siblings) over the light's
    double emitter_area = g.area[l];
    for (const std::uint32_t s : siblings) emitter_area += g.area[s];
    const double area_ratio = emitter_area / g.area[l];
    // The regions the light's hemicube reached, or could not see: the others get no light, so
    // no shadow edge
    std::vector<char> reached(regions.planar.size(), 0);
    for (const std::uint32_t j : receivers)
        if (shot.form_factor[j] > 0.0 || unseen_from_centroid(light, g.patches[j]))
            reached[regions.of_triangle[j]] = 1;
    std::mutex accumulate;
    tbb::parallel_for(
        tbb::blocked_range<std::size_t>(0, receivers.size(), 32), [&](const auto& range) {
            std::vector<LitSegment> here;
            std::vector<std::uint32_t> ids;
            std::vector<const Patch*> occ;
            ShadowStats s;
            visdb::ShadowEdgeStats counts;
            for (std::size_t ji = range.begin(); ji != range.end(); ++ji) {
                const std::uint32_t j = receivers[ji];
                if (j == l || visdb::any_positive(g.emittance[j]) ||
                    !reached[regions.of_triangle[j]])
                    continue;
                const Patch& r = g.patches[j];
                if (!may_light(light, r)) continue;
                const glm::dvec3 rn = unit_normal(r);
                const std::size_t n_listed = edge_occluders(g, bvh, l, j, shot, ids);
                if (ids.empty()) continue;
                ++counts.receivers;
                counts.occluders_listed += n_listed;
                counts.occluders_added_by_bvh += ids.size() - n_listed;
                occ.clear();
                for (std::uint32_t id : ids) occ.push_back(&g.patches[id]);
                // The light's largest unoccluded form factor on the receiver (at its corners
                // and centroid): a shadow edge bounds a region of the receiver where this
                // light's part changes by up to that much (at the light's own plane it is 0 on
                // the edge and grows beside it)
                double f_receiver = -1.0;
                for (const ShadowSegment& seg :
                     shadow_edges(light, model, r, occ, kLengthTolerance * g.size, &s, emitter)) {
                    if (f_receiver < 0.0) {
                        f_receiver = visible_form_factor(centroid(r), rn, light, {});
                        for (const glm::dvec3& x : r.p)
                            f_receiver =
                                std::max(f_receiver, visible_form_factor(x, rn, light, {}));
                    }
                    double f = f_receiver;
                    for (const glm::dvec3& x : {seg.a, 0.5 * (seg.a + seg.b), seg.b})
                        f = std::max(f, visible_form_factor(x, rn, light, {}));
                    here.push_back({j, l, seg, emittance * f, area_ratio * emittance * f,
                                    area_ratio * visdb::channel_mean(out.triangle[j])});
                }
            }
            std::lock_guard lock(accumulate);
            add_segments(here, s, counts, out);
        });
}

// What every light's culled shot shares: each planar region's triangles, ascending (the
// receivers of the regions a shot reached), and the walls and slabs its walk rasterizes first.
struct ShotContext {
    std::vector<std::uint32_t> region_start, region_triangles;
    std::optional<Occluders> occluders;
};

ShotContext shot_context(const BakeGeometry& g, const Regions& regions,
                         const BakeOptions& options) {
    ShotContext c;
    c.region_start.assign(regions.planar.size() + 1, 0);
    for (const std::uint32_t r : regions.of_triangle) ++c.region_start[r + 1];
    for (std::size_t r = 0; r < regions.planar.size(); ++r)
        c.region_start[r + 1] += c.region_start[r];
    c.region_triangles.resize(regions.of_triangle.size());
    std::vector<std::uint32_t> fill(c.region_start.begin(), c.region_start.end() - 1);
    for (std::size_t t = 0; t < regions.of_triangle.size(); ++t)
        c.region_triangles[fill[regions.of_triangle[t]]++] = static_cast<std::uint32_t>(t);
    // The interreflection's rule: a cell of its element grid and larger
    c.occluders.emplace(large_occluders(g.patches, options.element_size * options.element_size,
                                        kNearOccluders * options.element_size));
    return c;
}

// The triangles of every region light l's culled shot reached (a triangle with some of its
// light, or one the hemicube cannot see the front of though part of the light is in front of
// it: unseen_from_centroid), ascending, the light excluded. A triangle of a reached region that
// the walk culled (behind closed pixels as seen from the centroid) is a receiver too: part of
// the light may still reach it past the occluders that hid it (penumbra). So are the
// triangles of the regions of `corner_lit` (lit_from_corners).
std::vector<std::uint32_t> reached_triangles(const BakeGeometry& g, const Regions& regions,
                                             const ShotContext& c, std::uint32_t l,
                                             const ShootResult& shot,
                                             std::span<const std::uint32_t> corner_lit) {
    const Patch& light = g.patches[l];
    const glm::dvec3 normal = unit_normal(light);
    std::vector<std::uint32_t> reached;
    for (const std::uint32_t id : shot.rasterized) {
        bool lit = shot.form_factor[id] > 0.0;
        if (!lit) {
            const Patch& r = g.patches[id];
            bool in_front = false;
            for (const glm::dvec3& x : r.p) in_front |= glm::dot(x - light.p[0], normal) > 0.0;
            lit = in_front && unseen_from_centroid(light, r);
        }
        if (lit) reached.push_back(regions.of_triangle[id]);
    }
    for (const std::uint32_t id : corner_lit) reached.push_back(regions.of_triangle[id]);
    std::sort(reached.begin(), reached.end());
    reached.erase(std::unique(reached.begin(), reached.end()), reached.end());
    std::vector<std::uint32_t> out;
    for (const std::uint32_t r : reached)
        for (std::uint32_t k = c.region_start[r]; k < c.region_start[r + 1]; ++k)
            if (c.region_triangles[k] != l) out.push_back(c.region_triangles[k]);
    std::sort(out.begin(), out.end());
    return out;
}

constexpr double kCornerInset = 0.01;  // of the way from a light's corner to its centroid

// The triangles that hemicubes at light l's corners (pulled 1 % toward its centroid) give
// light and that its centroid's `shot` does not, ascending: receivers the light reaches only
// from part of itself, which the centroid's hemicube cannot tell from those it does not reach.
// A face the centroid sees only behind an occluder (lit through a gap by the light's far end),
// or smaller than a sample from the centroid, would otherwise get none of the light's exact
// irradiance: its region would not ask the light. Such regions ask it, but get no shadow edges
// from it (the refinement follows its light there): they are faces of a few square
// centimetres or in a penumbra, and their edges cost more mesh than they buy.
std::vector<std::uint32_t> lit_from_corners(const BakeGeometry& g, const Bvh& bvh,
                                            const ShotContext& context, const Hemicube& hemicube,
                                            std::uint32_t l, const ShootResult& shot,
                                            const BakeOptions& options) {
    const Patch& light = g.patches[l];
    const glm::dvec3 c = centroid(light), n = unit_normal(light);
    ShootOptions so{.method = options.method, .subpixels = options.subpixels, .occlusion = false};
    so.exclude = l;
    so.bvh = &bvh;
    so.sparse = true;
    so.occluders_first = &*context.occluders;
    std::vector<std::uint32_t> out;
    for (const glm::dvec3& p : light.p) {
        const ShootResult corner =
            shoot(ShooterFrame::at(p + kCornerInset * (c - p), n), g.patches, hemicube, so);
        for (const PatchFormFactor& hit : corner.hits)
            if (!(shot.form_factor[hit.patch] > 0.0)) out.push_back(hit.patch);
    }
    std::sort(out.begin(), out.end());
    out.erase(std::unique(out.begin(), out.end()), out.end());
    return out;
}

// Shoots from light l and computes what the bake asks of it.
OneLight shoot_one(const BakeGeometry& g, const Regions& regions, const Bvh& bvh,
                   const ShotContext& context, const Hemicube& hemicube, std::uint32_t l,
                   const EmitterEdges& emitter, std::span<const std::uint32_t> siblings,
                   const BakeOptions& options) {
    const bool exact = options.shading == Shading::Exact;
    OneLight out;
    const auto t0 = Clock::now();
    // Hemicube at the light triangle's centroid, around its front normal. With DM or patch
    // shading (and unlimited reach) the shot walks the BVH front to back and culls what lies
    // behind closed pixels, so that it costs what the light sees, not the building; its
    // receivers are then the triangles of the regions it reached (reached_triangles). Exact
    // shading without DM, or a limited reach, draws every triangle in front of the light
    // within its reach (cull.h): the vertices' occlusion lists then spare most of those behind
    // walls the shaft query (shade_vertices_exactly).
    ShootOptions so{
        .method = options.method, .subpixels = options.subpixels, .occlusion = exact || options.dm};
    so.exclude = l;
    const bool walk = (options.dm || !exact) && !(options.reach > 0.0);
    if (walk) {
        so.bvh = &bvh;
        so.cull_listed = true;
        so.occluders_first = &*context.occluders;
    } else {
        out.near = light_candidates(bvh, g.patches, l, options.reach);
        out.near_vertices = vertices_of(out.near, g.mesh.triangles);
        so.only = &out.near;
    }
    const ShooterFrame from = frame_of(g.patches[l]);
    const ShootResult shot = shoot(from, g.patches, hemicube, so);
    if (walk) {
        if (options.dm)
            out.corner_lit = lit_from_corners(g, bvh, context, hemicube, l, shot, options);
        out.near = reached_triangles(g, regions, context, l, shot, out.corner_lit);
    }
    out.shoot.seconds_cpu = seconds_since(t0);

    out.triangle.assign(g.patches.size(), visdb::Rgb(0.0));
    out.shoot.form_factor_sum =
        add_patch_irradiance(shot, from, g.emittance[l], g.area[l], g, out.triangle);
    out.shoot.fragments = shot.fragments;
    out.shoot.undersampled_fragments = shot.undersampled_pixels;
    out.shoot.occlusion_pairs = shot.occlusion.size();
    out.shoot.occlusion_pairs_raw = shot.raw_pairs;
    out.shoot.seconds_occlusion_cpu = shot.seconds_occlusion;

    const auto t1 = Clock::now();
    if (exact && !options.dm) shade_vertices_exactly(g, bvh, l, shot, out.near_vertices, out);
    out.exact.seconds_cpu = seconds_since(t1);

    const auto t2 = Clock::now();
    if (options.dm)
        project_shadow_edges(g, regions, bvh, l, shot, out.near, options.lights, emitter, siblings,
                             out);
    out.shadow.seconds_cpu = seconds_since(t2);
    return out;
}

// A luminaire's light at `x` on a surface of unit normal `n` were nothing in the way (mean
// over RGB): I(−ω)·cos θ / d².
double unoccluded_point_irradiance(const visdb::Luminaire& lum, const glm::dvec3& x,
                                   const glm::dvec3& n) {
    const glm::dvec3 to = lum.position - x;
    const double d2 = glm::dot(to, to);
    if (!(d2 > 0.0)) return 0.0;
    const glm::dvec3 w = to / std::sqrt(d2);
    const double cos_theta = glm::dot(n, w);
    return cos_theta > 0.0 ? visdb::channel_mean(lum.intensity(-w)) * cos_theta / d2 : 0.0;
}

// The points on a flat luminous opening (rectangle or disc, of positive size) its penumbra
// edges are cast from: the rectangle's four corners, or kDiscRimPoints points on the disc's
// rim (an ellipse of semi-axes length/2, width/2). Empty for a point or a solid opening (those
// are lit from the centre alone, direct.cpp).
constexpr int kDiscRimPoints = 8;
std::vector<glm::dvec3> opening_corners(const visdb::Luminaire& lum) {
    using Shape = visdb::LuminousOpening::Shape;
    const visdb::LuminousOpening& o = lum.opening;
    std::vector<glm::dvec3> out;
    if ((o.shape != Shape::Rectangle && o.shape != Shape::Disc) ||
        !(o.length > 0.0 && o.width > 0.0))
        return out;
    const double ax = 0.5 * o.length, ay = 0.5 * o.width;
    if (o.shape == Shape::Rectangle) {
        for (const double u : {-ax, ax})
            for (const double v : {-ay, ay})
                out.push_back(lum.position + u * lum.axis_x + v * lum.axis_y);
        return out;
    }
    for (int k = 0; k < kDiscRimPoints; ++k) {
        const double phi = 2.0 * std::numbers::pi * k / kDiscRimPoints;
        out.push_back(lum.position + ax * std::cos(phi) * lum.axis_x +
                      ay * std::sin(phi) * lum.axis_y);
    }
    return out;
}

// Distance from `x` to the axis-aligned box of triangle `r`: a lower bound of its distance to
// any point of the triangle.
double distance_to_box(const glm::dvec3& x, const Patch& r) {
    Box box;
    for (const glm::dvec3& p : r.p) box.grow(p);
    return std::sqrt(Bvh::distance2(box, x));
}

// Removes segments equal to an earlier one (either way round): a contact edge, cast alike from
// every point of an opening, is kept once.
void drop_repeated_segments(std::vector<ShadowSegment>& segments) {
    std::vector<ShadowSegment> kept;
    kept.reserve(segments.size());
    for (const ShadowSegment& s : segments) {
        const bool repeated = std::any_of(kept.begin(), kept.end(), [&s](const ShadowSegment& k) {
            return (k.a == s.a && k.b == s.b) || (k.a == s.b && k.b == s.a);
        });
        if (!repeated) kept.push_back(s);
    }
    segments.swap(kept);
}

// Shadow edges of a point source (a luminaire) on every receiver its hemicubes reached that
// faces the point: the occluders' silhouette edges projected from the point
// (point_shadow_edges). Occluders: the patches in the tetrahedron of the point and the
// receiver whose plane separates the point from some of the receiver. A receiver lit through
// a flat opening (closer to its box than five times the opening's size: the exact field
// integrates over the opening there, direct.cpp) gets the edges cast from the opening's
// corners (opening_corners) too: the bounds of the umbra and penumbra, as the vertices of a
// light triangle give (`--lights vertices`).
void project_point_shadow_edges(const BakeGeometry& g, const Regions& regions, const Bvh& bvh,
                                const visdb::Luminaire& lum, OneLight& out) {
    const glm::dvec3 source = lum.position;
    const std::vector<glm::dvec3> corners_of_opening = opening_corners(lum);
    const double opening_reach = kFiveTimes * lum.opening.size();
    std::vector<char> reached(regions.planar.size(), 0);
    for (const std::uint32_t j : out.near)
        if (visdb::any_positive(out.triangle[j])) reached[regions.of_triangle[j]] = 1;
    std::mutex accumulate;
    tbb::parallel_for(
        tbb::blocked_range<std::size_t>(0, out.near.size(), 32), [&](const auto& range) {
            std::vector<LitSegment> here;
            std::vector<const Patch*> occ;
            std::vector<ShadowSegment> segments;
            std::vector<glm::dvec3> points;
            ShadowStats s;
            visdb::ShadowEdgeStats counts;
            for (std::size_t ji = range.begin(); ji != range.end(); ++ji) {
                const std::uint32_t j = out.near[ji];
                const Patch& r = g.patches[j];
                if (visdb::any_positive(g.emittance[j]) || !reached[regions.of_triangle[j]])
                    continue;
                const glm::dvec3 rn = unit_normal(r);
                if (glm::dot(source - r.p[0], rn) <= 0.0) continue;  // the point is behind it
                // The points the edges are cast from: the centre, and the opening's corners
                // where the receiver is lit through the opening
                points.assign(1, source);
                if (!corners_of_opening.empty() && distance_to_box(source, r) < opening_reach)
                    points.insert(points.end(), corners_of_opening.begin(),
                                  corners_of_opening.end());
                segments.clear();
                bool any_occluder = false;
                for (const glm::dvec3& from : points) {
                    if (glm::dot(from - r.p[0], rn) <= 0.0) continue;  // behind the receiver
                    const Patch point{{from, from, from}, 1.0};
                    occ.clear();
                    const glm::dvec3 corners[4] = {from, r.p[0], r.p[1], r.p[2]};
                    bvh.query(Hull(corners), [&](std::uint32_t id) {
                        if (id != j && can_occlude(g.patches[id], point, r))
                            occ.push_back(&g.patches[id]);
                    });
                    if (occ.empty()) continue;
                    any_occluder = true;
                    counts.occluders_added_by_bvh += occ.size();
                    for (const ShadowSegment& seg :
                         point_shadow_edges(from, r, occ, kLengthTolerance * g.size, &s))
                        segments.push_back(seg);
                }
                if (!any_occluder) continue;
                ++counts.receivers;
                if (points.size() > 1) drop_repeated_segments(segments);
                // The most the point's light changes across a segment: its largest unoccluded
                // value on the receiver and the segment
                double f_receiver = -1.0;
                for (const ShadowSegment& seg : segments) {
                    if (f_receiver < 0.0) {
                        f_receiver = unoccluded_point_irradiance(lum, centroid(r), rn);
                        for (const glm::dvec3& x : r.p)
                            f_receiver =
                                std::max(f_receiver, unoccluded_point_irradiance(lum, x, rn));
                    }
                    double f = f_receiver;
                    for (const glm::dvec3& x : {seg.a, 0.5 * (seg.a + seg.b), seg.b})
                        f = std::max(f, unoccluded_point_irradiance(lum, x, rn));
                    here.push_back({j, kNoLight, seg, f, f, visdb::channel_mean(out.triangle[j])});
                }
            }
            std::lock_guard lock(accumulate);
            add_segments(here, s, counts, out);
        });
}

// The triangles a luminaire shoots onto: every one, or those whose centroid is within the
// reach (cull.h).
std::vector<std::uint32_t> luminaire_receivers(const BakeGeometry& g, const visdb::Luminaire& lum,
                                               double reach) {
    std::vector<std::uint32_t> near;
    for (std::size_t j = 0; j < g.patches.size(); ++j) {
        const glm::dvec3 d = glm::abs(centroid(g.patches[j]) - lum.position);
        if (reach <= 0.0 || (d.x <= reach && d.y <= reach && d.z <= reach))
            near.push_back(static_cast<std::uint32_t>(j));
    }
    return near;
}

// Shoots from a luminaire as a point source: its two weighted hemicubes give each triangle
// the flux it stops (patch irradiance); exact vertex irradiance without DM, shadow segments
// from the point with DM.
OneLight shoot_luminaire(const BakeGeometry& g, const Regions& regions, const Bvh& bvh,
                         const visdb::Luminaire& lum, const BakeOptions& options) {
    OneLight out;
    const auto t0 = Clock::now();
    out.near = luminaire_receivers(g, lum, options.reach);
    out.near_vertices = vertices_of(out.near, g.mesh.triangles);
    ShootOptions so{.method = options.method, .subpixels = options.subpixels, .occlusion = false};
    so.only = &out.near;
    out.triangle.assign(g.patches.size(), visdb::Rgb(0.0));
    const visdb::Rgb power = luminaire_power(lum);
    for (const PointShooter& shooter : point_shooters(lum, options.resolution)) {
        const ShootResult shot = shoot(shooter.frame, g.patches, shooter.hemicube, so);
        out.shoot.form_factor_sum += add_flux_irradiance(shot, power, g, out.triangle);
        out.shoot.fragments += shot.fragments;
        out.shoot.undersampled_fragments += shot.undersampled_pixels;
    }
    out.shoot.seconds_cpu = seconds_since(t0);

    const auto t1 = Clock::now();
    if (options.shading == Shading::Exact && !options.dm) {
        out.vertex.assign(g.mesh.positions.size(), visdb::Rgb(0.0));
        tbb::parallel_for(std::size_t{0}, out.near_vertices.size(), [&](std::size_t vi) {
            const std::uint32_t v = out.near_vertices[vi];
            out.vertex[v] = point_source_irradiance(lum, g.patches, bvh, g.mesh.positions[v],
                                                    glm::dvec3(g.mesh.normals[v]));
        });
    }
    out.exact.seconds_cpu = seconds_since(t1);

    const auto t2 = Clock::now();
    if (options.dm) project_point_shadow_edges(g, regions, bvh, lum, out);
    out.shadow.seconds_cpu = seconds_since(t2);
    return out;
}

// Per light (index into g.lights): the edges it shares with another triangle of its emitter
// (the same planar region, so one surface and one plane, and the same emittance), across
// which the emitter's light is continuous: they cast no shadow edge.
std::vector<EmitterEdges> emitter_edges(const BakeGeometry& g, const Regions& regions) {
    std::vector<EmitterEdges> out(g.lights.size());
    for (std::size_t li = 0; li < g.lights.size(); ++li) {
        const std::uint32_t l = g.lights[li];
        const glm::u32vec3 t = g.mesh.triangles[l];
        for (int e = 0; e < 3; ++e) {
            const std::uint32_t a = t[e], b = t[(e + 1) % 3];
            for (std::uint32_t k = g.incident_start[a]; k < g.incident_start[a + 1]; ++k) {
                const std::uint32_t o = g.incident[k];
                if (o == l || regions.of_triangle[o] != regions.of_triangle[l] ||
                    g.emittance[o] != g.emittance[l])
                    continue;
                const glm::u32vec3 u = g.mesh.triangles[o];
                if (u.x == b || u.y == b || u.z == b) {
                    out[li].interior[static_cast<std::size_t>(e)] = true;
                    break;
                }
            }
        }
    }
    return out;
}

// Per light (index into g.lights): the other light triangles of its emitter, those of the same
// planar region (one surface, one plane) and the same emittance: a panel's other half.
std::vector<std::vector<std::uint32_t>> emitter_siblings(const BakeGeometry& g,
                                                         const Regions& regions) {
    std::map<std::uint32_t, std::vector<std::uint32_t>> by_region;
    for (const std::uint32_t l : g.lights) by_region[regions.of_triangle[l]].push_back(l);
    std::vector<std::vector<std::uint32_t>> out(g.lights.size());
    for (std::size_t li = 0; li < g.lights.size(); ++li) {
        const std::uint32_t l = g.lights[li];
        for (const std::uint32_t s : by_region[regions.of_triangle[l]])
            if (s != l && g.emittance[s] == g.emittance[l]) out[li].push_back(s);
    }
    return out;
}

// True when segment s of light triangle s.l on receiver s.j earns a mesh edge by its
// contrast (docs/algorithms.md#which-shadow-edges-earn-a-mesh-edge): its emitter's light
// changes across it, within `delta`, by at least `tolerance` of the irradiance there (the
// emitter's largest value beside it and `others`, the other sources' patch irradiance on j).
// The emitter's unoccluded light (s.emitter_unoccluded, its triangles taken alike) bounds the
// change: below the tolerance of the others it is dropped unmeasured, and the measure stops
// once the change passes the tolerance of that bound and the others. Occluders: those in the hull
// of the light and the segment's strip of half width delta whose plane separates the light from the
// receiver.
bool earns_edge(const BakeGeometry& g, const Bvh& bvh, const LitSegment& s,
                std::span<const std::uint32_t> siblings, double others, double tolerance,
                double delta, std::vector<const Patch*>& lights,
                std::vector<const Patch*>& occluders) {
    const Patch& light = g.patches[s.l];
    const Patch& r = g.patches[s.j];
    const double emittance = visdb::channel_mean(g.emittance[s.l]);
    const glm::dvec3 rn = unit_normal(r);
    const glm::dvec3 d = s.segment.b - s.segment.a;
    const glm::dvec3 across = glm::cross(rn, d);
    if (!(emittance > 0.0) || !(glm::length(across) > 0.0)) return true;
    const glm::dvec3 m = delta * glm::normalize(across);
    const double bound = s.emitter_unoccluded;
    if (bound < tolerance * others) return false;
    lights.assign(1, &light);
    for (const std::uint32_t k : siblings) lights.push_back(&g.patches[k]);
    const glm::dvec3 shaft[7] = {light.p[0],      light.p[1],      light.p[2],     s.segment.a + m,
                                 s.segment.a - m, s.segment.b + m, s.segment.b - m};
    occluders.clear();
    bvh.query(Hull(shaft), [&](std::uint32_t id) {
        if (id != s.l && id != s.j && can_occlude(g.patches[id], light, r))
            occluders.push_back(&g.patches[id]);
    });
    const ShadowContrast c = shadow_contrast(lights, r, occluders, s.segment, delta,
                                             tolerance * (bound + others) / emittance);
    return emittance * c.change >= tolerance * (emittance * c.level + others);
}

// The shadow segments that earn a mesh edge go to their receivers: those of a light that gives
// the receiver more than the refinement's floor (1/1000 of the brightest patch's irradiance),
// and, of a light triangle, across which its emitter's light changes by `tolerance` of the
// irradiance there (earns_edge). The others mark a change the refinement would not mesh
// either: a weak or distant light, or a weak, distant or tiny occluder (a shallow penumbra).
// A luminaire's shadow is hard: its edges change its light by its whole value. Returns how
// many were dropped.
std::uint64_t keep_strong(const BakeGeometry& g, const Bvh& bvh,
                          const std::vector<std::vector<std::uint32_t>>& siblings,
                          std::vector<LitSegment>& lit, LightShots& shots, double tolerance,
                          double delta, bool contrast) {
    double h_max = 0.0;
    for (const visdb::Rgb& h : shots.triangle_irradiance)
        h_max = std::max(h_max, visdb::channel_mean(h));
    std::vector<std::uint32_t> light_index(g.patches.size(), 0);
    for (std::size_t li = 0; li < g.lights.size(); ++li)
        light_index[g.lights[li]] = static_cast<std::uint32_t>(li);
    std::vector<char> keep(lit.size(), 0);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, lit.size(), 16), [&](const auto& range) {
        std::vector<const Patch*> lights, occluders;
        for (std::size_t i = range.begin(); i != range.end(); ++i) {
            const LitSegment& s = lit[i];
            if (s.unoccluded < 1e-3 * h_max) continue;
            if (s.l == kNoLight || !contrast) {
                keep[i] = 1;
                continue;
            }
            const double others = std::max(
                0.0, visdb::channel_mean(shots.triangle_irradiance[s.j]) - s.emitter_patch);
            keep[i] = earns_edge(g, bvh, s, siblings[light_index[s.l]], others, tolerance, delta,
                                 lights, occluders);
        }
    });
    std::uint64_t dropped = 0;
    for (std::size_t i = 0; i < lit.size(); ++i) {
        if (!keep[i]) {
            ++dropped;
            continue;
        }
        shots.segments[lit[i].j].push_back(lit[i].segment);
    }
    lit = {};
    return dropped;
}

// One (triangle, source) pair: the source's hemicube gave the triangle some light.
struct SourceOf {
    std::uint32_t triangle, source;
};

// The statistics of the sources' shots.
struct SourceStats {
    visdb::ShootStats shoot;
    visdb::ExactShadeStats exact;
    visdb::ShadowEdgeStats shadow;
};

// What a rank's sources add up to, before the ranks combine their parts.
struct SourceSums {
    SourceSums(std::size_t triangles, std::size_t vertices)
        : triangle(3 * triangles), vertex(3 * vertices) {}
    void add_triangle(std::uint32_t j, const visdb::Rgb& h) {
        for (int c = 0; c < 3; ++c) triangle.add(3 * std::size_t{j} + c, h[c]);
    }
    void add_vertex(std::uint32_t v, const visdb::Rgb& h) {
        for (int c = 0; c < 3; ++c) vertex.add(3 * std::size_t{v} + c, h[c]);
    }
    ExactSums triangle, vertex;  // patch irradiance, exact vertex irradiance (RGB)
    std::vector<LitSegment> lit;
    std::vector<SourceOf> lights_of, luminaires_of;
    SourceStats stats;
};

// The sources a rank shoots: indices into g.lights and g.luminaires, ascending.
struct SourceShare {
    std::vector<std::uint32_t> lights, luminaires;
};

// The sources this rank shoots, shared over the cluster's ranks by cost: a source's cost is
// the number of triangles it may reach (its hemicube draws them; its exact shading and shadow
// edges visit them and their vertices), twice for a luminaire (two hemicubes), plus one.
SourceShare share_sources(const BakeGeometry& g, const Bvh& bvh, const BakeOptions& options,
                          const Cluster& cluster) {
    const std::size_t nl = g.lights.size(), nk = g.luminaires.size();
    std::vector<double> cost(nl + nk, 1.0);
    if (cluster.size() > 1) {
        tbb::parallel_for(std::size_t{0}, nl, [&](std::size_t li) {
            cost[li] += static_cast<double>(
                light_candidates(bvh, g.patches, g.lights[li], options.reach).size());
        });
        for (std::size_t k = 0; k < nk; ++k)
            cost[nl + k] +=
                2.0 *
                static_cast<double>(luminaire_receivers(g, g.luminaires[k], options.reach).size());
    }
    SourceShare out;
    for (const std::uint32_t i : cluster.share(cost))
        (i < nl ? out.lights : out.luminaires)
            .push_back(i < nl ? i : i - static_cast<std::uint32_t>(nl));
    return out;
}

// Per triangle, the sources of `pairs`, ascending.
void sources_per_triangle(std::span<const std::byte> pairs,
                          std::vector<std::vector<std::uint32_t>>& out) {
    for (const SourceOf& p : values_of<SourceOf>(pairs)) out[p.triangle].push_back(p.source);
    for (auto& list : out) std::sort(list.begin(), list.end());
}

// Every rank's sums added up (exactly), its segments and pairs gathered, into `shots` on every
// rank (nt triangles, nv vertices); returns the statistics summed over the ranks.
SourceStats combine(Cluster& cluster, SourceSums& sums, std::size_t nt, std::size_t nv, bool dm,
                    LightShots& shots) {
    static_assert(std::is_trivially_copyable_v<LitSegment> &&
                  std::is_trivially_copyable_v<SourceStats>);
    cluster.sum(sums.triangle.limbs(), "shoot");
    cluster.sum(sums.vertex.limbs(), "shoot");
    shots.triangle_irradiance.assign(nt, visdb::Rgb(0.0));
    for (std::size_t j = 0; j < nt; ++j)
        for (int c = 0; c < 3; ++c)
            shots.triangle_irradiance[j][c] = sums.triangle.value(3 * j + c);
    shots.vertex_irradiance.assign(nv, visdb::Rgb(0.0));
    if (sums.vertex.size() > 0)
        for (std::size_t v = 0; v < nv; ++v)
            for (int c = 0; c < 3; ++c)
                shots.vertex_irradiance[v][c] = sums.vertex.value(3 * v + c);
    sums.lit = values_of<LitSegment>(cluster.all_gather(as_bytes_of(sums.lit), "shoot"));
    shots.lights_of_triangle.resize(dm ? nt : 0);
    shots.luminaires_of_triangle.resize(dm ? nt : 0);
    if (dm) {
        sources_per_triangle(cluster.all_gather(as_bytes_of(sums.lights_of), "shoot"),
                             shots.lights_of_triangle);
        sources_per_triangle(cluster.all_gather(as_bytes_of(sums.luminaires_of), "shoot"),
                             shots.luminaires_of_triangle);
    }
    const std::vector<SourceStats> parts = values_of<SourceStats>(
        cluster.all_gather(as_bytes_of(std::vector<SourceStats>{sums.stats}), "shoot"));
    SourceStats total;
    for (const SourceStats& p : parts) {
        total.shoot += p.shoot;
        total.exact += p.exact;
        total.shadow += p.shadow;
    }
    return total;
}

}  // namespace

LightShots shoot_lights(const BakeGeometry& g, const Regions& regions, const Bvh& bvh,
                        const Hemicube& hemicube, const BakeOptions& options,
                        visdb::BakeStats* stats, const ProgressFn& progress) {
    const std::size_t nt = g.mesh.triangles.size(), nv = g.mesh.positions.size();
    const bool exact_vertices = options.shading == Shading::Exact && !options.dm;
    LightShots shots;
    shots.segments.resize(options.dm ? nt : 0);
    // The sums over the sources are exact (exact_sum.h): the same bits whatever order the
    // sources finish in and however many ranks share them
    SourceSums sums(nt, exact_vertices ? nv : 0);
    std::mutex accumulate;
    std::size_t done = 0;
    const std::vector<EmitterEdges> emitter =
        options.dm ? emitter_edges(g, regions) : std::vector<EmitterEdges>(g.lights.size());
    const std::vector<std::vector<std::uint32_t>> siblings =
        options.dm ? emitter_siblings(g, regions)
                   : std::vector<std::vector<std::uint32_t>>(g.lights.size());

    // The sources this rank shoots (all of them without MPI), shared by their cost
    Cluster alone;
    Cluster& cluster = options.cluster ? *options.cluster : alone;
    const SourceShare mine = share_sources(g, bvh, options, cluster);
    const ShotContext context = shot_context(g, regions, options);
    const std::size_t sources = mine.lights.size() + mine.luminaires.size();
    // Adds one source's shot to the totals (under the lock)
    // (`light`: an area light's triangle, whose hemicube from the centroid may miss a receiver
    // it lights; a luminaire's two hemicubes see every direction)
    auto add = [&](const OneLight& one, std::vector<SourceOf>& sources_of, std::uint32_t source,
                   const Patch* light) {
        // The source's receivers and their vertices are the only non-zero entries
        for (const std::uint32_t j : one.near) sums.add_triangle(j, one.triangle[j]);
        if (exact_vertices)
            for (const std::uint32_t v : one.near_vertices) sums.add_vertex(v, one.vertex[v]);
        sums.lit.insert(sums.lit.end(), one.segments.begin(), one.segments.end());
        if (options.dm)
            for (const std::uint32_t j : one.near)
                if (visdb::any_positive(one.triangle[j]) ||
                    (light && unseen_from_centroid(*light, g.patches[j])))
                    sources_of.push_back({j, source});
        for (const std::uint32_t j : one.corner_lit) sources_of.push_back({j, source});
        sums.stats.shoot += one.shoot;
        sums.stats.exact += one.exact;
        sums.stats.shadow += one.shadow;
        ++done;
        if (progress) progress("shoot", done, sources);
    };
    if (progress) progress("shoot", 0, sources);
    tbb::parallel_for(std::size_t{0}, mine.lights.size(), [&](std::size_t i) {
        const std::uint32_t li = mine.lights[i], l = g.lights[li];
        const OneLight one =
            shoot_one(g, regions, bvh, context, hemicube, l, emitter[li], siblings[li], options);
        std::lock_guard lock(accumulate);
        add(one, sums.lights_of, l, &g.patches[l]);
    });
    // Luminaires one after the other (each shades and casts in parallel)
    for (const std::uint32_t k : mine.luminaires) {
        const OneLight one = shoot_luminaire(g, regions, bvh, g.luminaires[k], options);
        add(one, sums.luminaires_of, k, nullptr);
    }

    // Every rank's part, added up on every rank
    const SourceStats totals = combine(cluster, sums, nt, nv, options.dm, shots);
    const visdb::ShootStats& shoot_stats = totals.shoot;
    const visdb::ExactShadeStats& exact_stats = totals.exact;
    visdb::ShadowEdgeStats shadow_stats = totals.shadow;
    std::vector<LitSegment>& lit = sums.lit;
    if (options.dm)
        shadow_stats.segments_weak = keep_strong(
            g, bvh, siblings, lit, shots, options.shadow_contrast * options.refine_tolerance,
            refine_min_edge(options, g.size),
            options.shadow_contrast > 0.0 && options.lights != LightModel::Centroid);

    if (stats) {
        // Energy: emitted power, and power arriving on the receivers (from the hemicube)
        double emitted = 0.0, received = 0.0, light_area = 0.0;
        for (std::uint32_t l : g.lights) {
            emitted += visdb::channel_mean(g.emittance[l]) * g.area[l];
            light_area += g.area[l];
        }
        for (const visdb::Luminaire& lum : g.luminaires)
            emitted += visdb::channel_mean(luminaire_power(lum));
        for (std::size_t t = 0; t < nt; ++t)
            received += visdb::channel_mean(shots.triangle_irradiance[t]) * g.area[t];
        stats->light_triangles = g.lights.size();
        stats->light_area_m2 = light_area;
        stats->shoot = shoot_stats;
        const std::size_t all_sources = g.lights.size() + g.luminaires.size();
        stats->mean_form_factor_sum =
            all_sources > 0 ? shoot_stats.form_factor_sum / static_cast<double>(all_sources) : 0.0;
        stats->emitted_power_w = emitted;
        stats->received_power_w = received;
        if (options.dm) {
            if (!stats->dm) stats->dm.emplace();
            stats->dm->shadow = shadow_stats;
        } else {
            stats->exact_shade = exact_stats;
        }
    }
    return shots;
}

}  // namespace abrad::radiosity
