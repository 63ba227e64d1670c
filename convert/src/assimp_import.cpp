// Reading the CAD and mesh formats through Assimp (5.2) into a raw polygon soup: glTF/GLB, 3DS,
// Collada, FBX, DXF, IFC, STL, PLY, OFF and whatever else Assimp reads. Healing (welding,
// triangulation, degenerate and duplicate removal) is done afterwards by heal(), so Assimp runs
// with aiProcess_ValidateDataStructure only: its polygons arrive untouched.
//
// What each format loses on the way (observed with Assimp 5.2.5 on the shared test files):
// - All: Assimp stores positions and node transforms in float (~7 significant digits), so
//   survey coordinates lose millimetre detail; use OBJ for those. Textures, normals, UVs,
//   vertex colours, animation and lights are dropped (lights: one note). Point and line
//   primitives are skipped (one note).
// - glTF/GLB: materials are the PBR base colour, emissive factor (× KHR emissive strength) and
//   opacity; metallic/roughness are ignored. Faces with indices out of range are dropped by
//   Assimp with only a log warning: we turn that warning into an ImportError.
// - DXF: only 3DFACE and POLYLINE (polyface and polygon meshes) give polygons; LINE/3DLINE
//   give lines (skipped); LWPOLYLINE, CIRCLE, SOLID, hatches, text and ACIS bodies are ignored.
//   Colours (ACI and true colour) are not mapped: every layer gets the default material.
//   Assimp merges all entities of a layer into one mesh named after the layer, so a DXF object
//   is its layer. Assimp 5.2 misplaces INSERTs (translation multiplied by the scale, rotation
//   ignored, nested INSERTs dropped), so expand_dxf_inserts() below expands the INSERTs of the
//   ENTITIES section before Assimp sees the file. $INSUNITS is read by us, not by Assimp.
// - IFC: Assimp tessellates the swept and boolean solids itself (polygons of up to ~110
//   corners come out) and cuts openings (IfcOpeningElement) out of walls, so windows sit in
//   real holes; IfcSpace volumes are skipped. Materials are Assimp's rendering of the
//   IfcSurfaceStyle colours (one aiMaterial per product, same names repeated with the same
//   values); products without a style get '<IFCDefault>' (our "default"). Node names are
//   "IfcWallStandardCase_Wand-Ext-ERDG-1_3rPX_Juz59peXXY6wDJl18" (entity type, product Name or
//   "Unnamed", 22-character GlobalId): we use the entity type as layer and the product name as
//   object; mapped items ("IfcMappedItem" nodes: windows, doors) take their product's names.
//   Storeys, property sets and GlobalIds are not kept. SI length units are converted to metres
//   by Assimp (we divide out its float factor exactly); conversion-based units (feet, inches)
//   are not, so we apply them. A truncated IFC file imports silently in Assimp (only the site
//   survives), so a missing END-ISO-10303-21 is an error here.
// - 3DS: object (node) names and material colours survive; smoothing groups and keyframes do
//   not. Files without a hierarchy give "3DSMesh_N" nodes: the object is then the file stem.
// - Collada: node names (the `name` attribute, not the id) and lambert/phong colours survive;
//   layers do not. Assimp applies <unit>; we make it leave <up_axis> alone and apply it.
// - FBX: node names and material colours survive; we apply UnitScaleFactor and UpAxis from the
//   file's global settings (front/coord axes other than the usual right-handed sets are not
//   checked).
// - PLY/STL/OFF/OBJ: geometry only; no units (taken as metres), Z up. PLY files are walked by
//   check_ply() first: Assimp's PLY reader hangs or reads out of bounds on damaged files.
//
// Frames: Assimp rotates 3DS, DXF and IFC scenes from Z up to Y up in the root node. We undo
// that rotation (for IFC with the same float matrix Assimp used, so walls stay exactly
// vertical), then apply the file's up axis: options.up, else the format's convention or what
// the file declares (glTF: Y; Collada <up_axis>; FBX UpAxis; everything else Z).

#include <assimp/DefaultIOSystem.h>
#include <assimp/config.h>
#include <assimp/material.h>
#include <assimp/metadata.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <algorithm>
#include <array>
#include <assimp/DefaultLogger.hpp>
#include <assimp/Importer.hpp>
#include <assimp/Logger.hpp>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>
#include <glm/mat4x4.hpp>
#include <glm/vec4.hpp>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <stdexcept>
#include <tuple>
#include <unordered_map>
#include <utility>

#include "abrad/convert/import.h"
#include "abrad/convert/obj_import.h"
#include "abrad/visdb/material_check.h"
#include "child_process.h"
#include "format_checks.h"
#include "raw_model.h"

namespace abrad::convert::detail {

namespace {

/// Names quoted in messages keep up to 60 characters.
std::string quote_name(std::string_view s) { return quote(s, 60); }

constexpr double kMaxReflectance = 0.999;  ///< radiosity needs ρ < 1
constexpr const char* kDefaultMaterialName = "default";
constexpr double kPi = 3.14159265358979323846;

std::string lower(std::string_view s) {
    std::string out(s);
    for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return out;
}

std::string_view trim(std::string_view s) {
    while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
    while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
    return s;
}

std::string format_number(double x) {
    std::array<char, 32> buf{};
    std::snprintf(buf.data(), buf.size(), "%.6g", x);
    return buf.data();
}

std::optional<double> parse_double(std::string_view s) {
    s = trim(s);
    if (!s.empty() && s.front() == '+') s.remove_prefix(1);
    double v = 0.0;
    const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
    if (ec != std::errc() || ptr != s.data() + s.size() || !std::isfinite(v)) return std::nullopt;
    return v;
}

std::optional<long> parse_long(std::string_view s) {
    s = trim(s);
    if (!s.empty() && s.front() == '+') s.remove_prefix(1);
    long v = 0;
    const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
    if (ec != std::errc() || ptr != s.data() + s.size()) return std::nullopt;
    return v;
}

// ---------------------------------------------------------------------------------------------
// Assimp's logger

/// Collects Assimp's warnings and errors (its only channel for dropped data) instead of
/// printing them.
class CollectingLogger : public Assimp::Logger {
  public:
    explicit CollectingLogger(std::vector<std::string>& sink) : m_sink(sink) {}
    bool attachStream(Assimp::LogStream*, unsigned int) override { return false; }
    bool detachStream(Assimp::LogStream*, unsigned int) override { return false; }

  private:
    void OnDebug(const char*) override {}
    void OnVerboseDebug(const char*) override {}
    void OnInfo(const char*) override {}
    void OnWarn(const char* message) override { m_sink.emplace_back(message); }
    void OnError(const char* message) override { m_sink.emplace_back(message); }

    std::vector<std::string>& m_sink;
};

/// Installs a CollectingLogger for one read. Assimp's logger is process-global state (the one
/// exception to our no-globals rule, imposed by Assimp): reads through Assimp are serialised
/// by a mutex, and a logger someone else installed is left alone (nothing is collected then).
class LoggerScope {
  public:
    explicit LoggerScope(std::vector<std::string>& sink) : m_lock(mutex()) {
        if (Assimp::DefaultLogger::isNullLogger()) {
            Assimp::DefaultLogger::set(new CollectingLogger(sink));  // Assimp takes ownership
            m_installed = true;
        }
    }
    ~LoggerScope() {
        if (m_installed) Assimp::DefaultLogger::set(nullptr);  // deletes ours, back to null
    }
    LoggerScope(const LoggerScope&) = delete;
    LoggerScope& operator=(const LoggerScope&) = delete;

  private:
    static std::mutex& mutex() {
        static std::mutex m;
        return m;
    }
    std::lock_guard<std::mutex> m_lock;
    bool m_installed = false;
};

/// Assimp's file system for one model: every file a reader opens (a glTF's buffers, an OBJ's
/// material library, a texture) must be a regular file and, unless `allow_outside`, lie in the
/// model's folder tree, like an OBJ's mtllib. A refused file is not opened (the reader then
/// fails or goes on without it); the first refusal is kept for the error message.
class GuardedIOSystem : public Assimp::DefaultIOSystem {
  public:
    GuardedIOSystem(std::filesystem::path model, bool allow_outside)
        : m_model(std::move(model)), m_allow_outside(allow_outside) {}

    Assimp::IOStream* Open(const char* name, const char* mode) override {
        if (!allowed(name)) return nullptr;
        return Assimp::DefaultIOSystem::Open(name, mode);
    }
    /// The first file refused ("FILE: referenced file 'X' is outside the model's folder ..."),
    /// if any.
    const std::optional<ImportError>& refusal() const { return m_refusal; }

  private:
    bool allowed(const char* name) {
        std::error_code ec;
        const std::filesystem::path path(name);
        if (std::filesystem::exists(path, ec) && !std::filesystem::is_regular_file(path, ec)) {
            refuse(
                ImportError(m_model.string(), 0,
                            "referenced file " + quote(path.string()) + " is not a regular file"));
            return false;
        }
        if (m_allow_outside || path == m_model) return true;
        try {
            detail::check_reference_inside(path, m_model, m_model.string(), 0,
                                           "referenced file (buffer, texture or library)");
        } catch (const ImportError& e) {
            refuse(e);
            return false;
        }
        return true;
    }
    void refuse(const ImportError& e) {
        if (!m_refusal) m_refusal = e;
    }
    std::filesystem::path m_model;
    bool m_allow_outside;
    std::optional<ImportError> m_refusal;
};

/// Assimp's message without the file path (our messages name the file first), trailing
/// punctuation or line breaks.
std::string clean_message(std::string message, const std::string& path) {
    const std::array<std::pair<std::string, std::string>, 4> kReplace = {
        {{" of file \"" + path + "\"", ""},
         {"\"" + path + "\"", "the file"},
         {"'" + path + "'", "the file"},
         {path, "the file"}}};
    for (const auto& [from, to] : kReplace) {
        if (path.empty()) break;
        for (std::size_t at = message.find(from); at != std::string::npos;
             at = message.find(from, at + to.size())) {
            message.replace(at, from.size(), to);
        }
    }
    for (char& c : message) {
        if (c == '\n' || c == '\r' || c == '\t') c = ' ';
    }
    std::string_view t = trim(message);
    while (!t.empty() && (t.back() == '.' || t.back() == ' ')) t.remove_suffix(1);
    return std::string(t);
}

// ---------------------------------------------------------------------------------------------
// Collada

/// Checks a Collada file's index lists (<p>, <v>, <vcount>, <h>) hold whole numbers only and
/// every count="N" attribute is at most the file's size: Assimp 5.2 read fractional indices
/// ("0.5 1.5 2.5") into a 24 GB allocation. Throws ImportError at the line.
void check_collada(std::string_view bytes, const std::string& file) {
    const auto line_at = [&](std::size_t at) {
        return static_cast<std::size_t>(std::count(bytes.begin(), bytes.begin() + at, '\n')) + 1;
    };
    for (const std::string_view tag : {"<p>", "<v>", "<vcount>", "<h>"}) {
        for (std::size_t at = bytes.find(tag); at != std::string_view::npos;
             at = bytes.find(tag, at + 1)) {
            const std::size_t begin = at + tag.size();
            const std::size_t end = std::min(bytes.find('<', begin), bytes.size());
            const std::size_t bad =
                bytes.substr(begin, end - begin).find_first_not_of("0123456789 \t\r\n");
            if (bad != std::string_view::npos) {
                throw ImportError(file, line_at(begin + bad),
                                  "Collada " + std::string(tag) + " holds " +
                                      quote(bytes.substr(begin + bad, std::min<std::size_t>(
                                                                          12, end - begin - bad))) +
                                      ": indices and counts are whole numbers");
            }
        }
    }
    constexpr std::string_view kCount = " count=\"";
    for (std::size_t at = bytes.find(kCount); at != std::string_view::npos;
         at = bytes.find(kCount, at + 1)) {
        const std::string_view digits = bytes.substr(at + kCount.size(), 20);
        std::optional<long> n = parse_long(digits.substr(0, digits.find('"')));
        if (!n && !digits.empty() && std::isdigit(static_cast<unsigned char>(digits[0])) != 0)
            n = std::numeric_limits<long>::max();  // more digits than a long holds
        if (n && (*n < 0 || static_cast<std::uint64_t>(*n) > bytes.size())) {
            throw ImportError(file, line_at(at),
                              "Collada count=\"" + std::to_string(*n) +
                                  "\" is more than the file could hold (" +
                                  std::to_string(bytes.size()) + " bytes)");
        }
    }
}

// ---------------------------------------------------------------------------------------------
// glTF (JSON)

/// SAX handler that accepts every value and keeps the first syntax error: the JSON is
/// checked without building it (no memory for huge arrays, no recursion for deep nesting).
struct JsonSyntax : nlohmann::json_sax<nlohmann::json> {
    bool null() override { return true; }
    bool boolean(bool /*unused*/) override { return true; }
    bool number_integer(number_integer_t /*unused*/) override { return true; }
    bool number_unsigned(number_unsigned_t /*unused*/) override { return true; }
    bool number_float(number_float_t /*unused*/, const string_t& /*unused*/) override {
        return true;
    }
    bool string(string_t& /*unused*/) override { return true; }
    bool binary(binary_t& /*unused*/) override { return true; }
    bool start_object(std::size_t /*unused*/) override { return true; }
    bool key(string_t& /*unused*/) override { return true; }
    bool end_object() override { return true; }
    bool start_array(std::size_t /*unused*/) override { return true; }
    bool end_array() override { return true; }
    bool parse_error(std::size_t position, const std::string& /*unused*/,
                     const nlohmann::detail::exception& e) override {
        at = position;
        message = e.what();
        return false;
    }
    std::size_t at = 0;
    std::string message;
};

/// Checks a .gltf file is JSON before Assimp reads it (Assimp says only "No suitable reader
/// found" for a truncated one); throws ImportError at the line and column of the first error.
void check_gltf_json(std::string_view bytes, const std::string& file) {
    JsonSyntax sax;
    if (nlohmann::json::sax_parse(bytes, &sax)) return;
    // nlohmann's position counts the bytes read, the offending one included
    const std::size_t at = std::min(sax.at > 0 ? sax.at - 1 : 0, bytes.size());
    const std::size_t line =
        static_cast<std::size_t>(std::count(bytes.begin(), bytes.begin() + at, '\n')) + 1;
    const std::size_t line_start = bytes.rfind('\n', at == 0 ? 0 : at - 1);
    const std::size_t column =
        line_start == std::string_view::npos || at == 0 ? at + 1 : at - line_start;
    // "[json.exception.parse_error.101] parse error at line 1, column 5: syntax error while
    // parsing value - unexpected end of input; ..." -> "syntax error ... input"
    std::string what = sax.message;
    if (const std::size_t c = what.find(": "); c != std::string::npos) what.erase(0, c + 2);
    throw ImportError(file, line,
                      "column " + std::to_string(column) + " (byte " + std::to_string(at) +
                          "): not valid glTF JSON: " + clean_message(what, file));
}

// ---------------------------------------------------------------------------------------------
// GLB

/// Checks a binary glTF's header and chunk lengths against the file's size (Assimp allocates
/// what a chunk claims before reading it: a 2 GiB claim took 2 GB); throws ImportError naming
/// the byte where the bad length is.
void check_glb(std::string_view bytes, const std::string& file) {
    const auto u32 = [&](std::size_t at) {
        std::uint32_t v = 0;
        for (std::size_t i = 4; i-- > 0;) v = (v << 8) | static_cast<unsigned char>(bytes[at + i]);
        return v;
    };
    const auto fail = [&](std::size_t at, const std::string& message) {
        throw ImportError(file, 0, "GLB byte " + std::to_string(at) + ": " + message);
    };
    if (bytes.size() < 12) fail(0, "header cut short (a GLB header is 12 bytes)");
    if (u32(8) != bytes.size()) {
        fail(8, "the header gives the file's length as " + std::to_string(u32(8)) +
                    " bytes, but it has " + std::to_string(bytes.size()));
    }
    for (std::size_t at = 12, chunk = 0; at < bytes.size(); ++chunk) {
        if (bytes.size() - at < 8) fail(at, "chunk " + std::to_string(chunk) + " header cut short");
        const std::uint64_t length = u32(at);
        if (length > bytes.size() - at - 8) {
            fail(at, "chunk " + std::to_string(chunk) + " claims " + std::to_string(length) +
                         " bytes, but only " + std::to_string(bytes.size() - at - 8) + " follow");
        }
        at += 8 + length;
    }
}

// ---------------------------------------------------------------------------------------------
// Units

/// A length unit: metres per file unit and how to name it in Source::unit.
struct Unit {
    double metres = 1.0;
    std::string label = "m";
};

Unit unit_from_metres(double metres) {
    static const std::array<std::pair<const char*, double>, 5> kNamed = {
        {{"mm", 0.001}, {"cm", 0.01}, {"m", 1.0}, {"in", 0.0254}, {"ft", 0.3048}}};
    for (const auto& [name, m] : kNamed) {
        if (std::abs(metres - m) <= 1e-9 * m) return {m, name};
    }
    return {metres, "scale " + format_number(metres)};
}

/// What a file says about its length unit and how much of it Assimp already applied.
struct DeclaredUnit {
    Unit unit;              ///< metres per unit of the numbers in the file
    bool declared = false;  ///< the file states it (else metres by default)
    double applied = 1.0;   ///< factor Assimp already multiplied in (float), 1 if none
    std::string what;       ///< where it was declared, for notes
};

// ---------------------------------------------------------------------------------------------
// DXF text: group code / value pairs

struct DxfPair {
    int code = 0;
    std::string_view value;  ///< trimmed
    std::size_t line = 0;    ///< line of the group code, 1-based
};

/// Splits an ASCII DXF into pairs, up to (0, EOF); nullopt for a binary DXF (Assimp reports
/// those). Throws on a group code that is not a number: the file is corrupt, and Assimp reads
/// on out of step (it once asked for 48 GB on such a file).
std::optional<std::vector<DxfPair>> dxf_pairs(std::string_view text, const std::string& file) {
    if (text.starts_with("AutoCAD Binary DXF")) return std::nullopt;
    std::vector<DxfPair> pairs;
    std::size_t pos = 0;
    std::size_t line = 0;
    const auto next_line = [&](std::string_view& out) {
        if (pos >= text.size()) return false;
        const std::size_t end = text.find('\n', pos);
        const std::size_t stop = end == std::string_view::npos ? text.size() : end;
        out = text.substr(pos, stop - pos);
        pos = end == std::string_view::npos ? text.size() : end + 1;
        ++line;
        return true;
    };
    std::string_view code_line;
    std::string_view value_line;
    while (next_line(code_line)) {
        if (trim(code_line).empty() && pos >= text.size()) break;  // trailing blank line
        const std::size_t at = line;
        const std::optional<long> code = parse_long(code_line);
        if (!code || *code < 0 || *code > 1071) {
            throw ImportError(file, at,
                              "DXF group code " + quote_name(trim(code_line)) +
                                  " is not a group code number (corrupt file?)");
        }
        if (!next_line(value_line)) {
            throw ImportError(file, at, "DXF group code without a value (truncated file?)");
        }
        pairs.push_back({static_cast<int>(*code), trim(value_line), at});
        if (*code == 0 && pairs.back().value == "EOF") break;
    }
    return pairs;
}

/// Throws on POLYLINE vertex/face counts (groups 71/72) that are negative or larger than the
/// file: Assimp reserves memory for them (a corrupt count asks for gigabytes).
void check_dxf_polyline_counts(const std::vector<DxfPair>& pairs, const std::string& file) {
    bool in_polyline = false;
    for (const DxfPair& p : pairs) {
        if (p.code == 0) in_polyline = p.value == "POLYLINE";
        if (!in_polyline || (p.code != 71 && p.code != 72)) continue;
        const std::optional<long> n = parse_long(p.value);
        if (!n || *n < 0 || static_cast<std::size_t>(*n) > pairs.size()) {
            throw ImportError(file, p.line + 1,
                              "POLYLINE " + std::string(p.code == 71 ? "vertex" : "face") +
                                  " count " + quote_name(p.value) + " out of range");
        }
    }
}

/// $INSUNITS of the HEADER section (0 or absent: unitless).
DeclaredUnit dxf_declared_unit(const std::vector<DxfPair>& pairs) {
    DeclaredUnit d;
    for (std::size_t i = 0; i + 1 < pairs.size(); ++i) {
        if (pairs[i].code == 0 && pairs[i].value == "ENDSEC") break;  // end of HEADER
        if (pairs[i].code != 9 || pairs[i].value != "$INSUNITS") continue;
        const std::optional<long> v = parse_long(pairs[i + 1].value);
        if (!v) break;
        d.what = "$INSUNITS " + std::to_string(*v);
        switch (*v) {
            case 1:
                d.unit = {0.0254, "in"};
                break;
            case 2:
                d.unit = {0.3048, "ft"};
                break;
            case 4:
                d.unit = {0.001, "mm"};
                break;
            case 5:
                d.unit = {0.01, "cm"};
                break;
            case 6:
                d.unit = {1.0, "m"};
                break;
            case 7:
                d.unit = unit_from_metres(1000.0);
                break;
            case 10:
                d.unit = unit_from_metres(0.9144);
                break;
            case 14:
                d.unit = unit_from_metres(0.1);
                break;
            default:
                return DeclaredUnit{};  // unitless or exotic: metres
        }
        d.declared = true;
        return d;
    }
    return d;
}

/// A 4x4 affine transform of DXF block geometry.
using Affine = glm::dmat4;

/// The arbitrary axis algorithm of the DXF reference: the OCS of extrusion direction `n`.
Affine dxf_ocs(glm::dvec3 n) {
    n = glm::normalize(n);
    const glm::dvec3 ax = (std::abs(n.x) < 1.0 / 64.0 && std::abs(n.y) < 1.0 / 64.0)
                              ? glm::normalize(glm::cross(glm::dvec3(0, 1, 0), n))
                              : glm::normalize(glm::cross(glm::dvec3(0, 0, 1), n));
    const glm::dvec3 ay = glm::cross(n, ax);
    Affine m(1.0);
    m[0] = glm::dvec4(ax, 0.0);
    m[1] = glm::dvec4(ay, 0.0);
    m[2] = glm::dvec4(n, 0.0);
    return m;
}

/// Most entities the expansion of a file's INSERTs may copy (a 3DFACE, a polyline vertex or a
/// line each; about 350 bytes of DXF text each, 1.7 GB in all, that Assimp then reads): nested
/// INSERTs and MINSERT arrays multiply, and a 300-byte file can ask for 10^10 faces.
constexpr std::uint64_t kMaxDxfBlockEntities = 5'000'000;
/// Most copies one INSERT places (MINSERT columns x rows); more are ignored with a note.
constexpr std::uint64_t kMaxDxfInsertCopies = 100'000;
/// Deepest nesting of INSERTs inside blocks; deeper ones are ignored with a note.
constexpr std::size_t kMaxDxfInsertDepth = 16;

/// Expands the INSERTs of the ENTITIES section into transformed copies of their blocks'
/// 3DFACE/POLYLINE/VERTEX/LINE entities (position, scale, rotation, extrusion, MINSERT arrays,
/// nested INSERTs; entities on layer 0 take the INSERT's layer), because Assimp 5.2 places them
/// wrongly. Throws ImportError, before expanding anything, when the copies would exceed
/// kMaxDxfBlockEntities. Returns nullopt when the file has no INSERT in ENTITIES (nothing to do).
std::optional<std::string> expand_dxf_inserts(const std::vector<DxfPair>& pairs,
                                              const std::string& file,
                                              std::vector<std::string>& notes) {
    // An entity: the indices [first, last) of its pairs, first is its (0, TYPE) pair
    struct Entity {
        std::size_t first = 0;
        std::size_t last = 0;
    };
    struct Block {
        glm::dvec3 base{0.0};
        std::vector<Entity> entities;
    };
    std::map<std::string, Block, std::less<>> blocks;
    std::vector<Entity> inserts;  // INSERTs of the ENTITIES section
    std::string section;
    Block* block = nullptr;
    for (std::size_t i = 0; i < pairs.size(); ++i) {
        const DxfPair& p = pairs[i];
        if (p.code != 0) continue;
        std::size_t end = i + 1;
        while (end < pairs.size() && pairs[end].code != 0) ++end;
        if (p.value == "SECTION") {
            section = end > i + 1 && pairs[i + 1].code == 2 ? std::string(pairs[i + 1].value) : "";
        } else if (p.value == "ENDSEC") {
            section.clear();
        } else if (section == "BLOCKS" && p.value == "BLOCK") {
            std::string name;
            glm::dvec3 base{0.0};
            for (std::size_t k = i + 1; k < end; ++k) {
                const std::optional<double> v = parse_double(pairs[k].value);
                if (pairs[k].code == 2) name = pairs[k].value;
                if (pairs[k].code == 10 && v) base.x = *v;
                if (pairs[k].code == 20 && v) base.y = *v;
                if (pairs[k].code == 30 && v) base.z = *v;
            }
            block = &blocks[name];
            *block = Block{base, {}};
        } else if (section == "BLOCKS" && p.value == "ENDBLK") {
            block = nullptr;
        } else if (section == "BLOCKS" && block != nullptr) {
            block->entities.push_back({i, end});
        } else if (section == "ENTITIES" && p.value == "INSERT") {
            inserts.push_back({i, end});
        }
        i = end - 1;
    }
    if (inserts.empty()) return std::nullopt;

    std::string out;
    out.reserve(pairs.size() * 16);
    const auto emit = [&out](int code, std::string_view value) {
        out += std::to_string(code);
        out += '\n';
        out += value;
        out += '\n';
    };
    const auto emit_number = [&emit](int code, double v) {
        std::array<char, 40> buf{};
        std::snprintf(buf.data(), buf.size(), "%.17g", v);
        emit(code, buf.data());
    };

    CappedNotes insert_notes(notes, "notes about INSERTs");
    std::set<std::string, std::less<>> expanding;  // blocks being expanded (cycle guard)

    // Copies block entity `e` transformed by `m` (layer 0 becomes `layer`)
    const auto copy_entity = [&](const Entity& e, const Affine& m, std::string_view layer) {
        const std::string_view type = pairs[e.first].value;
        const bool is_vertex = type == "VERTEX";
        long vertex_flags = 0;
        std::array<glm::dvec3, 4> points{};
        std::array<bool, 4> has_point{};
        for (std::size_t k = e.first + 1; k < e.last; ++k) {
            const int c = pairs[k].code;
            if (c == 70 && is_vertex) vertex_flags = parse_long(pairs[k].value).value_or(0);
            if ((c >= 10 && c <= 13) || (c >= 20 && c <= 23) || (c >= 30 && c <= 33)) {
                const std::size_t idx = static_cast<std::size_t>(c % 10);
                has_point[idx] = true;
                points[idx][c / 10 - 1] = parse_double(pairs[k].value).value_or(0.0);
            }
        }
        // Face records of polyface meshes carry no position (flag 128 without 64)
        const bool face_record = is_vertex && (vertex_flags & 128) != 0 && (vertex_flags & 64) == 0;
        const bool transform = type != "POLYLINE" && type != "SEQEND" && !face_record;
        emit(0, type);
        for (std::size_t k = e.first + 1; k < e.last; ++k) {
            const int c = pairs[k].code;
            const bool coordinate =
                (c >= 10 && c <= 13) || (c >= 20 && c <= 23) || (c >= 30 && c <= 33);
            if (transform && coordinate) continue;
            if (c == 8 && pairs[k].value == "0") {
                emit(8, layer);
            } else {
                emit(c, pairs[k].value);
            }
        }
        if (!transform) return;
        for (std::size_t idx = 0; idx < 4; ++idx) {
            if (!has_point[idx]) continue;
            const glm::dvec3 w = glm::dvec3(m * glm::dvec4(points[idx], 1.0));
            const int ci = static_cast<int>(idx);
            emit_number(10 + ci, w.x);
            emit_number(20 + ci, w.y);
            emit_number(30 + ci, w.z);
        }
    };

    // The fields of INSERT (or MINSERT) `e`
    struct Insert {
        std::string name;
        std::string layer = "0";
        std::string handle;
        std::size_t line = 0;
        glm::dvec3 pos{0.0};
        glm::dvec3 scale{1.0};
        glm::dvec3 extrusion{0.0, 0.0, 1.0};
        double angle_deg = 0.0;
        long columns = 1;
        long rows = 1;
        double column_spacing = 0.0;
        double row_spacing = 0.0;
        /// columns x rows, or 0 when over kMaxDxfInsertCopies (checked: the counts are any
        /// long the file gives)
        std::uint64_t copies = 1;
    };
    const auto parse_insert = [&](const Entity& e) {
        Insert ins;
        ins.line = pairs[e.first].line;
        for (std::size_t k = e.first + 1; k < e.last; ++k) {
            const std::string_view v = pairs[k].value;
            const double x = parse_double(v).value_or(0.0);
            switch (pairs[k].code) {
                case 2:
                    ins.name = v;
                    break;
                case 5:
                    ins.handle = v;
                    break;
                case 8:
                    ins.layer = v;
                    break;
                case 10:
                    ins.pos.x = x;
                    break;
                case 20:
                    ins.pos.y = x;
                    break;
                case 30:
                    ins.pos.z = x;
                    break;
                case 41:
                    ins.scale.x = x;
                    break;
                case 42:
                    ins.scale.y = x;
                    break;
                case 43:
                    ins.scale.z = x;
                    break;
                case 50:
                    ins.angle_deg = x;
                    break;
                case 70:
                    ins.columns = std::max(1L, parse_long(v).value_or(1));
                    break;
                case 71:
                    ins.rows = std::max(1L, parse_long(v).value_or(1));
                    break;
                case 44:
                    ins.column_spacing = x;
                    break;
                case 45:
                    ins.row_spacing = x;
                    break;
                case 210:
                    ins.extrusion.x = x;
                    break;
                case 220:
                    ins.extrusion.y = x;
                    break;
                case 230:
                    ins.extrusion.z = x;
                    break;
                default:
                    break;
            }
        }
        // Copies of a MINSERT array: each factor is checked before the product, which then
        // fits in 64 bits
        const auto c = static_cast<std::uint64_t>(ins.columns);
        const auto r = static_cast<std::uint64_t>(ins.rows);
        ins.copies =
            c <= kMaxDxfInsertCopies && r <= kMaxDxfInsertCopies && c * r <= kMaxDxfInsertCopies
                ? c * r
                : 0;
        return ins;
    };
    // What the expansion does with an INSERT: why it is skipped, or empty when it expands
    static constexpr std::string_view kUndefined = "undefined";
    const auto skip_reason = [&](const Insert& ins) -> std::string {
        if (blocks.find(ins.name) == blocks.end()) return std::string(kUndefined);
        if (expanding.count(ins.name) > 0 || expanding.size() >= kMaxDxfInsertDepth)
            return "inside itself (or nested too deep)";
        if (glm::length(ins.extrusion) == 0.0 || ins.copies == 0)
            return "with a zero extrusion direction or too many copies";
        return "";
    };
    const auto is_copied = [](std::string_view type) {
        return type == "3DFACE" || type == "POLYLINE" || type == "VERTEX" || type == "SEQEND" ||
               type == "LINE" || type == "3DLINE";
    };

    // Entities INSERT `e` would copy and block copies it would place (each placement is work
    // too: nested INSERTs of blocks with nothing to copy hung the expansion, fuzz finding
    // dxf/finding-9850d687b7c7), saturating at kMaxDxfBlockEntities + 1; memoized per
    // (block, nesting depth), so nested INSERT bombs are counted in time linear in the file
    std::map<std::pair<std::string, std::size_t>, std::uint64_t> counted;
    const auto count = [&](const auto& self, const Entity& e) -> std::uint64_t {
        const Insert ins = parse_insert(e);
        if (!skip_reason(ins).empty()) return 0;
        const auto key = std::make_pair(ins.name, expanding.size());
        auto memo = counted.find(key);
        if (memo == counted.end()) {
            expanding.insert(ins.name);
            std::uint64_t n = 0;
            for (const Entity& be : blocks.find(ins.name)->second.entities) {
                const std::string_view type = pairs[be.first].value;
                if (type == "INSERT") {
                    n += self(self, be);
                } else if (is_copied(type)) {
                    ++n;
                }
                n = std::min<std::uint64_t>(n, kMaxDxfBlockEntities + 1);
            }
            expanding.erase(ins.name);
            memo = counted.emplace(key, n).first;
        }
        // The factors are at most kMaxDxfBlockEntities + 2 and kMaxDxfInsertCopies: no overflow
        return std::min<std::uint64_t>((memo->second + 1) * ins.copies, kMaxDxfBlockEntities + 1);
    };
    const auto where = [&](const Insert& ins) {
        return "INSERT of block " + quote_name(ins.name) +
               (ins.handle.empty() ? std::string() : " (handle " + ins.handle + ")");
    };
    const auto over_budget = [&](const Insert& ins) {
        return ImportError(file, ins.line,
                           where(ins) + " expands the blocks to more than " +
                               std::to_string(kMaxDxfBlockEntities) +
                               " entities and block copies (nested INSERTs and MINSERT arrays "
                               "multiply); refused");
    };

    // Expands INSERT `e` under the transform `outer` (identity at the top level); `copied`
    // counts the entities copied so far, a guard behind the count made before expanding
    std::uint64_t copied = 0;
    const auto expand = [&](const auto& self, const Entity& e, const Affine& outer,
                            std::string_view outer_layer, const Insert& top) -> void {
        Insert ins = parse_insert(e);
        if (ins.layer == "0") ins.layer = outer_layer;
        const std::string reason = skip_reason(ins);
        if (!reason.empty()) {
            insert_notes.add(located(
                file, ins.line,
                reason == kUndefined
                    ? "INSERT of undefined block " + quote_name(ins.name) + " ignored"
                    : "INSERT of block " + quote_name(ins.name) + " " + reason + " ignored"));
            return;
        }
        expanding.insert(ins.name);
        const Block& b = blocks.find(ins.name)->second;
        const double a = ins.angle_deg * kPi / 180.0;
        Affine rot(1.0);
        rot[0] = glm::dvec4(std::cos(a), std::sin(a), 0.0, 0.0);
        rot[1] = glm::dvec4(-std::sin(a), std::cos(a), 0.0, 0.0);
        Affine scl(1.0);
        scl[0][0] = ins.scale.x;
        scl[1][1] = ins.scale.y;
        scl[2][2] = ins.scale.z;
        Affine to_base(1.0);
        to_base[3] = glm::dvec4(-b.base, 1.0);
        const Affine ocs = dxf_ocs(ins.extrusion);
        for (long r = 0; r < ins.rows; ++r) {
            for (long c = 0; c < ins.columns; ++c) {
                if (++copied > kMaxDxfBlockEntities) throw over_budget(top);
                // Array spacing is along the rotated block axes, not scaled
                Affine place(1.0);
                place[3] = glm::dvec4(
                    ins.pos +
                        glm::dvec3(rot * glm::dvec4(static_cast<double>(c) * ins.column_spacing,
                                                    static_cast<double>(r) * ins.row_spacing, 0.0,
                                                    0.0)),
                    1.0);
                const Affine m = outer * ocs * place * rot * scl * to_base;
                for (const Entity& be : b.entities) {
                    const std::string_view type = pairs[be.first].value;
                    if (type == "INSERT") {
                        self(self, be, m, ins.layer, top);
                    } else if (is_copied(type)) {
                        if (++copied > kMaxDxfBlockEntities) throw over_budget(top);
                        copy_entity(be, m, ins.layer);
                    }
                }
            }
        }
        expanding.erase(ins.name);
    };

    // The budget, before anything is expanded
    std::uint64_t total = 0;
    for (const Entity& e : inserts) {
        total += count(count, e);
        if (total > kMaxDxfBlockEntities) throw over_budget(parse_insert(e));
    }

    // Copy the file up to the end of the ENTITIES section header, then its entities with the
    // INSERTs expanded, then the rest
    std::size_t next_insert = 0;
    for (std::size_t i = 0; i < pairs.size(); ++i) {
        if (next_insert < inserts.size() && i == inserts[next_insert].first) {
            expand(expand, inserts[next_insert], Affine(1.0), "0",
                   parse_insert(inserts[next_insert]));
            i = inserts[next_insert].last - 1;
            ++next_insert;
            continue;
        }
        emit(pairs[i].code, pairs[i].value);
    }
    insert_notes.finish(file);
    return out;
}

// ---------------------------------------------------------------------------------------------
// PLY: checked before Assimp reads it. Assimp 5.2's PLY reader loops forever on some damaged
// headers and bodies, reads past the buffer on corrupt binary counts and indexes vertices with
// unchecked face indices; so the whole file is walked here first (header grammar, body
// length, list counts, vertex indices in range), with the line of the first fault.

struct PlyProperty {
    std::size_t size = 0;        ///< bytes of the value (binary), 0 for a list
    std::size_t count_size = 0;  ///< bytes of a list's count
    std::size_t item_size = 0;   ///< bytes of a list's items
    bool is_index_list = false;  ///< face vertex indices
    bool is_float = false;
};

struct PlyElement {
    std::string name;
    std::size_t count = 0;
    std::size_t line = 0;
    std::vector<PlyProperty> properties;
};

std::size_t ply_type_size(std::string_view t, bool& is_float) {
    is_float = t == "float" || t == "float32" || t == "double" || t == "float64";
    if (t == "char" || t == "uchar" || t == "int8" || t == "uint8") return 1;
    if (t == "short" || t == "ushort" || t == "int16" || t == "uint16") return 2;
    if (t == "int" || t == "uint" || t == "int32" || t == "uint32" || t == "float" ||
        t == "float32") {
        return 4;
    }
    if (t == "double" || t == "float64") return 8;
    return 0;
}

void check_ply(std::string_view text, const std::string& file) {
    // Header: "ply", format, elements with properties, end_header
    std::size_t pos = 0;
    std::size_t line = 0;
    std::string_view l;
    const auto next_line = [&]() {
        if (pos >= text.size()) return false;
        const std::size_t end = text.find('\n', pos);
        const std::size_t stop = end == std::string_view::npos ? text.size() : end;
        l = text.substr(pos, stop - pos);
        pos = end == std::string_view::npos ? text.size() : end + 1;
        ++line;
        if (!l.empty() && l.back() == '\r') l.remove_suffix(1);
        return true;
    };
    const auto fail = [&](std::size_t at, const std::string& message) {
        throw ImportError(file, at, "PLY: " + message);
    };
    std::vector<std::string_view> tokens;
    const auto split = [&](std::string_view s) {
        tokens.clear();
        std::size_t i = 0;
        while (i < s.size()) {
            while (i < s.size() && std::isspace(static_cast<unsigned char>(s[i]))) ++i;
            const std::size_t start = i;
            while (i < s.size() && !std::isspace(static_cast<unsigned char>(s[i]))) ++i;
            if (i > start) tokens.push_back(s.substr(start, i - start));
        }
    };
    if (!next_line() || trim(l) != "ply") fail(1, "first line is not 'ply'");
    int format = -1;  // 0 ascii, 1 little endian, 2 big endian
    std::vector<PlyElement> elements;
    bool ended = false;
    while (next_line()) {
        if (l.find('\0') != std::string_view::npos) fail(line, "NUL byte in the header");
        split(l);
        if (tokens.empty() || tokens[0] == "comment" || tokens[0] == "obj_info") continue;
        if (tokens[0] == "end_header") {
            ended = true;
            break;
        }
        if (tokens[0] == "format") {
            if (tokens.size() != 3) fail(line, "malformed format line");
            if (tokens[1] == "ascii")
                format = 0;
            else if (tokens[1] == "binary_little_endian")
                format = 1;
            else if (tokens[1] == "binary_big_endian")
                format = 2;
            else
                fail(line, "unknown format " + quote_name(tokens[1]));
        } else if (tokens[0] == "element") {
            const std::optional<long> n = tokens.size() == 3 ? parse_long(tokens[2]) : std::nullopt;
            if (!n || *n < 0) fail(line, "malformed element line");
            elements.push_back({std::string(tokens[1]), static_cast<std::size_t>(*n), line, {}});
        } else if (tokens[0] == "property") {
            if (elements.empty()) fail(line, "property before any element");
            PlyProperty p;
            bool is_float = false;
            if (tokens.size() == 5 && tokens[1] == "list") {
                p.count_size = ply_type_size(tokens[2], is_float);
                if (p.count_size == 0 || is_float) fail(line, "bad list count type");
                p.item_size = ply_type_size(tokens[3], is_float);
                if (p.item_size == 0) fail(line, "unknown type " + quote_name(tokens[3]));
                p.is_float = is_float;
                p.is_index_list = tokens[4] == "vertex_indices" || tokens[4] == "vertex_index";
            } else if (tokens.size() == 3) {
                p.size = ply_type_size(tokens[1], is_float);
                if (p.size == 0) fail(line, "unknown type " + quote_name(tokens[1]));
                p.is_float = is_float;
            } else {
                fail(line, "malformed property line");
            }
            elements.back().properties.push_back(p);
        } else {
            fail(line, "unknown header line " + quote_name(tokens[0]));
        }
    }
    if (!ended) fail(0, "header without end_header (truncated file?)");
    if (format < 0) fail(0, "header without a format line");
    std::size_t vertices = 0;
    for (const PlyElement& e : elements) {
        if (e.name == "vertex") vertices = e.count;
    }

    // Body
    if (format == 0) {
        for (const PlyElement& e : elements) {
            for (std::size_t i = 0; i < e.count; ++i) {
                // Elements are one per line; blank lines are skipped
                do {
                    if (!next_line()) {
                        fail(0, "file ends in element " + quote_name(e.name) + " " +
                                    std::to_string(i) + " of " + std::to_string(e.count) +
                                    " (truncated file?)");
                    }
                    split(l);
                } while (tokens.empty());
                if (l.find('\0') != std::string_view::npos) fail(line, "NUL byte");
                std::size_t t = 0;
                for (const PlyProperty& p : e.properties) {
                    if (p.size > 0) {
                        if (t >= tokens.size() || !parse_double(tokens[t])) {
                            fail(line, "missing or malformed number");
                        }
                        ++t;
                        continue;
                    }
                    const std::optional<long> n =
                        t < tokens.size() ? parse_long(tokens[t]) : std::nullopt;
                    if (!n || *n < 0 || static_cast<std::size_t>(*n) > tokens.size()) {
                        fail(line, "malformed list count");
                    }
                    ++t;
                    for (long k = 0; k < *n; ++k, ++t) {
                        if (t >= tokens.size()) fail(line, "list shorter than its count");
                        if (p.is_index_list) {
                            const std::optional<long> v = parse_long(tokens[t]);
                            if (!v || *v < 0 || static_cast<std::size_t>(*v) >= vertices) {
                                fail(line, "vertex index " + quote_name(tokens[t]) +
                                               " out of range (" + std::to_string(vertices) +
                                               " vertices)");
                            }
                        } else if (!parse_double(tokens[t])) {
                            fail(line, "malformed number");
                        }
                    }
                }
                if (t != tokens.size()) fail(line, "more values than the element's properties");
            }
        }
        return;
    }
    const bool big_endian = format == 2;
    const auto read_uint = [&](std::size_t at, std::size_t size) {
        std::uint64_t v = 0;
        for (std::size_t b = 0; b < size; ++b) {
            const std::size_t k = big_endian ? b : size - 1 - b;
            v = (v << 8) | static_cast<unsigned char>(text[at + k]);
        }
        return v;
    };
    std::size_t at = pos;
    for (const PlyElement& e : elements) {
        for (std::size_t i = 0; i < e.count; ++i) {
            for (const PlyProperty& p : e.properties) {
                const std::size_t need = p.size > 0 ? p.size : p.count_size;
                if (at + need > text.size()) {
                    fail(0, "file ends in element " + quote_name(e.name) + " " + std::to_string(i) +
                                " of " + std::to_string(e.count) + " (truncated file?)");
                }
                if (p.size > 0) {
                    at += p.size;
                    continue;
                }
                const std::uint64_t n = read_uint(at, p.count_size);
                at += p.count_size;
                if (n > (text.size() - at) / p.item_size) {
                    fail(0, "list count " + std::to_string(n) + " in element " +
                                quote_name(e.name) + " " + std::to_string(i) +
                                " runs past the end of the file");
                }
                if (p.is_index_list && !p.is_float) {
                    for (std::uint64_t k = 0; k < n; ++k) {
                        std::uint64_t v = read_uint(at + k * p.item_size, p.item_size);
                        const bool negative = (v >> (8 * p.item_size - 1)) & 1U;
                        if (negative || v >= vertices) {
                            fail(0, "vertex index out of range in element " + quote_name(e.name) +
                                        " " + std::to_string(i));
                        }
                    }
                }
                at += static_cast<std::size_t>(n) * p.item_size;
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Collada and IFC declarations

/// Collada <asset><unit meter=".."/> and <up_axis> of the document's own (first) asset.
struct ColladaAsset {
    std::optional<double> meter;
    char up = 'y';  ///< Y_UP is Collada's default
};

ColladaAsset collada_asset(std::string_view text) {
    ColladaAsset a;
    const std::size_t begin = text.find("<asset");
    if (begin == std::string_view::npos) return a;
    const std::size_t end = text.find("</asset>", begin);
    const std::string_view asset =
        text.substr(begin, end == std::string_view::npos ? std::string_view::npos : end - begin);
    const std::size_t unit = asset.find("<unit");
    if (unit != std::string_view::npos) {
        const std::size_t close = asset.find('>', unit);
        const std::string_view tag = asset.substr(unit, close - unit);
        const std::size_t m = tag.find("meter=");
        if (m != std::string_view::npos && m + 7 < tag.size()) {
            const char quote_char = tag[m + 6];
            const std::size_t stop = tag.find(quote_char, m + 7);
            if (stop != std::string_view::npos) {
                const std::optional<double> v = parse_double(tag.substr(m + 7, stop - m - 7));
                if (v && *v > 0.0) a.meter = v;
            }
        }
    }
    const std::size_t up = asset.find("<up_axis>");
    if (up != std::string_view::npos) {
        const std::string_view rest = trim(asset.substr(up + 9, 8));
        if (rest.starts_with("X_UP")) a.up = 'x';
        if (rest.starts_with("Z_UP")) a.up = 'z';
    }
    return a;
}

/// The IFC project's length unit: IFCSIUNIT(*,.LENGTHUNIT.,PREFIX,.METRE.) (Assimp applies it)
/// or IFCCONVERSIONBASEDUNIT(..,.LENGTHUNIT.,'FOOT'|'INCH',..) (Assimp ignores it).
DeclaredUnit ifc_declared_unit(std::string_view text) {
    DeclaredUnit d;
    for (std::size_t at = text.find(".LENGTHUNIT."); at != std::string_view::npos;
         at = text.find(".LENGTHUNIT.", at + 1)) {
        const std::size_t start = text.rfind('=', at);
        const std::size_t stop = text.find(';', at);
        if (start == std::string_view::npos || stop == std::string_view::npos) continue;
        const std::string entity = lower(text.substr(start, stop - start));
        if (entity.find("ifcsiunit") != std::string::npos) {
            static const std::array<std::pair<const char*, double>, 5> kPrefixes = {
                {{".milli.", 0.001},
                 {".centi.", 0.01},
                 {".deci.", 0.1},
                 {".kilo.", 1000.0},
                 {".micro.", 1e-6}}};
            double metres = 1.0;
            for (const auto& [prefix, f] : kPrefixes) {
                if (entity.find(prefix) != std::string::npos) metres = f;
            }
            d.unit = unit_from_metres(metres);
            d.applied = metres;  // refined from the root node below
            d.declared = true;
            d.what = "IFCSIUNIT";
            return d;
        }
        if (entity.find("ifcconversionbasedunit") != std::string::npos) {
            if (entity.find("'foot'") != std::string::npos) d.unit = {0.3048, "ft"};
            if (entity.find("'inch'") != std::string::npos) d.unit = {0.0254, "in"};
            d.declared = d.unit.label != "m";
            d.what = "IFCCONVERSIONBASEDUNIT";
            return d;
        }
    }
    return d;
}

// ---------------------------------------------------------------------------------------------
// Scenes

enum class Flavor { kGltf, kCollada, kFbx, kDxf, kIfc, k3ds, kOther };

/// Which Assimp importer read the scene (its SourceAsset_Format), else the extension.
Flavor flavor_of(const aiScene& scene, const std::string& ext) {
    aiString format;
    std::string f;
    if (scene.mMetaData != nullptr && scene.mMetaData->Get("SourceAsset_Format", format)) {
        f = lower(format.C_Str());
    }
    if (f.find("gltf") != std::string::npos) return Flavor::kGltf;
    if (f.find("collada") != std::string::npos) return Flavor::kCollada;
    if (f.find("fbx") != std::string::npos) return Flavor::kFbx;
    if (f.find("dxf") != std::string::npos) return Flavor::kDxf;
    if (f.find("ifc") != std::string::npos) return Flavor::kIfc;
    if (f.find("3ds") != std::string::npos) return Flavor::k3ds;
    if (!f.empty()) return Flavor::kOther;
    if (ext == "gltf" || ext == "glb") return Flavor::kGltf;
    if (ext == "dae") return Flavor::kCollada;
    if (ext == "fbx") return Flavor::kFbx;
    if (ext == "dxf") return Flavor::kDxf;
    if (ext == "ifc") return Flavor::kIfc;
    if (ext == "3ds") return Flavor::k3ds;
    return Flavor::kOther;
}

/// A numeric scene metadata entry of any numeric type.
std::optional<double> metadata_number(const aiScene& scene, const char* key) {
    const aiMetadata* md = scene.mMetaData;
    if (md == nullptr) return std::nullopt;
    const aiMetadataEntry* e = nullptr;
    for (unsigned i = 0; i < md->mNumProperties; ++i) {
        if (std::string_view(md->mKeys[i].C_Str()) == key) e = &md->mValues[i];
    }
    if (e == nullptr || e->mData == nullptr) return std::nullopt;
    switch (e->mType) {
        case AI_BOOL:
            return *static_cast<const bool*>(e->mData) ? 1.0 : 0.0;
        case AI_INT32:
            return static_cast<double>(*static_cast<const std::int32_t*>(e->mData));
        case AI_UINT64:
            return static_cast<double>(*static_cast<const std::uint64_t*>(e->mData));
        case AI_FLOAT:
            return static_cast<double>(*static_cast<const float*>(e->mData));
        case AI_DOUBLE:
            return *static_cast<const double*>(e->mData);
        default:
            return std::nullopt;
    }
}

glm::dmat4 to_dmat4(const aiMatrix4x4& m) {
    glm::dmat4 r(1.0);
    for (unsigned row = 0; row < 4; ++row) {
        for (unsigned col = 0; col < 4; ++col) {
            r[static_cast<int>(col)][static_cast<int>(row)] = static_cast<double>(m[row][col]);
        }
    }
    return r;
}

/// (x, y, z) -> (x, -z, y): a Y-up frame to Z up.
glm::dmat4 y_up_to_z_up() {
    glm::dmat4 m(0.0);
    m[0][0] = 1.0;   // x -> x
    m[1][2] = 1.0;   // y -> z
    m[2][1] = -1.0;  // z -> -y
    m[3][3] = 1.0;
    return m;
}

/// Collada X_UP (right -Y, up X) to Z up: (x, y, z) -> (-y, -z, x).
glm::dmat4 x_up_to_z_up() {
    glm::dmat4 m(0.0);
    m[0][2] = 1.0;   // x -> z
    m[1][0] = -1.0;  // y -> -x
    m[2][1] = -1.0;  // z -> -y
    m[3][3] = 1.0;
    return m;
}

bool is_synthetic_material(std::string_view name) {
    return name.empty() || name == AI_DEFAULT_MATERIAL_NAME || name == "<IFCDefault>";
}

/// Node names Assimp makes up (roots, IFC relation groups, FBX pivot helpers, glTF ids).
bool is_synthetic_node_name(std::string_view name, Flavor flavor, bool is_root) {
    if (name.empty()) return true;
    if (name.front() == '$' || (name.front() == '<' && name.back() == '>')) return true;
    if (name.find("$AssimpFbx$") != std::string_view::npos) return true;
    if (name == "IfcMappedItem") return true;
    if (flavor == Flavor::k3ds && name.starts_with("3DSMesh_")) return true;  // no hierarchy
    if (is_root && (name == "RootNode" || name == "ROOT" || name == "Scene")) return true;
    if (flavor == Flavor::kGltf && name.starts_with("nodes")) {
        // glTF nodes without a name get their id: "nodes[3]" or "nodes_3"
        std::string_view rest = name.substr(5);
        if (!rest.empty() && (rest.front() == '[' || rest.front() == '_')) rest.remove_prefix(1);
        if (!rest.empty() && rest.back() == ']') rest.remove_suffix(1);
        return !rest.empty() && std::all_of(rest.begin(), rest.end(), [](char c) {
            return std::isdigit(static_cast<unsigned char>(c)) != 0;
        });
    }
    return false;
}

/// An IFC product node "IfcType_Name_GlobalId": (type, name); name is the GlobalId when the
/// product is "Unnamed".
std::optional<std::pair<std::string, std::string>> ifc_product(std::string_view node) {
    constexpr std::size_t kGuid = 22;
    if (!node.starts_with("Ifc") || node.size() < 3 + 1 + 1 + kGuid) return std::nullopt;
    const std::size_t type_end = node.find('_');
    if (type_end == std::string_view::npos || node.size() < type_end + 2 + kGuid) {
        return std::nullopt;
    }
    if (node[node.size() - kGuid - 1] != '_') return std::nullopt;
    const std::string_view guid = node.substr(node.size() - kGuid);
    std::string_view name = node.substr(type_end + 1, node.size() - kGuid - 1 - (type_end + 1));
    if (name == "Unnamed" || name.empty()) name = guid;
    return std::make_pair(std::string(node.substr(0, type_end)), std::string(name));
}

/// Converts one aiMaterial into a visdb::Material, with notes on what was changed.
struct MaterialConverter {
    const std::string& file;
    Flavor flavor;
    CappedNotes& clamp_notes;
    CappedNotes& emitter_notes;

    visdb::Material operator()(const aiMaterial& m, const std::string& name) const {
        visdb::Material out;
        out.name = name;
        aiColor4D c;
        bool have = false;
        if (flavor == Flavor::kGltf && m.Get(AI_MATKEY_BASE_COLOR, c) == AI_SUCCESS) have = true;
        if (!have && m.Get(AI_MATKEY_COLOR_DIFFUSE, c) == AI_SUCCESS) have = true;
        if (have) {
            const visdb::Rgb rho{c.r, c.g, c.b};
            const visdb::Rgb clamped = glm::clamp(rho, 0.0, kMaxReflectance);
            if (!(clamped == rho)) {
                clamp_notes.add(located(file, 0,
                                        "material " + quote_name(name) + ": reflectance (" +
                                            format_number(rho.x) + ", " + format_number(rho.y) +
                                            ", " + format_number(rho.z) + ") clamped to [0, " +
                                            format_number(kMaxReflectance) + "]"));
            }
            out.reflectance = clamped;
        }
        if (m.Get(AI_MATKEY_COLOR_EMISSIVE, c) == AI_SUCCESS) {
            double strength = 1.0;
            float intensity = 0.0f;
            if (m.Get(AI_MATKEY_EMISSIVE_INTENSITY, intensity) == AI_SUCCESS && intensity > 0.0f) {
                strength = intensity;
            }
            const visdb::Rgb e = glm::max(visdb::Rgb{c.r, c.g, c.b} * strength, visdb::Rgb{0.0});
            if (std::isfinite(e.x) && std::isfinite(e.y) && std::isfinite(e.z)) {
                out.emittance = e;
            }
            if (e.x > visdb::kMaxEmittance || e.y > visdb::kMaxEmittance ||
                e.z > visdb::kMaxEmittance) {
                throw ImportError(file, 0,
                                  "material " + quote_name(name) + ": emissive colour (" +
                                      format_number(e.x) + ", " + format_number(e.y) + ", " +
                                      format_number(e.z) +
                                      ") over 1e10 W/m2, the most abrad bakes");
            }
            if (out.is_emitter()) {
                emitter_notes.add(located(file, 0,
                                          "material " + quote_name(name) + ": emissive colour (" +
                                              format_number(e.x) + ", " + format_number(e.y) +
                                              ", " + format_number(e.z) +
                                              ") taken as emittance in W/m²"));
            }
        }
        float opacity = 1.0f;
        if (m.Get(AI_MATKEY_OPACITY, opacity) == AI_SUCCESS) {
            out.opacity = opacity;
        } else if (m.Get(AI_MATKEY_TRANSPARENCYFACTOR, opacity) == AI_SUCCESS) {
            out.opacity = 1.0 - static_cast<double>(opacity);
        }
        if (!(out.opacity >= 0.0 && out.opacity <= 1.0)) {
            const double a = std::isfinite(out.opacity) ? std::clamp(out.opacity, 0.0, 1.0) : 1.0;
            clamp_notes.add(located(file, 0,
                                    "material " + quote_name(name) + ": opacity " +
                                        format_number(out.opacity) + " clamped to " +
                                        format_number(a)));
            out.opacity = a;
        }
        if (!std::isfinite(out.reflectance.x + out.reflectance.y + out.reflectance.z)) {
            out.reflectance = visdb::Material{}.reflectance;
        }
        return out;
    }
};

}  // namespace

// ---------------------------------------------------------------------------------------------

namespace {

/// What abrad does to a file before Assimp sees it.
struct BeforeAssimp {
    std::optional<std::vector<DxfPair>> dxf;  ///< a DXF's group pairs (ASCII DXF only)
    std::optional<std::string> dxf_expanded;  ///< the DXF with its INSERTs expanded
};

/// The checks and rewrites before Assimp: PLY walked, GLB chunk lengths, IFC end marker, DXF
/// pairs, POLYLINE counts and INSERT expansion. Throws ImportError on what they refuse.
BeforeAssimp check_and_expand(std::string_view bytes, const std::string& ext,
                              const std::string& file, std::vector<std::string>& notes) {
    // PLY: Assimp's reader hangs or crashes on damaged files, so they are checked first
    if (bytes.starts_with("ply") || bytes.starts_with("PLY")) check_ply(bytes, file);
    // GLB: Assimp allocates what a chunk claims before reading it
    if (bytes.starts_with("glTF")) check_glb(bytes, file);
    // glTF: Assimp names no place in a broken JSON file
    if (ext == "gltf") check_gltf_json(bytes, file);
    // Collada: Assimp reads fractional indices into a huge allocation
    if (ext == "dae" || bytes.substr(0, 1024).find("<COLLADA") != std::string_view::npos) {
        check_collada_xml(bytes, file);  // Assimp says only "malformed XML"
        check_collada(bytes, file);
    }
    // 3DS: Assimp says only "Chunk is too large"
    if (ext == "3ds") check_3ds_chunks(bytes, file);
    // IFC (STEP): Assimp reads a truncated file without a word, minus what was cut off
    if (bytes.starts_with("ISO-10303-21") &&
        !trim(std::string_view(bytes).substr(bytes.size() -
                                             std::min<std::size_t>(bytes.size(), 256)))
             .ends_with("END-ISO-10303-21;")) {
        throw ImportError(file, 0, "no END-ISO-10303-21; at the end (truncated file?)");
    }

    // DXF: expand INSERTs ourselves (see the top of this file), read $INSUNITS
    BeforeAssimp before;
    std::optional<std::vector<DxfPair>>& dxf = before.dxf;
    if (ext == "dxf") {
        dxf = dxf_pairs(bytes, file);
        if (dxf) {
            if (dxf->empty() || dxf->back().code != 0 || dxf->back().value != "EOF") {
                notes.push_back(located(file, 0,
                                        "no EOF at the end of the file: it may be truncated "
                                        "and the model incomplete"));
            }
            check_dxf_polyline_counts(*dxf, file);
            before.dxf_expanded = expand_dxf_inserts(*dxf, file, notes);
        }
    }
    return before;
}

/// "FILE: mesh 'Wall' face 12" for the Assimp reader's places: (instance + 1) << 32 | face,
/// where `labels[instance]` names the mesh instance.
std::function<std::string(std::size_t)> assimp_places(
    const std::string& file, std::shared_ptr<const std::vector<std::string>> labels) {
    return [file, labels = std::move(labels)](std::size_t place) {
        const std::size_t instance = place >> 32;
        if (instance == 0 || instance > labels->size()) return std::string(file);  // a copy
        const std::size_t face = place & 0xffffffffULL;
        return located(file, 0, (*labels)[instance - 1] + " face " + std::to_string(face));
    };
}

/// The format's name for messages ("glTF"), from the model format table, else the extension.
std::string format_name(const std::filesystem::path& path) {
    std::string ext = lower(path.extension().string());
    if (!ext.empty() && ext.front() == '.') ext.erase(0, 1);
    for (const ModelFormat& f : model_formats()) {
        if (std::find(f.extensions.begin(), f.extensions.end(), ext) != f.extensions.end())
            return f.name;
    }
    return ext.empty() ? std::string("model") : ext;
}

/// The line of the DXF value Assimp could not parse, when its message quotes one ("Cannot
/// parse string "abc" as a real number"): the first pair with a numeric group code (10-59,
/// 60-99, 110-149, 160-179, 210-239, 270-289, 370-389, 1010-1071) and that value; 0 if none.
std::size_t dxf_value_line(const std::vector<DxfPair>& pairs, const std::string& message) {
    const std::size_t open = message.find('"');
    const std::size_t close = open == std::string::npos ? open : message.find('"', open + 1);
    if (close == std::string::npos) return 0;
    const std::string_view value =
        trim(std::string_view(message).substr(open + 1, close - open - 1));
    const auto numeric = [](int c) {
        return (c >= 10 && c <= 99) || (c >= 110 && c <= 149) || (c >= 160 && c <= 179) ||
               (c >= 210 && c <= 239) || (c >= 270 && c <= 289) || (c >= 370 && c <= 389) ||
               (c >= 1010 && c <= 1071);
    };
    for (const DxfPair& p : pairs)
        if (numeric(p.code) && p.value == value) return p.line + 1;
    return 0;
}

/// read_assimp in this process; `labels` gets the mesh instances' labels (assimp_places).
RawModel read_assimp_here(const std::filesystem::path& path, const ImportOptions& options,
                          std::vector<std::string>& notes, std::vector<std::string>& labels) {
    const std::string file = path.string();
    const std::string bytes = read_file_bytes(path, file, "file");
    if (bytes.empty()) throw ImportError(file, 0, "empty file");
    std::string ext = lower(path.extension().string());
    if (!ext.empty() && ext.front() == '.') ext.erase(0, 1);

    RawModel raw;
    raw.file = file;
    const BeforeAssimp before = check_and_expand(bytes, ext, file, notes);
    const std::optional<std::vector<DxfPair>>& dxf = before.dxf;
    const std::optional<std::string>& dxf_expanded = before.dxf_expanded;

    // Read the scene, with Assimp's log collected instead of printed
    Assimp::Importer importer;
    importer.SetPropertyBool(AI_CONFIG_IMPORT_COLLADA_IGNORE_UP_DIRECTION, true);
    importer.SetPropertyBool(AI_CONFIG_IMPORT_COLLADA_USE_COLLADA_NAMES, true);
    importer.SetPropertyBool(AI_CONFIG_IMPORT_FBX_PRESERVE_PIVOTS, false);
    importer.SetPropertyBool(AI_CONFIG_FBX_CONVERT_TO_M, false);
    // The importer owns (and deletes) its IO handler
    auto* io = new GuardedIOSystem(path, options.allow_outside_refs);
    importer.SetIOHandler(io);
    std::vector<std::string> log;
    const aiScene* scene = nullptr;
    {
        LoggerScope logger(log);
        try {
            if (dxf_expanded) {
                scene = importer.ReadFileFromMemory(dxf_expanded->data(), dxf_expanded->size(),
                                                    aiProcess_ValidateDataStructure, "dxf");
            } else {
                scene = importer.ReadFile(file, aiProcess_ValidateDataStructure);
            }
        } catch (const std::exception& e) {
            if (io->refusal()) throw *io->refusal();
            const std::string message = clean_message(e.what(), file);
            throw ImportError(file, dxf ? dxf_value_line(*dxf, message) : 0,
                              "cannot read as " + format_name(path) + ": " + message);
        }
    }
    if (io->refusal()) throw *io->refusal();
    if (scene == nullptr || scene->mRootNode == nullptr) {
        std::string message = clean_message(importer.GetErrorString(), file);
        if (message.empty()) message = "Assimp could not read it";
        throw ImportError(file, dxf ? dxf_value_line(*dxf, message) : 0,
                          "cannot read as " + format_name(path) + ": " + message);
    }
    for (const std::string& entry : log) {
        if (entry.find("out-of-range") != std::string::npos ||
            entry.find("out of range") != std::string::npos) {
            throw ImportError(
                file, 0,
                "vertex indices out of range (Assimp: " + clean_message(entry, file) + ")");
        }
    }
    const Flavor flavor = flavor_of(*scene, ext);

    // Unit the numbers are in, and what Assimp already applied
    DeclaredUnit declared;
    switch (flavor) {
        case Flavor::kGltf:
            declared.unit = {1.0, "m"};  // glTF is metres by specification
            declared.declared = true;
            declared.what = "glTF (metres by specification)";
            break;
        case Flavor::kCollada: {
            const ColladaAsset asset = collada_asset(bytes);
            if (asset.meter) {
                declared.unit = unit_from_metres(*asset.meter);
                declared.declared = true;
                declared.applied = *asset.meter;
                declared.what = "<unit meter=\"" + format_number(*asset.meter) + "\">";
            }
            break;
        }
        case Flavor::kFbx:
            if (const std::optional<double> f = metadata_number(*scene, "UnitScaleFactor");
                f && *f > 0.0) {
                declared.unit = unit_from_metres(*f / 100.0);  // centimetres per unit
                declared.declared = true;
                declared.what = "UnitScaleFactor " + format_number(*f);
            }
            break;
        case Flavor::kDxf:
            if (dxf) declared = dxf_declared_unit(*dxf);
            break;
        case Flavor::kIfc:
            declared = ifc_declared_unit(bytes);
            break;
        default:
            break;
    }
    if (declared.applied != 1.0) {
        // The factor Assimp applied is a float in the root transform: take it from there (its
        // first column's length) so that dividing it out is exact
        const aiMatrix4x4& r = scene->mRootNode->mTransformation;
        const double len =
            std::sqrt(static_cast<double>(r.a1) * r.a1 + static_cast<double>(r.b1) * r.b1 +
                      static_cast<double>(r.c1) * r.c1);
        if (std::abs(len - declared.applied) <= 1e-6 * declared.applied) declared.applied = len;
    }
    Unit unit = declared.unit;
    if (!options.unit.empty()) {
        unit = unit_from_metres(metres_per_unit(options.unit));
        unit.label = options.unit;
        if (declared.declared && declared.unit.label != unit.label) {
            notes.push_back(located(file, 0,
                                    "the file declares its unit as " + declared.unit.label + " (" +
                                        declared.what + "); " + unit.label + " used as given"));
        }
    }
    const double scale = unit.metres / declared.applied;

    // Frame: undo Assimp's own Z-up -> Y-up rotation, then the file's up axis
    glm::dmat4 undo(1.0);
    if (flavor == Flavor::k3ds || flavor == Flavor::kDxf) {
        undo = y_up_to_z_up();  // Assimp's root rotation is exactly its inverse
    } else if (flavor == Flavor::kIfc) {
        aiMatrix4x4 rot;
        aiMatrix4x4::RotationX(-AI_MATH_HALF_PI_F, rot);  // as IFCLoader.cpp does, in float
        undo = glm::transpose(to_dmat4(rot));
    }
    char declared_up = 'z';
    std::string up_note;
    if (flavor == Flavor::kGltf) declared_up = 'y';
    if (flavor == Flavor::kCollada) declared_up = collada_asset(bytes).up;
    if (flavor == Flavor::kFbx) {
        const double axis = metadata_number(*scene, "UpAxis").value_or(1.0);
        const double sign = metadata_number(*scene, "UpAxisSign").value_or(1.0);
        declared_up = axis == 2.0 ? 'z' : 'y';
        if ((axis != 1.0 && axis != 2.0) || sign < 0.0) {
            up_note = "FBX UpAxis " + format_number(axis) + " sign " + format_number(sign) +
                      " not supported; taken as " + std::string(1, declared_up) + " up";
        }
    }
    const char up = options.up != 0 ? options.up : declared_up;
    if (!up_note.empty() && options.up == 0) notes.push_back(located(file, 0, up_note));
    glm::dmat4 axes(1.0);
    if (up == 'y') axes = y_up_to_z_up();
    if (up == 'x') axes = x_up_to_z_up();
    glm::dmat4 global_scaled = axes * undo;  // then the unit scale (not on w)
    for (int c = 0; c < 3; ++c) global_scaled[c] *= scale;

    // Walk the node tree: every mesh instance with its node's accumulated transform
    struct Frame {
        const aiNode* node;
        glm::dmat4 world;
        std::string object;  ///< nearest named node (IFC: product name); empty if none
        std::string layer;   ///< IFC entity type
    };
    std::vector<std::string>& instances = labels;  // "mesh 'NAME'" or "mesh #3 in 'OBJECT'"
    std::map<std::tuple<std::string, std::string, std::string>, std::uint32_t> slot_index;
    std::unordered_map<std::string, std::size_t> material_index;  // name -> raw.materials
    std::vector<std::optional<std::string>> material_name(scene->mNumMaterials);
    CappedNotes clamp_notes(notes, "materials clamped");
    CappedNotes emitter_notes(notes, "emitting materials");
    CappedNotes redefined_notes(notes, "materials defined again");
    const MaterialConverter convert_material{file, flavor, clamp_notes, emitter_notes};
    std::vector<visdb::Material> converted(scene->mNumMaterials);
    std::size_t points = 0;
    std::size_t lines = 0;
    std::size_t empty = 0;  // faces without corners (damaged PLY files give them)
    const std::string stem = path.stem().string();

    const auto material_of = [&](unsigned index) -> const std::string& {
        std::optional<std::string>& name = material_name[index];
        if (name) return *name;
        const aiMaterial& m = *scene->mMaterials[index];
        aiString ai_name;
        m.Get(AI_MATKEY_NAME, ai_name);
        const std::string_view n(ai_name.C_Str());
        if (is_synthetic_material(n)) {
            name = kDefaultMaterialName;
            converted[index] = visdb::Material{};
            converted[index].name = kDefaultMaterialName;
        } else {
            name = std::string(n);
            converted[index] = convert_material(m, *name);
        }
        const auto [it, added] = material_index.try_emplace(*name, raw.materials.size());
        if (added) {
            raw.materials.push_back(converted[index]);
        } else {
            const visdb::Material& first = raw.materials[it->second];
            if (first.reflectance != converted[index].reflectance ||
                first.emittance != converted[index].emittance ||
                first.opacity != converted[index].opacity) {
                redefined_notes.add(located(file, 0,
                                            "material " + quote_name(*name) +
                                                " defined again with other values; the first "
                                                "definition is kept"));
            }
        }
        return *name;
    };

    std::vector<std::uint32_t> local;  // mesh vertex -> raw.positions, per instance
    std::vector<Frame> stack;
    stack.push_back({scene->mRootNode, global_scaled, "", ""});
    while (!stack.empty()) {
        Frame frame = std::move(stack.back());
        stack.pop_back();
        const aiNode& node = *frame.node;
        const glm::dmat4 node_transform = to_dmat4(node.mTransformation);
        frame.world = frame.world * node_transform;
        const std::string_view name(node.mName.C_Str());
        if (flavor == Flavor::kIfc) {
            if (const auto product = ifc_product(name)) {
                frame.layer = product->first;
                frame.object = product->second;
            }
        } else if (!is_synthetic_node_name(name, flavor, node.mParent == nullptr)) {
            frame.object = std::string(name);
        }
        for (unsigned c = node.mNumChildren; c-- > 0;) {
            if (node.mChildren[c] != nullptr) {
                stack.push_back({node.mChildren[c], frame.world, frame.object, frame.layer});
            }
        }
        if (node.mNumMeshes == 0) continue;
        for (int r = 0; r < 4; ++r) {
            for (int c = 0; c < 4; ++c) {
                if (!std::isfinite(frame.world[c][r])) {
                    throw ImportError(file, 0,
                                      "node " + quote_name(name) + " has a non-finite transform");
                }
            }
        }
        const bool mirrored = glm::determinant(glm::dmat3(frame.world)) < 0.0;
        for (unsigned k = 0; k < node.mNumMeshes; ++k) {
            const unsigned mesh_index = node.mMeshes[k];
            const aiMesh& mesh = *scene->mMeshes[mesh_index];
            const std::string mesh_name(mesh.mName.C_Str());
            // 3DS mesh names are Assimp's mesh numbers
            const bool numbered =
                !mesh_name.empty() && std::all_of(mesh_name.begin(), mesh_name.end(), [](char ch) {
                    return std::isdigit(static_cast<unsigned char>(ch)) != 0;
                });
            const bool mesh_named = !mesh_name.empty() && !(flavor == Flavor::k3ds && numbered);
            // Object and layer names of this instance
            std::string object = frame.object;
            std::string layer = frame.layer;
            if (object.empty()) object = mesh_named ? mesh_name : stem;
            if (flavor == Flavor::kDxf) {
                // Assimp names each DXF mesh after the layer its entities are on
                layer = mesh_name;
                object = mesh_name.empty() ? stem : mesh_name;
            }
            const std::string& material = material_of(mesh.mMaterialIndex);
            const std::size_t instance = instances.size();
            std::string label = mesh_name.empty() ? "mesh #" + std::to_string(mesh_index)
                                                  : "mesh " + quote_name(mesh_name);
            if (mesh_name.empty() && !object.empty()) label += " in " + quote_name(object);
            instances.push_back(std::move(label));
            const auto [sit, added] =
                slot_index.try_emplace(std::make_tuple(object, layer, material),
                                       static_cast<std::uint32_t>(raw.slots.size()));
            const std::size_t place_base = (instance + 1) << 32;
            if (added) raw.slots.push_back({object, layer, material, place_base});

            local.assign(mesh.mNumVertices, std::numeric_limits<std::uint32_t>::max());
            for (unsigned f = 0; f < mesh.mNumFaces; ++f) {
                const aiFace& face = mesh.mFaces[f];
                if (face.mNumIndices < 3) {
                    (face.mNumIndices == 1 ? points : face.mNumIndices == 2 ? lines : empty) += 1;
                    continue;
                }
                if (face.mNumIndices > kMaxPolygonCorners) {
                    throw ImportError(file, 0,
                                      instances.back() + " face " + std::to_string(f) + ": " +
                                          too_many_corners(face.mNumIndices));
                }
                const std::size_t first = raw.corners.size();
                for (unsigned i = 0; i < face.mNumIndices; ++i) {
                    const unsigned v = face.mIndices[mirrored ? face.mNumIndices - 1 - i : i];
                    if (v >= mesh.mNumVertices) {  // ValidateDataStructure rejects these
                        throw ImportError(file, 0,
                                          instances.back() + " face " + std::to_string(f) +
                                              ": vertex index out of range");
                    }
                    std::uint32_t& id = local[v];
                    if (id == std::numeric_limits<std::uint32_t>::max()) {
                        const aiVector3D& p = mesh.mVertices[v];
                        const glm::dvec3 w(frame.world * glm::dvec4(p.x, p.y, p.z, 1.0));
                        if (!std::isfinite(w.x) || !std::isfinite(w.y) || !std::isfinite(w.z)) {
                            throw ImportError(
                                file, 0,
                                "mesh " + quote_name(mesh_name) + " vertex " + std::to_string(v) +
                                    ": coordinates are not finite (" + format_number(p.x) + ", " +
                                    format_number(p.y) + ", " + format_number(p.z) + ")");
                        }
                        if (raw.positions.size() >= std::numeric_limits<std::uint32_t>::max()) {
                            throw ImportError(file, 0, "too many vertices (more than 2^32)");
                        }
                        id = static_cast<std::uint32_t>(raw.positions.size());
                        raw.positions.push_back(w);
                    }
                    raw.corners.push_back(id);
                }
                raw.faces.push_back({place_base | f, sit->second, first, face.mNumIndices});
            }
        }
    }
    clamp_notes.finish(file);
    emitter_notes.finish(file);
    redefined_notes.finish(file);

    if (points + lines > 0) {
        notes.push_back(located(file, 0,
                                std::to_string(points) + " point and " + std::to_string(lines) +
                                    " line primitive(s) skipped (only polygons are imported)"));
    }
    if (empty > 0) {
        notes.push_back(
            located(file, 0, std::to_string(empty) + " face(s) without corners skipped"));
    }
    if (raw.faces.empty()) throw ImportError(file, 0, "no faces to import");

    // Assimp's warnings: each distinct one once, the first few shown
    {
        std::set<std::string> seen;
        CappedNotes log_notes(notes, "distinct Assimp warnings");
        for (const std::string& entry : log) {
            const std::string m = clean_message(entry, file);
            if (!m.empty() && seen.insert(m).second)
                log_notes.add(located(file, 0, "Assimp: " + m));
        }
        log_notes.finish(file);
    }

    // Cameras, placed by the node of the same name. mHorizontalFOV is documented as the half
    // angle, but the importers we use store the full horizontal angle; glTF stores yfov × aspect.
    for (unsigned i = 0; i < scene->mNumCameras; ++i) {
        const aiCamera& cam = *scene->mCameras[i];
        glm::dmat4 world = global_scaled;
        if (const aiNode* n = scene->mRootNode->FindNode(cam.mName)) {
            std::vector<const aiNode*> chain;
            for (const aiNode* a = n; a != nullptr; a = a->mParent) chain.push_back(a);
            for (auto it = chain.rbegin(); it != chain.rend(); ++it) {
                world = world * to_dmat4((*it)->mTransformation);
            }
        }
        // glTF cameras sit at their node's origin looking down -Z with +Y up; Assimp 5.2 also
        // copies the node translation into mPosition, which would count it twice
        glm::dvec3 position(cam.mPosition.x, cam.mPosition.y, cam.mPosition.z);
        glm::dvec3 look(cam.mLookAt.x, cam.mLookAt.y, cam.mLookAt.z);
        glm::dvec3 cam_up(cam.mUp.x, cam.mUp.y, cam.mUp.z);
        if (flavor == Flavor::kGltf) {
            position = glm::dvec3(0.0);
            look = glm::dvec3(0.0, 0.0, -1.0);
            cam_up = glm::dvec3(0.0, 1.0, 0.0);
        }
        const glm::dmat3 dir(world);
        visdb::Camera out;
        out.name = cam.mName.C_Str();
        out.position = glm::dvec3(world * glm::dvec4(position, 1.0));
        const glm::dvec3 look_dir = dir * look;
        const glm::dvec3 up_dir = dir * cam_up;
        if (glm::length(look_dir) > 0.0) out.look_at = out.position + glm::normalize(look_dir);
        if (glm::length(up_dir) > 0.0) out.up = glm::normalize(up_dir);
        const double aspect = cam.mAspect > 0.0f ? static_cast<double>(cam.mAspect) : 1.0;
        const double hfov = static_cast<double>(cam.mHorizontalFOV);
        double fov_y = 0.0;
        if (flavor == Flavor::kGltf) {
            fov_y = hfov / aspect;
        } else {
            fov_y = 2.0 * std::atan(std::tan(hfov / 2.0) / aspect);
        }
        if (hfov > 0.0 && std::isfinite(fov_y) && fov_y > 0.0 && fov_y < kPi) {
            out.fov_y_deg = fov_y * 180.0 / kPi;
        } else {
            notes.push_back(located(file, 0,
                                    "camera " + quote_name(out.name) +
                                        " has no usable field of view (orthographic?); "
                                        "60 degrees used"));
        }
        const bool finite =
            std::isfinite(out.position.x + out.position.y + out.position.z + out.look_at.x +
                          out.look_at.y + out.look_at.z + out.up.x + out.up.y + out.up.z);
        if (!finite) {
            notes.push_back(located(
                file, 0, "camera " + quote_name(out.name) + " has non-finite placement; ignored"));
            continue;
        }
        raw.cameras.push_back(std::move(out));
    }

    // Lights: not supported (area emitters only)
    if (scene->mNumLights > 0) {
        std::string list;
        for (unsigned i = 0; i < scene->mNumLights && i < CappedNotes::kShown; ++i) {
            if (!list.empty()) list += ", ";
            list += quote_name(scene->mLights[i]->mName.C_Str());
        }
        if (scene->mNumLights > CappedNotes::kShown) list += ", ...";
        notes.push_back(located(file, 0,
                                std::to_string(scene->mNumLights) +
                                    " light(s) in the file ignored: " + list +
                                    "; declare emitters in the scene file"));
    }

    // Where the file came from
    raw.source.path = file;
    raw.source.format = ext;
    raw.source.checksum = fnv1a64_hex(bytes);
    raw.source.size_bytes = bytes.size();
    raw.source.unit = unit.label;
    raw.source.up_axis = std::string(1, up);
    raw.where = assimp_places(file, std::make_shared<std::vector<std::string>>(labels));
    return raw;
}

// ---------------------------------------------------------------------------------------------
// The reader's child process: what it sends back

void put_vec3(ByteWriter& out, const glm::dvec3& v) {
    out.put(v.x);
    out.put(v.y);
    out.put(v.z);
}

glm::dvec3 get_vec3(ByteReader& in) {
    const double x = in.get<double>();
    const double y = in.get<double>();
    return {x, y, in.get<double>()};
}

void put_strings(ByteWriter& out, const std::vector<std::string>& strings) {
    out.put<std::uint64_t>(strings.size());
    for (const std::string& s : strings) out.put_string(s);
}

std::vector<std::string> get_strings(ByteReader& in) {
    std::vector<std::string> strings(in.get_count(sizeof(std::uint64_t)));
    for (std::string& s : strings) s = in.get_string();
    return strings;
}

/// A RawModel (all but `where`), the mesh instances' labels and the notes, as bytes.
std::string encode(const RawModel& raw, const std::vector<std::string>& labels,
                   const std::vector<std::string>& notes) {
    ByteWriter out;
    out.put<std::uint64_t>(raw.positions.size());
    for (const glm::dvec3& p : raw.positions) put_vec3(out, p);
    out.put<std::uint64_t>(raw.corners.size());
    out.bytes().append(reinterpret_cast<const char*>(raw.corners.data()),
                       raw.corners.size() * sizeof(std::uint32_t));
    out.put<std::uint64_t>(raw.faces.size());
    for (const RawFace& f : raw.faces) out.put(f);
    out.put<std::uint64_t>(raw.slots.size());
    for (const RawSlot& s : raw.slots) {
        put_strings(out, {s.name, s.layer, s.material});
        out.put<std::uint64_t>(s.place);
    }
    out.put<std::uint64_t>(raw.materials.size());
    for (const visdb::Material& m : raw.materials) {
        out.put_string(m.name);
        put_vec3(out, m.reflectance);
        put_vec3(out, m.emittance);
        out.put(m.opacity);
    }
    out.put<std::uint64_t>(raw.cameras.size());
    for (const visdb::Camera& c : raw.cameras) {
        out.put_string(c.name);
        put_vec3(out, c.position);
        put_vec3(out, c.look_at);
        put_vec3(out, c.up);
        out.put(c.fov_y_deg);
    }
    const visdb::Source& src = raw.source;
    put_strings(out, {src.path, src.format, src.checksum, src.unit, src.up_axis});
    out.put(src.size_bytes);
    put_strings(out, labels);
    put_strings(out, notes);
    return std::move(out.bytes());
}

/// encode's bytes back; `where` names places in `file`; the notes are appended to `notes`.
RawModel decode(std::string_view bytes, const std::string& file, std::vector<std::string>& notes) {
    ByteReader in(bytes);
    RawModel raw;
    raw.file = file;
    raw.positions.resize(in.get_count(3 * sizeof(double)));
    for (glm::dvec3& p : raw.positions) p = get_vec3(in);
    raw.corners.resize(in.get_count(sizeof(std::uint32_t)));
    for (std::uint32_t& c : raw.corners) c = in.get<std::uint32_t>();
    raw.faces.resize(in.get_count(sizeof(RawFace)));
    for (RawFace& f : raw.faces) f = in.get<RawFace>();
    raw.slots.resize(in.get_count(4 * sizeof(std::uint64_t)));
    for (RawSlot& s : raw.slots) {
        std::vector<std::string> names = get_strings(in);
        if (names.size() != 3) throw ChildFailed("its result was damaged");
        s = {std::move(names[0]), std::move(names[1]), std::move(names[2]),
             in.get<std::uint64_t>()};
    }
    raw.materials.resize(in.get_count(7 * sizeof(double)));
    for (visdb::Material& m : raw.materials) {
        m.name = in.get_string();
        m.reflectance = get_vec3(in);
        m.emittance = get_vec3(in);
        m.opacity = in.get<double>();
    }
    raw.cameras.resize(in.get_count(10 * sizeof(double)));
    for (visdb::Camera& c : raw.cameras) {
        c.name = in.get_string();
        c.position = get_vec3(in);
        c.look_at = get_vec3(in);
        c.up = get_vec3(in);
        c.fov_y_deg = in.get<double>();
    }
    std::vector<std::string> src = get_strings(in);
    if (src.size() != 5) throw ChildFailed("its result was damaged");
    raw.source.path = src[0];
    raw.source.format = src[1];
    raw.source.checksum = src[2];
    raw.source.unit = src[3];
    raw.source.up_axis = src[4];
    raw.source.size_bytes = in.get<std::uint64_t>();
    raw.where = assimp_places(file, std::make_shared<std::vector<std::string>>(get_strings(in)));
    for (std::string& note : get_strings(in)) notes.push_back(std::move(note));
    if (!in.at_end()) throw ChildFailed("its result was damaged");
    return raw;
}

}  // namespace

void check_before_assimp(std::string_view bytes, const std::string& ext, const std::string& file,
                         std::vector<std::string>& notes) {
    (void)check_and_expand(bytes, ext, file, notes);
}

RawModel read_assimp(const std::filesystem::path& path, const ImportOptions& options,
                     std::vector<std::string>& notes) {
    if (!options.unit.empty()) (void)metres_per_unit(options.unit);  // throws invalid_argument
    if (options.up != 0 && options.up != 'y' && options.up != 'z') {
        throw std::invalid_argument(std::string("up axis must be 'y' or 'z', got '") + options.up +
                                    "'");
    }
    const std::string file = path.string();
    // The child's result: 'R' and the model, or 'I' and the ImportError it threw
    const auto work = [&] {
        ByteWriter out;
        try {
            std::vector<std::string> child_notes;
            std::vector<std::string> labels;
            const RawModel raw = read_assimp_here(path, options, child_notes, labels);
            out.put('R');
            out.bytes() += encode(raw, labels, child_notes);
        } catch (const ImportError& e) {
            const std::string prefix = located(e.file(), e.line(), "");
            std::string_view message(e.what());
            if (message.starts_with(prefix)) message.remove_prefix(prefix.size());
            out.put('I');
            put_strings(out, {e.file(), std::string(message)});
            out.put<std::uint64_t>(e.line());
        }
        return std::move(out.bytes());
    };
    try {
        const std::string bytes = run_in_child(work);
        ByteReader in(bytes);
        if (in.get<char>() == 'R') return decode(bytes.substr(1), file, notes);
        const std::vector<std::string> error = get_strings(in);
        if (error.size() != 2) throw ChildFailed("its result was damaged");
        throw ImportError(error[0], in.get<std::uint64_t>(), error[1]);
    } catch (const ChildFailed& e) {
        throw ImportError(file, 0,
                          "the " + format_name(path) + " reader failed (" + e.what() + ")");
    }
}

}  // namespace abrad::convert::detail
