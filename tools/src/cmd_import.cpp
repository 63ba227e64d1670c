// abrad import: model files read, healed and appended to a visual database.

#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <system_error>

#include "abrad/convert/import.h"
#include "abrad/convert/scene_file.h"
#include "cli_common.h"
#include "scene_check.h"

namespace fs = std::filesystem;

namespace abrad::tools::cli {
namespace {

struct State {
    ImportArgs import;
    std::string db;
};

State& state() {
    static State s;
    return s;
}

// A database the import could not write, refused before any work: an existing one by the
// store's check (exit 1, or 2 when it is not an abrad database), a new one when its folder
// exists but is not writable. A missing folder is left to the store's open.
void refuse_unwritable(const std::string& db) {
    if (fs::exists(db)) {
        open_db(db).check_writable();
        return;
    }
    const fs::path dir = fs::path(db).has_parent_path() ? fs::path(db).parent_path() : ".";
    if (!fs::is_directory(dir) || ::access(dir.c_str(), W_OK | X_OK) == 0) return;
    const int err = errno;
    failure(db + ": cannot create: its directory " + dir.string() + " is not writable (" +
            std::generic_category().message(err) + ")");
}

}  // namespace

visdb::Scene read_models(const ImportArgs& a) {
    visdb::Scene all;
    convert::ImportOptions options;
    std::optional<convert::SceneFile> scene_file;
    if (!a.scene.empty()) {
        try {
            scene_file = convert::read_scene_file(a.scene, a.allow_outside_refs);
        } catch (const convert::ImportError& e) {
            bad_input(e.what());
        }
        convert::apply_import_settings(*scene_file, options);
    }
    if (!a.unit.empty()) options.unit = a.unit;
    if (!a.up.empty()) options.up = a.up.front();
    if (a.weld) options.weld_tolerance = *a.weld;
    options.allow_outside_refs = a.allow_outside_refs;
    for (const std::string& model : a.models) {
        convert::ImportResult r;
        try {
            const auto start = std::chrono::steady_clock::now();
            r = convert::import_model(model, options);
            std::fprintf(
                stderr, "import: %s read and healed in %.2f s\n", model.c_str(),
                std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
        } catch (const convert::ImportError& e) {
            bad_input(e.what());
        }
        std::cout << "imported " << model << "\n" << r.report.to_string();
        // Append, remapping material and source indices
        const auto material_base = static_cast<std::uint32_t>(all.materials.size());
        const auto source_base = static_cast<std::uint32_t>(all.sources.size());
        for (auto& m : r.scene.materials) all.materials.push_back(std::move(m));
        for (auto& s : r.scene.sources) all.sources.push_back(std::move(s));
        for (auto& c : r.scene.cameras) all.cameras.push_back(std::move(c));
        for (auto& s : r.scene.surfaces) {
            s.material += material_base;
            s.source += source_base;
            all.surfaces.push_back(std::move(s));
        }
    }
    if (scene_file) {
        try {
            const convert::SceneFileReport report = convert::apply_scene_file(*scene_file, all);
            std::cout << "applied " << a.scene << "\n" << report.to_string();
        } catch (const convert::ImportError& e) {
            bad_input(e.what());
        }
    }
    return all;
}

void import_into(const visdb::Scene& scene, const std::string& db) {
    visdb::Store store = open_db(db, visdb::OpenMode::CreateOrOpen);
    store.check_writable();
    // The same file twice would put every face on top of itself (coplanar overlaps): refused
    // inside the import's transaction, so two imports of one file at once store it once
    store.add_import(scene, visdb::SameSource::Refuse);
    std::cout << "stored " << scene.surfaces.size() << " surfaces, " << scene.triangle_count()
              << " triangles in " << db << "\n";
}

void add_import(CLI::App& app) {
    State& s = state();
    add_model_arguments(app, s.import);
    app.add_option("--db", s.db, "Visual database (.visdb), created when missing")->required();
    add_import_options(app, s.import);
}

int run_import(const Invocation&) {
    const State& s = state();
    refuse_unwritable(s.db);  // before the models are read and healed
    const visdb::Scene scene = read_models(s.import);
    print_scene_check(check_scene(scene), "import", std::cout, std::cerr);
    import_into(scene, s.db);
    return kExitOk;
}

}  // namespace abrad::tools::cli
