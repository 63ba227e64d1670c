// IES LM-63 and EULUMDAT readers (the formats are described in photometry.h): ANSI/IES
// LM-63-19 (and its 1986-2002 predecessors) and the EULUMDAT definition of Stockmar (1990).
// Both unfold the file's symmetry into a full web; both check every count, angle and value
// and refuse a malformed file at its line with the field's name.

#include "abrad/convert/photometry.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <optional>
#include <utility>

#include "raw_model.h"

namespace abrad::convert {
namespace {

using visdb::LuminousOpening;
using visdb::PhotometricType;
using visdb::PhotometricWeb;

constexpr double kMetresPerFoot = 0.3048;
/// Most angles on one axis: a finer web than 0.01° steps is no measurement.
constexpr long kMaxAngles = 36001;

std::string num(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%g", v);
    return buf;
}

std::string_view trim(std::string_view s) {
    while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
    while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
    return s;
}

std::string upper(std::string_view s) {
    std::string u(s);
    for (char& c : u) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    return u;
}

/// The lines of `text` (LF, CRLF or CR ends), without their ends.
std::vector<std::string_view> split_lines(std::string_view text) {
    std::vector<std::string_view> lines;
    std::size_t start = 0;
    for (std::size_t i = 0; i < text.size(); ++i) {
        if (text[i] != '\n' && text[i] != '\r') continue;
        lines.push_back(text.substr(start, i - start));
        if (text[i] == '\r' && i + 1 < text.size() && text[i + 1] == '\n') ++i;
        start = i + 1;
    }
    if (start < text.size()) lines.push_back(text.substr(start));
    return lines;
}

/// A finite number filling all of `token`; nullopt otherwise (NaN, Inf, junk).
std::optional<double> parse_number(std::string_view token) {
    const std::string s(token);
    if (s.empty()) return std::nullopt;
    char* end = nullptr;
    const double v = std::strtod(s.c_str(), &end);
    if (end != s.c_str() + s.size() || !std::isfinite(v)) return std::nullopt;
    return v;
}

/// The error for a bad value: "FIELD: must be WHAT, got 'TOKEN'".
[[noreturn]] void bad_value(const std::string& file, std::size_t line, const std::string& field,
                            const std::string& what, std::string_view token) {
    throw ImportError(file, line, field + ": must be " + what + ", got " + detail::quote(token));
}

/// An integer within [lo, hi] written as a number ("3" or "3.0").
long to_integer(const std::string& file, std::size_t line, const std::string& field,
                std::string_view token, double v, long lo, long hi) {
    if (v != std::floor(v) || v < static_cast<double>(lo) || v > static_cast<double>(hi)) {
        bad_value(file, line, field,
                  "an integer from " + std::to_string(lo) + " to " + std::to_string(hi), token);
    }
    return static_cast<long>(v);
}

/// `count` increasing angles in [lo, hi], read from `in` (a NumberStream or LdtLines):
/// "WHAT 3 of 19" in messages.
template <class Reader>
std::vector<double> read_angles(Reader& in, const std::string& file, const std::string& what,
                                long count, double lo, double hi) {
    std::vector<double> a;
    a.reserve(static_cast<std::size_t>(count));
    for (long i = 0; i < count; ++i) {
        const std::string field =
            what + " " + std::to_string(i + 1) + " of " + std::to_string(count);
        const double v = in.number(field, lo, hi, "in [" + num(lo) + ", " + num(hi) + "]");
        if (!a.empty() && !(v > a.back())) {
            bad_value(file, in.line(), field,
                      "greater than the angle before (" + num(a.back()) + ")", in.last());
        }
        a.push_back(v);
    }
    return a;
}

// ---------------------------------------------------------------------------------------------
// Unfolding symmetric type C webs

/// The horizontal symmetry of the planes a file gives.
enum class CSymmetry {
    Rotational,  ///< one plane
    Quadrant,    ///< C0..C90
    Plane0,      ///< C0..C180, mirrored about the C0-C180 plane
    Plane90,     ///< C90..C270, mirrored about the C90-C270 plane
    None,        ///< C0..C360 (or C0..C(360 - step): the 360 plane repeats C0)
};

/// The full type C web from planes `angles` (degrees, increasing) with their rows of
/// `values` (angles.size() × nv), by `symmetry`.
PhotometricWeb unfold_c(const std::vector<double>& angles, const std::vector<double>& gammas,
                        const std::vector<double>& values, CSymmetry symmetry) {
    PhotometricWeb web;
    web.type = PhotometricType::C;
    web.vertical = gammas;
    const std::size_t nv = gammas.size();
    if (symmetry == CSymmetry::Rotational) {
        web.horizontal = {0.0};
        web.candela.assign(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(nv));
        return web;
    }
    // Every image of every given plane in [0, 360], with the row it copies
    std::vector<std::pair<double, std::size_t>> images;
    for (std::size_t i = 0; i < angles.size(); ++i) {
        const double c = angles[i];
        images.emplace_back(c, i);
        switch (symmetry) {
            case CSymmetry::Quadrant:
                images.emplace_back(180.0 - c, i);
                images.emplace_back(180.0 + c, i);
                images.emplace_back(360.0 - c, i);
                break;
            case CSymmetry::Plane0:
                images.emplace_back(360.0 - c, i);
                break;
            case CSymmetry::Plane90:
                images.emplace_back(c <= 180.0 ? 180.0 - c : 540.0 - c, i);
                break;
            case CSymmetry::None:
            case CSymmetry::Rotational:
                break;
        }
    }
    std::sort(images.begin(), images.end());
    // The 360 plane repeats the 0 plane
    if (!images.empty() && images.front().first == 0.0 && images.back().first < 360.0) {
        images.emplace_back(360.0, images.front().second);
    }
    for (const auto& [c, row] : images) {
        if (!web.horizontal.empty() && c - web.horizontal.back() < 1e-9) continue;  // a mirror
        web.horizontal.push_back(c);
        const auto first = values.begin() + static_cast<std::ptrdiff_t>(row * nv);
        web.candela.insert(web.candela.end(), first, first + static_cast<std::ptrdiff_t>(nv));
    }
    return web;
}

/// The full type A/B web: horizontal angles starting at 0 are mirrored to negative ones, and
/// vertical angles likewise.
PhotometricWeb unfold_ab(PhotometricType type, const std::vector<double>& hs,
                         const std::vector<double>& vs, const std::vector<double>& values) {
    const auto mirrored = [](const std::vector<double>& a) {
        std::vector<std::pair<double, std::size_t>> out;
        if (a.front() == 0.0 && a.size() > 1) {
            for (std::size_t i = a.size() - 1; i > 0; --i) out.emplace_back(-a[i], i);
        }
        for (std::size_t i = 0; i < a.size(); ++i) out.emplace_back(a[i], i);
        return out;
    };
    const auto h = mirrored(hs);
    const auto v = mirrored(vs);
    PhotometricWeb web;
    web.type = type;
    for (const auto& e : h) web.horizontal.push_back(e.first);
    for (const auto& e : v) web.vertical.push_back(e.first);
    for (const auto& [hh, hi] : h) {
        for (const auto& [vv, vi] : v) web.candela.push_back(values[hi * vs.size() + vi]);
    }
    return web;
}

// ---------------------------------------------------------------------------------------------
// IES LM-63

/// The numbers after the TILT line: blank-, comma- or line-separated tokens, each with its
/// line, read one at a time with the field it stands for.
class NumberStream {
  public:
    NumberStream(const std::string& file, const std::vector<std::string_view>& lines,
                 std::size_t first_line)
        : m_file(file), m_lines(lines), m_line(first_line) {}

    /// The next token's value; the file's end, junk, NaN or Inf are errors naming `field`.
    double number(const std::string& field) {
        const std::string_view token = next(field);
        const auto v = parse_number(token);
        if (!v) bad_value(m_file, line(), field, "a finite number", token);
        return *v;
    }

    /// A number in [lo, hi].
    double number(const std::string& field, double lo, double hi, const std::string& what) {
        const double v = number(field);
        if (v < lo || v > hi) bad_value(m_file, line(), field, what, m_token);
        return v;
    }

    long integer(const std::string& field, long lo, long hi) {
        const double v = number(field);
        return to_integer(m_file, line(), field, m_token, v, lo, hi);
    }

    /// The line of the last token read (1-based).
    std::size_t line() const { return m_token_line + 1; }
    /// The last token read.
    std::string_view last() const { return m_token; }

    /// Refuses tokens after the last field.
    void expect_end(const std::string& after) {
        if (skip_blanks()) {
            const std::size_t start = m_pos;
            while (m_pos < m_lines[m_line].size() && !is_separator(m_lines[m_line][m_pos])) ++m_pos;
            throw ImportError(m_file, m_line + 1,
                              "unexpected " +
                                  detail::quote(m_lines[m_line].substr(start, m_pos - start)) +
                                  " after " + after + ": the counts do not match the data");
        }
    }

  private:
    static bool is_separator(char c) {
        return c == ',' || std::isspace(static_cast<unsigned char>(c)) != 0;
    }

    /// Moves to the next token; false at the end of the file.
    bool skip_blanks() {
        while (m_line < m_lines.size()) {
            const std::string_view l = m_lines[m_line];
            while (m_pos < l.size() && is_separator(l[m_pos])) ++m_pos;
            if (m_pos < l.size()) return true;
            ++m_line;
            m_pos = 0;
        }
        return false;
    }

    std::string_view next(const std::string& field) {
        if (!skip_blanks()) {
            throw ImportError(m_file, m_lines.empty() ? 0 : m_lines.size(),
                              field +
                                  ": the file ends before it (truncated, or a count is "
                                  "too large)");
        }
        const std::string_view l = m_lines[m_line];
        const std::size_t start = m_pos;
        while (m_pos < l.size() && !is_separator(l[m_pos])) ++m_pos;
        m_token = l.substr(start, m_pos - start);
        m_token_line = m_line;
        return m_token;
    }

    const std::string& m_file;
    const std::vector<std::string_view>& m_lines;
    std::size_t m_line;  // 0-based line of the reading position
    std::size_t m_pos = 0;
    std::string_view m_token;
    std::size_t m_token_line = 0;
};

/// The luminous opening from LM-63's width, length and height (metres, signs as written).
LuminousOpening opening_of(double w, double l, double h, const std::string& file,
                           std::size_t line) {
    using S = LuminousOpening::Shape;
    const auto sign = [](double v) { return v > 0.0 ? '+' : v < 0.0 ? '-' : '0'; };
    const std::string signs{sign(w), sign(l), sign(h)};
    struct Entry {
        const char* signs;
        S shape;
    };
    static constexpr Entry kTable[] = {
        {"000", S::Point},
        {"++0", S::Rectangle},
        {"+++", S::Box},
        {"--0", S::Disc},
        {"-00", S::Disc},  // LM-63-1995: a negative width alone is a circle
        {"--+", S::VerticalCylinder},
        {"-0+", S::VerticalCylinder},
        {"---", S::Sphere},
        {"-+-", S::CylinderAlongX},
        {"+--", S::CylinderAlongY},
        {"-0-", S::VerticalDiscFacingX},
        {"0--", S::VerticalDiscFacingY},
    };
    for (const Entry& e : kTable) {
        if (signs != e.signs) continue;
        LuminousOpening o;
        o.shape = e.shape;
        o.width = std::abs(w);
        o.length = std::abs(l);
        o.height = std::abs(h);
        // A circle written with its diameter once
        if (signs == "-00" || signs == "-0+") o.length = o.width;
        return o;
    }
    throw ImportError(file, line,
                      "luminous opening: width " + num(w) + ", length " + num(l) + ", height " +
                          num(h) +
                          " is none of LM-63's shapes (point 0 0 0, rectangle W L 0, "
                          "disc -D -D 0, sphere -D -D -D, ...)");
}

/// "LM-63-2002" from the first line, or "" when the file has no version line (1986).
std::string ies_version(std::string_view first) {
    std::string u = upper(trim(first));
    if (u.rfind("IESNA91", 0) == 0) return "LM-63-1991";
    if (u.rfind("IESNA:LM-63-", 0) == 0) return u.substr(6);
    if (u.rfind("IES:LM-63-", 0) == 0) return u.substr(4);
    if (u.rfind("IESNA", 0) == 0) return u;  // an unknown IESNA version line
    return "";
}

/// Type C symmetry from the first and last horizontal angles; nullopt when none fits.
std::optional<CSymmetry> c_symmetry(const std::vector<double>& h) {
    const double first = h.front();
    const double last = h.back();
    if (h.size() == 1 && first == 0.0) return CSymmetry::Rotational;
    if (first == 0.0 && last == 90.0) return CSymmetry::Quadrant;
    if (first == 0.0 && last == 180.0) return CSymmetry::Plane0;
    if (first == 90.0 && last == 270.0) return CSymmetry::Plane90;
    if (first == 0.0 && last == 360.0) return CSymmetry::None;
    return std::nullopt;
}

/// The [KEYWORD] lines and the TILT line; returns the index of the TILT line.
std::size_t read_ies_header(const std::string& file, const std::vector<std::string_view>& lines,
                            std::size_t first, PhotometricFile& out) {
    std::string manufacturer;
    std::string luminaire;
    std::string catalogue;
    for (std::size_t i = first; i < lines.size(); ++i) {
        const std::string_view l = trim(lines[i]);
        if (upper(l.substr(0, 5)) == "TILT=") {
            const std::string value = upper(trim(l.substr(5)));
            if (value == "NONE" || value == "INCLUDE") {
                out.tilt_geometry = value == "INCLUDE" ? -1 : 0;  // -1: read after the header
            } else {
                throw ImportError(file, i + 1,
                                  "TILT: a separate tilt file (" + detail::quote(l.substr(5)) +
                                      ") is not read; write TILT=NONE or TILT=INCLUDE with "
                                      "the tilt data in this file");
            }
            std::string d = manufacturer;
            for (const std::string* s : {&luminaire, &catalogue}) {
                if (s->empty()) continue;
                d += (d.empty() ? "" : ", ") + *s;
            }
            out.description = d;
            return i;
        }
        if (l.size() > 1 && l.front() == '[') {
            const std::size_t close = l.find(']');
            if (close == std::string_view::npos) continue;  // free text
            const std::string key = upper(l.substr(1, close - 1));
            const std::string value(trim(l.substr(close + 1)));
            if (key == "MANUFAC" && manufacturer.empty()) manufacturer = value;
            if (key == "LUMINAIRE" && luminaire.empty()) luminaire = value;
            if (key == "LUMCAT" && catalogue.empty()) catalogue = value;
        }
    }
    throw ImportError(file, lines.size(),
                      "TILT: no TILT= line (TILT=NONE or TILT=INCLUDE must end the header)");
}

}  // namespace

PhotometricFile read_ies(std::string_view text, const std::string& name) {
    PhotometricFile out;
    out.path = name;
    out.format = "ies";
    out.checksum = detail::fnv1a64_hex(text);
    out.size_bytes = text.size();
    if (text.size() >= 3 && text.substr(0, 3) == "\xEF\xBB\xBF") text.remove_prefix(3);  // BOM
    const std::vector<std::string_view> lines = split_lines(text);
    if (lines.empty()) throw ImportError(name, 0, "empty file, not an IES LM-63 file");
    const std::string version = ies_version(lines[0]);
    out.version = version.empty() ? "LM-63-1986" : version;
    const std::size_t tilt_line = read_ies_header(name, lines, version.empty() ? 0 : 1, out);
    NumberStream in(name, lines, tilt_line + 1);

    // Tilt table
    if (out.tilt_geometry == -1) {
        out.tilt_geometry = static_cast<int>(in.integer("lamp-to-luminaire geometry", 1, 3));
        const long n = in.integer("number of tilt angles", 1, kMaxAngles);
        out.tilt_angles = read_angles(in, name, "tilt angle", n, 0.0, 180.0);
        for (long i = 0; i < n; ++i) {
            out.tilt_factors.push_back(in.number(
                "tilt multiplying factor " + std::to_string(i + 1) + " of " + std::to_string(n),
                0.0, HUGE_VAL, "a number >= 0"));
        }
    }

    // The luminaire line and the ballast line
    const long lamps = in.integer("number of lamps", 1, 1000000);
    const double lumens_per_lamp = in.number("lumens per lamp");
    if (!(lumens_per_lamp > 0.0 || lumens_per_lamp == -1.0)) {
        bad_value(name, in.line(), "lumens per lamp", "> 0, or -1 for absolute photometry",
                  num(lumens_per_lamp));
    }
    const double multiplier = in.number("candela multiplier", 0.0, HUGE_VAL, "a number > 0");
    if (multiplier == 0.0) bad_value(name, in.line(), "candela multiplier", "> 0", "0");
    const long nv = in.integer("number of vertical angles", 2, kMaxAngles);
    const long nh = in.integer("number of horizontal angles", 1, kMaxAngles);
    const long type_code = in.integer("photometric type", 1, 3);
    const auto type = static_cast<PhotometricType>(type_code);
    const long units = in.integer("units type", 1, 2);
    const double to_metres = units == 1 ? kMetresPerFoot : 1.0;
    const double w = in.number("luminous opening width") * to_metres;
    const double l = in.number("luminous opening length") * to_metres;
    const double h = in.number("luminous opening height") * to_metres;
    out.opening = opening_of(w, l, h, name, in.line());
    const double ballast = in.number("ballast factor", 0.0, HUGE_VAL, "a number > 0");
    if (ballast == 0.0) bad_value(name, in.line(), "ballast factor", "> 0", "0");
    const bool before_2002 = out.version < "LM-63-2002";
    const double third = in.number(before_2002 ? "ballast-lamp photometric factor"
                                               : "future use / file generation type");
    if (before_2002 && !(third > 0.0)) {
        bad_value(name, in.line(), "ballast-lamp photometric factor", "> 0", num(third));
    }
    out.input_watts = in.number("input watts", 0.0, HUGE_VAL, "a number >= 0");

    // Angles
    const bool c = type == PhotometricType::C;
    const std::vector<double> vs = c ? read_angles(in, name, "vertical angle", nv, 0.0, 180.0)
                                     : read_angles(in, name, "vertical angle", nv, -90.0, 90.0);
    const std::size_t h_line = in.line() + 1;
    const std::vector<double> hs = c ? read_angles(in, name, "horizontal angle", nh, 0.0, 360.0)
                                     : read_angles(in, name, "horizontal angle", nh, -180.0, 180.0);
    std::optional<CSymmetry> symmetry;
    if (c) {
        symmetry = c_symmetry(hs);
        if (!symmetry) {
            throw ImportError(name, std::max(h_line, in.line()),
                              "horizontal angles: type C angles must run 0 (rotationally "
                              "symmetric), 0..90, 0..180, 90..270 or 0..360, got " +
                                  num(hs.front()) + ".." + num(hs.back()));
        }
    } else if (nh < 2) {
        throw ImportError(name, in.line(),
                          "number of horizontal angles: type A and B webs need at least 2");
    }

    // Candela
    const double factor = multiplier * ballast * (before_2002 ? third : 1.0);
    std::vector<double> values;
    values.reserve(static_cast<std::size_t>(std::min(nv * nh, 1L << 20)));
    for (long ih = 0; ih < nh; ++ih) {
        for (long iv = 0; iv < nv; ++iv) {
            const std::string field =
                "candela at horizontal " + num(hs[ih]) + ", vertical " + num(vs[iv]);
            values.push_back(in.number(field, 0.0, HUGE_VAL, "a number >= 0") * factor);
        }
    }
    in.expect_end("the candela values");

    out.web = c ? unfold_c(hs, vs, values, *symmetry) : unfold_ab(type, hs, vs, values);
    out.lamp_lumens =
        lumens_per_lamp > 0.0 ? static_cast<double>(lamps) * lumens_per_lamp * factor : 0.0;
    return out;
}

// ---------------------------------------------------------------------------------------------
// EULUMDAT

namespace {

/// Reads EULUMDAT's lines one value at a time, naming each line's field in errors.
class LdtLines {
  public:
    LdtLines(const std::string& file, const std::vector<std::string_view>& lines)
        : m_file(file), m_lines(lines) {}

    /// The next line as text.
    std::string_view text(const std::string& field) {
        if (m_next >= m_lines.size()) {
            throw ImportError(m_file, m_lines.size(),
                              "line " + std::to_string(m_next + 1) + " (" + field +
                                  "): the file ends before it (truncated, or a count is too "
                                  "large)");
        }
        return m_lines[m_next++];
    }

    /// The next line as a finite number (a decimal comma is read as a point).
    double number(const std::string& field) {
        std::string token(trim(text(field)));
        if (token.find('.') == std::string::npos)
            std::replace(token.begin(), token.end(), ',', '.');
        const auto v = parse_number(token);
        if (!v) bad_value(m_file, m_next, field, "a finite number", token);
        return *v;
    }

    double number(const std::string& field, double lo, double hi, const std::string& what) {
        const double v = number(field);
        if (v < lo || v > hi) bad_value(m_file, m_next, field, what, trim(m_lines[m_next - 1]));
        return v;
    }

    long integer(const std::string& field, long lo, long hi) {
        const double v = number(field);
        return to_integer(m_file, m_next, field, trim(m_lines[m_next - 1]), v, lo, hi);
    }

    std::size_t line() const { return m_next; }  ///< the line last read (1-based)
    std::string_view last() const { return trim(m_lines[m_next - 1]); }  ///< its text

    /// Refuses non-blank lines after the last field.
    void expect_end() {
        for (std::size_t i = m_next; i < m_lines.size(); ++i) {
            if (trim(m_lines[i]).empty()) continue;
            throw ImportError(m_file, i + 1,
                              "unexpected " + detail::quote(trim(m_lines[i])) +
                                  " after the intensities: the counts do not match the data");
        }
    }

  private:
    const std::string& m_file;
    const std::vector<std::string_view>& m_lines;
    std::size_t m_next = 0;  // 0-based index of the next line
};

/// The planes (first index into the C angles, count) an EULUMDAT symmetry indicator gives,
/// and its symmetry.
struct LdtPlanes {
    long first = 0;
    long count = 0;
    CSymmetry symmetry = CSymmetry::None;
};

LdtPlanes ldt_planes(long isym, long mc) {
    switch (isym) {
        case 1:
            return {0, 1, CSymmetry::Rotational};
        case 2:
            return {0, mc / 2 + 1, CSymmetry::Plane0};
        case 3:
            return {mc / 4, mc / 2 + 1, CSymmetry::Plane90};
        case 4:
            return {0, mc / 4 + 1, CSymmetry::Quadrant};
        default:
            return {0, mc, CSymmetry::None};
    }
}

}  // namespace

PhotometricFile read_eulumdat(std::string_view text, const std::string& name) {
    PhotometricFile out;
    out.path = name;
    out.format = "ldt";
    out.version = "EULUMDAT";
    out.checksum = detail::fnv1a64_hex(text);
    out.size_bytes = text.size();
    if (text.size() >= 3 && text.substr(0, 3) == "\xEF\xBB\xBF") text.remove_prefix(3);
    const std::vector<std::string_view> lines = split_lines(text);
    if (lines.empty()) throw ImportError(name, 0, "empty file, not an EULUMDAT file");
    LdtLines in(name, lines);

    const std::string company(trim(in.text("company identification")));
    in.integer("type indicator Ityp", 0, 3);
    const long isym = in.integer("symmetry indicator Isym", 0, 4);
    const long mc = in.integer("number of C-planes Mc", 1, kMaxAngles);
    const std::size_t mc_line = in.line();
    in.number("distance between C-planes Dc", 0.0, 360.0, "in [0, 360]");
    const long ng = in.integer("number of gamma angles Ng", 2, kMaxAngles);
    in.number("distance between gamma angles Dg", 0.0, 180.0, "in [0, 180]");
    in.text("measurement report number");
    const std::string luminaire(trim(in.text("luminaire name")));
    const std::string number(trim(in.text("luminaire number")));
    in.text("file name");
    in.text("date/user");
    for (const char* f : {"length/diameter of luminaire (mm)", "width of luminaire (mm)",
                          "height of luminaire (mm)"}) {
        in.number(f, 0.0, HUGE_VAL, "a number >= 0");
    }
    const double area_length =
        in.number("length/diameter of luminous area (mm)", 0.0, HUGE_VAL, "a number >= 0");
    const double area_width =
        in.number("width of luminous area (mm)", 0.0, HUGE_VAL, "a number >= 0");
    double area_height = 0.0;
    for (const char* f :
         {"height of luminous area C0 (mm)", "height of luminous area C90 (mm)",
          "height of luminous area C180 (mm)", "height of luminous area C270 (mm)"}) {
        area_height = std::max(area_height, in.number(f, 0.0, HUGE_VAL, "a number >= 0"));
    }
    in.number("downward flux fraction DFF (%)", 0.0, 100.0, "in [0, 100]");
    const double lorl = in.number("light output ratio LORL (%)", 0.0, 100.0, "in [0, 100]");
    const double conversion =
        in.number("conversion factor for luminous intensities", 0.0, HUGE_VAL, "a number > 0");
    if (conversion == 0.0)
        bad_value(name, in.line(), "conversion factor for luminous intensities", "> 0", "0");
    in.number("tilt of luminaire during measurement", -180.0, 180.0, "in [-180, 180]");
    const long sets = in.integer("number of standard sets of lamps n", 1, 20);
    std::vector<double> set_flux;
    std::vector<double> set_watts;
    for (long s = 1; s <= sets; ++s) {
        in.integer("number of lamps, set " + std::to_string(s), -1000000, 1000000);
    }
    for (long s = 1; s <= sets; ++s) in.text("type of lamps, set " + std::to_string(s));
    for (long s = 1; s <= sets; ++s) {
        set_flux.push_back(in.number("total luminous flux of lamps (lm), set " + std::to_string(s),
                                     0.0, HUGE_VAL, "a number > 0"));
        if (set_flux.back() == 0.0) {
            bad_value(name, in.line(),
                      "total luminous flux of lamps (lm), set " + std::to_string(s), "> 0", "0");
        }
    }
    for (long s = 1; s <= sets; ++s) in.text("colour appearance, set " + std::to_string(s));
    for (long s = 1; s <= sets; ++s) in.text("colour rendering, set " + std::to_string(s));
    for (long s = 1; s <= sets; ++s) {
        set_watts.push_back(in.number("wattage including ballast (W), set " + std::to_string(s),
                                      0.0, HUGE_VAL, "a number >= 0"));
    }
    for (int k = 1; k <= 10; ++k) {
        in.number("direct ratio " + std::to_string(k) + " of 10", 0.0, HUGE_VAL, "a number >= 0");
    }

    // The planes the symmetry indicator needs, checked against Mc and the C angles
    if ((isym == 2 || isym == 3) && mc % 2 != 0) {
        throw ImportError(name, mc_line,
                          "number of C-planes Mc: must be even for symmetry indicator " +
                              std::to_string(isym) + ", got " + std::to_string(mc));
    }
    if ((isym == 3 || isym == 4) && mc % 4 != 0) {
        throw ImportError(name, mc_line,
                          "number of C-planes Mc: must be a multiple of 4 for symmetry "
                          "indicator " +
                              std::to_string(isym) + ", got " + std::to_string(mc));
    }
    const std::size_t c_line = in.line() + 1;
    const std::vector<double> c_angles = read_angles(in, name, "C angle", mc, 0.0, 360.0);
    const std::vector<double> gammas = read_angles(in, name, "gamma angle", ng, 0.0, 180.0);
    const LdtPlanes planes = ldt_planes(isym, mc);
    const std::vector<double> given(c_angles.begin() + planes.first,
                                    c_angles.begin() + planes.first + planes.count);
    const double want_first = isym == 3 ? 90.0 : 0.0;
    const double want_last = isym == 2 ? 180.0 : isym == 3 ? 270.0 : isym == 4 ? 90.0 : -1.0;
    if (isym != 1 &&
        (given.front() != want_first || (want_last >= 0.0 && given.back() != want_last) ||
         (isym == 0 && given.back() >= 360.0))) {
        const bool first_wrong = given.front() != want_first;
        throw ImportError(
            name,
            c_line + static_cast<std::size_t>(planes.first + (first_wrong ? 0 : planes.count - 1)),
            "C angles: symmetry indicator " + std::to_string(isym) + " needs the planes " +
                (isym == 0 ? std::string("0 .. below 360")
                           : num(want_first) + " .. " + num(want_last)) +
                " at C angles " + std::to_string(planes.first + 1) + " .. " +
                std::to_string(planes.first + planes.count) + ", got " + num(given.front()) +
                " .. " + num(given.back()));
    }

    // Intensities, cd/klm
    const double factor = set_flux[0] / 1000.0 * conversion;
    std::vector<double> values;
    values.reserve(static_cast<std::size_t>(planes.count * ng));
    for (long ic = 0; ic < planes.count; ++ic) {
        for (long ig = 0; ig < ng; ++ig) {
            const std::string field = "luminous intensity at C " + num(given[ic]) + ", gamma " +
                                      num(gammas[ig]) + " (cd/klm)";
            values.push_back(in.number(field, 0.0, HUGE_VAL, "a number >= 0") * factor);
        }
    }
    in.expect_end();

    out.web = unfold_c(given, gammas, values, planes.symmetry);
    out.lamp_lumens = set_flux[0] * conversion;
    out.stated_lor = lorl / 100.0;
    out.input_watts = set_watts[0];
    out.description = company;
    for (const std::string* s : {&luminaire, &number}) {
        if (s->empty()) continue;
        out.description += (out.description.empty() ? "" : ", ") + *s;
    }
    // The luminous area: a rectangle (length along C0, width along C90) or a disc (width 0)
    LuminousOpening& o = out.opening;
    o.length = area_length / 1000.0;
    o.width = (area_width > 0.0 ? area_width : area_length) / 1000.0;
    o.height = area_height / 1000.0;
    using S = LuminousOpening::Shape;
    if (area_length == 0.0) {
        o = LuminousOpening{};
    } else if (area_width > 0.0) {
        o.shape = o.height > 0.0 ? S::Box : S::Rectangle;
    } else {
        o.shape = o.height > 0.0 ? S::VerticalCylinder : S::Disc;
    }
    return out;
}

PhotometricFile read_photometric_text(std::string_view text, const std::string& name) {
    std::string ext = std::filesystem::path(name).extension().string();
    ext = upper(ext);
    if (ext == ".IES") return read_ies(text, name);
    if (ext == ".LDT") return read_eulumdat(text, name);
    throw ImportError(name, 0,
                      "not a photometric file: the extension must be .ies (IES LM-63) or .ldt "
                      "(EULUMDAT)");
}

PhotometricFile read_photometric_file(const std::filesystem::path& path) {
    const std::string name = path.string();
    // Refuse a wrong extension before reading
    const std::string ext = upper(path.extension().string());
    if (ext != ".IES" && ext != ".LDT") return read_photometric_text("", name);
    const std::string bytes = detail::read_file_bytes(path, name, "photometric file");
    return read_photometric_text(bytes, name);
}

double PhotometricFile::tilt_multiplier(double tilt_degrees) const {
    const std::vector<double>& a = tilt_angles;
    if (a.empty()) return 1.0;
    if (tilt_degrees <= a.front()) return tilt_factors.front();
    if (tilt_degrees >= a.back()) return tilt_factors.back();
    // The last angle not above the tilt: a[i] <= tilt < a[i + 1] (angles ascend, read_angles)
    const auto i = static_cast<std::size_t>(std::upper_bound(a.begin(), a.end(), tilt_degrees) -
                                            a.begin() - 1);
    const double t = (tilt_degrees - a[i]) / (a[i + 1] - a[i]);
    return (1.0 - t) * tilt_factors[i] + t * tilt_factors[i + 1];
}

std::string PhotometricFile::flux_report() const {
    const double phi = flux();
    std::string s = "web " + num(phi) + " lm";
    if (lamp_lumens > 0.0) {
        char buf[32];
        std::snprintf(buf, sizeof buf, "%.3f", phi / lamp_lumens);
        s += ", lamps " + num(lamp_lumens) + " lm: LOR " + buf;
        if (stated_lor > 0.0) {
            std::snprintf(buf, sizeof buf, "%.3f", stated_lor);
            s += std::string(" (file states ") + buf + ")";
        }
    } else {
        s += " (absolute photometry)";
    }
    return s;
}

std::string PhotometricFile::to_string() const {
    std::string s = path + ": " + version;
    if (!description.empty()) s += " '" + description + "'";
    s += "; " + web.to_string() + "; opening " + visdb::to_string(opening.shape);
    if (opening.shape != LuminousOpening::Shape::Point) {
        s += " " + num(opening.length) + " x " + num(opening.width) + " x " + num(opening.height) +
             " m";
    }
    s += "; " + flux_report();
    return s;
}

}  // namespace abrad::convert
