// abrad run: import, bake, export (PLY, OBJ) and a first rendered look in one go. Everything
// is made in a staging folder inside the output folder and moved into it only when all of it
// was written, the database last, so a failure leaves the previous results as they were.

#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <filesystem>
#include <iostream>
#include <system_error>
#include <utility>
#include <vector>

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
    const fs::path out(s.out_dir);
    fs::create_directories(out);
    const std::string stem = fs::path(s.import.models.front()).stem().string();

    // Make every result in a staging folder inside OUT (same file system: moves are renames),
    // removed on the way out whatever happens; a failure leaves OUT as it was
    remove_stale_staging(out, ".abrad-run-");
    const fs::path stage = out / (".abrad-run-" + std::to_string(::getpid()));
    fs::remove_all(stage);
    fs::create_directory(stage);
    const StagingFolder guard{stage};
    const fs::path db = stage / (stem + ".visdb");
    import_into(scene, db.string());
    bake_into(db.string(), options, s.bake, (stage / (stem + ".")).string());
    for (const char* format : {"ply", "obj"}) {
        ExportArgs e;
        e.db = db.string();
        e.format = format;
        e.output = (stage / (stem + "." + format)).string();
        export_bake(e);
    }
    // A first look through the scene's first camera (or the default one)
    RenderArgs r;
    r.db = db.string();
    r.output = (stage / (stem + ".png")).string();
    render_image(r);

    // Move the results into OUT, the database last: it says the run finished
    std::vector<fs::path> made;
    for (const fs::directory_entry& entry : fs::directory_iterator(stage))
        if (entry.path() != db) made.push_back(entry.path());
    std::sort(made.begin(), made.end());
    made.push_back(db);
    for (const fs::path& file : made) {  // a folder in a result's place fails before any move
        std::error_code ec;
        if (fs::is_directory(fs::symlink_status(out / file.filename(), ec)))
            failure((out / file.filename()).string() + ": cannot write: it is a folder");
    }
    for (const fs::path& file : made) {
        std::error_code ec;
        fs::rename(file, out / file.filename(), ec);
        if (ec) failure((out / file.filename()).string() + ": cannot write: " + ec.message());
        std::cout << "wrote " << (out / file.filename()).string() << "\n";
    }
    std::cout << "database " << (out / db.filename()).string() << "\n";
    return kExitOk;
}

}  // namespace abrad::tools::cli
