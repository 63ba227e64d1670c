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
/// Luminance Y = 0.2126 r + 0.7152 g + 0.0722 b; the percentile interpolates linearly between
/// the closest ranks (rank 0.95 (n - 1) of the sorted finite Y); exposure = -ln(0.2) / Y95.
/// An empty or all-dark mesh (Y95 <= 0) gets exposure 1.
ToneMap auto_tone_map(const visdb::BakeMesh& mesh);

/// Display colour of one radiosity value (8-bit sRGB): per channel v' = 1 - exp(-exposure
/// max(v, 0)) (NaN counts as 0), the sRGB transfer function, rounded to 0..255.
std::array<std::uint8_t, 3> display_colour(const glm::vec3& radiosity, const ToneMap& tone);

struct PlyOptions {
    bool ascii = false;   ///< binary_little_endian when false
    std::string comment;  ///< written as `comment` header lines (one per line) when not empty
};

/// Writes the PLY contract: vertex x y z (double), nx ny nz (float), red green blue (uchar),
/// irradiance_r/g/b and radiosity_r/g/b (float); face vertex_indices (list uchar int) and
/// surface (int). Binary is little endian on any host; ASCII numbers read back exactly.
/// Throws ExportError naming `path` when the mesh is inconsistent (array lengths, indices out
/// of range) or the file cannot be written ("PATH: cannot write: ..."). Writes `PATH.tmp`
/// and renames it, so a failure leaves no partial file at `path`.
void write_ply(const std::filesystem::path& path, const visdb::BakeMesh& mesh,
               const ToneMap& tone, const PlyOptions& options = {});

/// Writes `v x y z r g b`, `vn`, faces grouped by surface with `usemtl`, and an MTL beside it
/// (same stem, .mtl) with each used surface's material (Kd = ρ, Ke = E, d = α). Display
/// colours are tone-mapped radiosity as 0..1 with 4 decimals; `o`/`usemtl` names have
/// whitespace replaced by `_`. Throws ExportError naming `path` on an inconsistent mesh, a
/// surface or material id out of range of `scene`, or an I/O failure; both files are written
/// to `.tmp` first and renamed.
void write_obj(const std::filesystem::path& path, const visdb::Scene& scene,
               const visdb::BakeMesh& mesh, const ToneMap& tone);

}  // namespace abrad::exporter
