// abrad field-error: the field error of a bake (docs/algorithms.md#field-error), its
// Gouraud-interpolated irradiance against the exact direct irradiance inside every receiver
// triangle, as `key: value` lines.

#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdio>

#include "abrad/radiosity/direct.h"
#include "abrad/radiosity/field_error.h"
#include "cli_common.h"

namespace abrad::tools::cli {
namespace {

struct FieldErrorArgs {
    std::string db;
    std::string bake;
    int subdivisions = 3;
};

FieldErrorArgs& state() {
    static FieldErrorArgs s;
    return s;
}

// The exact direct field of the database's scene; a scene without lights is bad input.
radiosity::DirectField direct_field_of(const std::string& db, const visdb::Scene& scene) {
    try {
        return radiosity::DirectField(scene);
    } catch (const radiosity::InputError& e) {
        bad_input(db + ": " + e.what());
    }
}

void field_error(const std::string& db, const std::string& bake_name, int subdivisions) {
    if (subdivisions < 1 || subdivisions > 64)
        bad_input("--subdivisions must be in [1, 64], got " + std::to_string(subdivisions));
    visdb::Store store = open_db(db);
    const visdb::Bake b = load_bake_for(store, db, bake_name, "measure");
    for (const auto& [key, value] : b.parameters)
        if (key == "bounces" && value != "0") {
            std::string message = db;
            message += ": bake '" + b.name + "' has interreflection (bounces " + value;
            message +=
                "); the field error measures direct light against its exact field: measure "
                "a --bounces 0 bake";
            bad_input(message);
        }
    const visdb::Scene scene = store.load_scene();
    const radiosity::DirectField field = direct_field_of(db, scene);
    const auto t0 = std::chrono::steady_clock::now();
    const radiosity::FieldError e = radiosity::field_error(
        scene, b.mesh,
        [&](const glm::dvec3& x, const glm::dvec3& n) { return field.irradiance(x, n); },
        {.subdivisions = subdivisions});
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::printf(
        "bake: %s\ntriangles: %zu\nreceiver_triangles: %zu\nreceiver_area_m2: %.6g\n"
        "samples: %zu\nrelative_l1: %.6g\nabsolute_l1_w_m2: %.6g\nmean_exact_w_m2: %.6g\n"
        "bake_seconds: %.6g\nmeasure_seconds: %.3g\n",
        b.name.c_str(), b.mesh.triangles.size(), e.triangles, e.area_m2, e.samples, e.relative_l1,
        e.absolute_l1, e.mean_exact, b.statistics.seconds_total, seconds);
}

}  // namespace

void add_field_error(CLI::App& app) {
    FieldErrorArgs& s = state();
    app.add_option("--db", s.db, "Visual database")->required();
    app.add_option("--bake", s.bake, "Bake name (default: the latest)");
    app.add_option("--subdivisions", s.subdivisions,
                   "Each triangle is sampled at the centroids "
                   "of its k x k sub-triangles")
        ->capture_default_str();
}

int run_field_error(const Invocation&) {
    const FieldErrorArgs& s = state();
    field_error(s.db, s.bake, s.subdivisions);
    return kExitOk;
}

}  // namespace abrad::tools::cli
