#pragma once
// The stages of the bake, in the order bake.cpp runs them (the shape they share is stated at
// the top of bake.h). Internal to the radiosity library: one file per stage.
//
//   build_bake_mesh     bake_mesh.cpp       the scene's triangles, split by surface and normal,
//                       contacts.cpp        less the parts pressed against or inside another solid
//   shoot_lights        shoot_lights.cpp    one hemicube per light: patch irradiance, exact
//                                           vertex irradiance (no DM), shadow segments (DM)
//   interreflect        interreflect.cpp    progressive refinement on elements (indirect.h)
//   mesh_discontinuities discontinuity.cpp  CDT per planar region with the shadow segments,
//                                           refined where the field (exact direct plus
//                                           interpolated indirect) is not linear
//   shade_patches       shade.cpp           the paper's patch shading on a new mesh
//   shade_vertices      shade.cpp           B = E + ρH at every output vertex

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <optional>
#include <vector>

#include "abrad/radiosity/bake.h"
#include "abrad/radiosity/bvh.h"
#include "abrad/radiosity/dm_mesh.h"
#include "abrad/radiosity/hemicube.h"
#include "abrad/radiosity/indirect.h"
#include "abrad/radiosity/shadow_edges.h"
#include "abrad/visdb/model.h"

namespace abrad::radiosity {

/// The stages' clock (wall time).
using Clock = std::chrono::steady_clock;

/// Wall seconds since `t0`.
inline double seconds_since(Clock::time_point t0) {
    return std::chrono::duration<double>(Clock::now() - t0).count();
}

/// Lengths in the meshing that only tell points apart (merging, region planes, shadow segments
/// too short to keep) are this fraction of the model's size (BakeGeometry::size): 1e-6 m in a
/// 10 m building, and the same fraction of a model in millimetres or kilometres.
inline constexpr double kLengthTolerance = 1e-7;
/// The default shortest edge the refinement splits (BakeOptions::refine_min_edge = 0): this
/// fraction of the model's size (0.05 m in a 4 x 4 x 3 m room), at most kMinEdgeMetres, so
/// that a model in millimetres is refined as in metres and a whole building as finely as one
/// of its rooms (a shadow's detail on a desk does not grow with the building around it).
inline constexpr double kMinEdgeFraction = 1.0 / 128.0;
inline constexpr double kMinEdgeMetres = 0.05;
/// The shortest edge the refinement splits in a model of `size` metres: the option's value, or
/// the default above.
inline double refine_min_edge(const BakeOptions& options, double size) {
    return options.refine_min_edge > 0.0 ? options.refine_min_edge
                                         : std::min(kMinEdgeMetres, kMinEdgeFraction * size);
}

/// The scene's surfaces with their hidden contacts cut away (contacts.cpp): the parts of a
/// face covered by an opaque face of another surface lying in its plane (within 1e-6 of the
/// model's size), facing it, with that surface's solid behind it (a wall's top under the slab,
/// its foot on the floor, a cupboard's bottom). Neither face can receive or send light there.
/// Also the parts of a face lying inside another surface's closed opaque solid (a slab's strip
/// inside an outer wall that runs through it). Cut faces are triangulated again from their convex
/// remainders, and their neighbours split where the cuts put vertices on their edges (no
/// T-junctions).
struct ContactCut {
    std::vector<std::optional<visdb::TriangleMesh>> meshes;  ///< per surface; none: unchanged
    double hidden_m2 = 0.0;                                  ///< area cut away
    std::size_t faces_cut = 0;                               ///< faces cut (or removed)
};
ContactCut hide_contacts(const visdb::Scene& scene, double size);

/// A mesh to shoot onto and shade, with what shading needs beside it: per triangle its
/// patch, area and material; per vertex its triangles (compressed rows).
struct BakeGeometry {
    visdb::BakeMesh mesh;
    /// The model's size, m: the diagonal of its vertices' bounding box; relative lengths
    /// (kLengthTolerance, kMinEdgeFraction) are fractions of it.
    double size = 0.0;
    std::vector<Patch> patches;                           ///< one per mesh triangle
    std::vector<double> area;                             ///< per triangle, m²
    std::vector<visdb::Rgb> emittance;                    ///< per triangle
    std::vector<visdb::Rgb> reflectance;                  ///< per triangle
    std::vector<std::uint32_t> incident_start, incident;  ///< triangles around each vertex
    std::vector<std::uint32_t> lights;                    ///< emitting triangles, ascending
    std::vector<visdb::Luminaire> luminaires;             ///< point sources (photometric files)
};

/// Planar regions: edge- or vertex-connected triangles of one surface and one plane.
struct Regions {
    std::vector<PlanarRegion> planar;
    std::vector<std::uint32_t> surface;      ///< per region
    std::vector<char> emitter;               ///< per region
    std::vector<std::uint32_t> of_triangle;  ///< per bake triangle
    /// Each region from its outline (outline_patches), for the DM's exact shadow queries and
    /// the interreflection's hemicubes; made by the bake when one of them runs, else empty
    Outlines outlines;
};

/// What the lights' shots leave for the later stages.
struct LightShots {
    std::vector<visdb::Rgb> triangle_irradiance;       ///< patch irradiance per triangle (hemicube)
    std::vector<visdb::Rgb> vertex_irradiance;         ///< exact, per vertex (exact shading, no DM)
    std::vector<std::vector<ShadowSegment>> segments;  ///< per triangle (DM only)
    /// Per triangle, the lights whose hemicubes (at the centroid, or at a corner) gave it some
    /// light, ascending (DM only): the exact irradiance on a region asks only these lights (a
    /// light that reaches no triangle of a region through any hemicube sample adds nothing
    /// there).
    std::vector<std::vector<std::uint32_t>> lights_of_triangle;
    /// Per triangle, the luminaires (indices into BakeGeometry::luminaires) whose hemicubes
    /// gave it some light, ascending (DM only), for the same purpose.
    std::vector<std::vector<std::uint32_t>> luminaires_of_triangle;
};

/// The discontinuity mesh with the exact direct irradiance at its vertices.
struct DiscontinuityMesh {
    visdb::BakeMesh mesh;                      ///< positions, normals, triangles, surfaces
    std::vector<std::uint32_t> vertex_region;  ///< planar region of each vertex
    std::vector<visdb::Rgb> irradiance;        ///< exact direct irradiance per vertex
};

/// The scene's triangles as one mesh whose vertices are split by surface and face normal.
/// Degenerate triangles are dropped and counted; the scene's luminaires are kept as point
/// sources. Throws InputError for a surface without a material, a scene without triangles or
/// without lights (neither an emitting triangle nor a luminaire).
BakeGeometry build_bake_mesh(const visdb::Scene& scene, visdb::BakeStats* stats);

/// `mesh`'s triangles described for shooting and shading (materials and luminaires from
/// `scene`).
BakeGeometry describe_mesh(const visdb::Scene& scene, visdb::BakeMesh mesh);

/// The planar regions of `g` (its vertices are already split by surface and normal, so
/// connected components are planar).
Regions make_regions(const BakeGeometry& g);

/// The unit normal of each planar region.
std::vector<glm::dvec3> region_normals(const Regions& regions);

/// Shoots from every light triangle (in parallel). Fills stats->shoot, the light and power
/// figures, and stats->exact_shade (exact shading without DM) or the shadow part of stats->dm.
/// Shadow edges of a light go only to regions its hemicube reached (some triangle with F > 0):
/// a region it does not light has no edge of its light.
LightShots shoot_lights(const BakeGeometry& g, const Regions& regions, const Bvh& bvh,
                        const Hemicube& hemicube, const BakeOptions& options,
                        visdb::BakeStats* stats, const ProgressFn& progress);

/// Meshes every planar region along its shadow segments and refines it; consumes `segments`.
/// Fills stats->dm (all but the shadow edge counters, which shoot_lights filled).
/// The exact irradiance on a region asks only the lights that reach some triangle of it
/// (LightShots::lights_of_triangle), so a vertex's cost follows the lights that see its room.
/// With `indirect` (the interreflection, solved first) the refinement tests the whole field,
/// exact direct plus the interpolated indirect part, so that surfaces lit only by reflected
/// light (ceilings) get the vertices their field needs; DiscontinuityMesh::irradiance stays
/// the direct part.
DiscontinuityMesh mesh_discontinuities(const BakeGeometry& g, const Bvh& bvh, Regions& regions,
                                       LightShots& shots, const IndirectSolution* indirect,
                                       const BakeOptions& options, visdb::BakeStats* stats,
                                       const ProgressFn& progress);

/// The interreflection solver's options from the bake's.
IndirectOptions solver_options(const BakeOptions& options);

/// Interreflection on `g`'s triangles clustered per planar region (options.bounces != 0);
/// fills stats->indirect but the per-vertex mean (shade_vertices adds it).
IndirectSolution interreflect(const BakeGeometry& g, const Regions& regions,
                              const BakeOptions& options, visdb::BakeStats* stats,
                              const ProgressFn& progress);

/// BakeOptions::edge_gather: the indirect part gathered at the vertices of `target` that lie
/// on a region of kGatherMinElements elements or more (rooms' walls, floors and ceilings, not
/// furniture's faces), within kGatherBand of its outline, where the element field's
/// interpolation extrapolates (IndirectSolution::interpolates). Each is a final gather from
/// `solution` (gather_indirect, the direct part of what it sees the bake's exact vertex values
/// `direct` interpolated over target's triangles), kGatherSweeps times, at a point
/// kGatherInset (at most
/// kGatherInsetFraction of the way to its triangles' centroid) inside the vertex's triangles
/// and kGatherLift in front of them. `sources` and `regions` are what the solution was solved
/// on. docs/algorithms.md#interreflection ("Where surfaces meet").
struct VertexGather {
    std::vector<std::uint32_t> vertices;  ///< ascending
    std::vector<visdb::Rgb> values;       ///< per entry of `vertices`
};
VertexGather gather_near_boundaries(const BakeGeometry& sources, const Regions& regions,
                                    const BakeOptions& options, const IndirectSolution& solution,
                                    const BakeGeometry& target,
                                    const std::vector<visdb::Rgb>& direct,
                                    const std::vector<std::uint32_t>& vertex_region,
                                    const ProgressFn& progress);
constexpr double kGatherInset = 1e-3;  // m
constexpr double kGatherInsetFraction = 0.05;
constexpr double kGatherLift = 1e-6;  // m
constexpr std::uint32_t kGatherMinElements = 16;
constexpr double kGatherBand = 0.15;  // m
/// Gathers per vertex: the second sees the first's values at the other vertices near edges
/// (the test room's 5 cm points: one sweep +4.9 % at worst, two 1.4 %)
constexpr int kGatherSweeps = 2;

/// The paper's patch shading on `target` (a new mesh): every light of `lights` shoots again
/// onto target's triangles; each vertex gets the area-weighted irradiance of its triangles.
std::vector<visdb::Rgb> shade_patches(const BakeGeometry& lights, const BakeGeometry& target,
                                      const Hemicube& hemicube, const BakeOptions& options);

/// Bounds each triangle's patch irradiance from the area lights of `lights` by the brightest
/// light's exitance (per channel): a receiver's form factors to all lights add up to at most 1.
/// Only for irradiance from area lights: a point source has no exitance to bound it by.
void bound_by_exitance(const BakeGeometry& lights, std::vector<visdb::Rgb>& triangle_irradiance);

/// Each vertex of `g` gets the area-weighted patch irradiance of its triangles.
std::vector<visdb::Rgb> average_to_vertices(const BakeGeometry& g,
                                            const std::vector<visdb::Rgb>& triangle_irradiance);

/// Patch irradiance H_j += E_L · F_jL of every triangle of `target` from one shot from
/// `from` (a light triangle's centroid and normal), with F_jL = F_Lj · A_L / A_j where F_Lj is
/// the shot's form factor, replaced by the unoccluded closed form from `from` to j when it is
/// more than twice that (a sliver smaller than a hemicube sample), and F_jL at most 1;
/// returns Σ F_Lj of the shot.
double add_patch_irradiance(const ShootResult& shot, const ShooterFrame& from,
                            const visdb::Rgb& emittance, double light_area,
                            const BakeGeometry& target,
                            std::vector<visdb::Rgb>& triangle_irradiance);

/// Patch irradiance H_j += Φ · F_j / A_j of every triangle of `target` from a luminaire's
/// weighted hemicube (F_j the fraction of the flux Φ that j takes); returns Σ F_j.
double add_flux_irradiance(const ShootResult& shot, const visdb::Rgb& flux,
                           const BakeGeometry& target,
                           std::vector<visdb::Rgb>& triangle_irradiance);

/// Irradiance H = direct + (with `indirect`) the interpolated indirect part, and radiosity
/// The indirect part at `target`'s vertices: the element solution's interpolated field
/// (IndirectSolution::at) scaled, per planar region and channel, so that the Gouraud field
/// over the region's triangles carries the flux its elements hold (Σ H·A), the scale kept
/// within [1/kMaxFluxScale, kMaxFluxScale]. docs/algorithms.md#interreflection ("At the vertices").
std::vector<visdb::Rgb> conservative_indirect(const BakeGeometry& target,
                                              const IndirectSolution& indirect,
                                              const std::vector<std::uint32_t>& vertex_region,
                                              const VertexGather* gathered = nullptr);
constexpr double kMaxFluxScale = 1.5;

/// B = E + ρH at every vertex of `target`; `vertex_region` gives each vertex's planar region
/// for the indirect lookup. Returns target's mesh with the shades; fills
/// stats->indirect->mean_at_vertices.
visdb::BakeMesh shade_vertices(BakeGeometry target, const std::vector<visdb::Rgb>& direct,
                               const IndirectSolution* indirect,
                               const std::vector<std::uint32_t>& vertex_region,
                               const VertexGather* gathered, visdb::BakeStats* stats);

}  // namespace abrad::radiosity
