// abrad simplify: a light mesh of a bake, stored as a new bake. OpenMesh's Decimater removes
// vertices while the irradiance at every removed vertex stays within a relative bound
// (export/src/simplify.cpp); the result is a bake like any other, so field-error, export,
// render and probe work on it unchanged.

#include <CLI/CLI.hpp>
#include <cmath>
#include <iostream>

#include "abrad/export/simplify.h"
#include "cli_common.h"

namespace abrad::tools::cli {
namespace {

struct SimplifyArgs {
    std::string db;
    std::string bake;
    double error = 0.0;
    double floor = exporter::SimplifyOptions{}.floor;
    bool refit = exporter::SimplifyOptions{}.refit;
    double budget = exporter::SimplifyOptions{}.budget;
    std::string name;
};

SimplifyArgs& state() {
    static SimplifyArgs s;
    return s;
}

// A bound outside (0, 1] (NaN included) is bad input naming the option.
void check_bound(double error, const std::string& option) {
    if (!(error > 0.0 && error <= 1.0))
        bad_input(option + " " + std::to_string(error) +
                  ": the relative irradiance bound must be in (0, 1] (e.g. 0.02 for 2 %)");
}

}  // namespace

void check_simplify_options(const exporter::SimplifyOptions& options,
                            const SimplifyOptionNames& names) {
    check_bound(options.error, names.error);
    if (!(options.floor >= 0.0 && options.floor <= 1.0))
        bad_input(names.prefix + "floor " + std::to_string(options.floor) + ": must be in [0, 1]");
    if (!(options.budget >= 0.0 && options.budget <= 1.0))
        bad_input(names.prefix + "budget " + std::to_string(options.budget) +
                  ": must be in [0, 1] (e.g. 0.005)");
}

visdb::BakeMesh simplify_mesh(const visdb::Bake& bake, const exporter::SimplifyOptions& options,
                              const SimplifyOptionNames& names) {
    check_simplify_options(options, names);
    exporter::SimplifyStats stats;
    visdb::BakeMesh mesh = exporter::simplify(bake.mesh, options, &stats);
    std::cerr << "simplify: bake '" << bake.name << "' within " << options.error * 100.0
              << " % of its irradiance (floor " << options.floor << ", refit "
              << (options.refit ? "true" : "false") << ", budget " << options.budget
              << "): " << exporter::to_string(stats) << "\n";
    return mesh;
}

void add_simplify(CLI::App& app) {
    SimplifyArgs& s = state();
    app.add_option("--db", s.db, "Visual database")->required();
    app.add_option("--bake", s.bake, "Bake to simplify (default: the latest)");
    app.add_option("--error", s.error,
                   "Relative irradiance change allowed at every removed vertex, in (0, 1]")
        ->required();
    app.add_option("--floor", s.floor,
                   "Absolute floor of the bound, a fraction of the bake's brightest irradiance: "
                   "where the irradiance is below it, the change allowed is --error times it")
        ->capture_default_str();
    app.add_option("--refit", s.refit,
                   "Refit the kept vertices' values by least squares to every vertex of the "
                   "bake (true) instead of keeping their baked values (false)")
        ->capture_default_str();
    app.add_option("--budget", s.budget,
                   "Area-weighted mean change of irradiance allowed over the whole mesh, a "
                   "fraction of the bake's area-weighted mean irradiance (0: none)")
        ->capture_default_str();
    app.add_option("--name", s.name,
                   "Name of the stored simplified bake (default: the bake's name with "
                   "'-simplified'); a bake of that name is replaced");
}

int run_simplify(const Invocation&) {
    const SimplifyArgs& s = state();
    const exporter::SimplifyOptions options{
        .error = s.error, .floor = s.floor, .refit = s.refit, .budget = s.budget};
    const SimplifyOptionNames names{.error = "--error", .prefix = "--"};
    check_simplify_options(options, names);
    visdb::Store store = open_db(s.db);
    store.check_writable();  // before the work
    visdb::Bake b = load_bake_for(store, s.db, s.bake, "simplify");
    const std::string source = b.name;
    b.name = s.name.empty() ? source + "-simplified" : s.name;
    if (b.name == source)
        bad_input("--name " + b.name +
                  ": the simplified bake would replace the bake it is made of");
    b.mesh = simplify_mesh(b, options, names);
    // The light groups' shades belong to the full mesh's vertices: the light mesh keeps none
    // (a light scene of it: export --simplify --scene-mix from the full bake)
    b.light_groups.clear();
    std::erase_if(b.parameters, [](const auto& p) { return p.first == "light_groups"; });
    b.created_at = utc_now();
    b.parameters.emplace_back("simplified_from", source);
    b.parameters.emplace_back("simplify_error", std::to_string(s.error));
    b.parameters.emplace_back("simplify_floor", std::to_string(s.floor));
    b.parameters.emplace_back("simplify_refit", s.refit ? "true" : "false");
    b.parameters.emplace_back("simplify_budget", std::to_string(s.budget));
    b.statistics.triangles = b.mesh.triangles.size();
    b.statistics.vertices = b.mesh.positions.size();
    store.add_bake(b);
    std::cout << "stored bake '" << b.name << "' (" << b.mesh.positions.size() << " vertices, "
              << b.mesh.triangles.size() << " triangles) simplified from '" << source << "'\n";
    return kExitOk;
}

}  // namespace abrad::tools::cli
