// Wavefront OBJ/MTL import: a strict reader that names FILE:LINE for every bad line, followed by
// reported healing (welding, ear-clipping triangulation after Eberly, "Triangulation by Ear
// Clipping" 2002, and removal of degenerate and duplicate triangles).
//
// We do not use Assimp or tinyobjloader here: both skip or default malformed numbers and
// out-of-range indices silently, and the import contract needs a file and line for each.
//
// Numeric assumptions: welding and duplicate detection compare converted coordinates exactly
// (bit equality, with -0 == +0). Triangulation works in double precision in the polygon's
// Newell plane; its orientation tests are not exact predicates, so polygons that defeat them
// (self-intersecting, collinear runs) fall back to clipping the most convex corner, which
// always yields n - 2 triangles; zero-area ones are dropped and counted afterwards.

#include "abrad/convert/obj_import.h"

#include <algorithm>
#include <array>
#include <bit>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <glm/geometric.hpp>
#include <glm/vec2.hpp>
#include <iterator>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <system_error>
#include <tuple>
#include <unordered_map>
#include <utility>

#include "abrad/visdb/material_check.h"
#include "raw_model.h"

namespace abrad::convert {

using detail::fnv1a64_hex;
using detail::located;
using detail::quote;
using detail::read_file_bytes;
using detail::utc_now_iso8601;

namespace {

constexpr double kMaxReflectance = 0.999;         ///< radiosity needs ρ < 1
constexpr std::size_t kUnknownKeywordNotes = 20;  ///< distinct unknown statements shown
constexpr const char* kDefaultMaterialName = "default";

// ---------------------------------------------------------------------------------------------
// Text input

bool is_blank(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; }

std::string_view trim(std::string_view s) {
    while (!s.empty() && is_blank(s.front())) s.remove_prefix(1);
    while (!s.empty() && is_blank(s.back())) s.remove_suffix(1);
    return s;
}

/// Splits a line at blanks.
void split(std::string_view line, std::vector<std::string_view>& tokens) {
    tokens.clear();
    std::size_t i = 0;
    while (i < line.size()) {
        while (i < line.size() && is_blank(line[i])) ++i;
        const std::size_t start = i;
        while (i < line.size() && !is_blank(line[i])) ++i;
        if (i > start) tokens.push_back(line.substr(start, i - start));
    }
}

/// Everything after the statement keyword, trimmed (names may contain blanks).
std::string_view rest_after_keyword(std::string_view line,
                                    const std::vector<std::string_view>& tokens) {
    if (tokens.size() < 2) return {};
    return trim(line.substr(static_cast<std::size_t>(tokens[1].data() - line.data())));
}

/// Logical lines of an OBJ or MTL file: CRLF or LF endings, a trailing backslash joins the
/// next line, `#` starts a comment, a leading UTF-8 byte order mark is skipped.
class LineReader {
  public:
    explicit LineReader(std::string_view text) : m_text(text) {
        if (m_text.substr(0, 3) == "\xEF\xBB\xBF") m_text.remove_prefix(3);
    }

    /// The next logical line and the number of its first physical line; false at the end.
    bool next(std::string_view& line, std::size_t& line_no) {
        if (m_pos >= m_text.size()) return false;
        line_no = m_line + 1;
        std::string_view physical = take_physical();
        if (!continues(physical)) {
            line = strip_comment(physical);
            return true;
        }
        // Join continuation lines with one blank in place of each backslash
        m_joined.assign(without_backslash(physical));
        while (m_pos < m_text.size()) {
            m_joined += ' ';
            physical = take_physical();
            if (!continues(physical)) {
                m_joined += physical;
                break;
            }
            m_joined += without_backslash(physical);
        }
        line = strip_comment(m_joined);
        return true;
    }

  private:
    std::string_view take_physical() {
        const std::size_t end = m_text.find('\n', m_pos);
        const std::size_t stop = end == std::string_view::npos ? m_text.size() : end;
        std::string_view s = m_text.substr(m_pos, stop - m_pos);
        m_pos = end == std::string_view::npos ? m_text.size() : end + 1;
        ++m_line;
        if (!s.empty() && s.back() == '\r') s.remove_suffix(1);
        return s;
    }

    static bool continues(std::string_view s) {
        const std::string_view t = trim(s);
        return !t.empty() && t.back() == '\\' && t.front() != '#';
    }

    static std::string_view without_backslash(std::string_view s) {
        std::string_view t = trim(s);
        t.remove_suffix(1);
        return t;
    }

    static std::string_view strip_comment(std::string_view s) {
        const std::size_t hash = s.find('#');
        return hash == std::string_view::npos ? s : s.substr(0, hash);
    }

    std::string_view m_text;
    std::size_t m_pos = 0;
    std::size_t m_line = 0;
    std::string m_joined;
};

// ---------------------------------------------------------------------------------------------
// Numbers

enum class NumberStatus { kOk, kMalformed, kNonFinite };

/// Parses a whole token as a decimal floating-point number (std::from_chars: no locale, no
/// trailing junk). A leading '+' is allowed. Overflow is non-finite; underflow gives ±0.
NumberStatus parse_double(std::string_view token, double& value) {
    if (!token.empty() && token.front() == '+') token.remove_prefix(1);
    if (token.empty() || token.front() == '+') return NumberStatus::kMalformed;
    const char* const first = token.data();
    const char* const last = first + token.size();
    double parsed = 0.0;
    const auto [ptr, ec] = std::from_chars(first, last, parsed, std::chars_format::general);
    if (ptr != last) return NumberStatus::kMalformed;
    if (ec == std::errc::result_out_of_range) {
        // Tell overflow from underflow by the sign of the exponent
        const std::size_t e = token.find_first_of("eE");
        if (e != std::string_view::npos && e + 1 < token.size() && token[e + 1] == '-') {
            value = token.front() == '-' ? -0.0 : 0.0;
            return NumberStatus::kOk;
        }
        return NumberStatus::kNonFinite;
    }
    if (ec != std::errc()) return NumberStatus::kMalformed;
    if (!std::isfinite(parsed)) return NumberStatus::kNonFinite;
    value = parsed;
    return NumberStatus::kOk;
}

/// Parses a whole token as a signed decimal integer.
bool parse_integer(std::string_view token, std::int64_t& value) {
    if (!token.empty() && token.front() == '+') token.remove_prefix(1);
    if (token.empty() || token.front() == '+') return false;
    const char* const last = token.data() + token.size();
    const auto [ptr, ec] = std::from_chars(token.data(), last, value);
    return ec == std::errc() && ptr == last;
}

/// Converts file units to metres: exactly x / divisor (mm, cm) or x × factor (in, ft), so that
/// 1234 mm is the double nearest to 1.234 m.
struct UnitScale {
    double factor = 1.0;
    double divisor = 1.0;

    double to_metres(double x) const { return x * factor / divisor; }
};

UnitScale unit_scale(std::string_view unit) {
    if (unit == "mm") return {1.0, 1000.0};
    if (unit == "cm") return {1.0, 100.0};
    return {metres_per_unit(unit), 1.0};
}

// ---------------------------------------------------------------------------------------------
// Notes

/// Statements skipped on purpose: the first occurrence of each keyword is reported with a count.
class IgnoredStatements {
  public:
    void add(std::string_view keyword, std::size_t line) {
        const auto [it, inserted] = m_index.try_emplace(std::string(keyword), m_entries.size());
        if (inserted) {
            m_entries.push_back({std::string(keyword), line, 1});
        } else {
            ++m_entries[it->second].count;
        }
    }

    /// Appends one note per keyword (first line and count) to `notes`.
    void flush(const std::string& file, std::vector<std::string>& notes) const {
        std::size_t unknown_shown = 0;
        std::size_t unknown_hidden = 0;
        for (const Entry& e : m_entries) {
            std::string message;
            if (e.keyword == "l") {
                message = "'l' (polyline) statement ignored";
            } else if (e.keyword == "p") {
                message = "'p' (point) statement ignored";
            } else {
                if (unknown_shown == kUnknownKeywordNotes) {
                    unknown_hidden += e.count;
                    continue;
                }
                ++unknown_shown;
                // A keyword is shown only when it looks like one (not a line of a binary file)
                const bool printable = std::all_of(e.keyword.begin(), e.keyword.end(),
                                                   [](char ch) { return ch > ' ' && ch < 127; });
                message = printable ? "unknown statement " + quote(e.keyword) + " ignored"
                                    : std::string("unknown statement (not text) ignored");
            }
            if (e.count > 1) message += " (" + std::to_string(e.count) + " times, first here)";
            notes.push_back(located(file, e.first_line, message));
        }
        if (unknown_hidden > 0) {
            notes.push_back(located(
                file, 0, std::to_string(unknown_hidden) + " further unknown statements ignored"));
        }
    }

  private:
    struct Entry {
        std::string keyword;
        std::size_t first_line = 0;
        std::size_t count = 0;
    };
    std::unordered_map<std::string, std::size_t> m_index;
    std::vector<Entry> m_entries;
};

// ---------------------------------------------------------------------------------------------
// MTL

/// One material as defined by an MTL file.
struct MtlEntry {
    visdb::Material material;
    bool has_d = false;  ///< `d` given: it wins over `Tr`
    std::string file;
    std::size_t line = 0;
};

/// Materials of every MTL library an OBJ file names, first definition of a name kept.
class MaterialLibrary {
  public:
    /// Reads the library at `path` once. A missing file is a note at the mtllib line; a
    /// malformed one throws ImportError naming the MTL file and line.
    void load(const std::filesystem::path& path, const std::string& obj_file, std::size_t obj_line,
              std::vector<std::string>& notes) {
        const std::string display = path.string();
        if (!m_loaded.insert(display).second) return;
        std::error_code ec;
        if (!std::filesystem::exists(path, ec)) {
            notes.push_back(located(obj_file, obj_line,
                                    "material library " + quote(display) +
                                        " not found; its materials get the default"));
            return;
        }
        const std::string text = read_file_bytes(path, display, "material library");
        parse(text, display, notes);
    }

    const MtlEntry* find(const std::string& name) const {
        const auto it = m_index.find(name);
        return it == m_index.end() ? nullptr : &m_entries[it->second];
    }

  private:
    void parse(std::string_view text, const std::string& file, std::vector<std::string>& out) {
        // Notes are kept apart until the file proves to be a material library: nothing of a
        // file that is not one (a binary, /etc/passwd) may reach the stored import report
        std::vector<std::string> notes;
        bool has_newmtl = false;
        std::size_t first_statement = 0;
        LineReader reader(text);
        std::string_view line;
        std::size_t line_no = 0;
        std::vector<std::string_view> tokens;
        IgnoredStatements ignored;
        MtlEntry scratch;  // receives a redefinition, validated then dropped
        MtlEntry* current = nullptr;
        while (reader.next(line, line_no)) {
            split(line, tokens);
            if (tokens.empty()) continue;
            const std::string_view key = tokens[0];
            if (first_statement == 0) first_statement = line_no;
            if (key == "newmtl") {
                has_newmtl = true;
                const std::string name(rest_after_keyword(line, tokens));
                if (name.empty()) throw ImportError(file, line_no, "newmtl without a name");
                if (const MtlEntry* earlier = find(name)) {
                    notes.push_back(located(
                        file, line_no,
                        "material " + quote(name) + " defined again; the definition at " +
                            earlier->file + ":" + std::to_string(earlier->line) + " is kept"));
                    scratch = MtlEntry{};
                    current = &scratch;
                } else {
                    m_index.emplace(name, m_entries.size());
                    m_entries.push_back({});
                    current = &m_entries.back();
                }
                current->material.name = name;
                current->file = file;
                current->line = line_no;
                continue;
            }
            if (!is_known(key)) {
                ignored.add(key, line_no);
                continue;
            }
            if (current == nullptr) {
                notes.push_back(located(file, line_no, quote(key) + " before any newmtl ignored"));
                continue;
            }
            apply(*current, tokens, file, line_no, notes);
        }
        if (first_statement > 0 && !has_newmtl) {
            throw ImportError(file, 0,
                              "not a material library (no newmtl statement); its content is "
                              "not shown");
        }
        ignored.flush(file, notes);
        out.insert(out.end(), std::make_move_iterator(notes.begin()),
                   std::make_move_iterator(notes.end()));
    }

    static bool is_known(std::string_view key) {
        static constexpr std::array<std::string_view, 23> kKnown = {
            "Kd",    "Ke", "d",         "Tr",   "Ka",   "Ks",    "Ns",    "Ni",
            "illum", "Tf", "sharpness", "bump", "disp", "decal", "refl",  "norm",
            "Pr",    "Pm", "Ps",        "Pc",   "Pcr",  "aniso", "anisor"};
        return key.starts_with("map_") ||
               std::find(kKnown.begin(), kKnown.end(), key) != kKnown.end();
    }

    /// Reads the numbers tokens[from..]; throws with the MTL location on bad ones.
    static std::vector<double> numbers(const std::vector<std::string_view>& tokens,
                                       std::size_t from, const std::string& file,
                                       std::size_t line) {
        std::vector<double> values;
        for (std::size_t i = from; i < tokens.size(); ++i) {
            double v = 0.0;
            switch (parse_double(tokens[i], v)) {
                case NumberStatus::kOk:
                    values.push_back(v);
                    break;
                case NumberStatus::kMalformed:
                    throw ImportError(
                        file, line,
                        "malformed number " + quote(tokens[i]) + " in " + quote(tokens[0]));
                case NumberStatus::kNonFinite:
                    throw ImportError(
                        file, line,
                        "non-finite value " + quote(tokens[i]) + " in " + quote(tokens[0]));
            }
        }
        return values;
    }

    /// An RGB triple given as `r` or `r g b`.
    static visdb::Rgb colour(const std::vector<std::string_view>& tokens, const std::string& file,
                             std::size_t line) {
        if (tokens.size() > 1 && (tokens[1] == "spectral" || tokens[1] == "xyz")) {
            throw ImportError(file, line,
                              quote(tokens[0]) + " " + std::string(tokens[1]) +
                                  " colours are not supported; give linear RGB");
        }
        const std::vector<double> v = numbers(tokens, 1, file, line);
        if (v.size() == 1) return {v[0], v[0], v[0]};
        if (v.size() == 3) return {v[0], v[1], v[2]};
        throw ImportError(
            file, line,
            quote(tokens[0]) + " needs 1 or 3 numbers, got " + std::to_string(v.size()));
    }

    static double scalar(const std::vector<std::string_view>& tokens, std::size_t from,
                         const std::string& file, std::size_t line) {
        const std::vector<double> v = numbers(tokens, from, file, line);
        if (v.size() != 1) {
            throw ImportError(
                file, line, quote(tokens[0]) + " needs 1 number, got " + std::to_string(v.size()));
        }
        return v[0];
    }

    static void apply(MtlEntry& entry, const std::vector<std::string_view>& tokens,
                      const std::string& file, std::size_t line, std::vector<std::string>& notes) {
        const std::string_view key = tokens[0];
        visdb::Material& m = entry.material;
        if (key == "Kd") {
            visdb::Rgb rho = colour(tokens, file, line);
            if (rho.x < 0.0 || rho.y < 0.0 || rho.z < 0.0) {
                throw ImportError(file, line, "Kd (reflectance) must not be negative");
            }
            if (rho.x > kMaxReflectance || rho.y > kMaxReflectance || rho.z > kMaxReflectance) {
                rho = glm::min(rho, visdb::Rgb(kMaxReflectance));
                notes.push_back(located(file, line,
                                        "reflectance of " + quote(m.name) +
                                            " clamped to 0.999 (radiosity needs Kd < 1)"));
            }
            m.reflectance = rho;
        } else if (key == "Ke") {
            const visdb::Rgb e = colour(tokens, file, line);
            if (e.x < 0.0 || e.y < 0.0 || e.z < 0.0) {
                throw ImportError(file, line, "Ke (emittance) must not be negative");
            }
            if (e.x > visdb::kMaxEmittance || e.y > visdb::kMaxEmittance ||
                e.z > visdb::kMaxEmittance) {
                throw ImportError(file, line,
                                  "Ke (emittance) over 1e10 W/m2, the most abrad bakes (the "
                                  "sun's surface is 6.3e7)");
            }
            m.emittance = e;
        } else if (key == "d") {
            const std::size_t from = tokens.size() > 1 && tokens[1] == "-halo" ? 2 : 1;
            const double d = scalar(tokens, from, file, line);
            if (d < 0.0 || d > 1.0) throw ImportError(file, line, "d must be in [0, 1]");
            m.opacity = d;
            entry.has_d = true;
        } else if (key == "Tr") {
            const double tr = scalar(tokens, 1, file, line);
            if (tr < 0.0 || tr > 1.0) throw ImportError(file, line, "Tr must be in [0, 1]");
            if (!entry.has_d) {
                m.opacity = 1.0 - tr;
                if (tr == 1.0) {
                    notes.push_back(located(file, line,
                                            "Tr 1 makes " + quote(m.name) +
                                                " fully transparent (some exporters write Tr "
                                                "as opacity; give d to be sure)"));
                }
            }
        } else if (key == "Ka" || key == "Ks" || key == "Tf") {
            // Accepted and ignored; numbers are still checked
            if (tokens.size() > 1 && (tokens[1] == "spectral" || tokens[1] == "xyz")) return;
            const std::vector<double> v = numbers(tokens, 1, file, line);
            if (v.size() != 1 && v.size() != 3) {
                throw ImportError(
                    file, line,
                    quote(key) + " needs 1 or 3 numbers, got " + std::to_string(v.size()));
            }
        } else if (key == "Ns" || key == "Ni" || key == "illum" || key == "sharpness" ||
                   key == "Pr" || key == "Pm" || key == "Ps" || key == "Pc" || key == "Pcr" ||
                   key == "aniso" || key == "anisor") {
            (void)scalar(tokens, 1, file, line);
        }
        // map_*, bump, disp, decal, refl, norm: texture statements, accepted and ignored
    }

    std::unordered_map<std::string, std::size_t> m_index;
    std::vector<MtlEntry> m_entries;
    std::set<std::string> m_loaded;
};

// ---------------------------------------------------------------------------------------------
// OBJ

/// One `f` statement: its corners are `corners[first, first + count)`, file vertex indices.
struct FaceRecord {
    std::size_t line = 0;
    std::uint32_t slot = 0;
    std::size_t first = 0;
    std::uint32_t count = 0;
};

/// A face that refers to a vertex, texture coordinate or normal defined later in the file.
struct ForwardReference {
    std::size_t line = 0;
    std::uint64_t max_v = 0;
    std::uint64_t max_vt = 0;
    std::uint64_t max_vn = 0;
};

/// An (object/group, material) pair: one future visdb::Surface.
struct Slot {
    std::string name;
    std::string layer;
    std::string material;
    std::size_t first_line = 0;
};

/// Everything the OBJ statements say, before healing.
struct ObjData {
    std::vector<glm::dvec3> positions;  ///< metres, Z up
    std::size_t texcoords = 0;
    std::size_t normals = 0;
    std::vector<std::uint32_t> corners;
    std::vector<FaceRecord> faces;
    std::vector<ForwardReference> forward;
    std::vector<Slot> slots;
    std::vector<std::pair<std::string, std::size_t>> usemtl;  ///< name, first line
    std::size_t first_face_without_usemtl = 0;                ///< line, 0 if none
};

class ObjParser {
  public:
    ObjParser(std::string file, std::filesystem::path directory, std::string stem, UnitScale scale,
              char up, bool allow_outside_refs, MaterialLibrary& library,
              std::vector<std::string>& notes)
        : m_file(std::move(file)),
          m_directory(std::move(directory)),
          m_allow_outside_refs(allow_outside_refs),
          m_stem(std::move(stem)),
          m_scale(scale),
          m_up(up),
          m_library(library),
          m_notes(notes) {}

    ObjData parse(std::string_view text) {
        LineReader reader(text);
        std::string_view line;
        std::size_t line_no = 0;
        std::vector<std::string_view> tokens;
        while (reader.next(line, line_no)) {
            split(line, tokens);
            if (tokens.empty()) continue;
            const std::string_view key = tokens[0];
            if (key == "v") {
                read_vertex(tokens, line_no);
            } else if (key == "vt") {
                ++m_data.texcoords;
            } else if (key == "vn") {
                ++m_data.normals;
            } else if (key == "f") {
                read_face(tokens, line_no);
            } else if (key == "o") {
                m_object = std::string(rest_after_keyword(line, tokens));
                m_group.clear();  // a new object starts outside any group
                m_slot_valid = false;
            } else if (key == "g") {
                m_group = tokens.size() > 1 ? std::string(tokens[1]) : std::string();
                m_slot_valid = false;
            } else if (key == "usemtl") {
                set_material(std::string(rest_after_keyword(line, tokens)), line_no);
            } else if (key == "mtllib") {
                for (std::size_t i = 1; i < tokens.size(); ++i) {
                    const std::filesystem::path name{std::string(tokens[i])};
                    const std::filesystem::path path =
                        name.is_absolute() ? name : m_directory / name;
                    if (!m_allow_outside_refs) {
                        detail::check_reference_inside(path, std::filesystem::path(m_file), m_file,
                                                       line_no, "material library");
                    }
                    m_library.load(path, m_file, line_no, m_notes);
                }
            } else if (key == "s") {
                // smoothing groups do not matter to a diffuse bake
            } else {
                m_ignored.add(key, line_no);  // l, p and unknown statements
            }
        }
        m_ignored.flush(m_file, m_notes);
        check_forward_references();
        return std::move(m_data);
    }

  private:
    [[noreturn]] void fail(std::size_t line, const std::string& message) const {
        throw ImportError(m_file, line, message);
    }

    void read_vertex(const std::vector<std::string_view>& tokens, std::size_t line) {
        const std::size_t values = tokens.size() - 1;
        if (values < 3) {
            fail(line,
                 "too few coordinates on 'v' (need x y z, got " + std::to_string(values) + ")");
        }
        if (values > 7) {
            fail(line,
                 "too many values on 'v' (x y z [w] [r g b], got " + std::to_string(values) + ")");
        }
        std::array<double, 7> v{};
        for (std::size_t i = 0; i < values; ++i) {
            switch (parse_double(tokens[i + 1], v[i])) {
                case NumberStatus::kOk:
                    break;
                case NumberStatus::kMalformed:
                    fail(line, "malformed number " + quote(tokens[i + 1]));
                case NumberStatus::kNonFinite:
                    fail(line, "non-finite coordinate " + quote(tokens[i + 1]));
            }
        }
        if (m_data.positions.size() == std::numeric_limits<std::uint32_t>::max()) {
            fail(line, "too many vertices (more than 2^32 - 1)");
        }
        // Convert to metres, then rotate a Y-up file to Z up
        const glm::dvec3 p{m_scale.to_metres(v[0]), m_scale.to_metres(v[1]),
                           m_scale.to_metres(v[2])};
        m_data.positions.push_back(m_up == 'y' ? glm::dvec3{p.x, -p.z, p.y} : p);
    }

    /// Resolves one index of a face corner; 0-based result. Positive indices beyond the
    /// elements read so far are allowed here and checked at the end of the file.
    std::uint64_t resolve(std::string_view text, std::string_view corner, std::size_t defined,
                          const char* what, std::size_t line, std::uint64_t& max_forward) const {
        std::int64_t index = 0;
        if (!parse_integer(text, index)) {
            fail(line, "malformed " + std::string(what) + " index " + quote(text) +
                           " in face corner " + quote(corner));
        }
        if (index == 0) {
            fail(line, std::string(what) + " index 0 in face corner " + quote(corner) +
                           " (OBJ indices start at 1)");
        }
        if (index < 0) {
            // Relative index: counts back from the last element read so far
            const std::uint64_t back = static_cast<std::uint64_t>(-(index + 1)) + 1;
            if (back > defined) {
                fail(line, std::string(what) + " index " + std::to_string(index) +
                               " out of range (" + std::to_string(defined) + " defined above)");
            }
            return defined - back;
        }
        const auto one_based = static_cast<std::uint64_t>(index);
        if (one_based > std::numeric_limits<std::uint32_t>::max()) {
            fail(line, std::string(what) + " index " + std::to_string(index) + " out of range");
        }
        if (one_based > defined) max_forward = std::max(max_forward, one_based);
        return one_based - 1;
    }

    void read_face(const std::vector<std::string_view>& tokens, std::size_t line) {
        const std::size_t n = tokens.size() - 1;
        if (n < 3) {
            fail(line, "face with " + std::to_string(n) + " vertices (at least 3 needed)");
        }
        if (n > detail::kMaxPolygonCorners) fail(line, detail::too_many_corners(n));
        ForwardReference forward{line, 0, 0, 0};
        const std::size_t first = m_data.corners.size();
        for (std::size_t i = 1; i <= n; ++i) {
            const std::string_view corner = tokens[i];
            // Split v[/vt[/vn]] at its slashes
            std::array<std::string_view, 3> part{};
            std::size_t parts = 0;
            std::size_t start = 0;
            while (true) {
                const std::size_t slash = corner.find('/', start);
                if (parts == 3) fail(line, "malformed face corner " + quote(corner));
                part[parts++] =
                    corner.substr(start, slash == std::string_view::npos ? std::string_view::npos
                                                                         : slash - start);
                if (slash == std::string_view::npos) break;
                start = slash + 1;
            }
            const bool well_formed = !part[0].empty() && (parts != 2 || !part[1].empty()) &&
                                     (parts != 3 || !part[2].empty());
            if (!well_formed) {
                fail(line, "malformed face corner " + quote(corner) +
                               " (expected v, v/vt, v//vn or v/vt/vn)");
            }
            const std::uint64_t v =
                resolve(part[0], corner, m_data.positions.size(), "vertex", line, forward.max_v);
            if (parts >= 2 && !part[1].empty()) {
                (void)resolve(part[1], corner, m_data.texcoords, "texture coordinate", line,
                              forward.max_vt);
            }
            if (parts == 3) {
                (void)resolve(part[2], corner, m_data.normals, "normal", line, forward.max_vn);
            }
            m_data.corners.push_back(static_cast<std::uint32_t>(v));
        }
        if (forward.max_v > 0 || forward.max_vt > 0 || forward.max_vn > 0) {
            m_data.forward.push_back(forward);
        }
        m_data.faces.push_back({line, current_slot(line), first, static_cast<std::uint32_t>(n)});
        if (m_material.empty() && m_data.first_face_without_usemtl == 0) {
            m_data.first_face_without_usemtl = line;
        }
    }

    void set_material(std::string name, std::size_t line) {
        if (name.empty()) name = kDefaultMaterialName;
        const bool seen = std::any_of(m_data.usemtl.begin(), m_data.usemtl.end(),
                                      [&](const auto& u) { return u.first == name; });
        if (!seen) m_data.usemtl.emplace_back(name, line);
        m_material = std::move(name);
        m_slot_valid = false;
    }

    std::uint32_t current_slot(std::size_t line) {
        if (m_slot_valid) return m_slot;
        // Surface name: object, else group, else file stem; the group is the layer when both
        Slot key;
        if (!m_object.empty()) {
            key.name = m_object;
            key.layer = m_group;
        } else {
            key.name = m_group.empty() ? m_stem : m_group;
        }
        key.material = m_material.empty() ? std::string(kDefaultMaterialName) : m_material;
        const auto [it, inserted] =
            m_slot_index.try_emplace(std::tie(key.name, key.layer, key.material),
                                     static_cast<std::uint32_t>(m_data.slots.size()));
        if (inserted) {
            key.first_line = line;
            m_data.slots.push_back(std::move(key));
        }
        m_slot = it->second;
        m_slot_valid = true;
        return m_slot;
    }

    void check_forward_references() const {
        for (const ForwardReference& f : m_data.forward) {
            if (f.max_v > m_data.positions.size()) {
                fail(f.line, "vertex index " + std::to_string(f.max_v) + " out of range (" +
                                 std::to_string(m_data.positions.size()) + " vertices in file)");
            }
            if (f.max_vt > m_data.texcoords) {
                fail(f.line, "texture coordinate index " + std::to_string(f.max_vt) +
                                 " out of range (" + std::to_string(m_data.texcoords) +
                                 " in file)");
            }
            if (f.max_vn > m_data.normals) {
                fail(f.line, "normal index " + std::to_string(f.max_vn) + " out of range (" +
                                 std::to_string(m_data.normals) + " in file)");
            }
        }
    }

    std::string m_file;
    std::filesystem::path m_directory;
    bool m_allow_outside_refs = false;
    std::string m_stem;
    UnitScale m_scale;
    char m_up;
    MaterialLibrary& m_library;
    std::vector<std::string>& m_notes;
    ObjData m_data;
    IgnoredStatements m_ignored;
    std::string m_object;
    std::string m_group;
    std::string m_material;  ///< empty until the first usemtl
    std::map<std::tuple<std::string, std::string, std::string>, std::uint32_t> m_slot_index;
    std::uint32_t m_slot = 0;
    bool m_slot_valid = false;
};

}  // namespace

// ---------------------------------------------------------------------------------------------

ImportError::ImportError(std::string file, std::size_t line, const std::string& message)
    : std::runtime_error(located(file, line, message)), m_file(std::move(file)), m_line(line) {}

double metres_per_unit(std::string_view unit) {
    if (unit == "mm") return 0.001;
    if (unit == "cm") return 0.01;
    if (unit == "m") return 1.0;
    if (unit == "in") return 0.0254;
    if (unit == "ft") return 0.3048;
    throw std::invalid_argument("unknown unit '" + std::string(unit) +
                                "' (expected mm, cm, m, in or ft)");
}

std::string ImportReport::to_string() const {
    std::string s;
    const auto row = [&s](const char* label, std::size_t value) {
        s += label;
        s += ": ";
        s += std::to_string(value);
        s += '\n';
    };
    row("vertices read", vertices_read);
    row("faces read", faces_read);
    row("triangles kept", triangles);
    row("polygons triangulated", polygons_triangulated);
    row("vertices welded", vertices_welded);
    row("  of them within the weld distance", vertices_welded_near);
    s += "weld distance: " + std::to_string(weld_distance) + " m\n";
    row("degenerate triangles dropped", degenerate_dropped);
    row("duplicate triangles dropped", duplicates_dropped);
    row("unused vertices", unused_vertices);
    row("non-planar polygons", non_planar_polygons);
    row("triangles flipped to consistent winding", triangles_flipped);
    row("  in surfaces", surfaces_flipped);
    row("coplanar overlapping triangle pairs (z-fighting)", overlapping_pairs);
    row("emitter triangles", emitter_triangles);
    row("notes", notes.size());
    for (const std::string& note : notes) {
        s += "  ";
        s += note;
        s += '\n';
    }
    return s;
}

namespace detail {

RawModel read_obj(const std::filesystem::path& path, const ImportOptions& options,
                  std::vector<std::string>& notes) {
    const std::string unit = options.unit.empty() ? "m" : options.unit;
    const char up = options.up == 0 ? 'z' : options.up;
    const UnitScale scale = unit_scale(unit);  // throws std::invalid_argument
    if (up != 'y' && up != 'z') {
        throw std::invalid_argument(std::string("up axis must be 'y' or 'z', got '") + up + "'");
    }
    const std::string file = path.string();
    const std::string bytes = read_file_bytes(path, file, "file");

    // Read the statements of the OBJ file and its material libraries
    MaterialLibrary library;
    ObjParser parser(file, path.parent_path(), path.stem().string(), scale, up,
                     options.allow_outside_refs, library, notes);
    ObjData data = parser.parse(bytes);
    if (data.faces.empty()) throw ImportError(file, 0, "no faces to import");

    // Report material names no library defines
    for (const auto& [name, line] : data.usemtl) {
        if (library.find(name) == nullptr) {
            notes.push_back(located(file, line,
                                    "material " + quote(name) +
                                        " is not defined; it gets the default "
                                        "(reflectance 0.5, emittance 0, opacity 1)"));
        }
    }
    if (data.first_face_without_usemtl > 0 && library.find(kDefaultMaterialName) == nullptr) {
        notes.push_back(located(file, data.first_face_without_usemtl,
                                "faces without usemtl get the default material "
                                "(reflectance 0.5, emittance 0, opacity 1)"));
    }

    RawModel raw;
    raw.file = file;
    raw.positions = std::move(data.positions);
    raw.corners = std::move(data.corners);
    raw.faces.reserve(data.faces.size());
    for (const FaceRecord& f : data.faces) raw.faces.push_back({f.line, f.slot, f.first, f.count});
    raw.slots.reserve(data.slots.size());
    for (Slot& slot : data.slots)
        raw.slots.push_back({std::move(slot.name), std::move(slot.layer), std::move(slot.material),
                             slot.first_line});
    for (const RawSlot& slot : raw.slots) {
        const MtlEntry* entry = library.find(slot.material);
        if (entry == nullptr) continue;
        visdb::Material m = entry->material;
        m.name = slot.material;
        raw.materials.push_back(std::move(m));
    }
    raw.where = [file](std::size_t line) {
        return line > 0 ? file + ":" + std::to_string(line) : file;
    };
    raw.source.path = file;
    raw.source.format = "obj";
    raw.source.checksum = fnv1a64_hex(bytes);
    raw.source.size_bytes = bytes.size();
    raw.source.unit = unit;
    raw.source.up_axis = std::string(1, up);
    return raw;
}

}  // namespace detail

}  // namespace abrad::convert
