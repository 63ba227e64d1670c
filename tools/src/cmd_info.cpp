// abrad info: what a visual database holds.

#include <CLI/CLI.hpp>
#include <glm/geometric.hpp>
#include <iostream>

#include "cli_common.h"
#include "scene_check.h"

namespace abrad::tools::cli {
namespace {

std::string& db_path() {
    static std::string db;
    return db;
}

void print_info(const std::string& db) {
    visdb::Store store = open_db(db);
    const visdb::Scene scene = store.load_scene();
    std::cout << db << ": abrad visual database, schema " << store.schema_version() << "\n";
    std::cout << "sources (" << scene.sources.size() << "):\n";
    for (const auto& s : scene.sources)
        std::cout << "  " << s.path << "  [" << s.format << ", " << s.size_bytes << " bytes, fnv1a "
                  << s.checksum << ", unit " << s.unit << ", up " << s.up_axis << ", imported "
                  << s.imported_at << "]\n";
    std::size_t light_tris = 0;
    double light_area = 0.0, light_power = 0.0;
    std::cout << "surfaces (" << scene.surfaces.size() << "), triangles " << scene.triangle_count()
              << ":\n";
    for (const auto& s : scene.surfaces) {
        const auto& m = scene.materials[s.material];
        std::cout << "  " << s.name << (s.layer.empty() ? "" : " (layer " + s.layer + ")") << ": "
                  << s.mesh.triangles.size() << " triangles, material " << m.name << " rho ("
                  << m.reflectance.x << " " << m.reflectance.y << " " << m.reflectance.z
                  << ") alpha " << m.opacity;
        if (m.is_emitter()) {
            double area = 0.0;
            for (const auto& t : s.mesh.triangles)
                area += visdb::triangle_area(s.mesh.positions[t.x], s.mesh.positions[t.y],
                                             s.mesh.positions[t.z]);
            light_tris += s.mesh.triangles.size();
            light_area += area;
            light_power += area * visdb::channel_mean(m.emittance);
            std::cout << ", emits E (" << m.emittance.x << " " << m.emittance.y << " "
                      << m.emittance.z << ") " << scene.emittance_unit << " over " << area << " m2";
            if (!m.group.empty()) std::cout << ", group " << m.group;
        }
        std::cout << "\n";
    }
    const bool photometric = scene.emittance_unit == "lm/m2";
    print_scene_check(check_scene(scene), "info", std::cout, std::cerr);
    std::cout << "lights: " << light_tris << " triangles, " << light_area << " m2, " << light_power
              << (photometric ? " lm" : " W") << " (mean over RGB)\n";
    std::cout << "cameras (" << scene.cameras.size() << ")";
    for (const auto& c : scene.cameras) std::cout << " " << c.name;
    std::cout << "\n";
    std::cout << "grids (" << scene.grids.size() << "):\n";
    for (const auto& g : scene.grids)
        std::cout << "  " << g.name << ": x " << g.min.x << ".." << g.max.x << ", y " << g.min.y
                  << ".." << g.max.y << ", z " << g.z << ", spacing " << g.spacing << " m\n";
    std::cout << "luminaires (" << scene.luminaires.size() << "):\n";
    for (const auto& l : scene.luminaires) {
        std::cout << "  " << l.name << ": " << l.file << " at (" << l.position.x << " "
                  << l.position.y << " " << l.position.z << "), nadir toward (" << -l.axis_z.x
                  << " " << -l.axis_z.y << " " << -l.axis_z.z << "), " << l.flux() << " lm, "
                  << l.web.max_candela() * l.scale() << " cd max, opening "
                  << visdb::to_string(l.opening.shape)
                  << (l.group.empty() ? "" : ", group " + l.group) << "\n";
    }
    const auto bakes = store.list_bakes();
    std::cout << "bakes (" << bakes.size() << "):\n";
    for (const auto& b : bakes) {
        std::cout << "  " << b.name << "  [" << b.created_at << ", " << b.vertex_count
                  << " vertices, " << b.triangle_count << " triangles, unit " << b.unit
                  << "]\n    parameters:";
        for (const auto& [k, v] : b.parameters) std::cout << " " << k << "=" << v;
        std::cout << "\n    statistics:";
        for (const auto& [k, v] : visdb::to_pairs(b.statistics)) std::cout << " " << k << "=" << v;
        std::cout << "\n";
    }
}

}  // namespace

void add_info(CLI::App& app) { app.add_option("--db", db_path(), "Visual database")->required(); }

int run_info(const Invocation&) {
    print_info(db_path());
    return kExitOk;
}

}  // namespace abrad::tools::cli
