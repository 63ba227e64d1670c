#pragma once
// Scenes shared by the exporter tests.

#include <cstdint>
#include <glm/geometric.hpp>
#include <string>

#include "abrad/visdb/model.h"

namespace abrad::testing {

/// Two surfaces, "floor" (material 0, "floor") and "wall" (material 1, "wall"), without
/// meshes: the scene of a two-surface bake mesh (triangle_surface 0 and 1).
inline visdb::Scene two_surfaces() {
    visdb::Scene s;
    s.materials = {{.name = "floor"}, {.name = "wall"}};
    s.surfaces.resize(2);
    s.surfaces[0].name = "floor";
    s.surfaces[0].material = 0;
    s.surfaces[1].name = "wall";
    s.surfaces[1].material = 1;
    return s;
}

/// A camera named `name` at `position` looking at `look_at`, `up` up, `fov_y_deg` high.
inline visdb::Camera make_camera(const std::string& name, const glm::dvec3& position,
                                 const glm::dvec3& look_at, const glm::dvec3& up,
                                 double fov_y_deg) {
    visdb::Camera c;
    c.name = name;
    c.position = position;
    c.look_at = look_at;
    c.up = up;
    c.fov_y_deg = fov_y_deg;
    return c;
}

/// Two surfaces near a survey origin (1e6 m, 2e6 m, plus a millimetre), millimetre detail: a
/// floor triangle (surface 0) and a wall triangle (surface 1) over six vertices, irradiance
/// twice the radiosity. `interleaved` adds a second floor triangle (and a seventh vertex) after
/// the wall's, so the surfaces' triangles interleave and a writer that groups them by surface
/// (OBJ) reorders them.
inline visdb::BakeMesh survey_mesh(bool interleaved) {
    visdb::BakeMesh m;
    const glm::dvec3 o(1.0e6 + 0.001, 2.0e6 + 0.002, 10.0);
    m.positions = {o + glm::dvec3(0, 0, 0),     o + glm::dvec3(1.001, 0, 0),
                   o + glm::dvec3(0, 2.002, 0), o + glm::dvec3(0, 0, 0.5),
                   o + glm::dvec3(0, 2.002, 0), o + glm::dvec3(0, 0, 3.003)};
    m.normals = {{0, 0, 1}, {0, 0, 1}, {0, 0, 1}, {1, 0, 0}, {1, 0, 0}, {1, 0, 0}};
    m.triangles = {{0, 1, 2}, {3, 5, 4}};
    m.triangle_surface = {0, 1};
    m.radiosity = {{10, 20, 30}, {1, 2, 3}, {0, 0, 0}, {5, 5, 5}, {50, 0, 0}, {0, 0, 500}};
    if (interleaved) {
        m.positions.push_back(o + glm::dvec3(1.001, 2.002, 0));
        m.normals.emplace_back(0, 0, 1);
        m.radiosity.emplace_back(2, 2, 2);
        m.triangles.push_back({1, 6, 2});
        m.triangle_surface.push_back(0);
    }
    for (const auto& b : m.radiosity) m.irradiance.push_back(2.0f * b);
    return m;
}

/// Appends a quad a, b, c, d (counter-clockwise seen from the front, two triangles of
/// `surface`) whose vertices get radiosity `radiosity(position)` and irradiance
/// `irradiance(position)` (glm::vec3 from a glm::dvec3).
template <typename B, typename H>
void add_quad(visdb::BakeMesh& m, std::uint32_t surface, const glm::dvec3& a, const glm::dvec3& b,
              const glm::dvec3& c, const glm::dvec3& d, B radiosity, H irradiance) {
    const auto base = static_cast<std::uint32_t>(m.positions.size());
    const glm::vec3 n = glm::vec3(glm::normalize(glm::cross(b - a, c - a)));
    for (const auto& p : {a, b, c, d}) {
        m.positions.push_back(p);
        m.normals.push_back(n);
        m.radiosity.push_back(radiosity(p));
        m.irradiance.push_back(irradiance(p));
    }
    m.triangles.push_back({base, base + 1, base + 2});
    m.triangles.push_back({base, base + 2, base + 3});
    m.triangle_surface.push_back(surface);
    m.triangle_surface.push_back(surface);
}

/// add_quad with the same radiosity and irradiance at every vertex.
inline void add_quad(visdb::BakeMesh& m, std::uint32_t surface, const glm::dvec3& a,
                     const glm::dvec3& b, const glm::dvec3& c, const glm::dvec3& d,
                     const glm::vec3& radiosity, const glm::vec3& irradiance) {
    add_quad(
        m, surface, a, b, c, d, [&](const glm::dvec3&) { return radiosity; },
        [&](const glm::dvec3&) { return irradiance; });
}

}  // namespace abrad::testing
