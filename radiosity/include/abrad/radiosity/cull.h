#pragma once
// Culling before a light shoots (issue 6): what a light triangle cannot light or shadow is left
// out of its hemicube, its exact shading and its shadow edges, so a bake's cost follows what
// each light sees instead of the whole building.

#include <cstdint>
#include <span>
#include <vector>

#include "abrad/radiosity/bvh.h"
#include "abrad/radiosity/shoot.h"

namespace abrad::radiosity {

/// The patches that may receive light from, or stop light of, patches[light]: every patch
/// with a corner strictly in front of the light's plane (one wholly on or behind it is neither
/// lit nor between the light and anything lit), and when `reach` > 0 metres only those whose
/// box meets the cube of half side `reach` around the light's centroid. The light itself is
/// left out. Sorted ascending.
///
/// `reach` = 0 culls nothing the light can reach (exact). `reach` > 0 drops the light's
/// contribution beyond that distance, bounded by E·A/(π·(reach − r_light)²) W/m² per light of
/// emittance E, area A and circumradius r_light (the disc bound on a point-to-polygon form
/// factor): a cost bound for large buildings, where walls hide far lights anyway.
std::vector<std::uint32_t> light_candidates(const Bvh& bvh, std::span<const Patch> patches,
                                            std::uint32_t light, double reach);

/// The vertices of `triangles` (indices into `mesh_triangles`), sorted and unique.
std::vector<std::uint32_t> vertices_of(std::span<const std::uint32_t> triangles,
                                       std::span<const glm::u32vec3> mesh_triangles);

}  // namespace abrad::radiosity
