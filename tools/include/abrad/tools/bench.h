#pragma once
// The benchmark (docs/design.md#tests-and-measurements): bakes scenes over a grid of settings
// and records, per run, the wall time of every stage, peak memory, triangles, the hemicube's
// form-factor error against the closed form and the field error against exact irradiance;
// then the scaling of the default settings on generated floors of growing size. Writes CSV,
// a speed-against-error plot and a scaling plot (PNG, through gnuplot when installed) and a
// Markdown summary naming the Pareto-best settings.

#include <cstddef>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "abrad/radiosity/bake.h"
#include "abrad/visdb/model.h"

namespace abrad::tools {

/// A scene to bake over the settings grid.
struct BenchScene {
    std::string name;
    visdb::Scene scene;
};

struct BenchOptions {
    std::filesystem::path out;       ///< directory for CSV, PNG, Markdown, work database
    std::vector<BenchScene> scenes;  ///< baked over the whole settings grid
    /// Whole buildings: each baked once with the `scaling` settings (the full default bake:
    /// DM and converged interreflection), reported with the floors
    std::vector<BenchScene> buildings;
    bool quick = false;              ///< a small grid (3 hemicubes, DM off/area, both shadings)
    std::vector<std::size_t> sizes;  ///< generated floors (target triangles) for the scaling curve
    std::vector<int> light_counts;   ///< lights per room for the light scaling, at `lights_at`
    std::size_t lights_at = 30000;   ///< target triangles of the light-scaling floor
    radiosity::BakeOptions scaling;  ///< settings of the scaling runs (the defaults)
    std::size_t field_error_max =
        200000;            ///< skip the field error above this many output triangles
    int subdivisions = 2;  ///< field-error samples: k² per triangle
    int threads = 0;       ///< 0 = all cores
    bool plot = true;      ///< run gnuplot (when found) for the PNGs
    std::string command;   ///< the command line, quoted in the summary
    /// The mesh trade-off on every grid scene: DM at these refine tolerances against uniform
    /// meshes of the same size (empty: none)
    std::vector<double> tradeoff_tolerances;
    /// What abrad bake does to a bake after radiosity::bake (its --coarsen), timed with the
    /// bake: set by the command line, which holds the export library (empty: nothing)
    std::function<void(visdb::Bake&, const radiosity::BakeOptions&)> finish;
};

/// One bake of the benchmark.
struct BenchRun {
    std::string scene;
    std::string kind;  ///< "grid", "scaling", "lights", "building" or "tradeoff"
    std::size_t triangles_in = 0, light_triangles = 0, triangles_out = 0;
    radiosity::BakeOptions options;
    double seconds_wall = 0.0;    ///< the bake call, wall clock
    double seconds_cpu = 0.0;     ///< the bake call, CPU (user + system, all threads)
    double seconds_store = 0.0;   ///< writing the bake to the database
    double peak_rss_mb = 0.0;     ///< peak resident memory of the process during the bake and store
                                  ///< (sampled every 2 ms), MB
    double ff_error = -1.0;       ///< hemicube form-factor error, relative L1 (-1: not measured)
    double field_error = -1.0;    ///< field error, relative L1 (-1: not measured)
    visdb::BakeStats statistics;  ///< the bake's own
};

/// The settings grid: Z-buffer at R = 50, 100, 200, 400; A-buffer at R = 26 (the even resolution
/// nearest 25), 50, 100 with 4x4, 8x8 and 16x16 masks; DM off, or on with each light model; patch
/// and exact shading (quick: Z-buffer 50, A-buffer 26/4x4 and 50/8x8, DM off and area).
std::vector<radiosity::BakeOptions> settings_grid(bool quick, int threads);

/// "abuffer R50 8x8, DM area, exact".
std::string label(const radiosity::BakeOptions& o);

/// Form-factor error of one hemicube setting: a shooting point on the floor of a closed
/// 4 x 4 x 3 m box cut into 0.25 m patches (nothing occludes, so Lambert's closed form is
/// exact for each patch); returns Σ|F_hemicube − F_exact| / Σ F_exact over the patches.
double hemicube_ff_error(radiosity::Visibility method, int resolution, int subpixels);

/// Indices of the Pareto-best runs (no other run of the scene both faster and more
/// accurate) among `runs` with a measured field error, by (seconds_wall, field_error).
std::vector<std::size_t> pareto_front(const std::vector<BenchRun>& runs);

/// Energy balance of a bake with interreflection: (absorbed + escaped + unshot) / emitted
/// (1 when every watt is accounted for), or -1 without interreflection.
double energy_closure(const visdb::BakeStats& statistics);

/// The scene with its receivers' triangles split, longest edge first over the whole scene,
/// until it has at least `triangles` triangles in all (or nothing is left to split): the
/// uniform mesh of the same size as a discontinuity mesh, the baseline of the mesh
/// trade-off. A split halves both triangles on the edge (the globally longest edge is the
/// longest of each: conforming within a surface, and no angle falls below half the smallest
/// one the surface started with, Rosenberg and Stenger). Emitters are left as they are.
visdb::Scene subdivide_uniformly(const visdb::Scene& scene, std::size_t triangles);

/// The mesh trade-off rows of one scene: direct light (bounces 0) baked with `base`'s
/// discontinuity mesh at each refine tolerance, and each time the scene subdivided uniformly
/// to the same triangle count and baked without DM; kind "tradeoff", options.dm telling which.
/// Field errors against the scene's exact direct light.
std::vector<BenchRun> mesh_tradeoff(const BenchScene& scene, const radiosity::BakeOptions& base,
                                    const std::vector<double>& tolerances,
                                    const BenchOptions& bench);

/// Runs everything and writes DIR/bench.csv, DIR/scaling.csv, DIR/speed_error.png,
/// DIR/scaling.png, DIR/summary.md, and DIR/tradeoff.csv with tradeoff_tolerances. Progress
/// lines go to stderr. Returns the runs.
std::vector<BenchRun> run_bench(const BenchOptions& options);

}  // namespace abrad::tools
