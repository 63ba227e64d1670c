#pragma once
// A luminaire shot as a point source: two opposite hemicubes at its photometric centre whose
// pixels carry the web's intensity times the pixel's solid angle instead of the delta form
// factors of a Lambertian patch (docs/algorithms.md#luminaires-as-point-sources).

#include <array>

#include "abrad/radiosity/hemicube.h"
#include "abrad/visdb/model.h"

namespace abrad::radiosity {

/// One hemicube of a point source: its frame (at the photometric centre) and its weighted
/// pixels.
struct PointShooter {
    ShooterFrame frame;
    Hemicube hemicube;
};

/// The two hemicubes (around the luminaire's axis_z and its opposite) that together see the
/// whole sphere around `luminaire`. Each pixel's weight is the fraction of the luminaire's
/// flux that leaves through it: I(ω)·Δω / Σ I·Δω over both hemicubes, so that the weights
/// sum to 1 (a shot's form factors are fractions of luminaire_power; what no patch stops
/// escapes). Weights are all 0 for a web without light.
std::array<PointShooter, 2> point_shooters(const visdb::Luminaire& luminaire, int resolution);

/// The luminaire's emitted power per channel (lm, or W in a radiometric scene): its web's
/// flux × flux_scale × maintenance_factor × colour.
visdb::Rgb luminaire_power(const visdb::Luminaire& luminaire);

}  // namespace abrad::radiosity
