#pragma once
// Hand-built test surfaces and scenes shared by the radiosity tests.

#include <cstdint>
#include <glm/vec3.hpp>
#include <string>

#include "abrad/visdb/model.h"

namespace abrad::testing {

// A quad surface [x0,x1]×[y0,y1] at height z split into n×n cells, facing up or down.
inline visdb::Surface grid(const std::string& name, std::uint32_t material, double x0, double x1,
                           double y0, double y1, double z, int n, bool up) {
    visdb::Surface s;
    s.name = name;
    s.material = material;
    for (int j = 0; j <= n; ++j)
        for (int i = 0; i <= n; ++i)
            s.mesh.positions.push_back({x0 + (x1 - x0) * i / n, y0 + (y1 - y0) * j / n, z});
    auto id = [n](int i, int j) { return static_cast<std::uint32_t>(j * (n + 1) + i); };
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            const auto a = id(i, j), b = id(i + 1, j), c = id(i + 1, j + 1), d = id(i, j + 1);
            if (up) {
                s.mesh.triangles.push_back({a, b, c});
                s.mesh.triangles.push_back({a, c, d});
            } else {
                s.mesh.triangles.push_back({a, c, b});
                s.mesh.triangles.push_back({a, d, c});
            }
        }
    return s;
}

// A parallelogram o + s·u + t·v (s, t in [0, 1]) of n×n cells, front = u × v.
inline visdb::Surface quad_grid(const std::string& name, std::uint32_t material, glm::dvec3 o,
                                glm::dvec3 u, glm::dvec3 v, int n) {
    visdb::Surface s;
    s.name = name;
    s.material = material;
    for (int j = 0; j <= n; ++j)
        for (int i = 0; i <= n; ++i)
            s.mesh.positions.push_back(o + u * (double(i) / n) + v * (double(j) / n));
    auto id = [n](int i, int j) { return static_cast<std::uint32_t>(j * (n + 1) + i); };
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            s.mesh.triangles.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
            s.mesh.triangles.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
        }
    return s;
}

// The floor-and-light scene of the radiosity tests (the paper's set-up): a 2×2 m floor
// [-1,1]² at z = 0 of floor_cells × floor_cells cells facing up, under a 1×1 m light
// [-0.5,0.5]² at 1.5 m facing down with E = (10, 20, 5) W/m². Materials: 0 "floor" (ρ 0.5),
// 1 "light", 2 "occluder" (grey, ρ 0.3). With `occluder`, a third surface: a 0.4 m square
// [-0.2,0.2]² of material 2 at 0.75 m facing up (half way, so its shadow is twice its size).
inline visdb::Scene floor_and_light(int floor_cells = 8, bool occluder = false) {
    visdb::Scene scene;
    scene.materials.push_back({"floor", {0.5, 0.5, 0.5}, {0, 0, 0}, 1.0});
    scene.materials.push_back({"light", {0, 0, 0}, {10, 20, 5}, 1.0});
    scene.materials.push_back({"occluder", {0.3, 0.3, 0.3}, {0, 0, 0}, 1.0});
    scene.surfaces.push_back(grid("floor", 0, -1, 1, -1, 1, 0, floor_cells, true));
    scene.surfaces.push_back(grid("light", 1, -0.5, 0.5, -0.5, 0.5, 1.5, 1, false));
    if (occluder)
        scene.surfaces.push_back(grid("occluder", 2, -0.2, 0.2, -0.2, 0.2, 0.75, 1, true));
    return scene;
}

}  // namespace abrad::testing
