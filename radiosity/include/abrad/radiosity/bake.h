#pragma once
// The bake: one shooting iteration per light-source triangle with the A-buffer (or Z-buffer)
// hemicube (Wang et al., "Using A-Buffer in Radiosity"), discontinuity meshing along the
// shadow edges, interreflection when asked, and a radiosity value at every vertex
// (docs/algorithms.md#overview-of-a-bake).
//
// The bake is a pipeline of named stages (radiosity/src/stages.h, one file each), run in this
// order by `bake`:
//
//   build bake mesh → shoot the lights (irradiance, occlusion lists, shadow segments)
//     → discontinuity mesh → interreflection → shade vertices → statistics
//
// Common principles of the stages (as OpenImageIO states its own for its algorithms):
// - Shape: `Out stage(const In&, const Options&, visdb::BakeStats*, const ProgressFn&)`. A
//   stage takes its input by const reference (a stage that refines its input in place, the
//   discontinuity mesher adding points to the regions, says so) and returns its output by
//   value; nothing is shared between stages but what they return.
// - Units: metres, W/m² (or lm/m² and lux for photometric scenes), radiometric RGB; positions
//   in double, in the bake's local frame (visdb::local_origin), hemicube depths in float.
// - Failure: bad settings or a scene that cannot be baked throw InputError (stage.h) naming
//   the option or the scene element, before any work where possible; anything else that
//   throws (std::bad_alloc...) is a failure, not the input's fault. A stage never exits.
// - Statistics: each stage fills its own named fields of visdb::BakeStats (bake_stats.h);
//   counters of parallel work are summed per thread and added with `operator+=`. Times are
//   wall seconds, or CPU seconds summed over threads where the name says `_cpu`.
// - Progress: ProgressFn(stage label, done, total), from the stage's thread or under its
//   lock; `total` 0 when the end is not known in advance.
// - Threads: TBB, inside the task arena the caller's `threads` setting makes; a stage sets no
//   process-wide state.

#include <cstddef>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "abrad/radiosity/indirect.h"
#include "abrad/radiosity/shadow_edges.h"
#include "abrad/radiosity/shoot.h"
#include "abrad/radiosity/stage.h"
#include "abrad/visdb/model.h"

namespace abrad::radiosity {

class Cluster;

/// How vertex shades are computed.
enum class Shading {
    Exact,  ///< exact direct irradiance at each vertex, occluders from the fragment lists
    Patch,  ///< area-weighted irradiance of the vertex's patches from the hemicube (the paper)
};

/// Settings of a bake. Defaults are the documented command-line defaults.
struct BakeOptions {
    std::string name;  ///< stored bake name; empty = "bake-<n>" chosen by the caller
    Visibility method = Visibility::ABuffer;
    int resolution = 50;  ///< hemicube resolution R (even)
    int subpixels = 8;    ///< A-buffer mask side
    /// Interreflection: -1 = shoot from reflecting elements until the unshot fraction is below
    /// `converge` (the default: the full solution), 0 = direct light only (the paper's
    /// setting), N = N bounces (Jacobi sweeps).
    int bounces = -1;
    /// Unshot power / emitted power at which to stop (without the ambient term: the light still
    /// to come / the reflected light, IndirectOptions::converge)
    double converge = 0.005;
    double element_size = 0.5;  ///< metres: element grid of the interreflection solution
    /// Hemicube resolution of the element rows (the lights' shots onto the elements use
    /// `resolution`): element-to-element form factors are sums over many pixels.
    int element_resolution = 40;
    /// A-buffer mask side of the element rows (4, 8 or 16; the lights' shots use `subpixels`).
    int element_subpixels = 4;
    /// Elements shoot in groups of shooter_cells × shooter_cells cells (1 = alone).
    int shooter_cells = 2;
    double overrelaxation = 1.0;  ///< Southwell ω in [1, 2) when converging
    bool ambient = true;          ///< spread what is left unshot as the ambient term
    /// The indirect part at output vertices within kGatherBand of a large region's edge
    /// gathered from the element solution by a hemicube at the vertex (gather_indirect),
    /// instead of extrapolated from the elements' centres: corners within a few percent, at a
    /// hemicube per such vertex (docs/algorithms.md#interreflection, "Where surfaces meet").
    bool edge_gather = false;
    /// When set, receives the convergence curve (unshot fraction against shots and time).
    std::vector<ConvergenceSample>* convergence = nullptr;
    Shading shading = Shading::Exact;
    int threads = 0;  ///< 0 = all cores
    /// Light reach in metres (0 = unlimited): a light shoots, shades and casts shadow edges only
    /// on triangles whose box meets the cube of this half side around it (cull.h states the
    /// error bound). Triangles wholly behind a light's plane are always culled (exact).
    double reach = 0.0;
    /// Discontinuity meshing: receivers re-meshed along the shadow edges (CGAL CDT per
    /// planar region), then refined where the exact irradiance departs from linear.
    bool dm = true;
    LightModel lights = LightModel::Vertices;  ///< how lights cast shadow edges
    double dm_min_angle = 0.0;  ///< Ruppert/Chew minimum angle, degrees (0 = none, max 20.7)
    int refine_rounds = 5;      ///< illumination-driven refinement rounds (0 = shadow edges only)
    /// Split an edge when its midpoint's exact irradiance departs from the linear
    /// interpolation by more than this, relative, and by more than half this of the
    /// receivers' mean irradiance; and a triangle at least 8 shortest refined edges long,
    /// likewise, at its centroid (docs/algorithms.md#illumination-driven-refinement).
    double refine_tolerance = 0.02;
    /// Edges shorter than this (metres) are not split; 0: 1/128 of the model's size (its
    /// bounding-box diagonal: 0.05 m in a 4 x 4 x 3 m room) and at most 0.05 m, so that a
    /// small model meshes as it would in metres and a building as finely as a room.
    double refine_min_edge = 0.0;
    /// With DM and the vertices or area light model: a light triangle's shadow segment is cast
    /// only where its emitter's light departs from linear across it (within the shortest edge)
    /// by at least this times refine_tolerance of the irradiance there; 0 (the default): every
    /// segment. 0.02 drops tiny, weak and distant occluders' edges (docs/algorithms.md
    /// #which-shadow-edges-earn-a-mesh-edge) but costs the FZK-Haus a third more CPU.
    double shadow_contrast = 0.0;
    /// When set, the MPI ranks the bake's work is shared with (cluster.h): every rank calls
    /// `bake` with the same scene and options; rank 0 returns the bake, the others an empty
    /// one once their share is done. Null: this process alone.
    Cluster* cluster = nullptr;
};

/// Checks options (resolution even in [2, 4096], subpixels 4/8/16, bounces in [-1, 1000],
/// converge in (0, 1), element_size > 0, overrelaxation in [1, 2), threads >= 0,
/// reach >= 0,
/// dm_min_angle in [0, 20.7], refine_rounds in [0, 20], refine_tolerance > 0,
/// refine_min_edge >= 0); throws InputError naming the option and value.
void validate(const BakeOptions& options);

/// pbrt-v4's ReportUnused for the bake: throws InputError naming the first of `given` (the
/// settings the user gave, by command-line name: "--converge", "--subpixels"...) that
/// `options` does not use, e.g. `--converge` with `--bounces 0`, `--lights` or `--refine-*`
/// with `--dm off`, `--subpixels` with `--method zbuffer`. Names this function does not
/// know are ignored (they are always used).
void check_unused(const BakeOptions& options, std::span<const std::string> given);

/// Bakes direct light into `scene`, then (bounces != 0) interreflection: the indirect part,
/// interpolated from the element solution, is added to every vertex's direct value. Without
/// discontinuity meshing the result's mesh is the scene's, with one vertex per (surface,
/// position, face normal); with it, each planar region is re-meshed (conforming: no
/// T-vertices) and every vertex, old and new, is shaded by the shading mode. Parameters and
/// statistics are filled, `name` is options.name. Runs its parallel work in a TBB task arena
/// of `options.threads` threads (0: all cores). Throws InputError (stage.h).
visdb::Bake bake(const visdb::Scene& scene, const BakeOptions& options,
                 const ProgressFn& progress = {});

std::string to_string(Shading shading);

}  // namespace abrad::radiosity
