// Direct-light bake: one A-buffer hemicube shot per light-source triangle (the paper's
// progressive refinement restricted to the lights), then vertex shades.

#include "abrad/radiosity/bake.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <mutex>
#include <numeric>
#include <optional>
#include <string>
#include <vector>

#include <glm/geometric.hpp>
#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include "abrad/radiosity/bvh.h"
#include "abrad/radiosity/direct.h"
#include "abrad/radiosity/exact.h"

namespace abrad::radiosity {

namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) {
    return std::chrono::duration<double>(Clock::now() - t0).count();
}

// The bake mesh with what shading needs beside it.
struct Work {
    visdb::BakeMesh mesh;
    std::vector<Patch> patches;          // one per mesh triangle
    std::vector<double> area;            // per triangle, m²
    std::vector<visdb::Rgb> emittance;   // per triangle
    std::vector<visdb::Rgb> reflectance; // per triangle
    std::vector<std::uint32_t> incident_start, incident;  // triangles around each vertex (CSR)
    std::size_t degenerate = 0;
};

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
        std::vector<std::vector<std::pair<std::uint32_t, glm::dvec3>>> made(surface.mesh.positions.size());
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
    // Incident triangles of each vertex
    const std::size_t nv = w.mesh.positions.size();
    w.incident_start.assign(nv + 1, 0);
    for (const auto& t : w.mesh.triangles)
        for (int k = 0; k < 3; ++k) ++w.incident_start[t[k] + 1];
    for (std::size_t i = 0; i < nv; ++i) w.incident_start[i + 1] += w.incident_start[i];
    w.incident.resize(w.incident_start[nv]);
    std::vector<std::uint32_t> fill(w.incident_start.begin(), w.incident_start.end() - 1);
    for (std::size_t t = 0; t < w.mesh.triangles.size(); ++t)
        for (int k = 0; k < 3; ++k)
            w.incident[fill[w.mesh.triangles[t][k]]++] = static_cast<std::uint32_t>(t);
    return w;
}

double mean(const visdb::Rgb& c) { return (c.x + c.y + c.z) / 3.0; }

}  // namespace

std::string to_string(Shading shading) { return shading == Shading::Exact ? "exact" : "patch"; }

void validate(const BakeOptions& o) {
    if (o.resolution < 2 || o.resolution > 4096 || o.resolution % 2 != 0)
        throw BakeError("--resolution must be an even number in [2, 4096], got " +
                        std::to_string(o.resolution));
    if (o.method == Visibility::ABuffer && o.subpixels != 4 && o.subpixels != 8 &&
        o.subpixels != 16)
        throw BakeError("--subpixels must be 4, 8 or 16, got " + std::to_string(o.subpixels));
    if (o.bounces != 0)
        throw BakeError("--bounces " + std::to_string(o.bounces) +
                        ": only direct light (--bounces 0) is implemented so far");
    if (o.threads < 0) throw BakeError("--threads must be >= 0, got " + std::to_string(o.threads));
}

visdb::Bake bake(const visdb::Scene& scene, const BakeOptions& options, const ProgressFn& progress) {
    validate(options);
    const auto t_start = Clock::now();
    Work w = build_mesh(scene);
    const std::size_t nt = w.mesh.triangles.size(), nv = w.mesh.positions.size();
    if (nt == 0) throw BakeError("the scene has no triangles to bake");

    std::vector<std::uint32_t> lights;
    for (std::size_t t = 0; t < nt; ++t)
        if (w.emittance[t].x > 0.0 || w.emittance[t].y > 0.0 || w.emittance[t].z > 0.0)
            lights.push_back(static_cast<std::uint32_t>(t));
    if (lights.empty())
        throw BakeError("the scene has no light sources (no material with emittance > 0)");

    std::optional<tbb::global_control> limit;
    if (options.threads > 0)
        limit.emplace(tbb::global_control::max_allowed_parallelism,
                      static_cast<std::size_t>(options.threads));

    const Hemicube hemicube(options.resolution);
    const bool exact = options.shading == Shading::Exact;
    const ShootOptions shoot_options{.method = options.method,
                                     .subpixels = options.subpixels,
                                     .occlusion = exact};

    // Shoot from every light triangle; accumulate irradiance per triangle (patch shading)
    // and per vertex (exact shading)
    std::vector<visdb::Rgb> tri_irradiance(nt, visdb::Rgb(0.0));
    std::vector<visdb::Rgb> vert_irradiance(nv, visdb::Rgb(0.0));
    std::mutex accumulate;
    std::size_t fragments = 0, undersampled = 0, pairs = 0, raw_pairs = 0, done = 0;
    std::size_t occluders_tested = 0, occluders_touched = 0, occluders_missed_by_lists = 0;
    const Bvh bvh(w.patches);
    double ff_sum_total = 0.0, seconds_shoot = 0.0, seconds_shade = 0.0;
    if (progress) progress("shoot", 0, lights.size());

    tbb::parallel_for(std::size_t{0}, lights.size(), [&](std::size_t li) {
        const std::uint32_t l = lights[li];
        const Patch& light = w.patches[l];
        const auto t0 = Clock::now();
        // Hemicube at the light triangle's centroid, around its front normal
        const glm::dvec3 centroid = (light.p[0] + light.p[1] + light.p[2]) / 3.0;
        const glm::dvec3 normal = glm::normalize(glm::cross(light.p[1] - light.p[0], light.p[2] - light.p[0]));
        ShootOptions so = shoot_options;
        so.exclude = l;
        const ShootResult shot = shoot(ShooterFrame::at(centroid, normal), w.patches, hemicube, so);
        const double t_shoot = seconds_since(t0);

        // Patch irradiance: H_j = E_L · F_Lj · A_L / A_j
        std::vector<visdb::Rgb> tri(nt, visdb::Rgb(0.0));
        double ff_sum = 0.0;
        for (std::size_t j = 0; j < nt; ++j) {
            if (shot.form_factor[j] <= 0.0) continue;
            ff_sum += shot.form_factor[j];
            tri[j] = w.emittance[l] * (shot.form_factor[j] * w.area[l] / w.area[j]);
        }

        // Exact vertex irradiance past the occluders the fragment lists found
        std::vector<visdb::Rgb> vert;
        std::size_t tested = 0, touched_total = 0, missed = 0;
        const auto t1 = Clock::now();
        if (exact) {
            vert.assign(nv, visdb::Rgb(0.0));
            // Candidates: the occlusion lists of the vertex's triangles (Algorithm 2, from
            // the light's centroid), completed by a conservative bounding-volume query of the
            // region between the vertex and the light: occluders that hide only part of the
            // light (penumbra) may be invisible from the centroid.
            tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nv, 64), [&](const auto& range) {
                std::vector<std::uint32_t> ids, listed, touched;
                std::vector<const Patch*> occ;
                VisibleStats vs;
                vs.touched = &touched;
                std::size_t missed_here = 0;
                for (std::size_t v = range.begin(); v != range.end(); ++v) {
                    const glm::dvec3 x = w.mesh.positions[v];
                    if (glm::dot(x - light.p[0], normal) <= 0.0) continue;  // behind the light
                    listed.clear();
                    for (std::uint32_t k = w.incident_start[v]; k < w.incident_start[v + 1]; ++k)
                        for (const OcclusionPair& p : shot.occluders_of(w.incident[k]))
                            if (p.occluder != l) listed.push_back(p.occluder);
                    std::sort(listed.begin(), listed.end());
                    listed.erase(std::unique(listed.begin(), listed.end()), listed.end());
                    ids = listed;
                    for_each_shadow_candidate(bvh, w.patches, l, x, [&](std::uint32_t id) {
                        if (!std::binary_search(listed.begin(), listed.end(), id)) ids.push_back(id);
                    });
                    occ.clear();
                    for (std::uint32_t id : ids) occ.push_back(&w.patches[id]);
                    touched.clear();
                    const double f = visible_form_factor(x, glm::dvec3(w.mesh.normals[v]), light, occ, &vs);
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

        std::lock_guard lock(accumulate);
        for (std::size_t j = 0; j < nt; ++j) tri_irradiance[j] += tri[j];
        if (exact)
            for (std::size_t v = 0; v < nv; ++v) vert_irradiance[v] += vert[v];
        fragments += shot.fragments;
        undersampled += shot.undersampled_pixels;
        pairs += shot.occlusion.size();
        raw_pairs += shot.raw_pairs;
        occluders_tested += tested;
        occluders_touched += touched_total;
        occluders_missed_by_lists += missed;
        ff_sum_total += ff_sum;
        seconds_shoot += t_shoot;
        seconds_shade += t_shade;
        ++done;
        if (progress) progress("shoot", done, lights.size());
    });

    // Patch shading: each vertex gets the area-weighted irradiance of its triangles
    if (!exact) {
        for (std::size_t v = 0; v < nv; ++v) {
            visdb::Rgb sum(0.0);
            double area = 0.0;
            for (std::uint32_t k = w.incident_start[v]; k < w.incident_start[v + 1]; ++k) {
                const std::uint32_t t = w.incident[k];
                sum += tri_irradiance[t] * w.area[t];
                area += w.area[t];
            }
            vert_irradiance[v] = area > 0.0 ? sum / area : visdb::Rgb(0.0);
        }
    }

    // Radiosity B = E + ρH at each vertex (material of its first triangle: all of a vertex's
    // triangles belong to one surface)
    visdb::BakeMesh& mesh = w.mesh;
    mesh.irradiance.resize(nv);
    mesh.radiosity.resize(nv);
    for (std::size_t v = 0; v < nv; ++v) {
        const std::uint32_t t = w.incident[w.incident_start[v]];
        const visdb::Rgb h = vert_irradiance[v];
        mesh.irradiance[v] = glm::vec3(h);
        mesh.radiosity[v] = glm::vec3(w.emittance[t] + w.reflectance[t] * h);
    }

    // Energy: emitted power, and power arriving on the receivers (from the hemicube)
    double emitted = 0.0, received = 0.0, light_area = 0.0;
    for (std::uint32_t l : lights) {
        emitted += mean(w.emittance[l]) * w.area[l];
        light_area += w.area[l];
    }
    for (std::size_t t = 0; t < nt; ++t) received += mean(tri_irradiance[t]) * w.area[t];

    visdb::Bake result;
    result.name = options.name;
    result.unit = "W/m2";
    result.parameters = {{"method", to_string(options.method)},
                         {"resolution", std::to_string(options.resolution)},
                         {"subpixels", options.method == Visibility::ABuffer
                                           ? std::to_string(options.subpixels)
                                           : std::string("1")},
                         {"bounces", std::to_string(options.bounces)},
                         {"shading", to_string(options.shading)},
                         {"lights", "centroid"},
                         {"threads", std::to_string(options.threads)}};
    result.statistics = {{"triangles", double(nt)},
                         {"vertices", double(nv)},
                         {"degenerate_skipped", double(w.degenerate)},
                         {"light_triangles", double(lights.size())},
                         {"light_area_m2", light_area},
                         {"fragments", double(fragments)},
                         {"undersampled_fragments", double(undersampled)},
                         {"occlusion_pairs", double(pairs)},
                         {"occlusion_pairs_raw", double(raw_pairs)},
                         {"occluders_tested", double(occluders_tested)},
                         {"occluders_hiding_light", double(occluders_touched)},
                         {"occluders_missed_by_lists", double(occluders_missed_by_lists)},
                         {"mean_form_factor_sum", ff_sum_total / double(lights.size())},
                         {"emitted_power_w", emitted},
                         {"received_power_w", received},
                         {"seconds_shoot_cpu", seconds_shoot},
                         {"seconds_shade_cpu", seconds_shade},
                         {"seconds_total", seconds_since(t_start)}};
    result.mesh = std::move(mesh);
    return result;
}

}  // namespace abrad::radiosity
