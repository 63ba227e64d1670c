#pragma once
// Import sanity: the model's size, floor area, and warnings for the mistakes that otherwise
// show only after a bake (a model in the wrong unit, the wrong up axis, a light buried in a
// wall). `abrad import` and `abrad info` print it.

#include <ostream>
#include <string>
#include <vector>

#include "abrad/visdb/model.h"

namespace abrad::tools::cli {

/// What the check found in a scene (abrad's frame: metres, Z up).
struct SceneCheck {
    glm::dvec3 lo{0.0}, hi{0.0};  ///< bounding box, metres (zero for an empty scene)
    double area = 0.0;            ///< all faces, m²
    double floor_area = 0.0;      ///< faces within 30° of facing up (+Z), m²
    /// The area-weighted median height from the up-facing faces to the first face straight
    /// above them, metres (0: no face has one).
    double storey = 0.0;
    /// One line each, with a suggested fix: size over 2 km or under 0.5 m, or (under 2 km) a
    /// storey height over 50 m (a centimetre house read as metres); less than 5 % of
    /// the area facing up, or every light facing sideways; a light whose emission is mostly
    /// (over half) stopped within 1 cm by opaque faces (opacity ≥ 0.5).
    std::vector<std::string> warnings;
};

/// Checks `scene`. The buried-light test casts 16 rays of 1 cm over the hemisphere in front
/// of 4 points of each emitter triangle (weighted by cos θ and area) against the faces near
/// it (a BVH over every triangle's box).
SceneCheck check_scene(const visdb::Scene& scene);

/// Prints the box, the size and the floor area, then each warning as
/// "abrad CMD: warning: ..." on `warn`.
void print_scene_check(const SceneCheck& check, const std::string& command, std::ostream& out,
                       std::ostream& warn);

}  // namespace abrad::tools::cli
