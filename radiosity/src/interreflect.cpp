// Stage 4 of the bake: interreflection on the scene's triangles, clustered into elements per
// planar region, solved by progressive refinement (indirect.h states the method and papers;
// docs/algorithms.md#interreflection).

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "abrad/check.h"
#include "stages.h"

namespace abrad::radiosity {

IndirectSolution interreflect(const BakeGeometry& g, const Regions& regions,
                              const BakeOptions& options, visdb::BakeStats* stats,
                              const ProgressFn& progress) {
    const std::vector<glm::dvec3> region_normal = region_normals(regions);
    const IndirectInput input{
        .patches = g.patches,
        .reflectance = g.reflectance,
        .emittance = g.emittance,
        .region = regions.of_triangle,
        .region_normal = region_normal,
        .luminaires = g.luminaires,
        .outlines = regions.outlines.patches.empty() ? nullptr : &regions.outlines};
    const IndirectOptions io{.bounces = std::max(options.bounces, 0),
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

}  // namespace abrad::radiosity
