#pragma once
// The field error (docs/algorithms.md#field-error): the Gouraud-interpolated irradiance of a
// baked mesh against the exact irradiance at points inside its triangles, area-weighted
// relative L1 over all receivers.

#include <cstddef>
#include <cstdint>
#include <functional>
#include <glm/vec3.hpp>
#include <vector>

#include "abrad/radiosity/stage.h"
#include "abrad/visdb/model.h"

namespace abrad::radiosity {

/// The exact irradiance (W/m², per channel) at a point with a unit normal.
using IrradianceFn = std::function<visdb::Rgb(const glm::dvec3& x, const glm::dvec3& n)>;

struct FieldErrorOptions {
    int subdivisions = 3;  ///< each triangle is sampled at the centroids of its k² sub-triangles
};

/// One receiver surface's share of the field error.
struct SurfaceFieldError {
    std::uint32_t surface = 0;  ///< index in scene.surfaces
    double error = 0.0;         ///< Σ A·mean|interpolated − exact| over its triangles, W
    double exact = 0.0;         ///< Σ A·mean|exact| over its triangles, W
    double area_m2 = 0.0;
    std::size_t triangles = 0;
};

struct FieldError {
    double relative_l1 = 0.0;  ///< Σ A·mean|interpolated − exact| / Σ A·mean|exact| (channel mean)
    double absolute_l1 = 0.0;   ///< Σ A·mean|interpolated − exact| / Σ A, W/m²
    double mean_exact = 0.0;    ///< Σ A·mean(exact) / Σ A, W/m²
    double area_m2 = 0.0;       ///< receiver area measured
    std::size_t triangles = 0;  ///< receiver triangles measured
    std::size_t samples = 0;    ///< points evaluated
    /// Per receiver surface with measured triangles, by surface index: the share of the
    /// whole is error / (the sum of every surface's exact), its own error error / exact.
    std::vector<SurfaceFieldError> surfaces;
};

/// Measures `mesh` (its `irradiance` per vertex) against `exact` over every triangle whose
/// surface is a receiver (reflectance > 0 and no emittance in `scene`). Each triangle's
/// normal is its geometric one (counter-clockwise front). Parallel over triangles; `exact`
/// must be safe to call concurrently. Throws InputError (stage.h) for a mesh without
/// irradiance or with a surface index outside `scene`.
FieldError field_error(const visdb::Scene& scene, const visdb::BakeMesh& mesh,
                       const IrradianceFn& exact, const FieldErrorOptions& options = {});

}  // namespace abrad::radiosity
