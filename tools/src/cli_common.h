#pragma once
// The pieces the subcommands of the abrad command line share (internal to tools/): exit
// statuses and the error that carries one, the option groups several subcommands take
// (import, bake, view), opening databases, and the steps `run` chains (import, bake, export,
// render), each implemented in its subcommand's file.

#include <chrono>
#include <exception>
#include <filesystem>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "abrad/export/simplify.h"
#include "abrad/export/writers.h"
#include "abrad/radiosity/bake.h"
#include "abrad/radiosity/indirect.h"
#include "abrad/visdb/model.h"
#include "abrad/visdb/store.h"

namespace CLI {
class App;
}

namespace abrad::tools::cli {

/// Exit statuses of abrad (README "Using it").
inline constexpr int kExitOk = 0;
inline constexpr int kExitFailure = 1;   ///< I/O, a locked or full database, internal errors
inline constexpr int kExitBadInput = 2;  ///< a malformed model or database, an unusable option

/// An error already phrased for the user, with the exit status it calls for.
struct CommandError {
    int status;
    std::string message;
};

/// Throws CommandError{kExitBadInput, message}.
[[noreturn]] void bad_input(const std::string& message);
/// Throws CommandError{kExitFailure, message}.
[[noreturn]] void failure(const std::string& message);

/// Writes the error `error` (thrown by a subcommand) to stderr as "abrad <command>: <prefix>
/// <message>" and returns its exit status: a CommandError's own, 1 for a failed or locked
/// database, 2 for a malformed one and for a scene or settings that cannot be baked, 1 for
/// anything else.
int report_failure(const char* command, const std::string& prefix, std::exception_ptr error);

/// What a subcommand's run function gets: its own parsed app, and the whole command line.
struct Invocation {
    const CLI::App& app;
    int argc;
    char** argv;
};

/// One subcommand of the table in tools/abrad.cpp.
struct Command {
    const char* name;
    const char* description;
    void (*add_options)(CLI::App& app);  ///< declares the options (bound to the file's state)
    int (*run)(const Invocation& call);  ///< runs it once parsed; returns the exit status
};

// ---------------------------------------------------------------------------------------
// Option groups

/// Options of reading model files (import, run, bench).
struct ImportArgs {
    std::vector<std::string> models;
    std::string unit;  ///< empty: the scene file's, else the file's own, else metres
    std::string up;    ///< empty: the scene file's, else the format's convention
    std::optional<double> weld;
    std::string scene;
    bool allow_outside_refs = false;  ///< read files a model refers to outside its folder
};

/// The library's bake defaults, which the command line's are (one place to change them).
inline const radiosity::BakeOptions kBakeDefaults{};

/// Options of a bake (bake, run, bench).
struct BakeArgs {
    std::string name;
    std::string method = "abuffer";
    int resolution = kBakeDefaults.resolution;
    int subpixels = kBakeDefaults.subpixels;
    std::string bounces = "converge";
    double converge = kBakeDefaults.converge;
    double element_size = kBakeDefaults.element_size;
    int element_resolution = kBakeDefaults.element_resolution;
    int element_subpixels = kBakeDefaults.element_subpixels;
    int shooter_cells = kBakeDefaults.shooter_cells;
    double overrelax = kBakeDefaults.overrelaxation;
    std::string ambient = "on";
    std::string edge_gather = "off";
    std::string convergence_csv;
    std::string shading = "exact";
    int threads = kBakeDefaults.threads;
    std::string dm = "on";
    std::string lights = "vertices";
    double dm_angle = kBakeDefaults.dm_min_angle;
    int refine_rounds = kBakeDefaults.refine_rounds;
    double refine_tolerance = kBakeDefaults.refine_tolerance;
    double refine_min_edge = kBakeDefaults.refine_min_edge;
    double reach = kBakeDefaults.reach;
    /// coarsen_bake's budget (not a radiosity::BakeOptions); empty: coarsen_budget's default
    std::optional<double> coarsen;
};

/// The default budget of coarsen_bake.
inline constexpr double kCoarsenBudget = 0.001;

/// The bake's coarsening budget: --coarsen when given, else kCoarsenBudget, or 0 with
/// --dm-angle > 0 (asked for well-shaped triangles, which the decimation does not keep).
inline double coarsen_budget(const BakeArgs& a) {
    return a.coarsen.value_or(a.dm_angle > 0.0 ? 0.0 : kCoarsenBudget);
}

/// Options of the image-making exports and of render.
struct ViewArgs {
    std::string camera;  ///< empty: the scene's first camera, else the default camera
    int width = 640;
    int height = 480;
    std::optional<double> exposure;  ///< empty: camera_tone_map of the bake through the camera
    int light_samples = 256;
    int reference_bounces = 0;
    std::string quality = "medium";
};

/// The model-file arguments: MODEL (required) with the formats convert reads.
void add_model_arguments(CLI::App& app, ImportArgs& a);
/// --unit, --up, --weld, --scene, --allow-outside-refs.
void add_import_options(CLI::App& app, ImportArgs& a);
/// --name, --method, --resolution ... --reach.
void add_bake_options(CLI::App& app, BakeArgs& a);
/// --camera, --width, --height, --exposure.
void add_view_options(CLI::App& app, ViewArgs& v);

/// The bake options of `a`, validated: a bad value is bad input naming the option, and so is
/// a bake option given on `app`'s command line that the chosen settings do not use
/// (radiosity::check_unused).
radiosity::BakeOptions to_options(const BakeArgs& a, const CLI::App& app);

// ---------------------------------------------------------------------------------------
// Databases

/// Opens the visual database `db` (StoreError on failure, mapped to its exit status).
visdb::Store open_db(const std::string& db, visdb::OpenMode mode = visdb::OpenMode::ReadWrite);

/// The named bake (empty = the latest) for a command that needs one: an empty database or an
/// unknown name is bad input. `purpose` completes "no bake to ...".
visdb::Bake load_bake_for(visdb::Store& store, const std::string& db, const std::string& bake_name,
                          const std::string& purpose);

/// Declares --scene-mix on `app`, bound to `mix`.
void add_scene_mix_option(CLI::App& app, std::string& mix);

/// Applies the light scene `mix` (the text of --scene-mix, visdb::parse_scene_mix; empty:
/// nothing) to `bake` and the `scene` it was baked from (visdb::apply_scene_mix), and records
/// it as the bake's parameter `scene_mix` (unless it is the bake's own). A malformed mix or a
/// group the bake does not have is bad input naming the option.
void mix_light_scene(const std::string& mix, visdb::Scene& scene, visdb::Bake& bake);

/// Direct plus gathered indirect irradiance at points; a scene without lights is bad input.
radiosity::PointIrradiance point_irradiance_of(const std::string& db, const visdb::Scene& scene,
                                               const visdb::Bake* bake);

/// The camera `v` names in `scene`; an unknown or degenerate camera is bad input.
visdb::Camera camera_for(const visdb::Scene& scene, const ViewArgs& v);

/// The tone map of `bake` seen through `v`'s camera: `--exposure` when given, else
/// exporter::camera_tone_map for that camera and image size.
exporter::ToneMap exposure_for(const visdb::Bake& bake, const visdb::Scene& scene,
                               const ViewArgs& v);

/// A folder removed, with what it holds, when this goes out of scope: where `run` and `report`
/// make their results before moving them into place.
struct StagingFolder {
    explicit StagingFolder(std::filesystem::path p) : path(std::move(p)) {}
    StagingFolder(const StagingFolder&) = delete;
    StagingFolder& operator=(const StagingFolder&) = delete;
    ~StagingFolder();
    std::filesystem::path path;
};

/// Removes the staging folders `<prefix><pid>` in `dir` that killed commands left: those whose
/// process is gone (a live one, perhaps another command writing there, is left alone).
void remove_stale_staging(const std::filesystem::path& dir, const std::string& prefix);

/// Seconds since `start` on the steady clock.
double seconds_since(std::chrono::steady_clock::time_point start);

/// The time now, UTC, as ISO 8601 ("2026-11-30T18:06:40Z"), for a stored bake.
std::string utc_now();

// ---------------------------------------------------------------------------------------
// The steps (each in its subcommand's file)

/// Reads and heals the model files with the scene file applied (cmd_import.cpp).
visdb::Scene read_models(const ImportArgs& a);
/// Appends `scene` to the database, created when missing (cmd_import.cpp).
void import_into(const visdb::Scene& scene, const std::string& db);
/// Bakes the database's scene (with `args`' --coarsen and --convergence-csv besides `options`),
/// stores and summarises the bake, evaluates its grids into `<grid_prefix>grid-<name>.csv/.png`
/// (default: beside the database) (cmd_bake.cpp).
visdb::Bake bake_into(const std::string& db, const radiosity::BakeOptions& options,
                      const BakeArgs& args, const std::string& grid_prefix = {});

/// The floor of coarsen_bake's bound at a removed vertex: a fraction of the brightest
/// irradiance, under which the change allowed is absolute.
inline constexpr double kCoarsenFloor = 0.01;
/// coarsen_bake's limit of removed vertices a triangle holds (exporter::SimplifyOptions).
inline constexpr std::size_t kCoarsenMaxHeld = 16;

/// The discontinuity mesh of `b` made light where its light is near linear
/// (docs/algorithms.md#coarsening-the-discontinuity-mesh): exporter::simplify with the
/// refinement's `tolerance` as the bound at every removed vertex (kCoarsenFloor), an
/// area-weighted `budget` of the bake's mean irradiance, and the kept vertices' exact values;
/// the light groups' shades follow, and the statistics (dm_triangles_meshed,
/// dm_coarsen_change, seconds_coarsen) and the parameter `coarsen` say what it did. Nothing
/// for a budget of 0 or a bake without discontinuity meshing (cmd_bake.cpp).
void coarsen_bake(visdb::Bake& b, double budget, double tolerance,
                  const radiosity::ProgressFn& progress = {});

/// The light mesh of `export --simplify E` unless told otherwise: the least-squares refit and
/// an area-weighted budget of 0.4 % of the bake's mean irradiance, the best found
/// (docs/benchmarks.md#light-meshes-simplification; `--simplify 1` leaves the budget alone to
/// decide). `abrad simplify`'s own defaults stay the per-vertex bound alone.
inline constexpr exporter::SimplifyOptions kExportSimplify{
    .error = 1.0, .floor = 0.1, .refit = true, .budget = 0.004};

/// What export writes (cmd_export.cpp).
struct ExportArgs {
    std::string db;
    std::string format;  ///< empty: from the output's extension
    std::string output;
    std::string bake;  ///< empty: the latest
    bool ascii = false;
    std::string up;                    ///< y|z; empty: the format's convention (obj y, ply z)
    std::string positions = "double";  ///< ply: double|float
    std::string surface_ids = "face";  ///< ply: face|vertex
    std::optional<double> simplify;    ///< export a light mesh: simplify_mesh's error bound
    /// --simplify-floor, --simplify-refit, --simplify-budget: the light mesh's other options
    double simplify_floor = kExportSimplify.floor;
    bool simplify_refit = kExportSimplify.refit;
    double simplify_budget = kExportSimplify.budget;
    bool pov_tone_map = false;  ///< pov: tone-mapped colours for PNG, not linear ones
    std::string scene_mix;      ///< --scene-mix: light groups dimmed; empty: the bake's
    ViewArgs view;
};
/// Exports a bake (or the model, pov-reference) in `a.format`, or the format the output's
/// extension names; options the format does not use are checked by the export subcommand.
void export_bake(const ExportArgs& a);

/// The options of a light mesh on the command line: `error` names the per-vertex bound's
/// option, `prefix` the others' ("--" gives simplify's --floor, --refit, --budget;
/// "--simplify-" export's).
struct SimplifyOptionNames {
    std::string error;
    std::string prefix;
};

/// Bad input (exit 2) naming the option for options outside their ranges: the bound in
/// (0, 1], the floor and the budget in [0, 1] (cmd_simplify.cpp).
void check_simplify_options(const exporter::SimplifyOptions& options,
                            const SimplifyOptionNames& names);

/// The bake's mesh simplified with `options` (exporter::simplify), the options and the
/// statistics on stderr; options outside their ranges are bad input naming `names`'
/// options (cmd_simplify.cpp).
visdb::BakeMesh simplify_mesh(const visdb::Bake& bake, const exporter::SimplifyOptions& options,
                              const SimplifyOptionNames& names);

/// What render draws (cmd_render.cpp).
struct RenderArgs {
    std::string db;
    std::string bake;
    std::string output;
    ViewArgs view;
    bool false_colour = false;
    std::optional<double> vmin, vmax;
    std::string scene_mix;  ///< --scene-mix: light groups dimmed; empty: the bake's
};
/// Renders a bake with abrad's rasterizer into an image file.
void render_image(const RenderArgs& a);

// ---------------------------------------------------------------------------------------
// The subcommands: add_<name> declares the options, run_<name> runs it

void add_import(CLI::App& app);
int run_import(const Invocation& call);
void add_bake(CLI::App& app);
int run_bake(const Invocation& call);
void add_export(CLI::App& app);
int run_export(const Invocation& call);
void add_render(CLI::App& app);
int run_render(const Invocation& call);
void add_compare(CLI::App& app);
int run_compare(const Invocation& call);
void add_info(CLI::App& app);
int run_info(const Invocation& call);
void add_probe(CLI::App& app);
int run_probe(const Invocation& call);
void add_field_error(CLI::App& app);
int run_field_error(const Invocation& call);
void add_run(CLI::App& app);
int run_run(const Invocation& call);
void add_generate(CLI::App& app);
int run_generate(const Invocation& call);
void add_bench(CLI::App& app);
int run_bench(const Invocation& call);
void add_simplify(CLI::App& app);
int run_simplify(const Invocation& call);
void add_report(CLI::App& app);
int run_report(const Invocation& call);

}  // namespace abrad::tools::cli
