#pragma once
// Exact direct irradiance at any point of a scene: every light-source triangle, seen past
// every occluder between the point and the light (conservative bounding-volume candidates,
// exact clipping in visible_form_factor).

#include <algorithm>
#include <array>
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

/// Light triangles that make a convex quadrilateral two by two: two triangles that share an
/// edge (the same two corners, bit for bit, in opposite directions), lie in one plane (unit
/// normals within 1e-9) and give the same emittance, and whose union is convex. Most lights
/// of a building are rectangles, two triangles each; the exact evaluation then sees the
/// quadrilateral past the union of both triangles' occluder candidates once (each candidate
/// tested and subtracted once, not twice). Pairs are made in the order of `lights`, each
/// triangle with the first neighbour across its edges (in edge order) still free.
class LightQuads {
  public:
    struct Quad {
        std::uint32_t first = kNoPatch, second = kNoPatch;  ///< the two light triangles
        std::array<glm::dvec3, 4> corners;  ///< counter-clockwise seen from the front
    };

    LightQuads() = default;
    LightQuads(std::span<const Patch> patches, std::span<const visdb::Rgb> emittance,
               std::span<const std::uint32_t> lights);

    /// Light triangle l's quadrilateral, or null when it makes none.
    const Quad* quad_of(std::uint32_t l) const {
        return l < m_quad_of.size() && m_quad_of[l] != kNoPatch ? &m_quads[m_quad_of[l]] : nullptr;
    }
    std::size_t size() const { return m_quads.size(); }

  private:
    std::vector<std::uint32_t> m_quad_of;  // per patch id up to the largest light's
    std::vector<Quad> m_quads;
};

/// exact_irradiance (below) with each light's occluder candidates from `candidates(k, occ)`,
/// which appends to `occ` those that may lie between x and the light triangle
/// patches[lights[k]]: exact_irradiance's shaft query, or a shorter list a caller filters
/// alike (discontinuity.cpp's tiles). One loop, so both skip the same lights. `lights` is
/// ascending. With `quads`, two lights of `lights` that make a quadrilateral and both give
/// light here (x in front, within reach) are seen as the quadrilateral, past the union of
/// their candidates (the pyramid of x and the quadrilateral is the union of the two shafts);
/// the same light in exact arithmetic, each occluder once. `coplanar`: visible_form_factor's.
template <typename Candidates>
visdb::Rgb exact_irradiance_with(std::span<const Patch> patches,
                                 std::span<const visdb::Rgb> emittance,
                                 std::span<const std::uint32_t> lights, const glm::dvec3& x,
                                 const glm::dvec3& n, std::vector<const Patch*>& occ, double reach,
                                 Candidates&& candidates, const LightQuads* quads = nullptr,
                                 double coplanar = 0.0) {
    // Whether light triangle l gives light at x: in front of its plane, within its reach
    // (cull.h)
    const auto gives = [&](std::uint32_t l) {
        const Patch& lp = patches[l];
        if (glm::dot(x - lp.p[0], cross_normal(lp)) <= 0.0) return false;
        if (reach > 0.0) {
            const glm::dvec3 d = glm::abs(x - centroid(lp));
            if (d.x > reach || d.y > reach || d.z > reach) return false;
        }
        return true;
    };
    const auto alone = [&](std::size_t k) {
        occ.clear();
        candidates(k, occ);
        return emittance[lights[k]] *
               visible_form_factor(x, n, patches[lights[k]], occ, nullptr, coplanar);
    };
    visdb::Rgb h(0.0);
    for (std::size_t k = 0; k < lights.size(); ++k) {
        const std::uint32_t l = lights[k];
        const LightQuads::Quad* quad = quads ? quads->quad_of(l) : nullptr;
        std::size_t k2 = lights.size();  // the partner's place in `lights`, when listed
        if (quad) {
            const std::uint32_t other = quad->first == l ? quad->second : quad->first;
            const auto it = std::lower_bound(lights.begin(), lights.end(), other);
            if (it != lights.end() && *it == other)
                k2 = static_cast<std::size_t>(it - lights.begin());
        }
        if (k2 == lights.size()) {  // alone
            if (gives(l)) h += alone(k);
            continue;
        }
        if (k2 < k) continue;  // seen with its partner, listed first
        const bool first = gives(l), second = gives(lights[k2]);
        if (first && second) {
            occ.clear();
            candidates(k, occ);
            candidates(k2, occ);
            std::sort(occ.begin(), occ.end());
            occ.erase(std::unique(occ.begin(), occ.end()), occ.end());
            h += emittance[l] * visible_form_factor(x, n, quad->corners, occ, nullptr, coplanar);
        } else if (first) {
            h += alone(k);
        } else if (second) {
            h += alone(k2);
        }
    }
    return h;
}

/// Exact direct irradiance H (W/m², RGB) at `x` on a surface with unit normal `n` (its front)
/// from the light triangles patches[l], l in `lights`, each of emittance emittance[l], past
/// every occluder the BVH (built over `patches`) can place between x and the light. Lights
/// whose plane x is not in front of give nothing; with `reach` > 0 metres, lights whose
/// centroid is farther than `reach` along some axis are skipped (cull.h). `occ` is scratch.
/// With `quads` (made over `lights` or more), pairs of lights seen as quadrilaterals.
/// `coplanar`: visible_form_factor's.
visdb::Rgb exact_irradiance(std::span<const Patch> patches, std::span<const visdb::Rgb> emittance,
                            std::span<const std::uint32_t> lights, const Bvh& bvh,
                            const glm::dvec3& x, const glm::dvec3& n,
                            std::vector<const Patch*>& occ, double reach = 0.0,
                            const LightQuads* quads = nullptr, double coplanar = 0.0);

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
    /// normal `n` (its front): the light triangles' and the luminaires' (point sources). A
    /// triangle whose plane passes within the bake's length tolerance of x (1e-7 of the
    /// scene's bounding diagonal) hides nothing from it, as in the discontinuity mesh: a point
    /// on a surface sees what the points just in front of it see, whatever faces lie in that
    /// surface's plane to the tolerance (coplanar overlaps, a region's other triangles).
    visdb::Rgb irradiance(const glm::dvec3& x, const glm::dvec3& n) const;

    std::size_t light_triangles() const { return m_lights.size(); }

  private:
    std::vector<visdb::Rgb> m_emittance;  // per patch; declared first: filled with m_patches
    std::vector<Patch> m_patches;
    std::vector<std::uint32_t> m_lights;
    std::vector<visdb::Luminaire> m_luminaires;
    Bvh m_bvh;
    LightQuads m_quads;
    double m_coplanar = 0.0;  // metres
};

}  // namespace abrad::radiosity
