// abrad report: a bake as an HTML page for a person, in a folder that opens offline
// (export/include/abrad/export/report.h). The folder is made as a staging folder beside OUT and
// put in OUT's place only when every file of it was written, so a failure leaves OUT as it was.

#include <fcntl.h>
#include <stdio.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <system_error>
#include <tuple>

#include "abrad/convert/photometry.h"
#include "abrad/export/report.h"
#include "abrad/radiosity/grid.h"
#include "cli_common.h"

namespace fs = std::filesystem;

#ifndef ABRAD_VIEWER_DEFAULT
#define ABRAD_VIEWER_DEFAULT ""
#endif

namespace abrad::tools::cli {
namespace {

struct ReportArgs {
    std::string db;
    std::string bake;
    std::string out;
    std::string scene_mix;
};

ReportArgs& state() {
    static ReportArgs s;
    return s;
}

// The bundled viewer: $ABRAD_VIEWER (the script, or the folder holding abrad-viewer.js), else
// the build's (export/viewer/build_viewer.sh into the build folder)
fs::path viewer_script() {
    fs::path p = ABRAD_VIEWER_DEFAULT;
    if (const char* env = std::getenv("ABRAD_VIEWER"); env != nullptr) p = env;
    std::error_code ec;
    if (!p.empty() && fs::is_directory(p, ec)) p /= "abrad-viewer.js";
    return p;
}

constexpr const char* kViewerHint =
    "To get it, build the viewer once with `cmake --build BUILD_DIR --target abrad_viewer` "
    "(Node.js and npm, from scripts/install-deps.sh, and the npm registry the first time) or "
    "set ABRAD_VIEWER to an abrad-viewer.js, and run abrad report again.";

// True when `dir` holds a page abrad report wrote (its generator line in index.html)
bool is_report_folder(const fs::path& dir) {
    std::ifstream in(dir / "index.html");
    std::string line;
    for (int k = 0; k < 5 && std::getline(in, line); ++k)
        if (line.find("<meta name=\"generator\" content=\"abrad report\">") != std::string::npos)
            return true;
    return false;
}

// OUT may be missing, an empty folder or an earlier report; anything else is refused before
// any work (a folder of other files is never replaced)
void check_out(const fs::path& out) {
    std::error_code ec;
    const fs::file_status st = fs::symlink_status(out, ec);
    if (!fs::exists(st)) return;
    if (!fs::is_directory(st)) bad_input(out.string() + ": exists and is not a folder");
    if (!fs::is_empty(out, ec) && !is_report_folder(out))
        bad_input(out.string() +
                  ": is a folder of other files (not an earlier abrad report): give a new or "
                  "empty folder");
}

// Puts the finished `stage` in OUT's place: a rename, or an exchange with an earlier report
// (renameat2 RENAME_EXCHANGE: OUT is whole at every instant), whose files are then removed
void publish(const fs::path& stage, const fs::path& out) {
    std::error_code ec;
    if (!fs::exists(fs::symlink_status(out, ec))) {
        fs::rename(stage, out, ec);
        if (ec) failure(out.string() + ": cannot write: " + ec.message());
        return;
    }
    if (::renameat2(AT_FDCWD, stage.c_str(), AT_FDCWD, out.c_str(), RENAME_EXCHANGE) != 0)
        failure(out.string() + ": cannot write: " + std::generic_category().message(errno));
    // `stage` now holds the earlier report; the guard removes it
}

// The scene's grids evaluated on the bake, their CSVs written into `dir` as grid-N.csv
std::vector<exporter::ReportGrid> grids_of(const std::string& db, const visdb::Scene& scene,
                                           const visdb::Bake& bake, const fs::path& dir) {
    std::vector<exporter::ReportGrid> out;
    if (scene.grids.empty()) return out;
    const radiosity::PointIrradiance field = point_irradiance_of(db, scene, &bake);
    for (const visdb::CalculationGrid& g : scene.grids) {
        const radiosity::GridValues v = radiosity::evaluate_grid(field, g);
        exporter::ReportGrid& r = out.emplace_back();
        r.name = g.name;
        r.nx = v.nx;
        r.ny = v.ny;
        r.min_x = g.min.x;
        r.min_y = g.min.y;
        r.max_x = g.max.x;
        r.max_y = g.max.y;
        r.z = g.z;
        r.value = v.value;
        r.e_avg = v.e_avg;
        r.e_min = v.e_min;
        r.e_max = v.e_max;
        r.csv = "grid-" + std::to_string(out.size()) + ".csv";
        radiosity::write_grid_csv(dir / r.csv, v);  // OutputError naming the file
    }
    return out;
}

// The luminaire schedule: one line per photometric file and scale, in the scene's order, with
// the lamp flux and power the file states when it is still there as imported
std::vector<exporter::ReportLuminaireType> schedule_of(const visdb::Scene& scene) {
    std::vector<exporter::ReportLuminaireType> out;
    std::map<std::tuple<std::string, std::string, double>, std::size_t> line_of;
    for (const visdb::Luminaire& l : scene.luminaires) {
        const auto key = std::make_tuple(l.file, l.checksum, l.scale());
        auto [it, added] = line_of.try_emplace(key, out.size());
        if (!added) {
            out[it->second].names.push_back(l.name);
            continue;
        }
        exporter::ReportLuminaireType& t = out.emplace_back();
        t.file = l.file;
        t.names.push_back(l.name);
        t.web_flux = l.flux();
        t.scale = l.scale();
        std::error_code ec;
        if (!fs::is_regular_file(l.file, ec)) {
            t.file_note = "file not found: the lamp flux and power it states are not shown";
            continue;
        }
        try {
            const convert::PhotometricFile f = convert::read_photometric_file(l.file);
            if (f.checksum != l.checksum) {
                t.file_note = "the file changed since the import: its figures are not shown";
                continue;
            }
            t.description = f.description;
            t.lamp_lumens = f.lamp_lumens;
            t.input_watts = f.input_watts;
        } catch (const std::exception& e) {
            t.file_note = std::string("cannot read the file: ") + e.what();
        }
    }
    return out;
}

}  // namespace

void add_report(CLI::App& app) {
    ReportArgs& s = state();
    app.add_option("--db", s.db, "Visual database")->required();
    app.add_option("--bake", s.bake, "Bake to report (default: the latest)");
    add_scene_mix_option(app, s.scene_mix);
    app.add_option("--out", s.out,
                   "Output folder (created; an earlier report there is replaced): index.html "
                   "and the files it shows")
        ->required();
}

int run_report(const Invocation&) {
    const ReportArgs& s = state();
    const fs::path out = fs::absolute(fs::path(s.out)).lexically_normal();
    check_out(out);
    visdb::Store store = open_db(s.db, visdb::OpenMode::ReadOnly);
    visdb::Scene scene = store.load_scene();
    visdb::Bake bake = load_bake_for(store, s.db, s.bake, "report");
    // The exposure of the bake's own light scene, so that a dimmed one looks dimmer
    const ViewArgs view;
    const exporter::ToneMap tone = exposure_for(bake, scene, view);
    mix_light_scene(s.scene_mix, scene, bake);

    // Everything is written into a staging folder beside OUT (same file system), removed on
    // the way out whatever happens
    std::error_code ec;
    const fs::path parent = out.has_parent_path() ? out.parent_path() : fs::path(".");
    fs::create_directories(parent, ec);
    if (ec) failure(out.string() + ": cannot write: " + ec.message());
    const std::string prefix = "." + out.filename().string() + ".abrad-report-";
    remove_stale_staging(parent, prefix);  // left by killed reports
    const fs::path stage = parent / (prefix + std::to_string(::getpid()));
    fs::remove_all(stage, ec);
    if (!fs::create_directory(stage, ec) || ec)
        failure(out.string() + ": cannot write: " +
                (ec ? ec.message() : std::string("cannot make a folder beside it")));
    const StagingFolder guard{stage};

    exporter::ReportInput in;
    in.database = s.db;
    try {
        in.grids = grids_of(s.db, scene, bake, stage);
    } catch (const std::runtime_error& e) {  // a CSV that could not be written
        failure(e.what());
    }
    in.luminaires = schedule_of(scene);
    in.tone = tone;
    in.view = exporter::ReportView{camera_for(scene, view)};
    in.viewer_script = viewer_script();
    in.viewer_hint = kViewerHint;
    const exporter::ReportFiles files = exporter::write_report(stage, scene, bake, in);
    if (!files.has_3d_view)
        std::cerr << "abrad report: note: the 3D viewer is not installed"
                  << (in.viewer_script.empty() ? "" : " (" + in.viewer_script.string() + ")")
                  << ": the page has no 3D view. " << kViewerHint << "\n";
    publish(stage, out);
    for (const exporter::ReportGrid& g : in.grids)
        std::printf("grid '%s': E_avg %.4g, E_min %.4g, E_max %.4g %s, U0 %.3f\n", g.name.c_str(),
                    g.e_avg, g.e_min, g.e_max, bake.unit.c_str(),
                    g.e_avg > 0.0 ? g.e_min / g.e_avg : 0.0);
    std::cout << "wrote " << (out / "index.html").string() << " (" << files.files.size() << " files"
              << (files.has_3d_view ? ", with the 3D view" : ", no 3D view") << ")\n";
    return kExitOk;
}

}  // namespace abrad::tools::cli
