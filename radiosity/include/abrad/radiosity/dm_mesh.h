#pragma once
// Discontinuity meshing of planar regions (docs/algorithms.md#discontinuity-meshing): a
// constrained Delaunay triangulation (CGAL) of each planar region with its boundary and the
// shadow edges as constraints, exact predicates and exact intersections where constraints cross,
// optional Ruppert/Chew refinement, and conforming boundaries between regions (no T-vertices).
//
// The header holds plain structs only: CGAL stays inside one translation unit
// (src/dm_mesh.cpp, its own static library built with -O2 and CGAL_NDEBUG).

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <glm/vec3.hpp>
#include <limits>
#include <span>
#include <vector>

namespace abrad::radiosity {

inline constexpr std::uint32_t kNewVertex = std::numeric_limits<std::uint32_t>::max();

/// A planar, edge-connected piece of one surface: the triangles re-meshed together.
struct PlanarRegion {
    glm::dvec3 normal{0.0};  ///< unit normal; triangles are counter-clockwise seen from it
    std::vector<glm::dvec3> positions;    ///< the region's vertices (on the plane up to rounding)
    std::vector<glm::u32vec3> triangles;  ///< indices into positions; their union is the region
    /// Segments that must become mesh edges (shadow edges). They lie in the plane up to
    /// rounding; parts outside the region are dropped, and they may cross each other.
    std::vector<std::array<glm::dvec3, 2>> constraints;
    /// Points that must become mesh vertices (refinement); points outside are ignored.
    std::vector<glm::dvec3> points;
};

struct DmOptions {
    /// Minimum-angle bound of Ruppert/Chew refinement in degrees, in (0, 20.7]; 0 = none.
    double min_angle_deg = 0.0;
    /// Points closer than this (metres) are merged; a point this close to an edge of the
    /// region boundary is put on that edge.
    double merge_distance = 1e-6;
};

struct MeshedRegion {
    std::vector<glm::dvec3> positions;
    std::vector<glm::u32vec3> triangles;  ///< counter-clockwise seen from the region's normal
    std::vector<std::uint32_t>
        source_vertex;  ///< per vertex: index in the input positions, or kNewVertex
};

struct DmStats {
    std::size_t triangles_in = 0, triangles_out = 0;
    std::size_t constraints_in = 0;  ///< segments given
    std::size_t constraints_dropped =
        0;  ///< segments outside their region or shorter than merge_distance
    std::size_t points_merged = 0;  ///< points and segment ends snapped to another point or an edge
    std::size_t conformity_points =
        0;                   ///< vertices added on a boundary because a neighbour has them
    std::size_t rounds = 0;  ///< meshing rounds until every shared boundary conformed
};

/// The meshing shared among processes (the ranks of a distributed bake): each meshes the
/// regions `mine` gives it, the processes exchange the vertices that make neighbouring
/// regions conform after every meshing round, and each receives every region's mesh at the
/// end. Both functions are collectives in effect: every process calls them at the same
/// points, with the same arguments where they are alike.
struct MeshSharing {
    /// For each region, whether this process meshes it, from every region's cost (the same
    /// costs on every process).
    std::function<std::vector<char>(std::span<const double> cost)> mine;
    /// Every process's bytes, concatenated in process order, on every process.
    std::function<std::vector<std::byte>(std::span<const std::byte> mine)> all_gather;
    /// In: each region's meshing seconds measured by the last call (the share's cost; empty
    /// at first: a cost from the region's size). Out: this call's, the same on every process.
    std::vector<double> seconds;
};

/// Meshes every region. Original vertices keep their exact positions; new vertices lie in
/// the region's plane. A vertex of any region that lies on a boundary edge of another region
/// (within merge_distance), whether it was there in the input (a finely meshed floor meeting
/// a wall of two triangles) or added by constraints or refinement, becomes a vertex of both,
/// with the same position. Area is preserved to 1e-9 relative. Regions are meshed in parallel.
/// A region's output depends on its mesh alone, not on the order of its input or on memory
/// addresses: vertices sorted by position (x, then y, then z), triangles by their vertices,
/// each starting at its smallest. Throws std::invalid_argument for a region with a zero normal
/// or bad indices. With `sharing`, this process meshes only its share and the result is the
/// same as without, on every process.
std::vector<MeshedRegion> mesh_regions(std::span<const PlanarRegion> regions,
                                       const DmOptions& options, DmStats* stats = nullptr,
                                       MeshSharing* sharing = nullptr);

/// The region's union triangulated from its outline alone, for visibility (the
/// interreflection's hemicubes, where a finely meshed wall then costs what its outline costs):
/// the boundary edges (those of an odd number of triangles), each run of boundary vertices
/// within `tolerance` metres of one straight line made one edge, a constrained Delaunay
/// triangulation of those edges, and its faces inside (odd nesting), counter-clockwise seen from
/// the normal. Outline vertices keep their exact positions; none is added. Returns an empty
/// mesh when that is not fewer triangles than the region's own, or not the same area to a
/// relative 1e-6 (overlapping or folded triangles, outlines that cross once merged): the
/// caller then keeps the region's triangles.
MeshedRegion outline_triangulation(const PlanarRegion& region, double tolerance);

}  // namespace abrad::radiosity
