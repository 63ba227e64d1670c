#pragma once
// Exact direct irradiance at any point of a scene: every light-source triangle, seen past
// every occluder between the point and the light (conservative bounding-volume candidates,
// exact clipping in visible_form_factor).

#include <cstdint>
#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <glm/vec3.hpp>
#include <span>
#include <vector>

#include "abrad/radiosity/bvh.h"
#include "abrad/radiosity/exact.h"
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

/// exact_irradiance (below) with each light's occluder candidates from `candidates(k, occ)`,
/// which appends to `occ` (emptied before each light) those that may lie between x and the
/// light triangle patches[lights[k]]: exact_irradiance's shaft query, or a shorter list a
/// caller filters alike (discontinuity.cpp's tiles). One loop, so both skip the same lights.
template <typename Candidates>
visdb::Rgb exact_irradiance_with(std::span<const Patch> patches,
                                 std::span<const visdb::Rgb> emittance,
                                 std::span<const std::uint32_t> lights, const glm::dvec3& x,
                                 const glm::dvec3& n, std::vector<const Patch*>& occ, double reach,
                                 Candidates&& candidates) {
    visdb::Rgb h(0.0);
    for (std::size_t k = 0; k < lights.size(); ++k) {
        const Patch& lp = patches[lights[k]];
        // Behind the light's plane (it gives nothing), or beyond its reach (cull.h)
        if (glm::dot(x - lp.p[0], cross_normal(lp)) <= 0.0) continue;
        if (reach > 0.0) {
            const glm::dvec3 d = glm::abs(x - centroid(lp));
            if (d.x > reach || d.y > reach || d.z > reach) continue;
        }
        occ.clear();
        candidates(k, occ);
        h += emittance[lights[k]] * visible_form_factor(x, n, lp, occ);
    }
    return h;
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

/// A point of a luminous opening and its share of the luminaire's intensity.
struct OpeningSample {
    glm::dvec3 point{0.0};  ///< on the opening, world metres
    double weight = 0.0;    ///< the fraction of the opening's area it stands for (sum 1)
};

/// The five-times rule: a receiver closer than this many times the opening's size
/// (LuminousOpening::size) is lit by the opening, not by its centre.
inline constexpr double kFiveTimes = 5.0;
/// At most this many cells along each side (rectangle) or rings (disc) of an opening.
inline constexpr int kMaxOpeningCells = 16;

/// The quadrature points of a flat luminous opening (a rectangle, length along axis_x by
/// width along axis_y, or a disc or ellipse of diameters length by width, in the plane of
/// axis_x and axis_y through the photometric centre) for a receiver `distance` metres from
/// that centre: n = ceil(5 size / distance) cells each way (at most kMaxOpeningCells), two
/// Gauss-Legendre points each way per cell (rectangle: n × n cells; disc: n rings × 4n
/// sectors in polar coordinates). Empty when the receiver is at least 5 sizes away or the
/// opening is a point or not flat (box, cylinders, sphere: point sources).
std::vector<OpeningSample> opening_samples(const visdb::Luminaire& luminaire, double distance);

/// Exact direct illuminance (lux, RGB) at `x` on a surface with unit normal `n` (its front)
/// from a luminaire taken as a point source at its photometric centre: I(−ω)·cos θ / d², ω
/// the unit direction from x to the source at distance d, θ its angle to n, I the luminaire's
/// intensity toward x, times the transmittance past the patches. 0 when the source is not in
/// front of x. Closer than five times a flat opening's size (opening_samples), the same sum
/// over the opening's points, each with its weight's share of the intensity and its own
/// transmittance (a uniform-luminance opening for a cosine web: its exact irradiance up to the
/// quadrature and the web's interpolation).
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
