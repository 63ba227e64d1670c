#pragma once
// The range of a material's numbers, checked by the importers and by the bake (a damaged or
// edited database): emittance finite and bounded, reflectance below 1, opacity in [0, 1].

#include <string>

#include "abrad/visdb/model.h"

namespace abrad::visdb {

/// Largest emittance a material may have, per channel (W/m² or lm/m²): about 160 times the
/// sun's surface (6.3e7 W/m²). Larger values (1e300 from a damaged file) overflowed the bake
/// to inf/NaN; importers and the bake refuse them.
inline constexpr double kMaxEmittance = 1e10;

/// What is wrong with `m`'s numbers, or "" when nothing is: every channel of E finite and in
/// [0, kMaxEmittance], of ρ in [0, 1), α in [0, 1] (NaN fails every test).
inline std::string material_problem(const Material& m) {
    const auto fmt = [](const Rgb& c) {
        return "(" + std::to_string(c.x) + ", " + std::to_string(c.y) + ", " + std::to_string(c.z) +
               ")";
    };
    for (int k = 0; k < 3; ++k) {
        if (!(m.emittance[k] >= 0.0 && m.emittance[k] <= kMaxEmittance))
            return "emittance " + fmt(m.emittance) + " is not in [0, 1e10]";
    }
    for (int k = 0; k < 3; ++k) {
        if (!(m.reflectance[k] >= 0.0 && m.reflectance[k] < 1.0))
            return "reflectance " + fmt(m.reflectance) + " is not in [0, 1)";
    }
    if (!(m.opacity >= 0.0 && m.opacity <= 1.0))
        return "opacity " + std::to_string(m.opacity) + " is not in [0, 1]";
    return "";
}

}  // namespace abrad::visdb
