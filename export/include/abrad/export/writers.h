#pragma once
// Writers for baked meshes: PLY (the contract in DESIGN.md) and OBJ with an MTL.
// Namespace `abrad::exporter` because `export` is a C++ keyword.

#include <array>
#include <cstdint>
#include <filesystem>
#include <stdexcept>
#include <string>

#include "abrad/visdb/model.h"

namespace abrad::exporter {

/// An error writing an output file; `what()` names the path.
class ExportError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

/// Maps linear radiosity (W/m²) to display values: v' = 1 - exp(-exposure * v), then sRGB.
struct ToneMap {
    double exposure = 1.0;  ///< 1 / (W/m²)
};

/// Exposure chosen so the 95th percentile of vertex radiosity luminance maps to 0.8.
ToneMap auto_tone_map(const visdb::BakeMesh& mesh);

/// Display colour of one radiosity value (8-bit sRGB).
std::array<std::uint8_t, 3> display_colour(const glm::vec3& radiosity, const ToneMap& tone);

struct PlyOptions {
    bool ascii = false;   ///< binary_little_endian when false
    std::string comment;  ///< written as a `comment` header line when not empty
};

/// Writes the PLY contract: vertex x y z (double), nx ny nz (float), red green blue (uchar),
/// irradiance_r/g/b and radiosity_r/g/b (float); face vertex_indices (list uchar int) and
/// surface (int).
void write_ply(const std::filesystem::path& path, const visdb::BakeMesh& mesh,
               const ToneMap& tone, const PlyOptions& options = {});

/// Writes `v x y z r g b`, `vn`, faces grouped by surface with `usemtl`, and an MTL beside it
/// (same stem, .mtl) with each used surface's material (Kd = ρ, Ke = E, d = α).
void write_obj(const std::filesystem::path& path, const visdb::Scene& scene,
               const visdb::BakeMesh& mesh, const ToneMap& tone);

}  // namespace abrad::exporter
