// The bake's orchestrator: runs the stages of stages.h in order, in the scene's local frame
// and in a task arena of the asked thread count, and records parameters and statistics.

#include "abrad/radiosity/bake.h"

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include "abrad/radiosity/cluster.h"
#include "abrad/radiosity/direct.h"
#include "abrad/visdb/light_scene.h"
#include "abrad/visdb/material_check.h"
#include "stages.h"

namespace abrad::radiosity {

namespace {

// The settings the bake records with its result (the settings it used).
std::vector<std::pair<std::string, std::string>> parameters_of(const BakeOptions& o) {
    std::vector<std::pair<std::string, std::string>> p = {
        {"method", to_string(o.method)},
        {"resolution", std::to_string(o.resolution)},
        {"subpixels",
         o.method == Visibility::ABuffer ? std::to_string(o.subpixels) : std::string("1")},
        {"bounces", o.bounces < 0 ? std::string("converge") : std::to_string(o.bounces)},
        {"shading", to_string(o.shading)},
        {"dm", o.dm ? "on" : "off"},
        {"lights", to_string(o.lights)},
        {"threads", std::to_string(o.threads)}};
    if (o.reach > 0.0) p.emplace_back("reach", std::to_string(o.reach));
    if (o.bounces != 0) {
        if (o.bounces < 0) {
            p.emplace_back("converge", std::to_string(o.converge));
            p.emplace_back("overrelax", std::to_string(o.overrelaxation));
            p.emplace_back("ambient", o.ambient ? "on" : "off");
        }
        p.emplace_back("element_size", std::to_string(o.element_size));
        p.emplace_back("element_resolution", std::to_string(o.element_resolution));
        if (o.method == Visibility::ABuffer)
            p.emplace_back("element_subpixels", std::to_string(o.element_subpixels));
        p.emplace_back("shooter_cells", std::to_string(o.shooter_cells));
        if (o.edge_gather) p.emplace_back("edge_gather", "on");
    }
    if (o.dm) {
        p.emplace_back("dm_angle", std::to_string(o.dm_min_angle));
        p.emplace_back("refine_rounds", std::to_string(o.refine_rounds));
        p.emplace_back("refine_tolerance", std::to_string(o.refine_tolerance));
        p.emplace_back("refine_min_edge", o.refine_min_edge > 0.0
                                              ? std::to_string(o.refine_min_edge)
                                              : std::string("auto"));
    }
    return p;
}

// Each vertex's planar region: that of its first triangle (a vertex belongs to one region).
std::vector<std::uint32_t> vertex_regions(const BakeGeometry& g, const Regions& regions) {
    std::vector<std::uint32_t> out(g.mesh.positions.size());
    for (std::size_t v = 0; v < out.size(); ++v)
        out[v] = regions.of_triangle[g.incident[g.incident_start[v]]];
    return out;
}

// The light group of each triangle of `g` (its material's; "" for a triangle that emits
// nothing).
std::vector<std::string> triangle_groups(const visdb::Scene& scene, const BakeGeometry& g) {
    std::vector<std::string> out(g.mesh.triangles.size());
    for (const std::uint32_t t : g.lights)
        out[t] = visdb::light_group(
            scene.materials[scene.surfaces[g.mesh.triangle_surface[t]].material]);
    return out;
}

// `g` with the lights of `group` only: the others' triangles emit nothing (they stay
// reflectors, as in a bake of a scene without them) and the others' luminaires are gone.
BakeGeometry restrict_to_group(BakeGeometry g, const std::vector<std::string>& triangle_group,
                               const std::string& group) {
    std::vector<std::uint32_t> lights;
    for (const std::uint32_t t : g.lights) {
        if (triangle_group[t] == group) {
            lights.push_back(t);
        } else {
            g.emittance[t] = visdb::Rgb(0.0);
        }
    }
    g.lights = std::move(lights);
    std::erase_if(g.luminaires,
                  [&](const visdb::Luminaire& l) { return visdb::light_group(l) != group; });
    return g;
}

// The light groups of the bake's sources (`g`'s light triangles and luminaires), first seen
// first; empty unless the scene names some group and there are two or more.
std::vector<std::string> bake_light_groups(const visdb::Scene& scene, const BakeGeometry& g) {
    if (!visdb::names_light_groups(scene)) return {};
    std::vector<std::string> names;
    const auto add = [&](const std::string& n) {
        if (std::find(names.begin(), names.end(), n) == names.end()) names.push_back(n);
    };
    for (const std::string& n : triangle_groups(scene, g))
        if (!n.empty()) add(n);
    for (const visdb::Luminaire& l : g.luminaires) add(visdb::light_group(l));
    if (names.size() < 2) return {};
    return names;
}

// What the bake's direct stage gives target's vertices, from the lights of `source` only:
// without DM the same shots as the bake's own (so a group's share is, bit for bit, what a bake
// of its lights alone gives), with DM the exact sum over the group's sources at the
// discontinuity mesh's vertices (or its patch shading).
std::vector<visdb::Rgb> group_direct(const BakeGeometry& source, const Regions& regions,
                                     const Bvh& bvh, const Hemicube& hemicube,
                                     const BakeGeometry& target, bool dm,
                                     const BakeOptions& options) {
    const bool exact = options.shading == Shading::Exact;
    if (!dm) {
        BakeOptions o = options;
        o.dm = false;
        o.cluster = nullptr;
        LightShots shots = shoot_lights(source, regions, bvh, hemicube, o, nullptr, {});
        if (exact) return std::move(shots.vertex_irradiance);
        if (source.luminaires.empty()) bound_by_exitance(source, shots.triangle_irradiance);
        return average_to_vertices(source, shots.triangle_irradiance);
    }
    if (!exact) return shade_patches(source, target, hemicube, options);
    std::vector<visdb::Rgb> h(target.mesh.positions.size());
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, h.size(), 64), [&](const auto& range) {
        std::vector<const Patch*> occ;
        for (std::size_t v = range.begin(); v != range.end(); ++v) {
            const glm::dvec3 x = target.mesh.positions[v];
            const glm::dvec3 n(target.mesh.normals[v]);
            h[v] =
                exact_irradiance(source.patches, source.emittance, source.lights, bvh, x, n, occ,
                                 options.reach) +
                luminaires_irradiance(source.luminaires, source.patches, bvh, x, n, options.reach);
        }
    });
    return h;
}

// The bake's shades per light group (visdb::Bake::light_groups): per group, its direct light
// at target's vertices and (bounces != 0) an interreflection solve of its own, shaded as the
// bake shades its total. One solve per group: the cost of the bake's shoot and
// interreflection again, once over all groups' sources and once per group.
std::vector<visdb::LightGroupShades> shade_light_groups(
    const visdb::Scene& scene, const std::vector<std::string>& groups, const BakeGeometry& source,
    const Regions& regions, const Bvh& bvh, const Hemicube& hemicube, const BakeGeometry& target,
    const std::vector<std::uint32_t>& vertex_region, bool dm, const BakeOptions& options,
    const ProgressFn& progress) {
    const std::vector<std::string> source_group = triangle_groups(scene, source);
    const std::vector<std::string> target_group = triangle_groups(scene, target);
    BakeOptions o = options;
    o.convergence = nullptr;
    o.cluster = nullptr;  // rank 0 alone shades the groups
    std::vector<visdb::LightGroupShades> out;
    for (std::size_t i = 0; i < groups.size(); ++i) {
        if (progress) progress("light groups", i, groups.size());
        const BakeGeometry lights = restrict_to_group(source, source_group, groups[i]);
        BakeGeometry shaded = restrict_to_group(target, target_group, groups[i]);
        const std::vector<visdb::Rgb> direct =
            group_direct(lights, regions, bvh, hemicube, shaded, dm, o);
        std::optional<IndirectSolution> indirect;
        std::optional<VertexGather> gathered;
        if (options.bounces != 0) {
            indirect = interreflect(lights, regions, o, nullptr, {});
            if (options.edge_gather)
                gathered = gather_near_boundaries(lights, regions, o, *indirect, shaded, direct,
                                                  vertex_region, {});
        }
        visdb::BakeMesh m =
            shade_vertices(std::move(shaded), direct, indirect ? &*indirect : nullptr,
                           vertex_region, gathered ? &*gathered : nullptr, nullptr);
        out.push_back({groups[i], std::move(m.irradiance), std::move(m.radiosity)});
    }
    if (progress) progress("light groups", groups.size(), groups.size());
    return out;
}

// The pipeline, in the scene's own frame.
visdb::Bake bake_here(const visdb::Scene& scene, const BakeOptions& options,
                      const ProgressFn& progress) {
    const auto t_start = Clock::now();
    visdb::Bake result;
    visdb::BakeStats& stats = result.statistics;

    // Build the bake mesh and its planar regions
    BakeGeometry geometry = build_bake_mesh(scene, &stats);
    Regions regions = make_regions(geometry);
    if (options.dm || options.bounces != 0)
        regions.outlines =
            outline_patches(geometry.patches, regions.of_triangle, region_normals(regions));
    const Bvh bvh(geometry.patches);
    const Hemicube hemicube(options.resolution);  // the lights' shots, and patch shading

    // Shoot the lights: patch irradiance, exact vertex irradiance or shadow segments
    LightShots shots = shoot_lights(geometry, regions, bvh, hemicube, options, &stats, progress);

    // Interreflection on the imported mesh's elements (over the ranks, each its share of the
    // hemicubes: every rank ends with the same solution)
    std::optional<IndirectSolution> indirect;
    if (options.bounces != 0) indirect = interreflect(geometry, regions, options, &stats, progress);

    // Discontinuity mesh: the receivers re-meshed along the shadow segments and refined where
    // the whole field (the indirect part too) needs vertices
    std::optional<DiscontinuityMesh> dm;
    if (options.dm)
        dm = mesh_discontinuities(geometry, bvh, regions, shots, indirect ? &*indirect : nullptr,
                                  options, &stats, progress);

    // The other ranks have given their share (cluster.h): rank 0 finishes the bake
    if (options.cluster && options.cluster->size() > 1) {
        result.parameters.emplace_back("ranks", std::to_string(options.cluster->size()));
        options.cluster->add_up_sent();
        if (options.cluster->rank() != 0) return result;
    }

    // Shade vertices: direct irradiance at every output vertex, then B = E + ρ(direct +
    // indirect)
    const bool exact = options.shading == Shading::Exact;
    BakeGeometry target;
    std::vector<visdb::Rgb> direct;
    std::vector<std::uint32_t> vertex_region;
    const std::vector<std::string> groups = bake_light_groups(scene, geometry);
    const BakeGeometry* sources = &geometry;  // the imported mesh (moved into target without DM)
    if (dm) {
        target = describe_mesh(scene, std::move(dm->mesh));
        direct =
            exact ? std::move(dm->irradiance) : shade_patches(geometry, target, hemicube, options);
        vertex_region = std::move(dm->vertex_region);
    } else {
        // (the bound holds for area lights only: with luminaires the sum is not bounded)
        if (!exact && geometry.luminaires.empty())
            bound_by_exitance(geometry, shots.triangle_irradiance);
        direct = exact ? std::move(shots.vertex_irradiance)
                       : average_to_vertices(geometry, shots.triangle_irradiance);
        if (indirect) vertex_region = vertex_regions(geometry, regions);
        target = std::move(geometry);
        sources = &target;
    }

    // Shades per light group, when the scene names groups (light scenes without re-baking)
    if (!groups.empty()) {
        const auto t_groups = Clock::now();
        result.light_groups =
            shade_light_groups(scene, groups, *sources, regions, bvh, hemicube, target,
                               vertex_region, dm.has_value(), options, progress);
        stats.seconds_light_groups = seconds_since(t_groups);
    }
    std::optional<VertexGather> gathered;
    if (indirect && options.edge_gather) {
        const auto t_gather = Clock::now();
        gathered = gather_near_boundaries(*sources, regions, options, *indirect, target, direct,
                                          vertex_region, progress);
        stats.indirect->gathered_vertices = gathered->vertices.size();
        stats.indirect->seconds_gather = seconds_since(t_gather);
    }
    result.mesh = shade_vertices(std::move(target), direct, indirect ? &*indirect : nullptr,
                                 vertex_region, gathered ? &*gathered : nullptr, &stats);

    // Statistics and parameters
    stats.triangles = result.mesh.triangles.size();
    stats.vertices = result.mesh.positions.size();
    result.name = options.name;
    result.unit = scene.emittance_unit == "lm/m2" ? "lux" : "W/m2";
    const auto distributed = std::move(result.parameters);
    result.parameters = parameters_of(options);
    if (!groups.empty()) {
        std::string names;
        for (const std::string& g : groups) names += (names.empty() ? "" : ",") + g;
        result.parameters.emplace_back("light_groups", names);
    }
    result.parameters.insert(result.parameters.end(), distributed.begin(), distributed.end());
    stats.seconds_total = seconds_since(t_start);
    return result;
}

// One unused-setting rule: the option is used iff `used(options)`; `when` says when it is.
struct UsedWhen {
    const char* option;
    bool (*used)(const BakeOptions&);
    const char* when;
};

constexpr UsedWhen kUsedWhen[] = {
    {"--subpixels", [](const BakeOptions& o) { return o.method == Visibility::ABuffer; },
     "--method abuffer"},
    {"--converge", [](const BakeOptions& o) { return o.bounces < 0; }, "--bounces converge"},
    {"--overrelax", [](const BakeOptions& o) { return o.bounces < 0; }, "--bounces converge"},
    {"--ambient", [](const BakeOptions& o) { return o.bounces < 0; }, "--bounces converge"},
    {"--element-resolution", [](const BakeOptions& o) { return o.bounces != 0; },
     "--bounces converge or N > 0"},
    {"--element-subpixels",
     [](const BakeOptions& o) { return o.bounces != 0 && o.method == Visibility::ABuffer; },
     "--bounces converge or N > 0, with --method abuffer"},
    {"--element-size", [](const BakeOptions& o) { return o.bounces != 0; },
     "--bounces converge or N > 0"},
    {"--shooter-cells", [](const BakeOptions& o) { return o.bounces != 0; },
     "--bounces converge or N > 0"},
    {"--edge-gather", [](const BakeOptions& o) { return o.bounces != 0; },
     "--bounces converge or N > 0"},
    {"--convergence-csv", [](const BakeOptions& o) { return o.bounces != 0; },
     "--bounces converge or N > 0"},
    {"--lights", [](const BakeOptions& o) { return o.dm; }, "--dm on"},
    {"--dm-angle", [](const BakeOptions& o) { return o.dm; }, "--dm on"},
    {"--refine-rounds", [](const BakeOptions& o) { return o.dm; }, "--dm on"},
    {"--refine-tolerance", [](const BakeOptions& o) { return o.dm && o.refine_rounds > 0; },
     "--dm on and --refine-rounds > 0"},
    {"--refine-min-edge", [](const BakeOptions& o) { return o.dm && o.refine_rounds > 0; },
     "--dm on and --refine-rounds > 0"},
};

}  // namespace

std::string to_string(Shading shading) { return shading == Shading::Exact ? "exact" : "patch"; }

void validate(const BakeOptions& o) {
    if (o.resolution < 2 || o.resolution > 4096 || o.resolution % 2 != 0)
        throw InputError("--resolution must be an even number in [2, 4096], got " +
                         std::to_string(o.resolution));
    if (o.method == Visibility::ABuffer && !supported_subpixels(o.subpixels))
        throw InputError("--subpixels must be 4, 8 or 16, got " + std::to_string(o.subpixels));
    if (o.bounces < -1 || o.bounces > 1000)
        throw InputError("--bounces must be in [0, 1000] (or -1: until converged), got " +
                         std::to_string(o.bounces));
    validate(solver_options(o));
    if (!(o.reach >= 0.0 && o.reach < 1e7))
        throw InputError("--reach must be >= 0 metres (0 = unlimited), got " +
                         std::to_string(o.reach));
    if (o.threads < 0) throw InputError("--threads must be >= 0, got " + std::to_string(o.threads));
    if (!(o.dm_min_angle >= 0.0 && o.dm_min_angle <= 20.7))
        throw InputError("--dm-angle must be in [0, 20.7] degrees, got " +
                         std::to_string(o.dm_min_angle));
    if (o.refine_rounds < 0 || o.refine_rounds > 20)
        throw InputError("--refine-rounds must be in [0, 20], got " +
                         std::to_string(o.refine_rounds));
    if (!(o.refine_tolerance > 0.0 && o.refine_tolerance < 1e3))
        throw InputError("--refine-tolerance must be > 0, got " +
                         std::to_string(o.refine_tolerance));
    if (!(o.refine_min_edge >= 0.0 && std::isfinite(o.refine_min_edge)))
        throw InputError("--refine-min-edge must be >= 0 metres (0: 1/128 of the model), got " +
                         std::to_string(o.refine_min_edge));
}

void check_unused(const BakeOptions& options, std::span<const std::string> given) {
    for (const std::string& name : given)
        for (const UsedWhen& rule : kUsedWhen)
            if (name == rule.option && !rule.used(options))
                throw InputError(name + " is not used by this bake (it applies with " + rule.when +
                                 " only)");
}

visdb::Bake bake(const visdb::Scene& scene, const BakeOptions& options,
                 const ProgressFn& progress) {
    validate(options);
    // Materials as stored: a damaged or edited database (rho = 2) baked to NaN
    for (const visdb::Material& m : scene.materials) {
        const std::string problem = visdb::material_problem(m);
        if (!problem.empty()) throw InputError("material '" + m.name + "': " + problem);
    }
    tbb::task_arena arena(options.threads > 0 ? options.threads : tbb::task_arena::automatic);
    return arena.execute([&] {
        // Work in the local frame of a scene far from the origin (visdb::local_origin)
        const glm::dvec3 origin = visdb::local_origin(scene);
        if (origin == glm::dvec3(0.0)) return bake_here(scene, options, progress);
        visdb::Scene local = scene;
        for (auto& s : local.surfaces)
            for (glm::dvec3& p : s.mesh.positions) p -= origin;
        for (visdb::Luminaire& l : local.luminaires) l.position -= origin;
        visdb::Bake result = bake_here(local, options, progress);
        for (glm::dvec3& p : result.mesh.positions) p += origin;
        result.parameters.emplace_back("local_origin", std::to_string(origin.x) + " " +
                                                           std::to_string(origin.y) + " " +
                                                           std::to_string(origin.z));
        return result;
    });
}

}  // namespace abrad::radiosity
