#pragma once
// The scene file (`--scene scene.toml`): import settings, material and light rules by object,
// layer or material name, emitter rectangles, cameras, exclusions and calculation grids for
// models whose formats carry no usable lights or materials (DXF, IFC, 3DS...).
//
// ---------------------------------------------------------------------------------------------
// Format (TOML 1.0). Every key below is optional unless marked "required"; every other key, at
// any level, is an error naming the file, line and key. Numbers may be written as integers or
// decimals; NaN and infinity are rejected.
//
//   unit = "mm"          # mm|cm|m|in|ft: the models' unit (the command line --unit wins)
//   up = "y"             # y|z: the models' up axis (the command line --up wins)
//   origin_shift = [2500000.0, 1200000.0, 0.0]
//                        # metres, subtracted from every position after unit/axis conversion
//   weld_tolerance = 1e-6
//                        # >= 0, fraction of each model's bounding-box diagonal
//   photometric = true   # emittances are lm/m², fluxes lm, results lux. Default: true iff some
//                        # rule or emitter gives a flux. `false` together with a flux is an error.
//                        # In photometric mode every emittance, including those the model files
//                        # gave (OBJ Ke...), is read as lm/m² (a note says so).
//
//   [[rule]]             # set material properties on the surfaces it matches
//   object = "Wand*"     # glob on the surface's object name        } conditions: globs
//   layer = "IfcWall"    # glob on the surface's CAD layer          } (fnmatch * ? [...]),
//   material = "Conc*"   # glob on the material name the model gave } case-insensitive, ANDed;
//                        #                                            at least one is required
//   reflectance = 0.6    # ρ: a number (grey) or [r, g, b], each in [0, 0.999]
//   opacity = 1.0        # α in [0, 1] (1 = opaque)
//   emittance = 50.0     # E: a number (grey) or [r, g, b] >= 0, W/m² (lm/m² when photometric)
//   flux = 3000.0        # Φ >= 0, lumens per luminaire; implies photometric. A luminaire is the
//                        # set of surfaces this rule matches that share one object name:
//                        # E = Φ / (their total triangle area) · color. Not with `emittance`.
//   color = [1.0, 0.9, 0.8]
//                        # only with flux: relative colour, each >= 0, scaled to luminance 1
//                        # (Rec. 709: Y = 0.2126 R + 0.7152 G + 0.0722 B)
//   group = "office"     # only with emittance or flux: the light group of the surfaces it
//                        # lights (light scenes, --scene-mix); a non-empty name without ',' or
//                        # '='. Default "emitters". Also on [[emitter]] (objects or rectangles).
//   A rule needs at least one of reflectance, opacity, emittance, flux. Rules (and emitters that
//   match objects) apply in file order; a later one overrides an earlier one per property
//   (emittance and flux are the same property). Surfaces that share a material but end with
//   different properties get their own copy, named "NAME [rule line N]"; a material whose every
//   surface ends the same is changed in place. Materials left without surfaces are dropped.
//
//   [[emitter]]          # light named objects: conditions as in a rule (at least one),
//   object = "Lamp*"     # plus emittance or flux (required, one of them), color with flux
//   flux = 1200.0
//
//   [[emitter]]          # or a new rectangle (metres, Z up, after the origin shift)
//   name = "panel-1"     # required: the new surface's object name and its material's name
//   center = [3.0, 2.5, 2.99]   # required
//   size = [1.2, 0.3]    # required, > 0: width along `axis`, height along normal × axis
//   normal = [0, 0, -1]  # required, non-zero: the rectangle emits toward this side (its front)
//   axis = [1, 0, 0]     # projected into the plane, not parallel to normal. Default: world X
//                        # projected into the plane (world Y when the normal is along X)
//   flux = 3000.0        # or emittance (required, one of them); color with flux
//   The rectangle becomes a surface of two triangles, front facing `normal`, with a material
//   of reflectance 0, opacity 1 and the emittance (E = Φ / (width · height) · color).
//
//   [[luminaire]]        # luminaires from photometric files (implies photometric)
//   file = "downlight.ies"      # required: .ies (IES LM-63) or .ldt (EULUMDAT), relative to the
//                        # scene file's folder and inside it (unless --allow-outside-refs)
//   name = "DL"          # unique among the luminaires; default the file's stem and the line
//   position = [3.0, 2.0, 2.8]  # the photometric centre, metres (after the shift);
//                        # required unless object/layer place it (below)
//   rotation = [0, 30, 90]      # degrees about world x, then y, then z (R = Rz Ry Rx), taking
//                        # the photometric frame (x = C0, z up, light toward -z) to the world
//   target = [3.0, 2.0, 0.0]    # or: aim the nadir (γ = 0) at this point; the C0 axis then
//                        # lies along world x projected (world y when aiming along x).
//                        # Default: no rotation (a downlight hangs facing down).
//   count = 4            # >= 1: a row of luminaires position + i·step, named "NAME 1".."NAME 4"
//   step = [1.5, 0, 0]   # metres, required with count > 1
//   flux_scale = 1.0     # > 0: multiplies every candela (another lamp, dimming)
//   maintenance_factor = 0.8    # in (0, 1], default 1: multiplies every candela
//   color = [1.0, 0.9, 0.8]     # relative colour, each >= 0, scaled to luminance 1
//   opening = "point"    # file (default: the file's luminous opening) | point | rectangle |
//   opening_size = [1.2, 0.3]   # disc; rectangle and disc need opening_size = [length, width]
//                        # (metres, along the luminaire's x and y)
//   group = "corridor"   # its light group (as in a rule); default the photometric file's stem
//   object = "Leuchte*"  # instead of `position`: one luminaire per instance of the surfaces
//   layer = "LIGHTS"     # these globs match (as in a rule, ANDed; at least one), matched
//                        # against the surfaces as imported (before exclusions). An instance:
//                        # the matched surfaces are grouped by object name; within one object,
//                        # triangles sharing a vertex form a piece, and pieces whose bounding
//                        # boxes intersect (touching counts) are one instance. So a DXF block
//                        # INSERTed on a layer (one mesh to Assimp), an IFC light fixture
//                        # (IFC2X3: an IfcFlowTerminal; object: its Name, layer: its entity
//                        # type "IfcFlowTerminal") and an OBJ group each give one. A glob that
//                        # matches no surface is an error naming its line and key.
//   instances = "pieces" # or "objects": one luminaire per object name, however many pieces
//   mounting = "center"  # the instance's reference point: "center", its bounding-box centre
//                        # (a bare lamp, a panel); or "surface", where the aim from that centre
//                        # leaves the box (the underside's centre for a downlight: recessed,
//                        # surface-mounted and pendant luminaires emit through it)
//   keep_geometry = false       # false (default): the matched surfaces are removed, so the
//                        # luminaire's own faces neither shadow it nor take its light; true:
//                        # kept as they are (a housing, lit and shadowing, not emitting)
//   With object/layer, `rotation` turns every instance alike, `target` aims each one's nadir
//   from its reference point at the point, neither hangs it straight down; `count`, `step` and
//   `position` are errors. Instances are named "NAME 1".."NAME n" ("NAME" alone for one), in
//   order of object name, then x, y, z of the reference point.
//   A TILT=INCLUDE file's lamp-tilt factor at the luminaire's tilt (its nadir's angle from
//   straight down) multiplies every candela; a factor 0 there is an error at the table's line.
//   A malformed photometric file is an ImportError naming that file, its line and field.
//
//   [[camera]]
//   name = "entrance"    # required, unique among the scene's cameras
//   position = [1, 1, 1.6]      # required, metres
//   look_at = [5, 4, 1.2]       # required, != position
//   up = [0, 0, 1]       # default [0, 0, 1]; not parallel to the view direction
//   fov = 60.0           # full vertical field of view, degrees, in (0, 180); default 60
//
//   [[exclude]]          # remove the surfaces it matches; conditions as in a rule (at least
//   layer = "IfcSpace"   # one). Excluding every surface is an error.
//
//   [[grid]]             # a calculation grid (horizontal work plane facing up)
//   name = "office work plane"  # required, unique among the scene's grids
//   over = "Floor*"      # object glob: the grid covers the x-y bounding box of these surfaces
//                        # (matched before exclusions, so hidden IfcSpace volumes may serve),
//                        # at z = their lowest z + height
//   min = [0.0, 0.0]     # or, without `over`: the rectangle [min, max] in metres (both
//   max = [6.0, 4.0]     # required, min < max) at z = height
//   height = 0.8         # over: above the lowest z, default 0.8; min/max: absolute, required
//   spacing = 0.5        # > 0, metres between points; default 0.5
//   margin = 0.5         # >= 0, inset from each side of the rectangle; default 0. A margin
//                        # that leaves nothing is an error.
//
// A rule, emitter, exclusion or grid `over` that matches no surface gives a note
// "FILE:LINE: rule matches no surface (object 'X', layer 'Y')", not an error (a grid is then
// skipped); a [[luminaire]]'s object or layer that matches none is an error, at that key.
// Syntax errors, wrong types and out-of-range values are ImportErrors "FILE:LINE: ...".
// ---------------------------------------------------------------------------------------------

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <optional>
#include <string>
#include <vector>

#include "abrad/convert/obj_import.h"
#include "abrad/visdb/model.h"

namespace abrad::convert {

/// The conditions of a rule, emitter or exclusion: case-insensitive globs, ANDed; an unset
/// condition matches everything (at least one is set in a parsed file).
struct SurfaceMatch {
    std::optional<std::string> object;    ///< glob on Surface::name
    std::optional<std::string> layer;     ///< glob on Surface::layer
    std::optional<std::string> material;  ///< glob on the name of the surface's model material

    /// True when the surface (with its model material's name) meets every set condition.
    bool matches(const visdb::Surface& surface, const std::string& material_name) const;
    /// "object 'Wand*', layer 'IfcWall'" (only the set conditions).
    std::string to_string() const;
};

/// A [[rule]], or an [[emitter]] that lights named objects (`is_emitter`). Properties left
/// unset keep the surface's value.
struct SceneRule {
    std::size_t line = 0;     ///< line of the table header
    bool is_emitter = false;  ///< from [[emitter]] (needs emittance or flux)
    SurfaceMatch match;
    std::optional<visdb::Rgb> reflectance;  ///< each in [0, 0.999]
    std::optional<double> opacity;          ///< [0, 1]
    std::optional<visdb::Rgb> emittance;    ///< >= 0, W/m² (lm/m² when photometric)
    std::optional<double> flux;             ///< >= 0, lm per luminaire
    visdb::Rgb color{1.0, 1.0, 1.0};        ///< with flux: relative colour of luminance 1
    std::optional<std::string> group;       ///< light group of the matched emitters

    std::string to_string() const;
};

/// An [[emitter]] rectangle: a new emitting surface (metres, Z up, after the origin shift).
struct SceneRectangle {
    std::size_t line = 0;
    std::string name;
    glm::dvec3 center{0.0};
    glm::dvec2 size{0.0};                 ///< width along `axis`, height along normal × axis
    glm::dvec3 normal{0.0, 0.0, 1.0};     ///< unit; the front (emitting) side
    glm::dvec3 axis{1.0, 0.0, 0.0};       ///< unit, perpendicular to `normal` (resolved)
    std::optional<visdb::Rgb> emittance;  ///< set iff `flux` is not
    std::optional<double> flux;           ///< lm
    visdb::Rgb color{1.0, 1.0, 1.0};      ///< with flux: relative colour of luminance 1
    std::string group;                    ///< light group ("" = the default, "emitters")

    /// E: the emittance, or Φ / (width · height) · color.
    visdb::Rgb exitance() const;
    /// Two counter-clockwise triangles seen from the front: corners center ∓ axis·w/2
    /// ∓ (normal × axis)·h/2.
    visdb::TriangleMesh mesh() const;
    std::string to_string() const;
};

/// A [[camera]].
struct SceneCamera {
    std::size_t line = 0;
    visdb::Camera camera;
};

/// An [[exclude]].
struct SceneExclude {
    std::size_t line = 0;
    SurfaceMatch match;
};

/// A [[grid]] as written; resolved against the scene by apply_scene_file.
struct SceneGrid {
    std::size_t line = 0;
    std::string name;
    std::optional<std::string> over;  ///< object glob; when unset, `min`/`max` hold the rectangle
    glm::dvec2 min{0.0};              ///< metres (without `over`)
    glm::dvec2 max{0.0};
    double height = 0.8;   ///< over: above the lowest z; else the absolute z
    double spacing = 0.5;  ///< > 0
    double margin = 0.0;   ///< >= 0

    std::string to_string() const;
};

/// A [[luminaire]] (one of its `count`): the photometric file read and the frame resolved.
struct SceneLuminaire {
    std::size_t line = 0;
    visdb::Luminaire luminaire;
    std::string flux_report;  ///< the file's flux against its lamps (PhotometricFile::flux_report)

    std::string to_string() const;
};

/// A [[luminaire]] placed by the model (`object`/`layer` instead of `position`): resolved
/// against the scene's surfaces by apply_scene_file, one luminaire per instance.
struct SceneLuminairePlacement {
    /// Where an instance's luminaire goes: its bounding-box centre, or where the aim from there
    /// leaves the box.
    enum class Mounting { Center, Surface };

    std::size_t line = 0;        ///< line of the table header
    std::size_t match_line = 0;  ///< line of its `object` key, else of its `layer` key
    std::string match_key;       ///< "object" or "layer": the key at match_line
    SurfaceMatch match;          ///< object and/or layer globs (no material)
    bool per_object = false;     ///< instances = "objects"
    Mounting mounting = Mounting::Center;
    bool keep_geometry = false;
    /// The luminaire every instance copies: web, factors, opening, colour, group, and the frame
    /// of `rotation` (or unturned); its name is the base name, its position unset.
    visdb::Luminaire luminaire;
    std::optional<glm::dvec3> target;  ///< aim each instance's nadir at this point
    std::string flux_report;           ///< PhotometricFile::flux_report
    /// TILT=INCLUDE table (PhotometricFile::tilt_angles/tilt_factors): the tilt factor of an
    /// aimed instance depends on its aim. Empty without a table.
    std::vector<double> tilt_angles;
    std::vector<double> tilt_factors;

    std::string to_string() const;
};

/// One instance found for a SceneLuminairePlacement (placed_instances).
struct LuminaireInstance {
    std::string object;   ///< Surface::name of its surfaces
    glm::dvec3 min{0.0};  ///< bounding box of its triangles, metres
    glm::dvec3 max{0.0};
    std::vector<std::size_t> surfaces;  ///< indices into Scene::surfaces holding its triangles
    std::size_t triangles = 0;
};

/// The instances of `placement` among `scene`'s surfaces (see the format above), in the order
/// luminaires are named: object name, then the bounding-box centre's x, y, z. Empty when its
/// globs match no surface.
std::vector<LuminaireInstance> placed_instances(const SceneLuminairePlacement& placement,
                                                const visdb::Scene& scene);

/// A parsed and validated scene file. Sections keep file order; each carries the line of its
/// table header for messages.
struct SceneFile {
    std::string path;      ///< as given, for messages and the visdb::Source
    std::string checksum;  ///< FNV-1a 64 of the file's bytes, 16 hex digits
    std::uint64_t size_bytes = 0;

    std::optional<std::string> unit;         ///< mm, cm, m, in or ft
    std::optional<char> up;                  ///< 'y' or 'z'
    std::optional<glm::dvec3> origin_shift;  ///< metres
    std::optional<double> weld_tolerance;    ///< >= 0
    std::optional<bool> photometric;         ///< as written

    std::vector<SceneRule> rules;  ///< [[rule]] and object-matching [[emitter]], in file order
    std::vector<SceneRectangle> rectangles;  ///< [[emitter]] rectangles
    std::vector<SceneCamera> cameras;
    std::vector<SceneExclude> excludes;
    std::vector<SceneGrid> grids;
    std::vector<SceneLuminaire> luminaires;  ///< [[luminaire]], each of a count on its own
    /// [[luminaire]] tables placed by the model (object/layer), in file order
    std::vector<SceneLuminairePlacement> placements;

    /// True when some rule or rectangle gives a flux, or the file places luminaires.
    bool uses_flux() const;
    /// `photometric` as written, else uses_flux().
    bool is_photometric() const;
    /// One line per setting and section, for logs and test failures.
    std::string to_string() const;
};

/// Reads and validates a scene file (format above) and the photometric files it names. Throws
/// ImportError "FILE:LINE: message" on a missing file, a TOML syntax error, an unknown key
/// (named with the allowed keys), a wrong type or an out-of-range value, a photometric file
/// outside the scene file's folder (unless `allow_outside_refs`), or a malformed one.
SceneFile read_scene_file(const std::filesystem::path& path, bool allow_outside_refs = false);

/// Copies the settings the scene file sets (unit, up, origin_shift, weld_tolerance) into
/// `options`, leaving the others as they are. The command line applies its own afterwards.
void apply_import_settings(const SceneFile& file, ImportOptions& options);

/// What apply_scene_file did.
struct SceneFileReport {
    std::vector<std::string> notes;  ///< "FILE:LINE: ..." (unmatched rules, splits, exclusions)
    std::size_t surfaces_excluded = 0;
    std::size_t materials_overridden = 0;  ///< materials changed in place or split off
    std::size_t emitters_added = 0;        ///< rectangles + luminaires lit by object [[emitter]]s
    std::size_t cameras = 0;               ///< cameras added
    std::size_t grids = 0;                 ///< grids added
    std::size_t luminaires = 0;            ///< luminaires added (placed by the model too)

    std::string to_string() const;
};

/// Applies the scene file to the merged, healed scene (metres, Z up, origin shift applied):
/// resolves grids (against the surfaces before exclusions), removes excluded surfaces, applies
/// rules and object emitters in file order, adds emitter rectangles, cameras, grids and
/// luminaires (a note each with its flux against its lamps; luminaires placed by the model at
/// their instances, whose surfaces are removed unless keep_geometry), and
/// sets `emittance_unit` to "lm/m2" when photometric ("W/m2" when `photometric = false`).
/// Appends the scene file as a visdb::Source (format "scene", unit "m", up "z", its report);
/// rectangles belong to that source. Throws ImportError "FILE:LINE: message" for a rule that
/// cannot apply (a flux luminaire of zero area, every surface excluded, a duplicate camera,
/// grid or luminaire name, a grid margin that leaves nothing, a luminaire's object or layer
/// glob that matches no surface, or an aimed instance whose tilt factor is 0); the scene is then
/// unchanged.
SceneFileReport apply_scene_file(const SceneFile& file, visdb::Scene& scene);

}  // namespace abrad::convert
