#pragma once
// Exact direct irradiance at any point of a scene: every light-source triangle, seen past
// every occluder between the point and the light (conservative bounding-volume candidates,
// exact clipping in visible_form_factor).

#include <cstdint>
#include <glm/vec3.hpp>
#include <span>
#include <vector>

#include "abrad/radiosity/bvh.h"
#include "abrad/radiosity/geometry.h"
#include "abrad/visdb/model.h"

namespace abrad::radiosity {

/// Calls `visit(id)` for every patch that may lie between `x` and the light triangle
/// patches[light]: those whose box meets the tetrahedron of x and the light (a shaft query:
/// conservative; exact rejection is visible_form_factor's). The light itself is skipped.
template <typename Visit>
void for_each_shadow_candidate(const Bvh& bvh, std::span<const Patch> patches, std::uint32_t light,
                               const glm::dvec3& x, Visit&& visit) {
    const glm::dvec3 corners[4] = {patches[light].p[0], patches[light].p[1], patches[light].p[2],
                                   x};
    bvh.query(Hull(corners), [&](std::uint32_t id) {
        if (id != light) visit(id);
    });
}

/// Exact direct irradiance H (W/m², RGB) at `x` on a surface with unit normal `n` (its front)
/// from the light triangles patches[l], l in `lights`, each of emittance emittance[l], past
/// every occluder the BVH (built over `patches`) can place between x and the light. Lights
/// whose plane x is not in front of give nothing; with `reach` > 0 metres, lights whose
/// centroid is farther than `reach` along some axis are skipped (cull.h). `occ` is scratch.
visdb::Rgb exact_irradiance(std::span<const Patch> patches, std::span<const visdb::Rgb> emittance,
                            std::span<const std::uint32_t> lights, const Bvh& bvh,
                            const glm::dvec3& x, const glm::dvec3& n,
                            std::vector<const Patch*>& occ, double reach = 0.0);

/// Where the open segment (a, b) crosses the triangle `p`: the fraction t in (0, 1) along it,
/// or -1 when it does not (Möller-Trumbore in double precision, not exact). Crossings within
/// a relative 1e-9 of either end do not count (the receiver's own surface at a, a luminaire's
/// housing at b), nor does a segment in the triangle's plane.
double segment_crossing(const Patch& p, const glm::dvec3& a, const glm::dvec3& b);

/// The fraction of a point source's light at `source` that reaches `x`: the product of 1 − α
/// over the patches (of the BVH built over `patches`) that the segment between them crosses.
/// Crossings of coplanar patches at the same place (within 1e-9 of the segment) count once:
/// a segment through the edge two triangles of one surface share passes one surface.
double transmittance(std::span<const Patch> patches, const Bvh& bvh, const glm::dvec3& x,
                     const glm::dvec3& source);

/// Exact direct illuminance (lux, RGB) at `x` on a surface with unit normal `n` (its front)
/// from a luminaire taken as a point source at its photometric centre: I(−ω)·cos θ / d², ω
/// the unit direction from x to the source at distance d, θ its angle to n, I the luminaire's
/// intensity toward x, times the transmittance past the patches. 0 when the source is not in
/// front of x. Exact for a point source; a luminous opening larger than a fifth of d is not
/// integrated over yet.
visdb::Rgb point_source_irradiance(const visdb::Luminaire& luminaire,
                                   std::span<const Patch> patches, const Bvh& bvh,
                                   const glm::dvec3& x, const glm::dvec3& n);

/// Σ point_source_irradiance over `luminaires`; with `reach` > 0 metres, luminaires farther
/// than `reach` from `x` along some axis are skipped (as light triangles are, cull.h).
visdb::Rgb luminaires_irradiance(std::span<const visdb::Luminaire> luminaires,
                                 std::span<const Patch> patches, const Bvh& bvh,
                                 const glm::dvec3& x, const glm::dvec3& n, double reach = 0.0);

class DirectField {
  public:
    /// Prepares the scene's triangles and luminaires; throws InputError when the scene has
    /// neither an emitting material nor a luminaire.
    explicit DirectField(const visdb::Scene& scene);

    /// Irradiance H (W/m², RGB; lux in photometric scenes) at `x` on a surface with unit
    /// normal `n` (its front): the light triangles' and the luminaires' (point sources).
    visdb::Rgb irradiance(const glm::dvec3& x, const glm::dvec3& n) const;

    std::size_t light_triangles() const { return m_lights.size(); }

  private:
    std::vector<visdb::Rgb> m_emittance;  // per patch; declared first: filled with m_patches
    std::vector<Patch> m_patches;
    std::vector<std::uint32_t> m_lights;
    std::vector<visdb::Luminaire> m_luminaires;
    Bvh m_bvh;
};

}  // namespace abrad::radiosity
