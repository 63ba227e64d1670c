#pragma once
// Writers for baked meshes: PLY (the contract in docs/design.md#exported-ply-contract),
// OBJ with an MTL, POV-Ray scenes and glTF.
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

/// The tone curve on one linear value: 1 - exp(-exposure max(v, 0)) (NaN counts as 0), in
/// [0, 1), still linear (sRGB-encode it for display). Every image path uses it: PLY/OBJ/glTF
/// colours per vertex, `abrad render` and `abrad compare` per pixel.
double tone_value(double radiosity, const ToneMap& tone);

/// Display colour of one radiosity value (8-bit sRGB): per channel v' = 1 - exp(-exposure
/// max(v, 0)) (NaN counts as 0), the sRGB transfer function, rounded to 0..255.
std::array<std::uint8_t, 3> display_colour(const glm::vec3& radiosity, const ToneMap& tone);

/// The axis that points up in a written file. abrad's frame is Z up; `Y` writes abrad's
/// (x, y, z) as (x, z, -y), a rotation (positions and normals alike), as glTF and OBJ
/// viewers expect.
enum class UpAxis { Z, Y };

/// The type of PLY vertex positions.
enum class PlyPositions {
    Double,  ///< absolute, metres (the contract)
    Float,   ///< relative to the origin in the header's `comment origin X Y Z` line (metres, in
             ///< the file's frame): visdb::local_origin of the mesh, zero unless the model lies
             ///< 1 km or more from the origin. What web loaders (three.js) read.
};

/// Where a PLY carries each triangle's surface id.
enum class PlySurfaceIds {
    Face,    ///< `property int surface` of the face element, after vertex_indices (the contract)
    Vertex,  ///< `property int surface` as the vertex element's last property instead (bake
             ///< vertices are not shared across surfaces), the face element holding
             ///< vertex_indices only: what readers that take a face element's properties one
             ///< after the other for all faces, such as meshio 5's binary reader, can read.
};

struct PlyOptions {
    bool ascii = false;   ///< binary_little_endian when false
    std::string comment;  ///< written as `comment` header lines (one per line) when not empty
    UpAxis up = UpAxis::Z;
    PlyPositions positions = PlyPositions::Double;
    PlySurfaceIds surface_ids = PlySurfaceIds::Face;
};

struct ObjOptions {
    UpAxis up = UpAxis::Y;  ///< OBJ's convention (Blender, three.js and MeshLab import Y up)
};

/// Writes the PLY contract: vertex x y z (double), nx ny nz (float), red green blue (uchar),
/// irradiance_r/g/b and radiosity_r/g/b (float); face vertex_indices (list uchar int) and
/// surface (int). Binary is little endian on any host; ASCII numbers read back exactly.
/// `options.positions` Float writes x y z as float relative to a `comment origin` line, and
/// `options.up` Y turns the model Y up. `options.surface_ids` Vertex moves `surface` to the
/// vertices (a vertex no triangle uses gets -1).
/// Throws ExportError naming `path` when the mesh is inconsistent (array lengths, indices out
/// of range; with surface ids on vertices, a vertex shared by two surfaces) or the file cannot
/// be written ("PATH: cannot write: ..."). Writes a temporary
/// beside `path` and renames it (abrad/atomic_file.h), so a failure leaves no partial file.
void write_ply(const std::filesystem::path& path, const visdb::BakeMesh& mesh, const ToneMap& tone,
               const PlyOptions& options = {});

/// Writes `v x y z r g b`, `vn`, faces grouped by surface with `usemtl`, and an MTL beside it
/// (same stem, .mtl) with a material per used scene material that shows the bake: white
/// (`Kd 1 1 1`), no ambient or specular, unlit (`illum 0`), `d` = α, so a viewer that reads
/// the vertex colours shows them as they are; the material's ρ, E and α are in a comment line
/// (`# abrad material: Kd ρ Ke E d α`). Y up by default (`options.up`, OBJ's convention).
/// Display colours are tone-mapped radiosity as 0..1 with 4 decimals; `o`/`usemtl` names have
/// whitespace replaced by `_`. Throws ExportError naming `path` on an inconsistent mesh, a
/// surface or material id out of range of `scene`, or an I/O failure; both files are written
/// to temporaries first and renamed (abrad/atomic_file.h).
void write_obj(const std::filesystem::path& path, const visdb::Scene& scene,
               const visdb::BakeMesh& mesh, const ToneMap& tone, const ObjOptions& options = {});

/// What the POV-Ray exports look through and how bright they are.
struct PovView {
    visdb::Camera camera;  ///< see select_camera() (render.h)
    int width = 640;       ///< the image size the camera's aspect ratio is set for
    int height = 480;
    double exposure = 1.0;  ///< default of `Abrad_Exposure`: image value = exposure × B
    /// `pov` only: write the tone curve's display values 1 - exp(-exposure B) (tone_value) as
    /// the vertex colours, for an 8-bit PNG that looks like `abrad render`'s, instead of the
    /// linear exposure × B for OpenEXR.
    bool tone_mapped = false;
};

/// Writes the bake as POV-Ray 3.7 source: one `mesh2` per surface (vertices relative to an
/// origin near the mesh's centre, written as the shortest text that reads back as the same
/// float, plus a `translate`), a `texture_list` with each vertex's radiosity B as pigment and
/// `finish { ambient 0 diffuse 0 emission Abrad_Exposure }`, so POV-Ray shows the bake
/// Gouraud-interpolated and unlit, on the front of each face (the bake shades fronts only:
/// backs get a black `interior_texture`, the winding written reversed because POV-Ray's front
/// is left-handed); `camera` from `view`, no lights, black background.
/// `Abrad_Exposure` is declared only when not already defined (override it with
/// `Declare=Abrad_Exposure=1` on the povray command line for absolute values). Render to
/// OpenEXR (`+FE`) for linear values; a PNG clips them at 1. With `view.tone_mapped` the
/// colours are the tone curve's display values instead (tone_value with `view.exposure`,
/// Gouraud-interpolated between vertices), shown with `emission 1`, no `Abrad_Exposure`, for a
/// PNG (`+FN`; POV-Ray sRGB-encodes it). Throws ExportError naming `path` on an inconsistent
/// mesh or an I/O failure (written to a temporary and renamed).
void write_pov(const std::filesystem::path& path, const visdb::Scene& scene,
               const visdb::BakeMesh& mesh, const PovView& view);

/// POV-Ray radiosity settings of the reference scene.
enum class PovQuality { Low, Medium, High };

struct PovReferenceOptions {
    PovView view;
    /// Point lights sampling all emitters together (each emitter triangle gets k² of them,
    /// k = max(1, round(sqrt(light_samples × its share of the emitting area)))).
    int light_samples = 256;
    /// POV-Ray radiosity recursion limit: 0 = off (direct light only, to compare with a
    /// `--bounces 0` bake), 1..20 = that many diffuse bounces.
    int bounces = 0;
    PovQuality quality = PovQuality::Medium;  ///< radiosity count / error_bound / pretrace
};

/// Writes the scene lit by POV-Ray itself (the reference renderer's view of the same model):
/// each surface a `mesh2` with `pigment { rgb ρ transmit 1-α } finish { ambient 0 diffuse 1 }`;
/// each emitter drawn with its emittance E as emission on its front (its back black, as in the
/// `pov` export; `no_shadow`, `no_radiosity`) and
/// sampled by point lights: every emitter triangle is cut into k² equal sub-triangles, each a
/// `spotlight` at its centroid (1 mm in front) pointing along the normal with `tightness 1`
/// (intensity ∝ cos θ, a Lambertian emitter's falloff), `fade_power 2` and a `fade_distance`
/// of 0.1 mm (attenuation 2 F² / d² to within (F/d)²), and colour E dA / (2 π F²) × exposure,
/// so a surface of reflectance ρ shows exposure × ρ H as in the bake. bounces > 0 turns on
/// POV-Ray radiosity. Throws ExportError naming `path` on I/O failure or a surface or
/// material id out of range.
void write_pov_reference(const std::filesystem::path& path, const visdb::Scene& scene,
                         const PovReferenceOptions& options);

/// Writes the bake as glTF 2.0 (`.gltf` with the buffer embedded as a data URI, or binary
/// `.glb`, by the extension): one mesh per surface, its one primitive with accessors of its own
/// vertices only (the bake's vertices it uses, in their order; indices unsigned short below
/// 65,535 vertices, else unsigned int), so a viewer uploads every vertex once: POSITION (float,
/// metres, relative to the root node's translation, visdb::local_origin of the mesh), NORMAL,
/// COLOR_0 (the tone-mapped radiosity 1 - exp(-exposure B), linear float RGB as glTF requires) and
/// the application attributes _IRRADIANCE and _RADIOSITY (float RGB, W/m² or lux); materials are
/// `KHR_materials_unlit` with base colour white and single-sided (a bake shades fronts only), so
/// viewers show the bake as is. Y up as glTF requires: abrad's (x, y, z) is written as (x, z, -y).
/// Material and surface names that are not valid UTF-8 (JSON's encoding) are read as Windows-1252
/// (to_utf8 in text.h); returns how many were. Throws ExportError naming `path` on an inconsistent
/// mesh or a write failure.
std::size_t write_gltf(const std::filesystem::path& path, const visdb::Scene& scene,
                       const visdb::BakeMesh& mesh, const ToneMap& tone);

}  // namespace abrad::exporter
