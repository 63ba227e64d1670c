// abrad bench: speed against error over a grid of bake settings, and scaling on generated
// floors (tools/src/bench.cpp).

#include <CLI/CLI.hpp>
#include <charconv>
#include <filesystem>
#include <iostream>
#include <sstream>

#include "abrad/tools/bench.h"
#include "abrad/tools/floor_gen.h"
#include "cli_common.h"

namespace fs = std::filesystem;

namespace abrad::tools::cli {
namespace {

struct BenchArgs {
    std::string out;
    std::vector<std::string> models;
    std::vector<std::string> buildings;
    std::string scene;
    std::vector<std::string> sizes;
    std::vector<int> light_counts;
    std::size_t lights_at = 30000;
    bool quick = false;
    bool no_room = false;
    std::vector<double> tradeoff{0.2, 0.07, 0.01};
    bool no_tradeoff = false;
    int subdivisions = 2;
    std::size_t field_error_max = 200000;
    BakeArgs bake;
};

BenchArgs& state() {
    static BenchArgs s;
    return s;
}

std::size_t parse_count(const std::string& text) {
    std::size_t mult = 1;
    std::string digits = text;
    if (!digits.empty() && (digits.back() == 'k' || digits.back() == 'K'))
        mult = 1000, digits.pop_back();
    else if (!digits.empty() && (digits.back() == 'm' || digits.back() == 'M'))
        mult = 1000000, digits.pop_back();
    std::size_t v = 0;
    const auto [p, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), v);
    if (ec != std::errc() || p != digits.data() + digits.size() || v == 0 || v > 50'000'000 / mult)
        bad_input("--sizes: '" + text +
                  "' is not a triangle count in [1, 50M] (digits with an optional k or M)");
    return v * mult;
}

// A model file imported as by abrad import (with --scene), without the import report.
tools::BenchScene import_scene(const BenchArgs& a, const std::string& model) {
    ImportArgs ia;
    ia.models = {model};
    ia.scene = a.scene;
    std::ostringstream discard;
    auto* old = std::cout.rdbuf(discard.rdbuf());  // the import report is not the bench's output
    visdb::Scene scene;
    try {
        scene = read_models(ia);
    } catch (...) {
        std::cout.rdbuf(old);
        throw;
    }
    std::cout.rdbuf(old);
    return {fs::path(model).filename().string(), std::move(scene)};
}

// The scenes of the settings grid: the generated room unless --no-room, then the --model files.
std::vector<tools::BenchScene> bench_scenes(const BenchArgs& a) {
    std::vector<tools::BenchScene> scenes;
    if (!a.no_room) {
        tools::FloorOptions room;
        room.cell = 0.5;
        room.furniture = 3;
        room.lights = 2;
        scenes.push_back(
            {"generated room (" + tools::to_string(room) + ")", tools::generate_floor(room)});
    }
    for (const std::string& m : a.models) scenes.push_back(import_scene(a, m));
    return scenes;
}

}  // namespace

void add_bench(CLI::App& app) {
    BenchArgs& a = state();
    app.add_option("--out", a.out,
                   "Output directory: bench.csv, scaling.csv, speed_error.png, "
                   "scaling.png, summary.md")
        ->required();
    app.add_option("--model", a.models,
                   "Model files baked over the settings grid besides the "
                   "generated room (imported as by abrad import)");
    app.add_option("--building", a.buildings,
                   "Model files of whole buildings, each baked once with the bake options "
                   "(default: the full bake) and reported with time per stage, CPU, peak "
                   "memory, triangles out and energy balance (imported as by abrad import)");
    app.add_option("--scene", a.scene,
                   "Scene file (TOML) applied to the --model and --building files");
    app.add_flag("--no-room", a.no_room, "Leave out the generated one-room scene from the grid");
    app.add_flag("--quick", a.quick,
                 "A small grid (Z-buffer R50, A-buffer R26 4x4 and R50 8x8; DM off "
                 "and area) instead of the full one");
    app.add_option("--sizes", a.sizes,
                   "Scaling: generated floors of about these many triangles "
                   "(e.g. 3k 30k 300k 1M), baked with the bake options")
        ->delimiter(',');
    app.add_option("--light-counts", a.light_counts,
                   "Light scaling: ceiling panels per room, on a floor "
                   "of --lights-at triangles")
        ->delimiter(',');
    app.add_option("--lights-at", a.lights_at, "Triangles of the light-scaling floor")
        ->capture_default_str();
    app.add_option("--subdivisions", a.subdivisions,
                   "Field error: k x k sample points per triangle")
        ->capture_default_str();
    app.add_option("--field-error-max", a.field_error_max,
                   "Measure the field error only for bakes of "
                   "at most this many triangles")
        ->capture_default_str();
    app.add_option("--tradeoff", a.tradeoff,
                   "Mesh trade-off: bake every grid scene with DM at these refine tolerances and "
                   "uniformly subdivided to the same triangle count without DM (direct light), "
                   "and report triangles against field error (with --quick: the bake's "
                   "--refine-tolerance only)")
        ->delimiter(',')
        ->capture_default_str();
    app.add_flag("--no-tradeoff", a.no_tradeoff, "Leave out the mesh trade-off");
    add_bake_options(app, a.bake);
}

int run_bench(const Invocation& call) {
    const BenchArgs& a = state();
    if (a.subdivisions < 1 || a.subdivisions > 16)
        bad_input("--subdivisions must be in [1, 16], got " + std::to_string(a.subdivisions));
    for (int n : a.light_counts)
        if (n < 1 || n > 16)
            bad_input("--light-counts must be in [1, 16], got " + std::to_string(n));
    if (a.lights_at < 100 || a.lights_at > 50'000'000)
        bad_input("--lights-at must be in [100, 50000000]");
    tools::BenchOptions o;
    o.out = a.out;
    o.quick = a.quick;
    o.subdivisions = a.subdivisions;
    o.field_error_max = a.field_error_max;
    o.scaling = to_options(a.bake, call.app);
    o.threads = o.scaling.threads;
    o.finish = [coarsen = coarsen_budget(a.bake)](visdb::Bake& b,
                                                  const radiosity::BakeOptions& options) {
        coarsen_bake(b, coarsen, options.refine_tolerance);
    };
    for (const std::string& s : a.sizes) o.sizes.push_back(parse_count(s));
    o.light_counts = a.light_counts;
    for (double t : a.tradeoff)
        if (!(t > 0.0 && t < 1.0))
            bad_input("--tradeoff: refine tolerances must be in (0, 1), got " + std::to_string(t));
    if (!a.no_tradeoff) {
        const bool given = call.app.count("--tradeoff") > 0;
        o.tradeoff_tolerances =
            a.quick && !given ? std::vector<double>{o.scaling.refine_tolerance} : a.tradeoff;
    }
    o.lights_at = a.lights_at;
    for (int i = 0; i < call.argc; ++i)
        o.command += (i ? " " : "") + std::string(i ? call.argv[i] : "abrad");
    o.scenes = bench_scenes(a);
    for (const std::string& b : a.buildings) o.buildings.push_back(import_scene(a, b));
    if (o.scenes.empty() && o.buildings.empty() && o.sizes.empty() && o.light_counts.empty())
        bad_input(
            "nothing to run: give --model, --building, --sizes or --light-counts, or drop "
            "--no-room");
    std::vector<tools::BenchRun> runs;
    try {
        runs = tools::run_bench(o);
    } catch (const radiosity::InputError& e) {
        bad_input(e.what());
    }
    std::cout << "wrote " << (o.out / "bench.csv").string() << ", "
              << (o.out / "scaling.csv").string() << ", " << (o.out / "summary.md").string() << " ("
              << runs.size() << " runs)\n";
    return kExitOk;
}

}  // namespace abrad::tools::cli
