#pragma once
// Scenes shared by the exporter tests.

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

}  // namespace abrad::testing
