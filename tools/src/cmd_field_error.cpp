// abrad field-error: the field error of a bake (docs/algorithms.md#field-error), its
// Gouraud-interpolated irradiance against the exact direct irradiance inside every receiver
// triangle, as `key: value` lines.

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <vector>

#include "abrad/radiosity/direct.h"
#include "abrad/radiosity/field_error.h"
#include "cli_common.h"

namespace abrad::tools::cli {
namespace {

struct FieldErrorArgs {
    std::string db;
    std::string bake;
    int subdivisions = 3;
    int by_surface = 0;
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

void field_error(const std::string& db, const std::string& bake_name, int subdivisions,
                 int by_surface) {
    if (subdivisions < 1 || subdivisions > 64)
        bad_input("--subdivisions must be in [1, 64], got " + std::to_string(subdivisions));
    if (by_surface < 0)
        bad_input("--by-surface must be 0 or more, got " + std::to_string(by_surface));
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
    if (by_surface == 0) return;
    // The surfaces that carry most of the error: share of the whole, then their own error
    std::vector<radiosity::SurfaceFieldError> worst = e.surfaces;
    double exact = 0.0;
    for (const auto& s : worst) exact += s.exact;
    std::sort(worst.begin(), worst.end(), [](const auto& x, const auto& y) {
        return x.error > y.error || (x.error == y.error && x.surface < y.surface);
    });
    worst.resize(std::min(worst.size(), static_cast<std::size_t>(by_surface)));
    std::printf("receiver_surfaces: %zu\n", e.surfaces.size());
    for (std::size_t k = 0; k < worst.size(); ++k) {
        const radiosity::SurfaceFieldError& s = worst[k];
        std::printf(
            "surface_%zu: share=%.4g relative_l1=%.4g area_m2=%.4g triangles=%zu index=%u "
            "name=%s\n",
            k + 1, exact > 0.0 ? s.error / exact : 0.0, s.exact > 0.0 ? s.error / s.exact : 0.0,
            s.area_m2, s.triangles, s.surface, scene.surfaces[s.surface].name.c_str());
    }
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
    app.add_option("--by-surface", s.by_surface,
                   "Also list the N receiver surfaces that carry most of the error: each one's "
                   "share of the relative L1 (the shares add up to it), its own relative L1, "
                   "area and triangles")
        ->capture_default_str();
}

int run_field_error(const Invocation&) {
    const FieldErrorArgs& s = state();
    field_error(s.db, s.bake, s.subdivisions, s.by_surface);
    return kExitOk;
}

}  // namespace abrad::tools::cli
