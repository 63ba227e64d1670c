#pragma once
// What a reader hands to healing: a polygon soup in metres and Z up, before welding and
// triangulation, with enough bookkeeping to name the place of every face in a note.
// Internal to convert/: the OBJ reader and the Assimp reader fill it, heal() consumes it.

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <glm/vec3.hpp>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "abrad/convert/obj_import.h"
#include "abrad/visdb/model.h"

namespace abrad::convert::detail {

/// One future visdb::Surface: an (object, layer, material) triple of the source file.
struct RawSlot {
    std::string name;       ///< object, node or group name
    std::string layer;      ///< CAD layer; empty when the format has none
    std::string material;   ///< a name in RawModel::materials (or unknown: default material)
    std::size_t place = 0;  ///< where the slot first appears (see RawModel::where)
};

/// One polygon: corners `corners[first, first + count)`, indices into RawModel::positions.
struct RawFace {
    std::size_t place = 0;  ///< where the face is (see RawModel::where)
    std::uint32_t slot = 0;
    std::size_t first = 0;
    std::uint32_t count = 0;
};

/// The polygon soup of one file. Positions are finite, in metres, Z up (the reader converts
/// units and axes and rejects NaN/Inf); corner indices are in range (the reader checks).
struct RawModel {
    std::string file;  ///< the path as the user gave it, for messages
    std::vector<glm::dvec3> positions;
    std::vector<std::uint32_t> corners;
    std::vector<RawFace> faces;
    std::vector<RawSlot> slots;
    std::vector<visdb::Material> materials;  ///< by name; the first definition of a name wins
    std::vector<visdb::Camera> cameras;      ///< cameras the file carries (Z up, metres)
    /// The file: path, format ("obj", "gltf", "ifc"...), checksum, size, unit and up axis
    /// actually used (imported_at and report are filled later).
    visdb::Source source;
    /// "FILE:LINE" or "FILE: mesh 'Wall' face 12" for a place; the OBJ reader's places are
    /// lines, the Assimp reader's are (mesh, face) codes it alone understands.
    std::function<std::string(std::size_t place)> where;
};

/// Most corners of one polygon. heal() triangulates polygons of more than 256 corners in
/// O(n log n) (a constrained Delaunay triangulation; a 64k-corner face takes a fraction of a
/// second); the bound only keeps one face's work and memory in proportion to a file a CAD tool
/// writes (each corner is at least two bytes of an OBJ line, four of a binary index list).
inline constexpr std::size_t kMaxPolygonCorners = std::size_t{1} << 24;

/// "polygon with N corners (at most kMaxPolygonCorners...)": the message for a larger face.
inline std::string too_many_corners(std::size_t corners) {
    return "polygon with " + std::to_string(corners) + " corners (at most " +
           std::to_string(kMaxPolygonCorners) + "); split it into smaller faces";
}

/// Reads an OBJ file and its MTL libraries (obj_import.cpp). Notes go to `notes`.
RawModel read_obj(const std::filesystem::path& path, const ImportOptions& options,
                  std::vector<std::string>& notes);

/// Reads any format Assimp knows (assimp_import.cpp). Assimp runs in a child process with
/// kReaderLimits (child_process.h): its crash, hang or runaway allocation is an ImportError
/// "the FORMAT reader failed (REASON)". Notes go to `notes`.
RawModel read_assimp(const std::filesystem::path& path, const ImportOptions& options,
                     std::vector<std::string>& notes);

/// What read_assimp checks and rewrites before Assimp sees a file, in this process (the fuzz
/// targets' entry): PLY structure, GLB chunk lengths, the IFC end marker, DXF group pairs,
/// POLYLINE counts and INSERT expansion (`ext`: lower case, no dot). Throws ImportError.
void check_before_assimp(std::string_view bytes, const std::string& ext, const std::string& file,
                         std::vector<std::string>& notes);

/// Healing settings.
struct HealOptions {
    /// Vertices closer than this fraction of the model's bounding-box diagonal are welded
    /// (0 welds only bit-identical positions).
    double weld_tolerance = 1e-7;
};

/// Welds, triangulates, drops degenerate and duplicate triangles, makes winding consistent
/// within each connected surface and reports coplanar overlapping faces; fills the counts and
/// notes of `report`. Returns the scene's materials and surfaces (no sources, source index
/// 0). Throws ImportError when no triangle is left.
visdb::Scene heal(const RawModel& raw, const HealOptions& options, ImportReport& report);

/// `s` in single quotes for a message, cut to `max` characters (then "...") so binary junk
/// cannot flood the output.
std::string quote(std::string_view s, std::size_t max = 40);

/// "FILE:LINE: message", or "FILE: message" when `line` is 0.
std::string located(const std::string& file, std::size_t line, std::string_view message);

/// Notes of one kind (healing, Assimp warnings...): the first few verbatim, then a count of
/// the rest.
class CappedNotes {
  public:
    static constexpr std::size_t kShown = 5;

    CappedNotes(std::vector<std::string>& notes, std::string rest_label)
        : m_notes(notes), m_rest_label(std::move(rest_label)) {}

    void add(std::string note) {
        if (m_count++ < kShown) m_notes.push_back(std::move(note));
    }

    void finish(const std::string& file) {
        if (m_count > kShown) {
            m_notes.push_back(
                located(file, 0, std::to_string(m_count - kShown) + " more " + m_rest_label));
        }
    }

  private:
    std::vector<std::string>& m_notes;
    std::string m_rest_label;
    std::size_t m_count = 0;
};

/// FNV-1a 64 of `bytes` as 16 hex digits (Source::checksum).
std::string fnv1a64_hex(std::string_view bytes);

/// Current time as ISO 8601 UTC (Source::imported_at).
std::string utc_now_iso8601();

/// Reads a whole regular file; throws ImportError naming `display` when it cannot, or when it
/// is a directory, a device, a FIFO or a socket (which would block or never end).
std::string read_file_bytes(const std::filesystem::path& path, const std::string& display,
                            const char* what);

/// Throws ImportError at `referrer`:`line` unless `ref`, a file that model file `model` refers
/// to (`what`: "material library", "texture"...), resolves to a path inside the folder tree of
/// `model` (symbolic links followed; an absolute `ref` is checked the same way).
void check_reference_inside(const std::filesystem::path& ref, const std::filesystem::path& model,
                            const std::string& referrer, std::size_t line, std::string_view what);

}  // namespace abrad::convert::detail
