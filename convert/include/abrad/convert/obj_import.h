#pragma once
// Wavefront OBJ/MTL import into the visdb scene model, with reported healing.

#include <cstddef>
#include <filesystem>
#include <glm/vec3.hpp>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "abrad/visdb/model.h"

namespace abrad::convert {

/// Bad input: `what()` is "FILE:LINE: message" (LINE omitted when it does not apply).
class ImportError : public std::runtime_error {
  public:
    ImportError(std::string file, std::size_t line, const std::string& message);
    const std::string& file() const { return m_file; }
    std::size_t line() const { return m_line; }  ///< 1-based; 0 when not tied to a line

  private:
    std::string m_file;
    std::size_t m_line;
};

/// How to bring a file into the internal frame (metres, Z up).
struct ImportOptions {
    /// One of mm, cm, m, in, ft; empty: the unit the file declares (Assimp formats that carry
    /// one), else metres.
    std::string unit;
    /// 'y' rotates a Y-up file to Z up: (x, y, z) -> (x, -z, y); 'z' keeps it; 0: the format's
    /// convention (glTF is Y up; Collada and FBX say in the file; OBJ and the CAD formats are
    /// taken as Z up).
    char up = 0;
    /// Subtracted from every position after unit and axis conversion (metres, Z up): brings
    /// survey coordinates near the origin. The scene file's `origin_shift`.
    glm::dvec3 origin_shift{0.0};
    /// Vertices closer than this fraction of the model's bounding-box diagonal are welded.
    double weld_tolerance = 1e-6;
    /// Files a model refers to (an OBJ's `mtllib`) must be inside
    /// the model's folder tree, else the import fails; true reads them wherever they are.
    bool allow_outside_refs = false;
};

/// Metres per unit for "mm", "cm", "m", "in", "ft"; throws std::invalid_argument otherwise.
double metres_per_unit(std::string_view unit);

/// What the import read and what healing it did; every count is printed by `to_string`.
struct ImportReport {
    std::size_t vertices_read = 0;
    std::size_t faces_read = 0;             ///< polygons in the file
    std::size_t triangles = 0;              ///< triangles kept
    std::size_t polygons_triangulated = 0;  ///< faces with more than three corners
    std::size_t vertices_welded = 0;        ///< positions merged (equal or within tolerance)
    std::size_t vertices_welded_near = 0;   ///< of those, merged within tolerance but not equal
    double weld_distance = 0.0;             ///< metres: the tolerance welding used
    std::size_t degenerate_dropped = 0;     ///< zero-area triangles dropped
    std::size_t duplicates_dropped = 0;     ///< triangles repeating another (any rotation/winding)
    std::size_t unused_vertices = 0;        ///< vertices no face uses
    std::size_t non_planar_polygons = 0;    ///< polygons off their best-fit plane (noted)
    std::size_t triangles_flipped = 0;      ///< turned to agree with their surface's winding
    std::size_t surfaces_flipped = 0;       ///< surfaces with at least one flipped triangle
    std::size_t overlapping_pairs = 0;      ///< coplanar overlapping triangle pairs (z-fighting)
    std::size_t emitter_triangles = 0;
    std::vector<std::string> notes;  ///< "FILE:LINE: ..." warnings (unknown statements...)

    std::string to_string() const;
};

struct ImportResult {
    visdb::Scene scene;  ///< one Source, its materials and surfaces
    ImportReport report;
};

/// Reads an OBJ file and the MTL libraries it names. Kd -> reflectance, Ke -> emittance
/// (W/m²), d or 1 - Tr -> opacity. Throws ImportError on bad input; never returns a scene
/// without triangles.
ImportResult import_obj(const std::filesystem::path& path, const ImportOptions& options);

}  // namespace abrad::convert
