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

class DirectField {
  public:
    /// Prepares the scene's triangles; throws InputError when the scene has no light.
    explicit DirectField(const visdb::Scene& scene);

    /// Irradiance H (W/m², RGB) at `x` on a surface with unit normal `n` (its front).
    visdb::Rgb irradiance(const glm::dvec3& x, const glm::dvec3& n) const;

    std::size_t light_triangles() const { return m_lights.size(); }

  private:
    std::vector<visdb::Rgb> m_emittance;  // per patch; declared first: filled with m_patches
    std::vector<Patch> m_patches;
    std::vector<std::uint32_t> m_lights;
    Bvh m_bvh;
};

}  // namespace abrad::radiosity
