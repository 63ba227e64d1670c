#pragma once
// Exact direct illumination at a point from a Lambertian polygonal light with polygonal
// occluders: the light clipped to the point's hemisphere, minus the central projections of
// the occluders onto the light's plane, through Lambert's point-to-polygon form factor
// (Baum, Rushmeier & Winget 1989; docs/algorithms.md#exact-form-factors).
//
// Numeric assumptions: projections and polygon differences are constructed in double
// precision (not exact); occluder points within a relative 1e-9 of the light's plane or of
// the point's own parallel plane are clipped away before projecting.

#include <cstdint>
#include <glm/vec3.hpp>
#include <span>
#include <vector>

#include "abrad/radiosity/shoot.h"

namespace abrad::radiosity {

/// Counters for the exact shading work, for statistics.
struct VisibleStats {
    std::size_t occluders_tested = 0;
    std::size_t occluders_projected = 0;  ///< occluders that overlapped the light from x
    std::size_t max_pieces = 0;           ///< most convex pieces the visible light had
    /// When set, receives the positions in `occluders` of those that hid part of the light.
    std::vector<std::uint32_t>* touched = nullptr;
};

/// Form factor from the differential area at `x` (unit normal `n`) to the part of the light
/// triangle `light` (front = counter-clockwise) seen past `occluders`. A translucent occluder
/// of opacity α lets 1 − α through. Returns 0 when `x` is not in front of the light.
///
/// An occluder whose plane contains x hides nothing from it (the rays that meet it lie in its
/// plane): within 1e-9 of the occluder's size, or within `coplanar` metres when larger. The
/// discontinuity mesh and DirectField pass the length tolerance there: the mesh's vertices lie
/// on their region's mean plane, which a face planar only to the bake's tolerance leaves
/// micrometres off the edge it shares with a neighbour, models hold faces that overlap to a
/// few micrometres, and a point just behind such a plane would see most of the light hidden.
double visible_form_factor(const glm::dvec3& x, const glm::dvec3& n, const Patch& light,
                           std::span<const Patch* const> occluders, VisibleStats* stats = nullptr,
                           double coplanar = 0.0);

/// The same for a convex planar light polygon of 3 to 8 corners (counter-clockwise seen from
/// its front; its plane from the first three): two light triangles that make a quadrilateral
/// are seen past their occluders at once, each occluder tested once (LightQuads in direct.h).
double visible_form_factor(const glm::dvec3& x, const glm::dvec3& n,
                           std::span<const glm::dvec3> light,
                           std::span<const Patch* const> occluders, VisibleStats* stats = nullptr,
                           double coplanar = 0.0);

}  // namespace abrad::radiosity
