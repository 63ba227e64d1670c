// The shared pieces of the subcommands: see cli_common.h.

#include "cli_common.h"

#include <signal.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <ctime>
#include <iostream>
#include <utility>

#include "abrad/convert/import.h"
#include "abrad/export/exposure.h"
#include "abrad/export/render.h"
#include "abrad/visdb/light_scene.h"

namespace abrad::tools::cli {

void bad_input(const std::string& message) { throw CommandError{kExitBadInput, message}; }

void failure(const std::string& message) { throw CommandError{kExitFailure, message}; }

StagingFolder::~StagingFolder() {
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
}

void remove_stale_staging(const std::filesystem::path& dir, const std::string& prefix) {
    std::error_code ec;
    for (const auto& entry : std::filesystem::directory_iterator(dir, ec)) {
        const std::string name = entry.path().filename().string();
        if (name.rfind(prefix, 0) != 0 || !entry.is_directory(ec)) continue;
        const std::string digits = name.substr(prefix.size());
        pid_t pid = 0;
        const auto [end, error] =
            std::from_chars(digits.data(), digits.data() + digits.size(), pid);
        if (error != std::errc() || end != digits.data() + digits.size() || pid <= 0) continue;
        if (::kill(pid, 0) != 0 && errno == ESRCH) std::filesystem::remove_all(entry.path(), ec);
    }
}

int report_failure(const char* command, const std::string& prefix, std::exception_ptr error) {
    auto fail = [&](const char* what, int status) {
        std::cerr << "abrad " << command << ": " << prefix << what << "\n";
        return status;
    };
    try {
        std::rethrow_exception(std::move(error));
    } catch (const CommandError& e) {
        return fail(e.message.c_str(), e.status);
    } catch (const visdb::StoreError& e) {
        return fail(e.what(),
                    e.kind() == visdb::StoreError::Kind::Failure ? kExitFailure : kExitBadInput);
    } catch (const radiosity::InputError& e) {  // settings or a scene that cannot be baked
        return fail(e.what(), kExitBadInput);
    } catch (const std::exception& e) {  // ExportError, filesystem errors, bad_alloc...
        return fail(e.what(), kExitFailure);
    }
}

double seconds_since(std::chrono::steady_clock::time_point start) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// ---------------------------------------------------------------------------------------
// Option groups

void add_model_arguments(CLI::App& app, ImportArgs& a) {
    std::string formats;
    for (const std::string& e : convert::supported_extensions())
        formats += (formats.empty() ? "" : ", ") + e;
    app.add_option("MODEL", a.models, "Model files: " + formats)->required();
}

void add_import_options(CLI::App& app, ImportArgs& a) {
    app.add_option("--unit", a.unit,
                   "Length unit of the model files (default: the scene file's, else the unit the "
                   "file declares, else m)")
        ->check(CLI::IsMember({"mm", "cm", "m", "in", "ft"}));
    app.add_option("--up", a.up,
                   "Up axis of the model files, y is rotated to Z up (default: the scene file's, "
                   "else the format's: glTF y, Collada/FBX as declared, others z)")
        ->check(CLI::IsMember({"y", "z"}));
    app.add_option("--weld", a.weld,
                   "Weld vertices closer than this fraction of the model's bounding-box diagonal "
                   "(default 1e-6; 0 welds only identical positions)")
        ->check(CLI::Range(0.0, 1e-2));
    app.add_option("--scene", a.scene,
                   "Scene file (TOML): unit, up axis, origin shift, material and light rules by "
                   "object/layer/material name, emitter rectangles, cameras, exclusions, grids");
    app.add_flag("--allow-outside-refs", a.allow_outside_refs,
                 "Read files a model refers to (an OBJ's mtllib) even when they are outside the "
                 "model's folder tree (refused by default)");
}

void add_bake_options(CLI::App& app, BakeArgs& a) {
    app.add_option("--name", a.name,
                   "Name of the stored bake (default bake-<n>; an existing bake "
                   "of that name is replaced)");
    app.add_option("--method", a.method,
                   "Hemicube visibility: abuffer (fragment lists, coverage "
                   "masks, translucency) or zbuffer (point-sampled item buffer)")
        ->check(CLI::IsMember({"abuffer", "zbuffer"}))
        ->capture_default_str();
    app.add_option("--resolution", a.resolution, "Hemicube resolution R (even, 2..4096)")
        ->capture_default_str();
    app.add_option("--subpixels", a.subpixels,
                   "A-buffer mask side: 4, 8 or 16 (8 = 8x8 = one uint64)")
        ->capture_default_str();
    app.add_option("--bounces", a.bounces,
                   "Interreflection: converge (shoot from reflecting surfaces "
                   "until --converge, with the ambient term: the full solution), "
                   "0 (direct light only, the paper's setting) or a number of "
                   "bounces")
        ->capture_default_str();
    app.add_option("--converge", a.converge,
                   "Stop interreflection when the unshot power is below "
                   "this fraction of the emitted power (with --ambient off: when the light "
                   "still to come is below this fraction of the reflected light)")
        ->capture_default_str();
    app.add_option("--element-resolution", a.element_resolution,
                   "Hemicube resolution of the interreflection's element rows (even, 2..4096; "
                   "the lights' shots use --resolution)")
        ->capture_default_str();
    app.add_option("--element-subpixels", a.element_subpixels,
                   "A-buffer mask side of the element rows: 4, 8 or 16 (the lights' shots use "
                   "--subpixels)")
        ->capture_default_str();
    app.add_option("--shooter-cells", a.shooter_cells,
                   "Interreflection elements shoot in groups of N x N cells of a surface "
                   "(small faces grouped in cubes of that side), one hemicube per group "
                   "(1..16; 1 = every element alone)")
        ->capture_default_str();
    app.add_option("--element-size", a.element_size,
                   "Side of the interreflection elements, metres "
                   "(each planar region is cut into such cells)")
        ->capture_default_str();
    app.add_option("--overrelax", a.overrelax,
                   "Over-relaxation factor ω in [1, 2) of the "
                   "converging solution (1 = classic progressive "
                   "refinement)")
        ->capture_default_str();
    app.add_option("--ambient", a.ambient,
                   "Spread what is left unshot at convergence as the "
                   "ambient term")
        ->check(CLI::IsMember({"on", "off"}))
        ->capture_default_str();
    app.add_option("--edge-gather", a.edge_gather,
                   "Gather the indirect light at vertices near the edges of large surfaces "
                   "(room corners) with a hemicube each, instead of extrapolating it from "
                   "the elements: corners within a few percent, at a hemicube per such vertex")
        ->check(CLI::IsMember({"on", "off"}))
        ->capture_default_str();
    app.add_option("--convergence-csv", a.convergence_csv,
                   "Write the convergence curve (shots, "
                   "seconds, unshot fraction) to this CSV");
    app.add_option("--shading", a.shading,
                   "Vertex shades: exact (exact direct irradiance past the "
                   "occluders) or patch (area-weighted hemicube patches)")
        ->check(CLI::IsMember({"exact", "patch"}))
        ->capture_default_str();
    app.add_option("--threads", a.threads, "Worker threads (0 = all cores)")->capture_default_str();
    app.add_option("--dm", a.dm,
                   "Discontinuity meshing: re-mesh receivers along shadow edges and "
                   "refine where the light changes")
        ->check(CLI::IsMember({"on", "off"}))
        ->capture_default_str();
    app.add_option("--lights", a.lights,
                   "Light model for shadow edges: centroid (one point, hard "
                   "edges), vertices (umbra and penumbra) or area (also the "
                   "light-edge/occluder-vertex wedges)")
        ->check(CLI::IsMember({"centroid", "vertices", "area"}))
        ->capture_default_str();
    app.add_option("--dm-angle", a.dm_angle,
                   "Ruppert/Chew minimum triangle angle in degrees "
                   "(0 = no quality refinement, at most 20.7)")
        ->capture_default_str();
    app.add_option("--refine-rounds", a.refine_rounds,
                   "Rounds of refinement where the exact "
                   "irradiance departs from linear (0 = none)")
        ->capture_default_str();
    app.add_option("--refine-tolerance", a.refine_tolerance,
                   "Split an edge when its midpoint's exact irradiance differs from the "
                   "interpolated value by more than this fraction")
        ->capture_default_str();
    app.add_option("--refine-min-edge", a.refine_min_edge,
                   "Shortest edge refinement splits, metres (0: 1/128 of the model's size)")
        ->capture_default_str();
    app.add_option("--reach", a.reach,
                   "Light reach in metres: a light lights, shades and shadows only "
                   "what lies within this distance (per axis) of it (0 = unlimited)")
        ->capture_default_str();
    app.add_option("--coarsen", a.coarsen,
                   "With --dm on: the bake's mesh decimated (OpenMesh) where its light is near "
                   "linear, removing vertices while each changes by at most --refine-tolerance "
                   "and all by at most this area-weighted mean change, a fraction of the mean "
                   "irradiance, in [0, 0.1] (default 0.001; 0 with --dm-angle > 0; 0 = keep "
                   "every meshed triangle)");
}

radiosity::BakeOptions to_options(const BakeArgs& a, const CLI::App& app) {
    radiosity::BakeOptions o;
    o.name = a.name;
    o.method =
        a.method == "zbuffer" ? radiosity::Visibility::ZBuffer : radiosity::Visibility::ABuffer;
    o.resolution = a.resolution;
    o.subpixels = a.subpixels;
    if (a.bounces == "converge") {
        o.bounces = -1;
    } else {
        const auto [end, ec] =
            std::from_chars(a.bounces.data(), a.bounces.data() + a.bounces.size(), o.bounces);
        if (ec != std::errc() || end != a.bounces.data() + a.bounces.size() || o.bounces < 0)
            bad_input("--bounces must be 'converge' or a number of bounces >= 0, got '" +
                      a.bounces + "'");
    }
    o.converge = a.converge;
    o.element_size = a.element_size;
    o.element_resolution = a.element_resolution;
    o.element_subpixels = a.element_subpixels;
    o.shooter_cells = a.shooter_cells;
    o.overrelaxation = a.overrelax;
    o.ambient = a.ambient == "on";
    o.edge_gather = a.edge_gather == "on";
    o.shading = a.shading == "patch" ? radiosity::Shading::Patch : radiosity::Shading::Exact;
    o.threads = a.threads;
    o.dm = a.dm == "on";
    o.lights = *radiosity::parse_light_model(a.lights);
    o.dm_min_angle = a.dm_angle;
    o.refine_rounds = a.refine_rounds;
    o.refine_tolerance = a.refine_tolerance;
    o.refine_min_edge = a.refine_min_edge;
    o.reach = a.reach;
    // The options given on the command line, by long name
    std::vector<std::string> given;
    for (const CLI::Option* option : app.get_options())
        if (option->count() > 0)
            for (const std::string& name : option->get_lnames()) given.push_back("--" + name);
    try {
        radiosity::validate(o);
        radiosity::check_unused(o, given);
    } catch (const radiosity::InputError& e) {
        bad_input(e.what());
    }
    if (a.coarsen && !(*a.coarsen >= 0.0 && *a.coarsen <= 0.1))
        bad_input("--coarsen must be in [0, 0.1], got " + std::to_string(*a.coarsen));
    if (!o.dm && std::find(given.begin(), given.end(), "--coarsen") != given.end())
        bad_input("--coarsen is not used by this bake (it applies with --dm on only)");
    return o;
}

void add_view_options(CLI::App& app, ViewArgs& v) {
    app.add_option("--camera", v.camera,
                   "Camera name from the scene file or model (default: the "
                   "first one; 'default' or none: inside the largest room "
                   "looking at its centre)");
    app.add_option("--width", v.width, "Image width in pixels")
        ->capture_default_str()
        ->check(CLI::Range(1, 16384));
    app.add_option("--height", v.height, "Image height in pixels")
        ->capture_default_str()
        ->check(CLI::Range(1, 16384));
    app.add_option("--exposure", v.exposure,
                   "Exposure k per W/m2 (or lm/m2): image value k*B, "
                   "display 1-exp(-k*B) (default: the bake's, 95th "
                   "percentile radiosity luminance -> 0.8)")
        ->check(CLI::Validator(
            [](std::string& text) {
                // CLI::PositiveNumber lets nan and inf through (nan <= 0 is false)
                char* end = nullptr;
                const double k = std::strtod(text.c_str(), &end);
                if (end == text.c_str() || *end != '\0' || !std::isfinite(k) || k <= 0.0)
                    return std::string("must be a finite number > 0, got " + text);
                return std::string();
            },
            "POSITIVE"));
}

// ---------------------------------------------------------------------------------------
// Databases

visdb::Store open_db(const std::string& db, visdb::OpenMode mode) {
    return visdb::Store::open(db, mode);
}

visdb::Bake load_bake_for(visdb::Store& store, const std::string& db, const std::string& bake_name,
                          const std::string& purpose) {
    if (store.list_bakes().empty())
        bad_input(db + ": no bake to " + purpose + " (run abrad bake first)");
    try {
        return store.load_bake(bake_name);
    } catch (const visdb::StoreError& e) {
        if (e.kind() == visdb::StoreError::Kind::Failure) throw;
        bad_input(e.what());
    }
}

void add_scene_mix_option(CLI::App& app, std::string& mix) {
    app.add_option("--scene-mix", mix,
                   "Light scene: the bake's light groups dimmed, NAME=FACTOR,... (e.g. "
                   "office=1,corridor=0.3; a group not named keeps 1), without re-baking. The "
                   "groups are those the scene file's 'group' keys made (abrad info lists a "
                   "bake's)");
}

void mix_light_scene(const std::string& mix, visdb::Scene& scene, visdb::Bake& bake) {
    if (mix.empty()) return;
    try {
        const visdb::SceneMix parsed = visdb::parse_scene_mix(mix);
        visdb::apply_scene_mix(parsed, scene, bake);
        // The settings the report lists say which light scene it shows
        if (!parsed.is_identity()) bake.parameters.emplace_back("scene_mix", mix);
    } catch (const std::invalid_argument& e) {
        bad_input("--scene-mix '" + mix + "': " + e.what());
    }
}

radiosity::PointIrradiance point_irradiance_of(const std::string& db, const visdb::Scene& scene,
                                               const visdb::Bake* bake) {
    try {
        return radiosity::PointIrradiance(scene, bake);
    } catch (const radiosity::InputError& e) {
        bad_input(db + ": " + e.what());
    }
}

visdb::Camera camera_for(const visdb::Scene& scene, const ViewArgs& v) {
    try {
        visdb::Camera c = exporter::select_camera(scene, v.camera);
        (void)exporter::camera_frame(c, v.width, v.height);  // a degenerate camera is bad input
        return c;
    } catch (const std::invalid_argument& e) {
        bad_input(e.what());
    }
}

exporter::ToneMap exposure_for(const visdb::Bake& bake, const visdb::Scene& scene,
                               const ViewArgs& v) {
    if (v.exposure) return exporter::ToneMap{.exposure = *v.exposure};
    return exporter::camera_tone_map(bake.mesh, scene, camera_for(scene, v), v.width, v.height);
}

std::string utc_now() {
    const std::time_t t = std::time(nullptr);
    std::tm tm{};
    gmtime_r(&t, &tm);
    char buf[32];
    std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
    return buf;
}

}  // namespace abrad::tools::cli
