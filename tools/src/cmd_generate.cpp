// abrad generate: a generated building floor (tools/src/floor_gen.cpp) into a visual database.

#include <CLI/CLI.hpp>
#include <algorithm>
#include <iostream>

#include "abrad/tools/floor_gen.h"
#include "cli_common.h"

namespace abrad::tools::cli {
namespace {

struct FloorArgs {
    std::vector<int> rooms{1, 1};
    double cell = 0.5;
    int furniture = 2;
    int lights = 1;
    std::size_t triangles = 0;  ///< > 0: choose rooms and cell for about this many triangles
};

struct State {
    FloorArgs floor;
    std::string db;
};

State& state() {
    static State s;
    return s;
}

void add_floor_options(CLI::App& app, FloorArgs& a) {
    app.add_option("--rooms", a.rooms, "Rooms along x and y (5 x 4 x 3 m each)")
        ->expected(2)
        ->capture_default_str();
    app.add_option("--cell", a.cell,
                   "Largest triangle leg on floors, ceilings, walls, furniture (m)")
        ->capture_default_str();
    app.add_option("--furniture", a.furniture, "Pieces of furniture per room (0..16)")
        ->capture_default_str();
    app.add_option("--lights", a.lights, "Ceiling panels per room (0..16, two triangles each)")
        ->capture_default_str();
    app.add_option("--triangles", a.triangles,
                   "Choose rooms and cell for about this many triangles "
                   "(overrides --rooms and --cell)");
}

tools::FloorOptions to_floor(const FloorArgs& a) {
    tools::FloorOptions o;
    if (a.triangles > 0) {
        if (a.triangles > 50'000'000) bad_input("--triangles must be at most 50000000");
        o = tools::floor_for_triangles(a.triangles, std::clamp(a.lights, 0, 16));
    } else {
        o.rooms_x = a.rooms.at(0);
        o.rooms_y = a.rooms.at(1);
        o.cell = a.cell;
    }
    o.furniture = a.furniture;
    o.lights = a.lights;
    try {
        tools::validate(o);
    } catch (const std::invalid_argument& e) {
        bad_input(e.what());
    }
    return o;
}

}  // namespace

void add_generate(CLI::App& app) {
    State& s = state();
    app.add_option("--db", s.db, "Visual database, created when missing")->required();
    add_floor_options(app, s.floor);
}

int run_generate(const Invocation&) {
    const State& s = state();
    const tools::FloorOptions o = to_floor(s.floor);
    const visdb::Scene scene = tools::generate_floor(o);
    std::cout << "generated " << tools::to_string(o) << "\n";
    import_into(scene, s.db);
    return kExitOk;
}

}  // namespace abrad::tools::cli
