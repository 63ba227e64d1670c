// Stages 5 and 6 of the bake: the paper's patch shading (area-weighted patch irradiance at
// each vertex, section 3.5) and the radiosity B = E + ρH at every output vertex.
// docs/algorithms.md#vertex-shading.

#include <tbb/parallel_for.h>

#include <algorithm>
#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <mutex>
#include <vector>

#include "abrad/radiosity/form_factor.h"
#include "abrad/radiosity/point_source.h"
#include "stages.h"

namespace abrad::radiosity {

double add_patch_irradiance(const ShootResult& shot, const ShooterFrame& from,
                            const visdb::Rgb& emittance, double light_area,
                            const BakeGeometry& target,
                            std::vector<visdb::Rgb>& triangle_irradiance) {
    double ff_sum = 0.0;
    for (std::size_t j = 0; j < target.patches.size(); ++j) {
        if (shot.form_factor[j] <= 0.0 || !(target.area[j] > 0.0)) continue;
        ff_sum += shot.form_factor[j];
        // A patch smaller than a hemicube sample still takes a whole (fine) sample, and
        // dividing the light's share by a sliver's tiny area made it 300-1,700 times too
        // bright. A form factor more than kUndersampledFactor times the closed form of the patch's
        // unoccluded view from the shooting point can only be that: it is replaced by the
        // closed form (pixel-edge errors of larger patches, either way, stay as they were).
        // The receiver's form factor to the light F_jL = F_Lj A_L / A_j is at most 1.
        double f = shot.form_factor[j];
        const double f_max =
            unoccluded_triangle_form_factor(from.origin, from.n, target.patches[j].p);
        if (f > kUndersampledFactor * f_max) f = f_max;
        const double f_receiver = std::min(1.0, f * light_area / target.area[j]);
        triangle_irradiance[j] += emittance * f_receiver;
    }
    return ff_sum;
}

double add_flux_irradiance(const ShootResult& shot, const visdb::Rgb& flux,
                           const BakeGeometry& target,
                           std::vector<visdb::Rgb>& triangle_irradiance) {
    double ff_sum = 0.0;
    for (std::size_t j = 0; j < target.patches.size(); ++j) {
        if (shot.form_factor[j] <= 0.0 || !(target.area[j] > 0.0)) continue;
        ff_sum += shot.form_factor[j];
        triangle_irradiance[j] += flux * (shot.form_factor[j] / target.area[j]);
    }
    return ff_sum;
}

void bound_by_exitance(const BakeGeometry& lights, std::vector<visdb::Rgb>& triangle_irradiance) {
    visdb::Rgb e_max(0.0);
    for (const std::uint32_t l : lights.lights) e_max = glm::max(e_max, lights.emittance[l]);
    for (visdb::Rgb& h : triangle_irradiance) h = glm::min(h, e_max);
}

std::vector<visdb::Rgb> average_to_vertices(const BakeGeometry& g,
                                            const std::vector<visdb::Rgb>& triangle_irradiance) {
    std::vector<visdb::Rgb> vert(g.mesh.positions.size(), visdb::Rgb(0.0));
    for (std::size_t v = 0; v < vert.size(); ++v) {
        visdb::Rgb sum(0.0);
        double area = 0.0;
        for (std::uint32_t k = g.incident_start[v]; k < g.incident_start[v + 1]; ++k) {
            const std::uint32_t t = g.incident[k];
            sum += triangle_irradiance[t] * g.area[t];
            area += g.area[t];
        }
        vert[v] = area > 0.0 ? sum / area : visdb::Rgb(0.0);
    }
    return vert;
}

std::vector<visdb::Rgb> shade_patches(const BakeGeometry& lights, const BakeGeometry& target,
                                      const Hemicube& hemicube, const BakeOptions& options) {
    std::vector<visdb::Rgb> tri(target.mesh.triangles.size(), visdb::Rgb(0.0));
    const ShootOptions so{
        .method = options.method, .subpixels = options.subpixels, .occlusion = false};
    std::mutex accumulate;
    tbb::parallel_for(std::size_t{0}, lights.lights.size(), [&](std::size_t li) {
        const std::uint32_t l = lights.lights[li];
        // The light's own pieces lie in the shooter's plane and receive nothing
        const ShooterFrame frame = frame_of(lights.patches[l]);
        const ShootResult shot = shoot(frame, target.patches, hemicube, so);
        std::vector<visdb::Rgb> mine(tri.size(), visdb::Rgb(0.0));
        add_patch_irradiance(shot, frame, lights.emittance[l], lights.area[l], target, mine);
        std::lock_guard lock(accumulate);
        for (std::size_t j = 0; j < tri.size(); ++j) tri[j] += mine[j];
    });
    bound_by_exitance(lights, tri);
    // Luminaires: their point-source hemicubes, each pixel a fraction of the flux
    for (const visdb::Luminaire& lum : lights.luminaires)
        for (const PointShooter& shooter : point_shooters(lum, hemicube.resolution()))
            add_flux_irradiance(shoot(shooter.frame, target.patches, shooter.hemicube, so),
                                luminaire_power(lum), target, tri);
    return average_to_vertices(target, tri);
}

std::vector<visdb::Rgb> conservative_indirect(const BakeGeometry& target,
                                              const IndirectSolution& indirect,
                                              const std::vector<std::uint32_t>& vertex_region,
                                              const VertexGather* gathered) {
    const visdb::BakeMesh& mesh = target.mesh;
    std::vector<visdb::Rgb> x(mesh.positions.size());
    for (std::size_t v = 0; v < x.size(); ++v)
        x[v] = indirect.at(vertex_region[v], mesh.positions[v]);
    // Gathered vertices keep their values (point values, not extrapolations): the others carry
    // the scale
    std::vector<char> fixed(x.size(), 0);
    if (gathered)
        for (std::size_t k = 0; k < gathered->vertices.size(); ++k) {
            x[gathered->vertices[k]] = gathered->values[k];
            fixed[gathered->vertices[k]] = 1;
        }
    // Per region: the flux the solution holds (Σ H·A over its elements) and the Gouraud
    // field's (Σ over its triangles of the area times the mean of the corners), the fixed
    // vertices' share of it apart
    const std::size_t regions = indirect.grids.size();
    std::vector<visdb::Rgb> solution(regions, visdb::Rgb(0.0)), gouraud(regions, visdb::Rgb(0.0));
    std::vector<visdb::Rgb> kept(regions, visdb::Rgb(0.0));
    for (const IndirectSolution::Element& e : indirect.elements)
        solution[e.region] += e.indirect * e.area;
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
        const glm::u32vec3 tri = mesh.triangles[t];
        const std::uint32_t r = vertex_region[tri.x];
        if (r >= regions) continue;
        visdb::Rgb scaled(0.0), held(0.0);
        for (int k = 0; k < 3; ++k) (fixed[tri[k]] ? held : scaled) += x[tri[k]];
        gouraud[r] += target.area[t] / 3.0 * scaled;
        kept[r] += target.area[t] / 3.0 * held;
    }
    std::vector<visdb::Rgb> scale(regions, visdb::Rgb(1.0));
    for (std::size_t r = 0; r < regions; ++r)
        for (int c = 0; c < 3; ++c)
            if (gouraud[r][c] > 0.0 && solution[r][c] > 0.0)
                scale[r][c] = std::clamp((solution[r][c] - kept[r][c]) / gouraud[r][c],
                                         1.0 / kMaxFluxScale, kMaxFluxScale);
    for (std::size_t v = 0; v < x.size(); ++v)
        if (vertex_region[v] < regions && !fixed[v]) x[v] *= scale[vertex_region[v]];
    return x;
}

visdb::BakeMesh shade_vertices(BakeGeometry target, const std::vector<visdb::Rgb>& direct,
                               const IndirectSolution* indirect,
                               const std::vector<std::uint32_t>& vertex_region,
                               const VertexGather* gathered, visdb::BakeStats* stats) {
    // B = E + ρH with the material of the vertex's first triangle: all of a vertex's
    // triangles belong to one surface
    visdb::BakeMesh& mesh = target.mesh;
    const std::size_t n = mesh.positions.size();
    mesh.irradiance.resize(n);
    mesh.radiosity.resize(n);
    std::vector<visdb::Rgb> reflected;
    if (indirect) reflected = conservative_indirect(target, *indirect, vertex_region, gathered);
    double indirect_sum = 0.0;
    for (std::size_t v = 0; v < n; ++v) {
        const std::uint32_t t = target.incident[target.incident_start[v]];
        visdb::Rgb h = direct[v];
        if (indirect) {
            h += reflected[v];
            indirect_sum += visdb::channel_mean(reflected[v]);
        }
        mesh.irradiance[v] = glm::vec3(h);
        mesh.radiosity[v] = glm::vec3(target.emittance[t] + target.reflectance[t] * h);
    }
    if (stats && stats->indirect)
        stats->indirect->mean_at_vertices = n ? indirect_sum / static_cast<double>(n) : 0.0;
    return std::move(target.mesh);
}

}  // namespace abrad::radiosity
