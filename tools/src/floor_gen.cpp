// Generated building floors: rooms, thick walls with doors, furniture, ceiling panels.

#include "abrad/tools/floor_gen.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <glm/geometric.hpp>
#include <stdexcept>
#include <vector>

namespace abrad::tools {

namespace {

enum MaterialId : std::uint32_t { kFloor, kWall, kCeiling, kFurniture, kLight };

// A parallelogram o + s·u + t·v cut into cells no larger than `cell`, its front facing `n`
// (u and v are swapped when u × v points away from n).
void add_rect(visdb::Surface& s, glm::dvec3 o, glm::dvec3 u, glm::dvec3 v, const glm::dvec3& n,
              double cell) {
    if (glm::dot(glm::cross(u, v), n) < 0.0) std::swap(u, v);
    const int nu = std::max(1, static_cast<int>(std::ceil(glm::length(u) / cell - 1e-9)));
    const int nv = std::max(1, static_cast<int>(std::ceil(glm::length(v) / cell - 1e-9)));
    const auto base = static_cast<std::uint32_t>(s.mesh.positions.size());
    for (int j = 0; j <= nv; ++j)
        for (int i = 0; i <= nu; ++i)
            s.mesh.positions.push_back(o + u * (double(i) / nu) + v * (double(j) / nv));
    auto id = [&](int i, int j) { return base + static_cast<std::uint32_t>(j * (nu + 1) + i); };
    for (int j = 0; j < nv; ++j)
        for (int i = 0; i < nu; ++i) {
            s.mesh.triangles.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
            s.mesh.triangles.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
        }
}

// An axis-aligned box without its bottom face (it stands on something) unless `bottom`.
void add_box(visdb::Surface& s, const glm::dvec3& lo, const glm::dvec3& hi, double cell,
             bool bottom) {
    const glm::dvec3 d = hi - lo;
    const glm::dvec3 X{d.x, 0, 0}, Y{0, d.y, 0}, Z{0, 0, d.z};
    add_rect(s, {lo.x, lo.y, hi.z}, X, Y, {0, 0, 1}, cell);  // top
    if (bottom) add_rect(s, lo, X, Y, {0, 0, -1}, cell);
    add_rect(s, lo, X, Z, {0, -1, 0}, cell);
    add_rect(s, {lo.x, hi.y, lo.z}, X, Z, {0, 1, 0}, cell);
    add_rect(s, lo, Y, Z, {-1, 0, 0}, cell);
    add_rect(s, {hi.x, lo.y, lo.z}, Y, Z, {1, 0, 0}, cell);
}

// Maps (along, across, z) to world coordinates for a wall running along x (axis 0) or y (1).
glm::dvec3 wall_point(int axis, double along, double across, double z) {
    return axis == 0 ? glm::dvec3{along, across, z} : glm::dvec3{across, along, z};
}

// A wall strip [a0, a1] along `axis`, [c0, c0 + t] across, height h, with door openings
// (sorted, disjoint intervals along the wall, inside [a0, a1]) of height dh.
void add_wall(visdb::Surface& s, int axis, double a0, double a1, double c0, double t, double h,
              const std::vector<std::pair<double, double>>& doors, double dh, double cell) {
    const glm::dvec3 along = wall_point(axis, 1, 0, 0), across = wall_point(axis, 0, 1, 0);
    const glm::dvec3 up{0, 0, 1};
    // Both faces of the part [s0, s1] × [z0, z1]
    auto faces = [&](double s0, double s1, double z0, double z1) {
        if (s1 <= s0 || z1 <= z0) return;
        for (int side = 0; side < 2; ++side) {
            const glm::dvec3 o = wall_point(axis, s0, c0 + side * t, z0);
            add_rect(s, o, along * (s1 - s0), up * (z1 - z0), across * (side ? 1.0 : -1.0), cell);
        }
    };
    double at = a0;
    for (const auto& [d0, d1] : doors) {
        faces(at, d0, 0.0, h);
        faces(d0, d1, dh, h);  // lintel
        // Jambs facing into the opening, and the lintel's underside
        add_rect(s, wall_point(axis, d0, c0, 0), across * t, up * dh, along, cell);
        add_rect(s, wall_point(axis, d1, c0, 0), across * t, up * dh, -along, cell);
        add_rect(s, wall_point(axis, d0, c0, dh), across * t, along * (d1 - d0), -up, cell);
        at = d1;
    }
    faces(at, a1, 0.0, h);
}

void add_furniture(visdb::Surface& s, int kind, glm::dvec2 c, double cell) {
    switch (kind % 3) {
        case 0: {  // table: top slab and four legs
            const glm::dvec2 half{0.8, 0.4};
            add_box(s, {c.x - half.x, c.y - half.y, 0.71}, {c.x + half.x, c.y + half.y, 0.75}, cell,
                    true);
            for (int i = 0; i < 4; ++i) {
                const double x = i & 1 ? c.x + half.x - 0.1 : c.x - half.x + 0.05;
                const double y = i & 2 ? c.y + half.y - 0.1 : c.y - half.y + 0.05;
                add_box(s, {x, y, 0.0}, {x + 0.05, y + 0.05, 0.71}, cell, false);
            }
            break;
        }
        case 1:  // cabinet
            add_box(s, {c.x - 0.4, c.y - 0.2, 0.0}, {c.x + 0.4, c.y + 0.2, 1.8}, cell, false);
            break;
        default:  // chair: seat on a block, and a back
            add_box(s, {c.x - 0.22, c.y - 0.22, 0.0}, {c.x + 0.22, c.y + 0.22, 0.45}, cell, false);
            add_box(s, {c.x - 0.22, c.y + 0.18, 0.45}, {c.x + 0.22, c.y + 0.22, 0.9}, cell, false);
            break;
    }
}

std::uint64_t fnv1a(const std::string& text) {
    std::uint64_t h = 0xcbf29ce484222325ULL;
    for (unsigned char c : text) h = (h ^ c) * 0x100000001b3ULL;
    return h;
}

}  // namespace

void validate(const FloorOptions& o) {
    auto fail = [](const std::string& what) {
        throw std::invalid_argument("generated floor: " + what);
    };
    if (o.rooms_x < 1 || o.rooms_y < 1 || o.rooms_x > 1000 || o.rooms_y > 1000)
        fail("rooms must be in [1, 1000] along each axis");
    if (!(o.room_x >= 2.0 && o.room_y >= 2.0 && o.height >= 2.5 && o.room_x < 1e3 &&
          o.room_y < 1e3 && o.height < 1e2))
        fail("room must be at least 2 x 2 m and 2.5 m high");
    if (!(o.wall > 0.0 && o.wall < 1.0)) fail("wall thickness must be in (0, 1) m");
    if (!(o.door_width > 0.0 && o.door_width < std::min(o.room_x, o.room_y) - 0.2 &&
          o.door_height > 0.0 && o.door_height < o.height - 0.1))
        fail("doors must fit in the walls");
    if (!(o.cell >= 0.01 && o.cell <= 10.0)) fail("cell must be in [0.01, 10] m");
    if (o.furniture < 0 || o.furniture > 16) fail("furniture must be in [0, 16] per room");
    if (o.lights < 0 || o.lights > 16) fail("lights must be in [0, 16] per room");
    if (!(o.emittance > 0.0 && std::isfinite(o.emittance))) fail("emittance must be > 0");
}

std::string to_string(const FloorOptions& o) {
    char buf[160];
    std::snprintf(buf, sizeof buf, "%dx%d rooms, cell %g m, %d furniture, %d lights/room",
                  o.rooms_x, o.rooms_y, o.cell, o.furniture, o.lights);
    return buf;
}

visdb::Scene generate_floor(const FloorOptions& o) {
    validate(o);
    visdb::Scene scene;
    const std::string name = "generated:" + to_string(o);
    char checksum[17];
    std::snprintf(checksum, sizeof checksum, "%016llx",
                  static_cast<unsigned long long>(fnv1a(name)));
    scene.sources.push_back({.path = name,
                             .format = "generated",
                             .checksum = checksum,
                             .size_bytes = 0,
                             .unit = "m",
                             .up_axis = "z",
                             .imported_at = "",
                             .report = ""});
    scene.materials = {{.name = "floor", .reflectance = {0.3, 0.3, 0.3}},
                       {.name = "wall", .reflectance = {0.7, 0.7, 0.7}},
                       {.name = "ceiling", .reflectance = {0.8, 0.8, 0.8}},
                       {.name = "furniture", .reflectance = {0.5, 0.4, 0.3}},
                       {.name = "light",
                        .reflectance = {0.0, 0.0, 0.0},
                        .emittance = {o.emittance, o.emittance, o.emittance}}};
    const double px = o.room_x + o.wall, py = o.room_y + o.wall;
    const double total_x = o.rooms_x * px + o.wall;
    auto surface = [&](std::string n, std::uint32_t material) -> visdb::Surface& {
        scene.surfaces.push_back(
            {.name = std::move(n), .layer = "", .material = material, .source = 0, .mesh = {}});
        return scene.surfaces.back();
    };

    // Walls along x at every room boundary line y = j·py (full length), and along y between
    // them; inner walls have one door per room they separate, at the room's middle
    const double half_door = 0.5 * o.door_width;
    for (int j = 0; j <= o.rooms_y; ++j) {
        std::vector<std::pair<double, double>> doors;
        if (j > 0 && j < o.rooms_y)
            for (int i = 0; i < o.rooms_x; ++i) {
                const double c = o.wall + i * px + 0.5 * o.room_x;
                doors.emplace_back(c - half_door, c + half_door);
            }
        visdb::Surface& s = surface("wall_x" + std::to_string(j), kWall);
        add_wall(s, 0, 0.0, total_x, j * py, o.wall, o.height, doors, o.door_height, o.cell);
    }
    for (int i = 0; i <= o.rooms_x; ++i)
        for (int j = 0; j < o.rooms_y; ++j) {
            std::vector<std::pair<double, double>> doors;
            const double y0 = o.wall + j * py;
            if (i > 0 && i < o.rooms_x)
                doors.emplace_back(y0 + 0.5 * o.room_y - half_door,
                                   y0 + 0.5 * o.room_y + half_door);
            visdb::Surface& s =
                surface("wall_y" + std::to_string(i) + "_" + std::to_string(j), kWall);
            add_wall(s, 1, y0, y0 + o.room_y, i * px, o.wall, o.height, doors, o.door_height,
                     o.cell);
        }
    // Door thresholds (the floor inside the openings)
    {
        visdb::Surface& s = surface("thresholds", kFloor);
        for (int j = 1; j < o.rooms_y; ++j)
            for (int i = 0; i < o.rooms_x; ++i) {
                const double c = o.wall + i * px + 0.5 * o.room_x;
                add_rect(s, {c - half_door, j * py, 0}, {o.door_width, 0, 0}, {0, o.wall, 0},
                         {0, 0, 1}, o.cell);
            }
        for (int i = 1; i < o.rooms_x; ++i)
            for (int j = 0; j < o.rooms_y; ++j) {
                const double c = o.wall + j * py + 0.5 * o.room_y;
                add_rect(s, {i * px, c - half_door, 0}, {o.wall, 0, 0}, {0, o.door_width, 0},
                         {0, 0, 1}, o.cell);
            }
        if (s.mesh.triangles.empty()) scene.surfaces.pop_back();
    }

    for (int j = 0; j < o.rooms_y; ++j)
        for (int i = 0; i < o.rooms_x; ++i) {
            const std::string room = "room_" + std::to_string(i) + "_" + std::to_string(j);
            const double x0 = o.wall + i * px, y0 = o.wall + j * py;
            add_rect(surface(room + "_floor", kFloor), {x0, y0, 0}, {o.room_x, 0, 0},
                     {0, o.room_y, 0}, {0, 0, 1}, o.cell);
            add_rect(surface(room + "_ceiling", kCeiling), {x0, y0, o.height}, {o.room_x, 0, 0},
                     {0, o.room_y, 0}, {0, 0, -1}, o.cell);
            if (o.furniture > 0) {
                // Slots on a 4 x 4 grid over the room's middle, away from the doors
                visdb::Surface& s = surface(room + "_furniture", kFurniture);
                for (int k = 0; k < o.furniture; ++k) {
                    const int slot = (k * 5) % 16, column = slot % 4, row = slot / 4;
                    const glm::dvec2 c{x0 + o.room_x * (0.2 + 0.2 * column),
                                       y0 + o.room_y * (0.2 + 0.2 * row)};
                    add_furniture(s, k, c, o.cell);
                }
            }
            if (o.lights > 0) {
                // Panels 0.6 m square, 5 mm below the ceiling, on a grid, facing down
                visdb::Surface& s = surface(room + "_lights", kLight);
                const int cols = static_cast<int>(std::ceil(std::sqrt(double(o.lights))));
                const int rows = (o.lights + cols - 1) / cols;
                for (int k = 0; k < o.lights; ++k) {
                    const int column = k % cols, row = k / cols;  // integer division
                    const double cx = x0 + o.room_x * (column + 0.5) / cols;
                    const double cy = y0 + o.room_y * (row + 0.5) / rows;
                    add_rect(s, {cx - 0.3, cy - 0.3, o.height - 0.005}, {0.6, 0, 0}, {0, 0.6, 0},
                             {0, 0, -1}, 1.0);
                }
            }
        }
    return scene;
}

FloorOptions floor_for_triangles(std::size_t triangles, int lights_per_room) {
    FloorOptions o;
    o.lights = lights_per_room;
    o.cell = 0.25;
    // Triangles per room, measured on a 2 x 2 floor; coarser cells while one room is too many
    double per_room = 0.0;
    for (;;) {
        FloorOptions probe = o;
        probe.rooms_x = probe.rooms_y = 2;
        per_room = double(generate_floor(probe).triangle_count()) / 4.0;
        if (per_room <= 1.3 * double(triangles) || o.cell >= 2.0) break;
        o.cell *= 1.5;
    }
    const double rooms = std::max(1.0, std::round(double(triangles) / per_room));
    o.rooms_x = std::clamp(static_cast<int>(std::round(std::sqrt(rooms))), 1, 1000);
    o.rooms_y = std::clamp(static_cast<int>(std::round(rooms / o.rooms_x)), 1, 1000);
    return o;
}

}  // namespace abrad::tools
