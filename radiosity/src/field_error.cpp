// The field error of a bake (docs/algorithms.md#field-error): Gouraud-interpolated vertex
// irradiance against the exact field at the centroids of each triangle's k² similar
// sub-triangles.
//
// Numerics: vertex irradiance is stored in float and widened to double before
// interpolation; everything else is double. Sums are formed per fixed block of triangles and
// added in block order, so the result does not depend on the thread schedule.

#include "abrad/radiosity/field_error.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <glm/geometric.hpp>
#include <glm/vec2.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "abrad/radiosity/stage.h"

namespace abrad::radiosity {

namespace {

// Triangles per block of the parallel loop (and per partial sum).
constexpr std::size_t kBlock = 64;

struct Partial {
    double error = 0.0;  // Σ A·mean|interpolated − exact|
    double exact = 0.0;  // Σ A·mean|exact|
    double mean = 0.0;   // Σ A·mean(exact)
    double area = 0.0;   // Σ A
    std::size_t triangles = 0;
    std::size_t samples = 0;
};

double channel_mean(const visdb::Rgb& c) { return (c.x + c.y + c.z) / 3.0; }

visdb::Rgb abs(const visdb::Rgb& c) { return {std::abs(c.x), std::abs(c.y), std::abs(c.z)}; }

// A receiver reflects some light and emits none.
bool is_receiver(const visdb::Material& m) {
    const bool reflects = m.reflectance.x > 0.0 || m.reflectance.y > 0.0 || m.reflectance.z > 0.0;
    const bool emits = m.emittance.x != 0.0 || m.emittance.y != 0.0 || m.emittance.z != 0.0;
    return reflects && !emits;
}

// Barycentric (u, v) of the centroids of the regular subdivision of the triangle into k²
// similar ones, with weights (1 − u − v, u, v) on vertices (a, b, c): the k(k+1)/2 upward
// sub-triangles with lattice corners (i,j), (i+1,j), (i,j+1), i + j <= k − 1, and the
// k(k−1)/2 downward ones with corners (i+1,j), (i,j+1), (i+1,j+1), i + j <= k − 2.
std::vector<glm::dvec2> subtriangle_centroids(int k) {
    std::vector<glm::dvec2> uv;
    uv.reserve(static_cast<std::size_t>(k) * static_cast<std::size_t>(k));
    const double s = 1.0 / (3.0 * k);
    for (int j = 0; j < k; ++j)
        for (int i = 0; i + j < k; ++i) {
            uv.push_back({(3 * i + 1) * s, (3 * j + 1) * s});
            if (i + j <= k - 2) uv.push_back({(3 * i + 2) * s, (3 * j + 2) * s});
        }
    return uv;
}

// Checks that every index of the mesh and every surface it names resolves; throws
// InputError naming what does not.
void validate(const visdb::Scene& scene, const visdb::BakeMesh& mesh,
              const FieldErrorOptions& options) {
    if (options.subdivisions < 1)
        throw InputError("field_error: subdivisions must be >= 1, got " +
                         std::to_string(options.subdivisions));
    if (mesh.irradiance.size() != mesh.positions.size())
        throw InputError("field_error: the mesh has " + std::to_string(mesh.irradiance.size()) +
                         " irradiance values for " + std::to_string(mesh.positions.size()) +
                         " vertices");
    if (mesh.triangle_surface.size() != mesh.triangles.size())
        throw InputError("field_error: the mesh has " +
                         std::to_string(mesh.triangle_surface.size()) + " triangle surfaces for " +
                         std::to_string(mesh.triangles.size()) + " triangles");
    const std::size_t nv = mesh.positions.size();
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
        const glm::u32vec3& tri = mesh.triangles[t];
        if (tri.x >= nv || tri.y >= nv || tri.z >= nv)
            throw InputError("field_error: triangle " + std::to_string(t) +
                             " indexes a vertex outside the mesh's " + std::to_string(nv));
        const std::uint32_t s = mesh.triangle_surface[t];
        if (s >= scene.surfaces.size())
            throw InputError("field_error: triangle " + std::to_string(t) + " names surface " +
                             std::to_string(s) + " but the scene has " +
                             std::to_string(scene.surfaces.size()));
    }
    for (const visdb::Surface& surface : scene.surfaces)
        if (surface.material >= scene.materials.size())
            throw InputError("field_error: surface '" + surface.name + "' names material " +
                             std::to_string(surface.material) + " but the scene has " +
                             std::to_string(scene.materials.size()));
}

}  // namespace

FieldError field_error(const visdb::Scene& scene, const visdb::BakeMesh& mesh,
                       const IrradianceFn& exact, const FieldErrorOptions& options) {
    if (!exact) throw InputError("field_error: no exact irradiance function");
    validate(scene, mesh, options);

    // Receivers per surface
    std::vector<char> receiver(scene.surfaces.size());
    for (std::size_t s = 0; s < scene.surfaces.size(); ++s)
        receiver[s] = is_receiver(scene.materials[scene.surfaces[s].material]) ? 1 : 0;

    const std::vector<glm::dvec2> uv = subtriangle_centroids(options.subdivisions);
    const double weight = 1.0 / static_cast<double>(uv.size());  // 1/k²

    // Sum each block of triangles on its own
    const std::size_t nt = mesh.triangles.size();
    std::vector<Partial> partial((nt + kBlock - 1) / kBlock);
    // Each triangle's error and exact sums, for the surfaces' shares (added in order below)
    std::vector<double> tri_error(nt, 0.0), tri_exact(nt, 0.0), tri_area(nt, 0.0);
    tbb::parallel_for(
        tbb::blocked_range<std::size_t>(0, partial.size(), 1), [&](const auto& blocks) {
            for (std::size_t block = blocks.begin(); block != blocks.end(); ++block) {
                Partial& p = partial[block];
                const std::size_t end = std::min(nt, (block + 1) * kBlock);
                for (std::size_t t = block * kBlock; t < end; ++t) {
                    if (!receiver[mesh.triangle_surface[t]]) continue;
                    const glm::u32vec3& tri = mesh.triangles[t];
                    const glm::dvec3 a = mesh.positions[tri.x], b = mesh.positions[tri.y],
                                     c = mesh.positions[tri.z];
                    // Geometric normal _n_ and area _area_ (counter-clockwise front)
                    const glm::dvec3 cross = glm::cross(b - a, c - a);
                    const double twice_area = glm::length(cross);
                    if (!(twice_area > 0.0) || !std::isfinite(twice_area)) continue;  // degenerate
                    const glm::dvec3 n = cross / twice_area;
                    const double area = 0.5 * twice_area;
                    const visdb::Rgb ha(mesh.irradiance[tri.x]), hb(mesh.irradiance[tri.y]),
                        hc(mesh.irradiance[tri.z]);
                    // Mean error and mean exact value over the sub-triangle centroids
                    double error = 0.0, magnitude = 0.0, mean = 0.0;
                    for (const glm::dvec2& w : uv) {
                        const double wa = 1.0 - w.x - w.y;
                        const glm::dvec3 x = wa * a + w.x * b + w.y * c;
                        const visdb::Rgb interpolated = wa * ha + w.x * hb + w.y * hc;
                        const visdb::Rgb e = exact(x, n);
                        error += channel_mean(abs(interpolated - e));
                        magnitude += channel_mean(abs(e));
                        mean += channel_mean(e);
                    }
                    tri_error[t] = area * weight * error;
                    tri_exact[t] = area * weight * magnitude;
                    tri_area[t] = area;
                    p.error += area * weight * error;
                    p.exact += area * weight * magnitude;
                    p.mean += area * weight * mean;
                    p.area += area;
                    p.triangles += 1;
                    p.samples += uv.size();
                }
            }
        });

    // Add the blocks in order
    Partial sum;
    for (const Partial& p : partial) {
        sum.error += p.error;
        sum.exact += p.exact;
        sum.mean += p.mean;
        sum.area += p.area;
        sum.triangles += p.triangles;
        sum.samples += p.samples;
    }
    FieldError result;
    result.relative_l1 = sum.exact > 0.0 ? sum.error / sum.exact : 0.0;
    result.absolute_l1 = sum.area > 0.0 ? sum.error / sum.area : 0.0;
    result.mean_exact = sum.area > 0.0 ? sum.mean / sum.area : 0.0;
    result.area_m2 = sum.area;
    result.triangles = sum.triangles;
    result.samples = sum.samples;
    // Per surface, in triangle order (the same at any thread count); a measured triangle has
    // an area
    std::vector<SurfaceFieldError> per_surface(scene.surfaces.size());
    for (std::size_t t = 0; t < nt; ++t) {
        if (!(tri_area[t] > 0.0)) continue;
        SurfaceFieldError& e = per_surface[mesh.triangle_surface[t]];
        e.error += tri_error[t];
        e.exact += tri_exact[t];
        e.area_m2 += tri_area[t];
        e.triangles += 1;
    }
    for (std::size_t s = 0; s < per_surface.size(); ++s)
        if (per_surface[s].triangles > 0) {
            per_surface[s].surface = static_cast<std::uint32_t>(s);
            result.surfaces.push_back(per_surface[s]);
        }
    return result;
}

}  // namespace abrad::radiosity
