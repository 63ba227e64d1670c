#pragma once
// Exact direct irradiance at any point of a scene: every light-source triangle, seen past
// every occluder between the point and the light (conservative bounding-volume candidates,
// exact clipping in visible_form_factor).

#include <cstdint>
#include <glm/vec3.hpp>
#include <span>
#include <vector>

#include "abrad/radiosity/bvh.h"
#include "abrad/radiosity/shoot.h"
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

class DirectField {
  public:
    /// Prepares the scene's triangles; throws BakeError when the scene has no light.
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
