// Luminaires shot as point sources: hemicubes weighted by the photometric web.

#include "abrad/radiosity/point_source.h"

#include <glm/geometric.hpp>

namespace abrad::radiosity {

std::array<PointShooter, 2> point_shooters(const visdb::Luminaire& luminaire, int resolution) {
    // Intensity toward a direction of each frame's local coordinates (the web's own, unscaled)
    auto make = [&](const glm::dvec3& axis) {
        const ShooterFrame frame = ShooterFrame::at(luminaire.position, axis);
        return PointShooter{frame, Hemicube(resolution, [&](const glm::dvec3& local) {
                                const glm::dvec3 world =
                                    local.x * frame.u + local.y * frame.v + local.z * frame.n;
                                return luminaire.web.intensity(luminaire.to_local(world));
                            })};
    };
    std::array<PointShooter, 2> out{make(luminaire.axis_z), make(-luminaire.axis_z)};
    // Normalize: the pixels' weights are fractions of the flux the hemicubes see
    double total = 0.0;
    for (const PointShooter& s : out)
        for (const double w : s.hemicube.deltas()) total += w;
    if (total > 0.0)
        for (PointShooter& s : out) s.hemicube.scale(1.0 / total);
    return out;
}

visdb::Rgb luminaire_power(const visdb::Luminaire& luminaire) {
    return luminaire.color * luminaire.flux();
}

}  // namespace abrad::radiosity
