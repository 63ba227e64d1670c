#pragma once
// Generated building floors for the benchmark and the scaling curve: a grid of rooms with
// thick walls, door openings, furniture and ceiling light panels, tessellated to a chosen
// cell size so the triangle count can grow from a few thousand to millions.

#include <cstddef>
#include <string>

#include "abrad/visdb/model.h"

namespace abrad::tools {

/// Parameters of a generated floor. Lengths in metres; the floor lies at z = 0, Z up.
struct FloorOptions {
    int rooms_x = 1, rooms_y = 1;                     ///< rooms along x and y (each >= 1)
    double room_x = 5.0, room_y = 4.0, height = 3.0;  ///< inner room size
    double wall = 0.1;  ///< wall thickness (walls are boxes: both faces receive)
    double door_width = 0.9, door_height = 2.1;  ///< one door in every inner wall
    double cell = 0.5;         ///< floor, ceiling and wall faces are cut into cells of this size
    int furniture = 2;         ///< pieces per room (tables, cabinets, chairs cycle), 0..16
    int lights = 1;            ///< ceiling panels per room (0.6 x 0.6 m, two triangles each), 0..16
    double emittance = 100.0;  ///< W/m² of every panel
};

/// Throws std::invalid_argument naming the field when a value is out of range.
void validate(const FloorOptions& options);

/// The floor as a scene: materials floor, wall, ceiling, furniture and light; one surface per
/// room and kind; one Source named after the parameters ("generated:...").
visdb::Scene generate_floor(const FloorOptions& options);

/// Options whose floor has about `triangles` triangles (within a factor of about 1.3), with
/// the given lights per room: grows rooms first at a 0.25 m cell, then refines the cell.
FloorOptions floor_for_triangles(std::size_t triangles, int lights_per_room = 1);

/// "3x2 rooms, cell 0.5 m, 2 furniture, 1 lights/room".
std::string to_string(const FloorOptions& options);

}  // namespace abrad::tools
