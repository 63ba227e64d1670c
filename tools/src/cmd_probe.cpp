// abrad probe: irradiance at the points of a CSV file (radiosity/grid.h reads it): exact
// direct light plus the indirect part gathered from a bake, written as CSV to stdout.

#include <CLI/CLI.hpp>
#include <cstdio>
#include <optional>

#include "abrad/radiosity/grid.h"
#include "cli_common.h"

namespace abrad::tools::cli {
namespace {

struct ProbeArgs {
    std::string db;
    std::string points;
    std::string bake;
    std::string scene_mix;
};

ProbeArgs& state() {
    static ProbeArgs s;
    return s;
}

// The bake whose indirect part to gather: the named one, else the latest, else none ("none":
// direct light only, whatever the database holds).
std::optional<visdb::Bake> bake_to_gather(visdb::Store& store, const std::string& name) {
    if (name == "none" || (name.empty() && store.list_bakes().empty())) return std::nullopt;
    try {
        return store.load_bake(name);
    } catch (const visdb::StoreError& e) {
        if (e.kind() == visdb::StoreError::Kind::Failure) throw;
        bad_input(e.what());
    }
}

}  // namespace

void add_probe(CLI::App& app) {
    ProbeArgs& s = state();
    app.add_option("--db", s.db, "Visual database")->required();
    app.add_option("--points", s.points,
                   "CSV of x,y,z,nx,ny,nz per line (metres; a header "
                   "line allowed)")
        ->required();
    app.add_option("--bake", s.bake,
                   "Bake whose interreflection to gather and unit to "
                   "report (default: the latest; none: exact direct light only, as does a "
                   "database without bakes)");
    add_scene_mix_option(app, s.scene_mix);
}

int run_probe(const Invocation&) {
    const ProbeArgs& s = state();
    std::vector<radiosity::ProbePoint> points;
    try {
        points = radiosity::read_probe_points(s.points);
    } catch (const radiosity::InputFileError& e) {
        bad_input(e.what());
    }
    visdb::Store store = open_db(s.db);
    std::optional<visdb::Bake> bake = bake_to_gather(store, s.bake);
    visdb::Scene scene = store.load_scene();
    if (!s.scene_mix.empty()) {
        if (!bake) bad_input("--scene-mix needs a bake: its light groups are the bake's");
        mix_light_scene(s.scene_mix, scene, *bake);
    }
    const std::string unit = bake ? bake->unit : scene.emittance_unit == "lm/m2" ? "lux" : "W/m2";
    const radiosity::PointIrradiance field =
        point_irradiance_of(s.db, scene, bake ? &*bake : nullptr);
    std::fprintf(
        stderr, "probe: %zu points, %s, unit %s\n", points.size(),
        field.has_indirect()
            ? ("exact direct + indirect gathered from bake '" + bake->name + "'").c_str()
        : bake ? ("direct light only (bake '" + bake->name + "' has no interreflection)").c_str()
        : s.bake == "none" ? "direct light only (--bake none)"
                           : "direct light only (no bake yet)",
        unit.c_str());
    const std::vector<visdb::Rgb> h = field.at(points);
    std::printf("x,y,z,nx,ny,nz,irradiance_r,irradiance_g,irradiance_b\n");
    for (std::size_t i = 0; i < points.size(); ++i) {
        const radiosity::ProbePoint& pt = points[i];
        std::printf("%.17g,%.17g,%.17g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g\n", pt.x.x, pt.x.y, pt.x.z,
                    pt.n.x, pt.n.y, pt.n.z, h[i].x, h[i].y, h[i].z);
    }
    return kExitOk;
}

}  // namespace abrad::tools::cli
