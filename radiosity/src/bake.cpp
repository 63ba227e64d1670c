// Direct-light bake: one A-buffer hemicube shot per light-source triangle (the paper's
// progressive refinement restricted to the lights), then vertex shades.

#include "abrad/radiosity/bake.h"

#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <limits>
#include <mutex>
#include <numeric>
#include <optional>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "abrad/radiosity/bvh.h"
#include "abrad/radiosity/cull.h"
#include "abrad/radiosity/direct.h"
#include "abrad/radiosity/dm_mesh.h"
#include "abrad/radiosity/exact.h"
#include "abrad/radiosity/indirect.h"
#include "abrad/radiosity/shadow_edges.h"

namespace abrad::radiosity {

namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) {
    return std::chrono::duration<double>(Clock::now() - t0).count();
}

// The bake mesh with what shading needs beside it.
struct Work {
    visdb::BakeMesh mesh;
    std::vector<Patch> patches;                           // one per mesh triangle
    std::vector<double> area;                             // per triangle, m²
    std::vector<visdb::Rgb> emittance;                    // per triangle
    std::vector<visdb::Rgb> reflectance;                  // per triangle
    std::vector<std::uint32_t> incident_start, incident;  // triangles around each vertex (CSR)
    std::size_t degenerate = 0;
};

// Triangles around each vertex, as compressed rows.
void build_incidence(const visdb::BakeMesh& mesh, std::vector<std::uint32_t>& start,
                     std::vector<std::uint32_t>& incident) {
    const std::size_t nv = mesh.positions.size();
    start.assign(nv + 1, 0);
    for (const auto& t : mesh.triangles)
        for (int k = 0; k < 3; ++k) ++start[t[k] + 1];
    for (std::size_t i = 0; i < nv; ++i) start[i + 1] += start[i];
    incident.resize(start[nv]);
    std::vector<std::uint32_t> fill(start.begin(), start.end() - 1);
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t)
        for (int k = 0; k < 3; ++k)
            incident[fill[mesh.triangles[t][k]]++] = static_cast<std::uint32_t>(t);
}

// Splits vertices by surface and face normal: faces of different planes never share one.
Work build_mesh(const visdb::Scene& scene) {
    Work w;
    // Faces share a vertex when their exact (double) unit normals agree to cos >= 1 - 1e-9
    constexpr double kSameNormal = 1.0 - 1e-9;
    for (std::size_t s = 0; s < scene.surfaces.size(); ++s) {
        const visdb::Surface& surface = scene.surfaces[s];
        if (surface.material >= scene.materials.size())
            throw BakeError("surface '" + surface.name + "' has no material " +
                            std::to_string(surface.material));
        const visdb::Material& material = scene.materials[surface.material];
        // For each source vertex: the bake vertices made from it, with their exact normals
        std::vector<std::vector<std::pair<std::uint32_t, glm::dvec3>>> made(
            surface.mesh.positions.size());
        for (const glm::u32vec3& t : surface.mesh.triangles) {
            const glm::dvec3 a = surface.mesh.positions.at(t.x), b = surface.mesh.positions.at(t.y),
                             c = surface.mesh.positions.at(t.z);
            const glm::dvec3 cr = glm::cross(b - a, c - a);
            const double len = glm::length(cr);
            if (!(len > 0.0) || !std::isfinite(len)) {
                ++w.degenerate;
                continue;
            }
            const glm::dvec3 normal = cr / len;
            glm::u32vec3 tri;
            for (int k = 0; k < 3; ++k) {
                const std::uint32_t src = t[k];
                std::uint32_t found = kNoPatch;
                for (const auto& [cand, cand_normal] : made[src])
                    if (glm::dot(cand_normal, normal) >= kSameNormal) {
                        found = cand;
                        break;
                    }
                if (found == kNoPatch) {
                    found = static_cast<std::uint32_t>(w.mesh.positions.size());
                    w.mesh.positions.push_back(surface.mesh.positions[src]);
                    w.mesh.normals.push_back(glm::vec3(normal));
                    made[src].emplace_back(found, normal);
                }
                tri[k] = found;
            }
            w.mesh.triangles.push_back(tri);
            w.mesh.triangle_surface.push_back(static_cast<std::uint32_t>(s));
            w.patches.push_back({{a, b, c}, material.opacity});
            w.area.push_back(0.5 * len);
            w.emittance.push_back(material.emittance);
            w.reflectance.push_back(material.reflectance);
        }
    }
    build_incidence(w.mesh, w.incident_start, w.incident);
    return w;
}

double mean(const visdb::Rgb& c) { return (c.x + c.y + c.z) / 3.0; }

bool emits(const visdb::Rgb& e) { return e.x > 0.0 || e.y > 0.0 || e.z > 0.0; }

glm::dvec3 unit_normal(const Patch& p) {
    return glm::normalize(glm::cross(p.p[1] - p.p[0], p.p[2] - p.p[0]));
}

// False when `c` cannot hide any part of `light` from any part of `receiver`: the six
// corners lie on one closed side of c's plane, so no segment between them crosses it (a
// floor cannot shadow a wall standing on it; a wall cannot shadow the floor).
bool can_occlude(const Patch& c, const Patch& light, const Patch& receiver) {
    const glm::dvec3 cr = glm::cross(c.p[1] - c.p[0], c.p[2] - c.p[0]);
    const double len = glm::length(cr);
    if (!(len > 0.0)) return false;
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

// Exact direct irradiance at any point from every light; occluders from a conservative query
// of the box around the point and each light.
visdb::Rgb exact_irradiance(const Work& w, const Bvh& bvh, std::span<const std::uint32_t> lights,
                            const glm::dvec3& x, const glm::dvec3& n,
                            std::vector<const Patch*>& occ, double reach) {
    visdb::Rgb h(0.0);
    for (const std::uint32_t l : lights) {
        const Patch& lp = w.patches[l];
        // Behind the light's plane (it gives nothing), or beyond its reach (cull.h)
        if (glm::dot(x - lp.p[0], glm::cross(lp.p[1] - lp.p[0], lp.p[2] - lp.p[0])) <= 0.0)
            continue;
        if (reach > 0.0) {
            const glm::dvec3 d = glm::abs(x - (lp.p[0] + lp.p[1] + lp.p[2]) / 3.0);
            if (d.x > reach || d.y > reach || d.z > reach) continue;
        }
        occ.clear();
        for_each_shadow_candidate(bvh, w.patches, l, x,
                                  [&](std::uint32_t id) { occ.push_back(&w.patches[id]); });
        h += w.emittance[l] * visible_form_factor(x, n, w.patches[l], occ);
    }
    return h;
}

// Planar regions: edge- or vertex-connected triangles of one surface and one plane (bake
// vertices are already split by surface and normal, so connected components suffice).
struct Regions {
    std::vector<PlanarRegion> planar;
    std::vector<std::uint32_t> surface;      // per region
    std::vector<char> emitter;               // per region
    std::vector<std::uint32_t> of_triangle;  // per bake triangle
};

Regions make_regions(const Work& w) {
    const std::size_t nv = w.mesh.positions.size(), nt = w.mesh.triangles.size();
    std::vector<std::uint32_t> parent(nv);
    std::iota(parent.begin(), parent.end(), 0u);
    auto find = [&](std::uint32_t a) {
        while (parent[a] != a) a = parent[a] = parent[parent[a]];
        return a;
    };
    for (const auto& t : w.mesh.triangles) {
        const std::uint32_t a = find(t.x), b = find(t.y), c = find(t.z);
        parent[b] = a;
        parent[find(c)] = a;
    }
    Regions r;
    r.of_triangle.resize(nt);
    std::vector<std::uint32_t> region_of_root(nv, kNoPatch), local(nv, kNoPatch);
    std::vector<glm::dvec3> normal_sum;
    for (std::size_t t = 0; t < nt; ++t) {
        const glm::u32vec3 tri = w.mesh.triangles[t];
        const std::uint32_t root = find(tri.x);
        if (region_of_root[root] == kNoPatch) {
            region_of_root[root] = static_cast<std::uint32_t>(r.planar.size());
            r.planar.emplace_back();
            r.surface.push_back(w.mesh.triangle_surface[t]);
            r.emitter.push_back(emits(w.emittance[t]));
            normal_sum.emplace_back(0.0);
        }
        const std::uint32_t id = region_of_root[root];
        r.of_triangle[t] = id;
        PlanarRegion& region = r.planar[id];
        glm::u32vec3 lt;
        for (int k = 0; k < 3; ++k) {
            if (local[tri[k]] == kNoPatch) {
                local[tri[k]] = static_cast<std::uint32_t>(region.positions.size());
                region.positions.push_back(w.mesh.positions[tri[k]]);
            }
            lt[k] = local[tri[k]];
        }
        region.triangles.push_back(lt);
        const Patch& p = w.patches[t];
        normal_sum[id] += glm::cross(p.p[1] - p.p[0], p.p[2] - p.p[0]);
    }
    for (std::size_t i = 0; i < r.planar.size(); ++i)
        r.planar[i].normal = glm::normalize(normal_sum[i]);
    return r;
}

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

// The meshed regions as one bake mesh (each region's vertices its own).
void assemble(const Regions& regions, const std::vector<MeshedRegion>& meshed,
              visdb::BakeMesh& mesh, std::vector<std::uint32_t>& vertex_region) {
    mesh = {};
    vertex_region.clear();
    for (std::size_t r = 0; r < meshed.size(); ++r) {
        const auto base = static_cast<std::uint32_t>(mesh.positions.size());
        const glm::vec3 n(regions.planar[r].normal);
        for (const glm::dvec3& p : meshed[r].positions) {
            mesh.positions.push_back(p);
            mesh.normals.push_back(n);
            vertex_region.push_back(static_cast<std::uint32_t>(r));
        }
        for (const glm::u32vec3& t : meshed[r].triangles) {
            mesh.triangles.push_back(t + glm::u32vec3(base));
            mesh.triangle_surface.push_back(regions.surface[r]);
        }
    }
}

// Per triangle: the patch, its area, emittance and reflectance (for shooting onto a mesh).
void describe_triangles(const visdb::Scene& scene, Work& w) {
    w.patches.clear();
    w.area.clear();
    w.emittance.clear();
    w.reflectance.clear();
    for (std::size_t t = 0; t < w.mesh.triangles.size(); ++t) {
        const glm::u32vec3 tri = w.mesh.triangles[t];
        const visdb::Material& m =
            scene.materials[scene.surfaces[w.mesh.triangle_surface[t]].material];
        const Patch p{{w.mesh.positions[tri.x], w.mesh.positions[tri.y], w.mesh.positions[tri.z]},
                      m.opacity};
        w.patches.push_back(p);
        w.area.push_back(0.5 * glm::length(glm::cross(p.p[1] - p.p[0], p.p[2] - p.p[0])));
        w.emittance.push_back(m.emittance);
        w.reflectance.push_back(m.reflectance);
    }
    build_incidence(w.mesh, w.incident_start, w.incident);
}

// Patch irradiance H_j = E_L · F_Lj · A_L / A_j of every triangle of `target` from one shot
// at the light's centroid; returns Σ F.
double add_patch_irradiance(const ShootResult& shot, const visdb::Rgb& emittance, double light_area,
                            const Work& target, std::vector<visdb::Rgb>& tri) {
    double ff_sum = 0.0;
    for (std::size_t j = 0; j < target.patches.size(); ++j) {
        if (shot.form_factor[j] <= 0.0 || !(target.area[j] > 0.0)) continue;
        ff_sum += shot.form_factor[j];
        tri[j] += emittance * (shot.form_factor[j] * light_area / target.area[j]);
    }
    return ff_sum;
}

// Each vertex gets the area-weighted irradiance of its triangles.
std::vector<visdb::Rgb> average_to_vertices(const Work& w, const std::vector<visdb::Rgb>& tri) {
    std::vector<visdb::Rgb> vert(w.mesh.positions.size(), visdb::Rgb(0.0));
    for (std::size_t v = 0; v < vert.size(); ++v) {
        visdb::Rgb sum(0.0);
        double area = 0.0;
        for (std::uint32_t k = w.incident_start[v]; k < w.incident_start[v + 1]; ++k) {
            const std::uint32_t t = w.incident[k];
            sum += tri[t] * w.area[t];
            area += w.area[t];
        }
        vert[v] = area > 0.0 ? sum / area : visdb::Rgb(0.0);
    }
    return vert;
}

}  // namespace

std::string to_string(Shading shading) { return shading == Shading::Exact ? "exact" : "patch"; }

void validate(const BakeOptions& o) {
    if (o.resolution < 2 || o.resolution > 4096 || o.resolution % 2 != 0)
        throw BakeError("--resolution must be an even number in [2, 4096], got " +
                        std::to_string(o.resolution));
    if (o.method == Visibility::ABuffer && o.subpixels != 4 && o.subpixels != 8 &&
        o.subpixels != 16)
        throw BakeError("--subpixels must be 4, 8 or 16, got " + std::to_string(o.subpixels));
    if (o.bounces < -1 || o.bounces > 1000)
        throw BakeError("--bounces must be in [0, 1000] (or -1: until converged), got " +
                        std::to_string(o.bounces));
    validate(IndirectOptions{.bounces = std::max(o.bounces, 0),
                             .converge = o.converge,
                             .element_size = o.element_size,
                             .overrelaxation = o.overrelaxation});
    if (!(o.reach >= 0.0 && o.reach < 1e7))
        throw BakeError("--reach must be >= 0 metres (0 = unlimited), got " +
                        std::to_string(o.reach));
    if (o.threads < 0) throw BakeError("--threads must be >= 0, got " + std::to_string(o.threads));
    if (!(o.dm_min_angle >= 0.0 && o.dm_min_angle <= 20.7))
        throw BakeError("--dm-angle must be in [0, 20.7] degrees, got " +
                        std::to_string(o.dm_min_angle));
    if (o.refine_rounds < 0 || o.refine_rounds > 20)
        throw BakeError("--refine-rounds must be in [0, 20], got " +
                        std::to_string(o.refine_rounds));
    if (!(o.refine_tolerance > 0.0 && o.refine_tolerance < 1e3))
        throw BakeError("--refine-tolerance must be > 0, got " +
                        std::to_string(o.refine_tolerance));
    if (!(o.refine_min_edge > 0.0 && std::isfinite(o.refine_min_edge)))
        throw BakeError("--refine-min-edge must be > 0 metres, got " +
                        std::to_string(o.refine_min_edge));
}

namespace {

visdb::Bake bake_here(const visdb::Scene& scene, const BakeOptions& options,
                      const ProgressFn& progress);

/// The centre of the scene's bounding box rounded to whole metres: the origin of the local
/// frame the bake works in. Subtracting it from survey coordinates (1e6 m) is exact (Sterbenz),
/// and leaves the hemicube's float depths, the mesher's plane frames and every tolerance
/// working on coordinates of the building's own size.
glm::dvec3 local_origin(const visdb::Scene& scene) {
    glm::dvec3 lo{std::numeric_limits<double>::max()};
    glm::dvec3 hi{std::numeric_limits<double>::lowest()};
    for (const auto& s : scene.surfaces)
        for (const glm::dvec3& p : s.mesh.positions) {
            lo = glm::min(lo, p);
            hi = glm::max(hi, p);
        }
    if (!(lo.x <= hi.x)) return glm::dvec3{0.0};
    return glm::round(0.5 * (lo + hi));
}

}  // namespace

visdb::Bake bake(const visdb::Scene& scene, const BakeOptions& options,
                 const ProgressFn& progress) {
    const glm::dvec3 origin = local_origin(scene);
    // Within a kilometre of the origin the scene's own frame is local enough
    if (glm::length(origin) < 1e3) return bake_here(scene, options, progress);
    visdb::Scene local = scene;
    for (auto& s : local.surfaces)
        for (glm::dvec3& p : s.mesh.positions) p -= origin;
    visdb::Bake result = bake_here(local, options, progress);
    for (glm::dvec3& p : result.mesh.positions) p += origin;
    result.parameters.emplace_back(
        "local_origin",
        std::to_string(origin.x) + " " + std::to_string(origin.y) + " " + std::to_string(origin.z));
    return result;
}

namespace {

visdb::Bake bake_here(const visdb::Scene& scene, const BakeOptions& options,
                      const ProgressFn& progress) {
    validate(options);
    const auto t_start = Clock::now();
    Work w = build_mesh(scene);
    const std::size_t nt = w.mesh.triangles.size(), nv = w.mesh.positions.size();
    if (nt == 0) throw BakeError("the scene has no triangles to bake");

    std::vector<std::uint32_t> lights;
    for (std::size_t t = 0; t < nt; ++t)
        if (emits(w.emittance[t])) lights.push_back(static_cast<std::uint32_t>(t));
    if (lights.empty())
        throw BakeError("the scene has no light sources (no material with emittance > 0)");

    std::optional<tbb::global_control> limit;
    if (options.threads > 0)
        limit.emplace(tbb::global_control::max_allowed_parallelism,
                      static_cast<std::size_t>(options.threads));

    const Hemicube hemicube(options.resolution);
    const bool exact = options.shading == Shading::Exact;
    const bool dm = options.dm;
    const ShootOptions shoot_options{
        .method = options.method, .subpixels = options.subpixels, .occlusion = exact || dm};

    // Shoot from every light triangle: patch irradiance per triangle; without DM, exact
    // irradiance per vertex; with DM, the shadow edges on every receiver.
    std::vector<visdb::Rgb> tri_irradiance(nt, visdb::Rgb(0.0));
    std::vector<visdb::Rgb> vert_irradiance(nv, visdb::Rgb(0.0));
    std::vector<std::vector<ShadowSegment>> segments(dm ? nt : 0);
    ShadowStats shadow_stats;
    std::mutex accumulate;
    std::size_t fragments = 0, undersampled = 0, pairs = 0, raw_pairs = 0, done = 0;
    std::size_t occluders_tested = 0, occluders_touched = 0, occluders_missed_by_lists = 0;
    std::size_t shadow_receivers = 0, shadow_occluders_listed = 0, shadow_occluders_added = 0;
    const Bvh bvh(w.patches);
    double ff_sum_total = 0.0, seconds_shoot = 0.0, seconds_shade = 0.0, seconds_edges = 0.0;
    double seconds_occlusion = 0.0;
    if (progress) progress("shoot", 0, lights.size());

    tbb::parallel_for(std::size_t{0}, lights.size(), [&](std::size_t li) {
        const std::uint32_t l = lights[li];
        const Patch& light = w.patches[l];
        const auto t0 = Clock::now();
        // Hemicube at the light triangle's centroid, around its front normal
        const glm::dvec3 normal = unit_normal(light);
        ShootOptions so = shoot_options;
        so.exclude = l;
        // Culling: only triangles in front of the light and within its reach (cull.h)
        const std::vector<std::uint32_t> near = light_candidates(bvh, w.patches, l, options.reach);
        const std::vector<std::uint32_t> near_vertices = vertices_of(near, w.mesh.triangles);
        so.only = &near;
        const ShootResult shot = shoot(frame_of(light), w.patches, hemicube, so);
        const double t_shoot = seconds_since(t0);

        std::vector<visdb::Rgb> tri(nt, visdb::Rgb(0.0));
        const double ff_sum = add_patch_irradiance(shot, w.emittance[l], w.area[l], w, tri);

        // Exact vertex irradiance past the occluders the fragment lists found
        std::vector<visdb::Rgb> vert;
        std::size_t tested = 0, touched_total = 0, missed = 0;
        const auto t1 = Clock::now();
        if (exact && !dm) {
            vert.assign(nv, visdb::Rgb(0.0));
            // Candidates: the occlusion lists of the vertex's triangles (Algorithm 2, from
            // the light's centroid), completed by a conservative bounding-volume query of the
            // region between the vertex and the light: occluders that hide only part of the
            // light (penumbra) may be invisible from the centroid.
            tbb::parallel_for(
                tbb::blocked_range<std::size_t>(0, near_vertices.size(), 64),
                [&](const auto& range) {
                    std::vector<std::uint32_t> ids, listed, touched;
                    std::vector<const Patch*> occ;
                    VisibleStats vs;
                    vs.touched = &touched;
                    std::size_t missed_here = 0;
                    for (std::size_t vi = range.begin(); vi != range.end(); ++vi) {
                        const std::uint32_t v = near_vertices[vi];
                        const glm::dvec3 x = w.mesh.positions[v];
                        if (glm::dot(x - light.p[0], normal) <= 0.0) continue;  // behind the light
                        listed.clear();
                        for (std::uint32_t k = w.incident_start[v]; k < w.incident_start[v + 1];
                             ++k)
                            for (const OcclusionPair& p : shot.occluders_of(w.incident[k]))
                                if (p.occluder != l) listed.push_back(p.occluder);
                        std::sort(listed.begin(), listed.end());
                        listed.erase(std::unique(listed.begin(), listed.end()), listed.end());
                        ids = listed;
                        for_each_shadow_candidate(bvh, w.patches, l, x, [&](std::uint32_t id) {
                            if (!std::binary_search(listed.begin(), listed.end(), id))
                                ids.push_back(id);
                        });
                        occ.clear();
                        for (std::uint32_t id : ids) occ.push_back(&w.patches[id]);
                        touched.clear();
                        const double f =
                            visible_form_factor(x, glm::dvec3(w.mesh.normals[v]), light, occ, &vs);
                        for (std::uint32_t t : touched) missed_here += t >= listed.size();
                        vert[v] = w.emittance[l] * f;
                    }
                    std::lock_guard lock(accumulate);
                    tested += vs.occluders_tested;
                    touched_total += vs.occluders_projected;
                    missed += missed_here;
                });
        }
        const double t_shade = seconds_since(t1);

        // Shadow edges (Algorithm 3) on every receiver in front of the light that faces it.
        // Occluders: the receiver's occlusion list, completed by a conservative query of the
        // box around the light and the receiver (the lists come from the centroid only).
        std::vector<std::pair<std::uint32_t, ShadowSegment>> found;
        ShadowStats ss;
        std::size_t receivers = 0, listed_total = 0, added_total = 0;
        const auto t2 = Clock::now();
        if (dm) {
            tbb::parallel_for(
                tbb::blocked_range<std::size_t>(0, near.size(), 32), [&](const auto& range) {
                    std::vector<std::pair<std::uint32_t, ShadowSegment>> here;
                    std::vector<std::uint32_t> ids;
                    std::vector<const Patch*> occ;
                    ShadowStats s;
                    std::size_t rec = 0, lis = 0, add = 0;
                    for (std::size_t ji = range.begin(); ji != range.end(); ++ji) {
                        const std::size_t j = near[ji];
                        if (j == l || emits(w.emittance[j])) continue;
                        const Patch& r = w.patches[j];
                        const glm::dvec3 rn = unit_normal(r);
                        bool in_front = false, facing = false;
                        for (int k = 0; k < 3; ++k) {
                            in_front |= glm::dot(r.p[k] - light.p[0], normal) > 0.0;
                            facing |= glm::dot(light.p[k] - r.p[0], rn) > 0.0;
                        }
                        if (!in_front || !facing) continue;
                        ids.clear();
                        // Only occluders whose plane separates some light and receiver points
                        for (const OcclusionPair& p :
                             shot.occluders_of(static_cast<std::uint32_t>(j)))
                            if (p.occluder != l && can_occlude(w.patches[p.occluder], light, r))
                                ids.push_back(p.occluder);
                        const std::size_t n_listed = ids.size();
                        // Shaft of light and receiver: the convex hull of their six corners
                        const glm::dvec3 corners[6] = {light.p[0], light.p[1], light.p[2],
                                                       r.p[0],     r.p[1],     r.p[2]};
                        bvh.query(Hull(corners), [&](std::uint32_t id) {
                            if (id != l && id != j &&
                                std::find(ids.begin(), ids.begin() + n_listed, id) ==
                                    ids.begin() + n_listed &&
                                can_occlude(w.patches[id], light, r))
                                ids.push_back(id);
                        });
                        if (ids.empty()) continue;
                        ++rec;
                        lis += n_listed;
                        add += ids.size() - n_listed;
                        occ.clear();
                        for (std::uint32_t id : ids) occ.push_back(&w.patches[id]);
                        for (const ShadowSegment& seg :
                             shadow_edges(light, options.lights, r, occ, 1e-6, &s))
                            here.emplace_back(static_cast<std::uint32_t>(j), seg);
                    }
                    std::lock_guard lock(accumulate);
                    found.insert(found.end(), here.begin(), here.end());
                    ss += s;
                    receivers += rec;
                    listed_total += lis;
                    added_total += add;
                });
        }
        const double t_edges = seconds_since(t2);

        std::lock_guard lock(accumulate);
        for (const std::uint32_t j : near) tri_irradiance[j] += tri[j];
        if (exact && !dm)
            for (const std::uint32_t v : near_vertices) vert_irradiance[v] += vert[v];
        for (const auto& [j, seg] : found) segments[j].push_back(seg);
        shadow_stats += ss;
        shadow_receivers += receivers;
        shadow_occluders_listed += listed_total;
        shadow_occluders_added += added_total;
        fragments += shot.fragments;
        undersampled += shot.undersampled_pixels;
        pairs += shot.occlusion.size();
        raw_pairs += shot.raw_pairs;
        occluders_tested += tested;
        occluders_touched += touched_total;
        occluders_missed_by_lists += missed;
        ff_sum_total += ff_sum;
        seconds_shoot += t_shoot;
        seconds_occlusion += shot.seconds_occlusion;
        seconds_shade += t_shade;
        seconds_edges += t_edges;
        ++done;
        if (progress) progress("shoot", done, lights.size());
    });

    // Energy: emitted power, and power arriving on the receivers (from the hemicube)
    double emitted = 0.0, received = 0.0, light_area = 0.0;
    for (std::uint32_t l : lights) {
        emitted += mean(w.emittance[l]) * w.area[l];
        light_area += w.area[l];
    }
    for (std::size_t t = 0; t < nt; ++t) received += mean(tri_irradiance[t]) * w.area[t];

    // Interreflection on the scene's triangles, clustered into elements per planar region
    Regions regions = make_regions(w);
    std::optional<IndirectSolution> indirect;
    if (options.bounces != 0) {
        std::vector<glm::dvec3> region_normal;
        for (const PlanarRegion& r : regions.planar) region_normal.push_back(r.normal);
        const IndirectInput input{.patches = w.patches,
                                  .reflectance = w.reflectance,
                                  .emittance = w.emittance,
                                  .region = regions.of_triangle,
                                  .region_normal = region_normal};
        const IndirectOptions io{.bounces = std::max(options.bounces, 0),
                                 .converge = options.converge,
                                 .element_size = options.element_size,
                                 .overrelaxation = options.overrelaxation,
                                 .ambient = options.ambient,
                                 .method = options.method,
                                 .resolution = options.resolution,
                                 .subpixels = options.subpixels};
        std::string label;
        indirect = solve_indirect(
            input, io,
            [&](std::string_view stage, std::size_t shots_done, std::size_t total, double unshot) {
                if (!progress) return;
                char text[96];
                std::snprintf(text, sizeof text, "%.*s (unshot %.3g%%)", int(stage.size()),
                              stage.data(), 100.0 * unshot);
                label = text;
                progress(label, shots_done, total);
            });
        if (options.convergence) *options.convergence = indirect->curve;
    }

    std::vector<std::pair<std::string, double>> dm_statistics;
    std::vector<std::uint32_t> vertex_region;  // with DM: region of each output vertex
    Work target;  // the mesh whose vertices are shaded: the scene's, or the discontinuity mesh
    if (!dm) {
        if (!exact) vert_irradiance = average_to_vertices(w, tri_irradiance);
        target = std::move(w);
    } else {
        // Discontinuity meshing: per planar region, a CDT with the shadow edges, then rounds
        // of refinement where the exact irradiance at an edge's midpoint departs from the
        // linear interpolation of its ends.
        const auto t_dm = Clock::now();
        // Lights and receivers finish in any order: sort each triangle's segments so the CDT
        // sees its constraints in one order (the mesh was nondeterministic by a few triangles)
        auto lex = [](const ShadowSegment& x, const ShadowSegment& y) {
            return std::lexicographical_compare(&x.a.x, &x.a.x + 3, &y.a.x, &y.a.x + 3) ||
                   (x.a == y.a &&
                    std::lexicographical_compare(&x.b.x, &x.b.x + 3, &y.b.x, &y.b.x + 3));
        };
        for (auto& list : segments) std::sort(list.begin(), list.end(), lex);
        std::size_t constraints = 0;
        for (std::size_t t = 0; t < nt; ++t)
            for (const ShadowSegment& s : segments[t]) {
                regions.planar[regions.of_triangle[t]].constraints.push_back({s.a, s.b});
                ++constraints;
            }
        segments = {};
        const DmOptions dm_options{.min_angle_deg = options.dm_min_angle, .merge_distance = 1e-6};
        std::unordered_map<PointKey, visdb::Rgb, PointKeyHash> cache;
        visdb::BakeMesh mesh;
        std::vector<visdb::Rgb> h;
        DmStats dm_stats;
        std::size_t refine_points = 0, rounds = 0, evaluations = 0;
        double seconds_mesh = 0.0;
        for (int round = 0;; ++round) {
            if (progress)
                progress("mesh", std::size_t(round), std::size_t(options.refine_rounds) + 1);
            const auto tm = Clock::now();
            DmStats st;
            const std::vector<MeshedRegion> meshed = mesh_regions(regions.planar, dm_options, &st);
            seconds_mesh += seconds_since(tm);
            if (round == 0) dm_stats = st;
            dm_stats.triangles_out = st.triangles_out;
            dm_stats.conformity_points = st.conformity_points;
            ++rounds;
            assemble(regions, meshed, mesh, vertex_region);

            // Exact irradiance at every vertex (cached by region and position across rounds)
            const std::size_t n = mesh.positions.size();
            h.assign(n, visdb::Rgb(0.0));
            std::vector<char> fresh(n, 0);
            tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 64), [&](const auto& range) {
                std::vector<const Patch*> occ;
                for (std::size_t v = range.begin(); v != range.end(); ++v) {
                    const auto it = cache.find(key_of(vertex_region[v], mesh.positions[v]));
                    if (it != cache.end()) {
                        h[v] = it->second;
                        continue;
                    }
                    h[v] = exact_irradiance(w, bvh, lights, mesh.positions[v],
                                            regions.planar[vertex_region[v]].normal, occ,
                                            options.reach);
                    fresh[v] = 1;
                }
            });
            for (std::size_t v = 0; v < n; ++v)
                if (fresh[v]) {
                    cache.emplace(key_of(vertex_region[v], mesh.positions[v]), h[v]);
                    ++evaluations;
                }
            if (round >= options.refine_rounds) break;

            // Refinement: test every edge of every non-emitting region at its midpoint
            double h_max = 0.0;
            for (const visdb::Rgb& x : h) h_max = std::max(h_max, mean(x));
            const double floor = 1e-3 * h_max;
            std::vector<std::uint32_t> region_start(meshed.size() + 1, 0);
            for (std::size_t r = 0; r < meshed.size(); ++r)
                region_start[r + 1] =
                    region_start[r] + static_cast<std::uint32_t>(meshed[r].positions.size());
            std::vector<std::vector<glm::dvec3>> split(meshed.size());
            // Midpoints evaluated this round, cached like vertices: an edge that stays unsplit
            // keeps its midpoint's bits, so later rounds look it up instead of re-evaluating
            std::vector<std::vector<std::pair<PointKey, visdb::Rgb>>> evaluated(meshed.size());
            tbb::parallel_for(std::size_t{0}, meshed.size(), [&](std::size_t r) {
                if (regions.emitter[r]) return;
                const MeshedRegion& m = meshed[r];
                std::vector<std::pair<std::uint32_t, std::uint32_t>> edges;
                for (const glm::u32vec3& t : m.triangles)
                    for (int k = 0; k < 3; ++k)
                        edges.emplace_back(std::min(t[k], t[(k + 1) % 3]),
                                           std::max(t[k], t[(k + 1) % 3]));
                std::sort(edges.begin(), edges.end());
                edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
                std::vector<const Patch*> occ;
                const glm::dvec3 rn = regions.planar[r].normal;
                for (const auto& [a, b] : edges) {
                    const glm::dvec3 pa = m.positions[a], pb = m.positions[b];
                    if (glm::length(pb - pa) < options.refine_min_edge) continue;
                    // Canonical midpoint: the same bits from either region sharing the edge
                    const glm::dvec3 mid =
                        std::lexicographical_compare(&pa.x, &pa.x + 3, &pb.x, &pb.x + 3)
                            ? pa + 0.5 * (pb - pa)
                            : pb + 0.5 * (pa - pb);
                    const visdb::Rgb linear =
                        0.5 * (h[region_start[r] + a] + h[region_start[r] + b]);
                    const PointKey key = key_of(static_cast<std::uint32_t>(r), mid);
                    const auto hit = cache.find(key);
                    visdb::Rgb at_mid;
                    if (hit != cache.end()) {
                        at_mid = hit->second;
                    } else {
                        at_mid = exact_irradiance(w, bvh, lights, mid, rn, occ, options.reach);
                        evaluated[r].emplace_back(key, at_mid);
                    }
                    const double diff = mean(glm::abs(at_mid - linear));
                    if (diff > floor &&
                        diff > options.refine_tolerance * std::max(mean(at_mid), mean(linear)))
                        split[r].push_back(mid);
                }
            });
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
            refine_points += added;
            if (added == 0) break;
        }

        target.mesh = std::move(mesh);
        describe_triangles(scene, target);
        if (exact) {
            vert_irradiance = std::move(h);
        } else {
            // Patch shading on the new mesh: shoot again from every light onto its triangles
            std::vector<visdb::Rgb> tri(target.mesh.triangles.size(), visdb::Rgb(0.0));
            const ShootOptions so{
                .method = options.method, .subpixels = options.subpixels, .occlusion = false};
            tbb::parallel_for(std::size_t{0}, lights.size(), [&](std::size_t li) {
                const std::uint32_t l = lights[li];
                // The light's own pieces lie in the shooter's plane and receive nothing
                const ShootResult shot =
                    shoot(frame_of(w.patches[l]), target.patches, hemicube, so);
                std::vector<visdb::Rgb> mine(tri.size(), visdb::Rgb(0.0));
                add_patch_irradiance(shot, w.emittance[l], w.area[l], target, mine);
                std::lock_guard lock(accumulate);
                for (std::size_t j = 0; j < tri.size(); ++j) tri[j] += mine[j];
            });
            vert_irradiance = average_to_vertices(target, tri);
        }
        dm_statistics = {
            {"dm_regions", double(regions.planar.size())},
            {"dm_triangles_before", double(nt)},
            {"dm_shadow_receivers", double(shadow_receivers)},
            {"dm_shadow_occluders_listed", double(shadow_occluders_listed)},
            {"dm_shadow_occluders_added_by_bvh", double(shadow_occluders_added)},
            {"dm_shadow_edges_projected", double(shadow_stats.edges_projected)},
            {"dm_shadow_shared_edges_skipped", double(shadow_stats.shared_edges_skipped)},
            {"dm_shadow_segments_split", double(shadow_stats.segments_split)},
            {"dm_shadow_segments", double(constraints)},
            {"dm_constraints_dropped", double(dm_stats.constraints_dropped)},
            {"dm_points_merged", double(dm_stats.points_merged)},
            {"dm_conformity_points", double(dm_stats.conformity_points)},
            {"dm_refine_points", double(refine_points)},
            {"dm_rounds", double(rounds)},
            {"dm_exact_evaluations", double(evaluations)},
            {"seconds_shadow_edges_cpu", seconds_edges},
            {"seconds_mesh", seconds_mesh},
            {"seconds_dm", seconds_since(t_dm)}};
    }

    // Radiosity B = E + ρH at each vertex (material of its first triangle: all of a vertex's
    // triangles belong to one surface); H = direct + interpolated indirect
    visdb::BakeMesh& mesh = target.mesh;
    const std::size_t n_out = mesh.positions.size();
    mesh.irradiance.resize(n_out);
    mesh.radiosity.resize(n_out);
    double indirect_sum = 0.0;
    for (std::size_t v = 0; v < n_out; ++v) {
        const std::uint32_t t = target.incident[target.incident_start[v]];
        visdb::Rgb h = vert_irradiance[v];
        if (indirect) {
            const std::uint32_t region = dm ? vertex_region[v] : regions.of_triangle[t];
            const visdb::Rgb ind = indirect->at(region, mesh.positions[v]);
            h += ind;
            indirect_sum += mean(ind);
        }
        mesh.irradiance[v] = glm::vec3(h);
        mesh.radiosity[v] = glm::vec3(target.emittance[t] + target.reflectance[t] * h);
    }

    visdb::Bake result;
    result.name = options.name;
    result.unit = scene.emittance_unit == "lm/m2" ? "lux" : "W/m2";
    result.parameters = {
        {"method", to_string(options.method)},
        {"resolution", std::to_string(options.resolution)},
        {"subpixels", options.method == Visibility::ABuffer ? std::to_string(options.subpixels)
                                                            : std::string("1")},
        {"bounces",
         options.bounces < 0 ? std::string("converge") : std::to_string(options.bounces)},
        {"shading", to_string(options.shading)},
        {"dm", dm ? "on" : "off"},
        {"lights", to_string(options.lights)},
        {"threads", std::to_string(options.threads)}};
    if (options.reach > 0.0) result.parameters.emplace_back("reach", std::to_string(options.reach));
    if (options.bounces != 0) {
        if (options.bounces < 0) {
            result.parameters.emplace_back("converge", std::to_string(options.converge));
            result.parameters.emplace_back("overrelax", std::to_string(options.overrelaxation));
            result.parameters.emplace_back("ambient", options.ambient ? "on" : "off");
        }
        result.parameters.emplace_back("element_size", std::to_string(options.element_size));
    }
    if (dm) {
        result.parameters.emplace_back("dm_angle", std::to_string(options.dm_min_angle));
        result.parameters.emplace_back("refine_rounds", std::to_string(options.refine_rounds));
        result.parameters.emplace_back("refine_tolerance",
                                       std::to_string(options.refine_tolerance));
        result.parameters.emplace_back("refine_min_edge", std::to_string(options.refine_min_edge));
    }
    result.statistics = {{"triangles", double(mesh.triangles.size())},
                         {"vertices", double(n_out)},
                         {"degenerate_skipped", double(w.degenerate)},
                         {"light_triangles", double(lights.size())},
                         {"light_area_m2", light_area},
                         {"fragments", double(fragments)},
                         {"undersampled_fragments", double(undersampled)},
                         {"occlusion_pairs", double(pairs)},
                         {"occlusion_pairs_raw", double(raw_pairs)},
                         {"mean_form_factor_sum", ff_sum_total / double(lights.size())},
                         {"emitted_power_w", emitted},
                         {"received_power_w", received},
                         {"seconds_shoot_cpu", seconds_shoot},
                         {"seconds_occlusion_cpu", seconds_occlusion}};
    if (!dm)
        result.statistics.insert(result.statistics.end(),
                                 {{"occluders_tested", double(occluders_tested)},
                                  {"occluders_hiding_light", double(occluders_touched)},
                                  {"occluders_missed_by_lists", double(occluders_missed_by_lists)},
                                  {"seconds_shade_cpu", seconds_shade}});
    result.statistics.insert(result.statistics.end(), dm_statistics.begin(), dm_statistics.end());
    if (indirect) {
        const IndirectSolution& s = *indirect;
        const double last = s.curve.empty() ? 0.0 : s.curve.back().unshot_fraction;
        result.statistics.insert(
            result.statistics.end(),
            {{"indirect_elements", double(s.elements.size())},
             {"indirect_pieces", double(s.pieces)},
             {"indirect_shots", double(s.shots)},
             {"indirect_rows", double(s.rows_computed)},
             {"indirect_bounces", double(s.bounces_done)},
             {"indirect_unshot_fraction", last},
             {"indirect_ambient", mean(s.ambient_irradiance)},
             {"indirect_mean_at_vertices", n_out ? indirect_sum / double(n_out) : 0.0},
             {"energy_emitted_w", s.energy.emitted},
             {"energy_absorbed_w", s.energy.absorbed},
             {"energy_escaped_w", s.energy.escaped},
             {"energy_unshot_w", s.energy.unshot},
             {"seconds_indirect", s.seconds}});
    }
    result.statistics.emplace_back("seconds_total", seconds_since(t_start));
    result.mesh = std::move(mesh);
    return result;
}

}  // namespace

}  // namespace abrad::radiosity
