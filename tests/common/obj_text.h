#pragma once
// OBJ text for tests that write small models of their own.

#include <glm/vec3.hpp>
#include <sstream>
#include <string>

namespace abrad::testing {

/// OBJ text of the box [lo, hi] (faces facing out), its vertices numbered from `base` + 1.
inline std::string obj_box(const glm::dvec3& lo, const glm::dvec3& hi, int base) {
    std::ostringstream s;
    for (int k = 0; k < 8; ++k) {
        s << "v " << ((k & 1) != 0 ? hi.x : lo.x) << " " << ((k & 2) != 0 ? hi.y : lo.y) << " "
          << ((k & 4) != 0 ? hi.z : lo.z) << "\n";
    }
    const int faces[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                             {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
    for (const auto& f : faces) {
        s << "f";
        for (const int c : f) s << " " << base + c + 1;
        s << "\n";
    }
    return s.str();
}

}  // namespace abrad::testing
