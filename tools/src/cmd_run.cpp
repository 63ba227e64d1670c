// abrad run: import, bake, export (PLY, OBJ) and a first rendered look in one go.

#include <CLI/CLI.hpp>
#include <filesystem>
#include <iostream>

#include "cli_common.h"

namespace fs = std::filesystem;

namespace abrad::tools::cli {
namespace {

struct RunArgs {
    ImportArgs import;
    BakeArgs bake;
    std::string out_dir;
};

RunArgs& state() {
    static RunArgs s;
    return s;
}

}  // namespace

void add_run(CLI::App& app) {
    RunArgs& s = state();
    add_model_arguments(app, s.import);
    app.add_option("--out", s.out_dir,
                   "Output directory (STEM.visdb, STEM.ply, STEM.obj, STEM.png)")
        ->required();
    add_import_options(app, s.import);
    add_bake_options(app, s.bake);
}

int run_run(const Invocation& call) {
    const RunArgs& s = state();
    const radiosity::BakeOptions options = to_options(s.bake, call.app);
    const visdb::Scene scene = read_models(s.import);
    fs::create_directories(s.out_dir);
    const fs::path out(s.out_dir);
    const std::string stem = fs::path(s.import.models.front()).stem().string();
    const fs::path final_db = out / (stem + ".visdb");
    // Build the database beside its final name; replace only when everything worked
    const fs::path tmp_db = out / (stem + ".visdb.partial");
    fs::remove(tmp_db);
    try {
        import_into(scene, tmp_db.string());
        bake_into(tmp_db.string(), options, s.bake.convergence_csv, (out / (stem + ".")).string());
    } catch (...) {
        fs::remove(tmp_db);
        throw;
    }
    fs::rename(tmp_db, final_db);
    for (const char* format : {"ply", "obj"}) {
        ExportArgs e;
        e.db = final_db.string();
        e.format = format;
        e.output = (out / (stem + "." + format)).string();
        export_bake(e);
    }
    // A first look through the scene's first camera (or the default one)
    RenderArgs r;
    r.db = final_db.string();
    r.output = (out / (stem + ".png")).string();
    render_image(r);
    std::cout << "database " << final_db.string() << "\n";
    return kExitOk;
}

}  // namespace abrad::tools::cli
