// Tests of the PLY and OBJ writers and the tone map, against an independent PLY reader.

#include "abrad/export/writers.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <bit>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>
#include <string_view>
#include <system_error>
#include <variant>
#include <vector>

#include "temp_dir.h"

namespace abrad::exporter {
namespace {

namespace fs = std::filesystem;

// ---------------------------------------------------------------------------------------------
// A small PLY reader, independent of the writer: header, binary_little_endian and ascii bodies
// for the property types of the contract (double, float, uchar, int, list uchar int).

using Scalar = std::variant<double, float, std::uint8_t, std::int32_t>;

struct PlyProperty {
    std::string name;
    std::string type;        ///< scalar type, or the item type of a list
    std::string count_type;  ///< non-empty for a list
};

struct PlyElement {
    std::string name;
    std::size_t count = 0;
    std::vector<PlyProperty> properties;
    /// rows[r][p] holds the values of property p of row r (one value unless a list)
    std::vector<std::vector<std::vector<Scalar>>> rows;

    std::size_t index_of(const std::string& property) const {
        for (std::size_t i = 0; i < properties.size(); ++i) {
            if (properties[i].name == property) return i;
        }
        throw std::runtime_error("no property " + property);
    }
};

struct Ply {
    std::string format;
    std::vector<std::string> header_lines;  ///< every header line, without the newline
    std::vector<PlyElement> elements;

    const PlyElement& element(const std::string& name) const {
        for (const auto& e : elements) {
            if (e.name == name) return e;
        }
        throw std::runtime_error("no element " + name);
    }
};

std::string read_file(const fs::path& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw std::runtime_error("cannot open " + path.string());
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

std::vector<std::string> split_ws(std::string_view line) {
    std::vector<std::string> out;
    std::istringstream in{std::string(line)};
    for (std::string token; in >> token;) out.push_back(token);
    return out;
}

/// Reads a little-endian scalar of `type` from `data` at `pos`, assembling bytes by shifts.
class BinaryCursor {
  public:
    BinaryCursor(std::string_view data, std::size_t pos) : m_data(data), m_pos(pos) {}

    Scalar read(const std::string& type) {
        if (type == "double") return std::bit_cast<double>(bytes<std::uint64_t>(8));
        if (type == "float") return std::bit_cast<float>(bytes<std::uint32_t>(4));
        if (type == "uchar") return bytes<std::uint8_t>(1);
        if (type == "int") return std::bit_cast<std::int32_t>(bytes<std::uint32_t>(4));
        throw std::runtime_error("unsupported type " + type);
    }
    bool at_end() const { return m_pos == m_data.size(); }

  private:
    template <typename U>
    U bytes(std::size_t n) {
        if (m_pos + n > m_data.size()) throw std::runtime_error("binary body truncated");
        std::uint64_t v = 0;
        for (std::size_t i = 0; i < n; ++i) {
            v |= std::uint64_t{static_cast<unsigned char>(m_data[m_pos + i])} << (8 * i);
        }
        m_pos += n;
        return static_cast<U>(v);
    }

    std::string_view m_data;
    std::size_t m_pos;
};

/// Reads whitespace-separated tokens and parses them exactly (std::from_chars).
class AsciiCursor {
  public:
    explicit AsciiCursor(std::string_view body) : m_tokens(split_ws(body)) {}

    Scalar read(const std::string& type) {
        if (m_next >= m_tokens.size()) throw std::runtime_error("ascii body truncated");
        const std::string& t = m_tokens[m_next++];
        if (type == "double") return parse<double>(t);
        if (type == "float") return parse<float>(t);
        if (type == "uchar") {
            const int v = parse<int>(t);
            if (v < 0 || v > 255) throw std::runtime_error("uchar out of range: " + t);
            return static_cast<std::uint8_t>(v);
        }
        if (type == "int") return parse<std::int32_t>(t);
        throw std::runtime_error("unsupported type " + type);
    }
    bool at_end() const { return m_next == m_tokens.size(); }

  private:
    template <typename T>
    static T parse(const std::string& token) {
        T value{};
        const auto res = std::from_chars(token.data(), token.data() + token.size(), value);
        if (res.ec != std::errc{} || res.ptr != token.data() + token.size()) {
            throw std::runtime_error("bad number: " + token);
        }
        return value;
    }

    std::vector<std::string> m_tokens;
    std::size_t m_next = 0;
};

std::size_t list_count(const Scalar& s) {
    if (const auto* u = std::get_if<std::uint8_t>(&s)) return *u;
    throw std::runtime_error("list count is not uchar");
}

template <typename Cursor>
void read_body(Ply& ply, Cursor& cursor) {
    for (auto& e : ply.elements) {
        e.rows.resize(e.count);
        for (auto& row : e.rows) {
            for (const auto& p : e.properties) {
                std::vector<Scalar> values;
                if (!p.count_type.empty()) {
                    const std::size_t n = list_count(cursor.read(p.count_type));
                    for (std::size_t i = 0; i < n; ++i) values.push_back(cursor.read(p.type));
                } else {
                    values.push_back(cursor.read(p.type));
                }
                row.push_back(std::move(values));
            }
        }
    }
    if (!cursor.at_end()) throw std::runtime_error("trailing data after the last element");
}

Ply read_ply(const fs::path& path) {
    const std::string data = read_file(path);
    Ply ply;
    std::size_t pos = 0;
    for (;;) {
        const std::size_t eol = data.find('\n', pos);
        if (eol == std::string::npos) throw std::runtime_error("header without end_header");
        const std::string line = data.substr(pos, eol - pos);
        pos = eol + 1;
        ply.header_lines.push_back(line);
        const auto tokens = split_ws(line);
        if (tokens.empty()) throw std::runtime_error("empty header line");
        if (tokens[0] == "end_header") break;
        if (tokens[0] == "format") {
            ply.format = tokens.at(1);
        } else if (tokens[0] == "element") {
            ply.elements.push_back({tokens.at(1), std::stoul(tokens.at(2)), {}, {}});
        } else if (tokens[0] == "property") {
            if (ply.elements.empty()) throw std::runtime_error("property before element");
            if (tokens.at(1) == "list") {
                ply.elements.back().properties.push_back(
                    {tokens.at(4), tokens.at(3), tokens.at(2)});
            } else {
                ply.elements.back().properties.push_back({tokens.at(2), tokens.at(1), ""});
            }
        }
    }
    if (ply.header_lines.front() != "ply") throw std::runtime_error("no ply magic");
    if (ply.format == "binary_little_endian") {
        BinaryCursor cursor(data, pos);
        read_body(ply, cursor);
    } else if (ply.format == "ascii") {
        AsciiCursor cursor(std::string_view(data).substr(pos));
        read_body(ply, cursor);
    } else {
        throw std::runtime_error("unsupported format " + ply.format);
    }
    return ply;
}

template <typename T>
T get(const PlyElement& e, std::size_t row, const std::string& property) {
    const auto& values = e.rows.at(row).at(e.index_of(property));
    if (values.size() != 1) throw std::runtime_error(property + " is a list");
    return std::get<T>(values[0]);
}

// ---------------------------------------------------------------------------------------------
// Fixtures

/// A directory of its own for one test, removed when it passes (temp_dir.h).
using abrad::testing::TempDir;

constexpr double kLn2 = 0.69314718055994530942;

/// Two surfaces at survey coordinates: surface 0 a horizontal quad (two triangles), surface
/// 1 a vertical triangle. Its triangles interleave the surfaces: 0, 1, 0.
visdb::BakeMesh two_surface_mesh() {
    visdb::BakeMesh m;
    const double x0 = 1e6 + 0.001;
    const double y0 = 2e6 + 0.002;
    m.positions = {{x0, y0, 12.345},           {x0 + 1.0, y0, 12.345}, {x0 + 1.0, y0 + 1.0, 12.345},
                   {x0, y0 + 1.0, 12.345},     {x0, y0, 0.1},          {x0, y0 + 0.5, 0.1},
                   {x0, y0 + 0.25, 3.0 + 1e-9}};
    m.normals = {{0, 0, 1}, {0, 0, 1}, {0, 0, 1},         {0, 0, 1},
                 {1, 0, 0}, {1, 0, 0}, {0.6f, 0.0f, 0.8f}};
    m.triangles = {{0, 1, 2}, {4, 5, 6}, {0, 2, 3}};
    m.triangle_surface = {0, 1, 0};
    m.irradiance = {{0.1f, 0.2f, 0.3f}, {1.0f / 3.0f, 2.0f / 3.0f, 1e-7f},    {12345.678f, 0, 0},
                    {0, 0, 0},          {3.14159265f, 2.71828f, 1.41421356f}, {1e30f, 1e-30f, 5.5f},
                    {100, 200, 300}};
    m.radiosity = {{static_cast<float>(kLn2), 0.0f, 1000.0f},
                   {0.05f, 0.1f, 0.15f},
                   {1.0f, 1.0f, 1.0f},
                   {0, 0, 0},
                   {2.0f, 0.5f, 0.25f},
                   {0.75f, 0.125f, 9.0f},
                   {10, 20, 30}};
    return m;
}

visdb::Scene two_surface_scene() {
    visdb::Scene s;
    s.materials.push_back({"lamp", {0.1, 0.2, 0.3}, {100.0, 90.5, 80.25}, 1.0});
    s.materials.push_back({"unused", {0.5, 0.5, 0.5}, {0, 0, 0}, 1.0});
    s.materials.push_back({"white paint", {0.8, 0.75, 0.7}, {0, 0, 0}, 0.9});
    visdb::Surface floor;
    floor.name = "floor slab";
    floor.material = 2;
    visdb::Surface light;
    light.name = "ceiling light";
    light.material = 0;
    s.surfaces = {floor, light};
    return s;
}

/// The sRGB byte of linear radiosity v at exposure k, from the formulas of the tone map.
std::uint8_t expected_byte(double v, double k) {
    const double mapped = 1.0 - std::exp(-k * std::max(v, 0.0));
    const double s =
        mapped < 0.0031308 ? 12.92 * mapped : 1.055 * std::pow(mapped, 1 / 2.4) - 0.055;
    return static_cast<std::uint8_t>(std::lround(s * 255.0));
}

const std::vector<std::string> kContractProperties = {
    "property double x",           "property double y",           "property double z",
    "property float nx",           "property float ny",           "property float nz",
    "property uchar red",          "property uchar green",        "property uchar blue",
    "property float irradiance_r", "property float irradiance_g", "property float irradiance_b",
    "property float radiosity_r",  "property float radiosity_g",  "property float radiosity_b"};

std::vector<std::string> contract_header(const std::string& format,
                                         const std::vector<std::string>& comments, std::size_t n,
                                         std::size_t m) {
    std::vector<std::string> h = {"ply", "format " + format + " 1.0"};
    for (const auto& c : comments) h.push_back("comment " + c);
    h.push_back("element vertex " + std::to_string(n));
    h.insert(h.end(), kContractProperties.begin(), kContractProperties.end());
    h.push_back("element face " + std::to_string(m));
    h.push_back("property list uchar int vertex_indices");
    h.push_back("property int surface");
    h.push_back("end_header");
    return h;
}

/// Every value of the mesh read back bit for bit.
void expect_round_trip(const Ply& ply, const visdb::BakeMesh& mesh, const ToneMap& tone) {
    const auto& v = ply.element("vertex");
    ASSERT_EQ(v.count, mesh.positions.size());
    for (std::size_t i = 0; i < v.count; ++i) {
        SCOPED_TRACE("vertex " + std::to_string(i));
        const char* axes[] = {"x", "y", "z"};
        for (int k = 0; k < 3; ++k) {
            // bit-exact: survey coordinates must not lose their millimetres
            EXPECT_EQ(std::bit_cast<std::uint64_t>(get<double>(v, i, axes[k])),
                      std::bit_cast<std::uint64_t>(mesh.positions[i][k]));
        }
        const char* normal[] = {"nx", "ny", "nz"};
        const char* irr[] = {"irradiance_r", "irradiance_g", "irradiance_b"};
        const char* rad[] = {"radiosity_r", "radiosity_g", "radiosity_b"};
        for (int k = 0; k < 3; ++k) {
            EXPECT_EQ(std::bit_cast<std::uint32_t>(get<float>(v, i, normal[k])),
                      std::bit_cast<std::uint32_t>(mesh.normals[i][k]));
            EXPECT_EQ(std::bit_cast<std::uint32_t>(get<float>(v, i, irr[k])),
                      std::bit_cast<std::uint32_t>(mesh.irradiance[i][k]));
            EXPECT_EQ(std::bit_cast<std::uint32_t>(get<float>(v, i, rad[k])),
                      std::bit_cast<std::uint32_t>(mesh.radiosity[i][k]));
        }
        const char* rgb[] = {"red", "green", "blue"};
        for (int k = 0; k < 3; ++k) {
            EXPECT_EQ(get<std::uint8_t>(v, i, rgb[k]),
                      expected_byte(static_cast<double>(mesh.radiosity[i][k]), tone.exposure));
        }
    }
    const auto& f = ply.element("face");
    ASSERT_EQ(f.count, mesh.triangles.size());
    for (std::size_t t = 0; t < f.count; ++t) {
        SCOPED_TRACE("face " + std::to_string(t));
        const auto& list = f.rows[t].at(f.index_of("vertex_indices"));
        ASSERT_EQ(list.size(), 3u);
        for (int k = 0; k < 3; ++k) {
            EXPECT_EQ(std::get<std::int32_t>(list[static_cast<std::size_t>(k)]),
                      static_cast<std::int32_t>(mesh.triangles[t][k]));
        }
        EXPECT_EQ(get<std::int32_t>(f, t, "surface"),
                  static_cast<std::int32_t>(mesh.triangle_surface[t]));
    }
}

// ---------------------------------------------------------------------------------------------
// Tone map

TEST(ToneMap, DisplayColourFollowsFormulas) {
    const ToneMap one{.exposure = 1.0};
    // v = ln 2: v' = 1 - 1/2 = 0.5; sRGB 1.055 * 0.5^(1/2.4) - 0.055 = 0.73536; * 255 = 187.5 → 188
    EXPECT_EQ(display_colour({static_cast<float>(kLn2), 0.0f, -3.0f}, one)[0], 188);
    EXPECT_EQ(display_colour({static_cast<float>(kLn2), 0.0f, -3.0f}, one)[1], 0);
    EXPECT_EQ(display_colour({static_cast<float>(kLn2), 0.0f, -3.0f}, one)[2], 0);  // clamped
    // Linear segment: v' = 0.001 → 12.92 * 0.001 * 255 = 3.29 → 3
    EXPECT_EQ(display_colour({static_cast<float>(-std::log(0.999)), 0, 0}, one)[0], 3);
    // Saturation: v' → 1 → 255
    EXPECT_EQ(display_colour({1e6f, 1e6f, 1e6f}, one)[1], 255);
    // Exposure 2 at v = ln2 / 2 is the same as exposure 1 at ln 2
    EXPECT_EQ(display_colour({static_cast<float>(kLn2 / 2), 0, 0}, ToneMap{.exposure = 2.0})[0],
              188);
    // NaN shows as black
    EXPECT_EQ(display_colour({std::nanf(""), 0, 0}, one)[0], 0);
    // A sweep against the formulas
    for (double v = 0.0; v < 5.0; v += 0.01) {
        const auto c = display_colour({static_cast<float>(v), 0, 0}, ToneMap{.exposure = 0.7});
        EXPECT_EQ(c[0], expected_byte(static_cast<double>(static_cast<float>(v)), 0.7)) << v;
    }
}

TEST(ToneMap, AutoExposureMapsPercentileTo08) {
    // 97 grey vertices of luminance 2 and 3 bright outliers: the 95th percentile is 2
    visdb::BakeMesh mesh;
    for (int i = 0; i < 97; ++i) mesh.radiosity.push_back({2.0f, 2.0f, 2.0f});
    for (int i = 0; i < 3; ++i) mesh.radiosity.push_back({100.0f, 100.0f, 100.0f});
    const ToneMap tone = auto_tone_map(mesh);
    EXPECT_NEAR(tone.exposure, -std::log(0.2) / 2.0, 1e-9);
    EXPECT_NEAR(1.0 - std::exp(-tone.exposure * 2.0), 0.8, 1e-9);

    // Luminance weights: pure red of 1 has Y = 0.2126
    visdb::BakeMesh red;
    red.radiosity.assign(10, {1.0f, 0.0f, 0.0f});
    EXPECT_NEAR(auto_tone_map(red).exposure, -std::log(0.2) / 0.2126, 1e-9);
    visdb::BakeMesh green;
    green.radiosity.assign(10, {0.0f, 1.0f, 0.0f});
    EXPECT_NEAR(1.0 - std::exp(-auto_tone_map(green).exposure * 0.7152), 0.8, 1e-9);
}

TEST(ToneMap, AllDarkUsesExposureOne) {
    visdb::BakeMesh dark;
    dark.radiosity.assign(5, {0.0f, 0.0f, 0.0f});
    EXPECT_EQ(auto_tone_map(dark).exposure, 1.0);
    EXPECT_EQ(auto_tone_map(visdb::BakeMesh{}).exposure, 1.0);
}

// ---------------------------------------------------------------------------------------------
// PLY

TEST(PlyWriter, HeaderFollowsContract) {
    TempDir dir;
    const auto mesh = two_surface_mesh();
    const ToneMap tone{.exposure = 1.0};

    write_ply(dir / "b.ply", mesh, tone);
    EXPECT_EQ(read_ply(dir / "b.ply").header_lines,
              contract_header("binary_little_endian", {}, 7, 3));

    write_ply(dir / "a.ply", mesh, tone, {.ascii = true, .comment = "abrad bake 1\nsecond line"});
    EXPECT_EQ(read_ply(dir / "a.ply").header_lines,
              contract_header("ascii", {"abrad bake 1", "second line"}, 7, 3));
}

TEST(PlyWriter, BinaryRoundTripsEveryValue) {
    TempDir dir;
    const auto mesh = two_surface_mesh();
    const ToneMap tone{.exposure = 1.0};
    write_ply(dir / "b.ply", mesh, tone, {.ascii = false, .comment = "binary"});
    const Ply ply = read_ply(dir / "b.ply");
    EXPECT_EQ(ply.format, "binary_little_endian");
    expect_round_trip(ply, mesh, tone);
    EXPECT_EQ(dir.entry_count(), 1u);  // no PATH.tmp left behind
}

TEST(PlyWriter, AsciiRoundTripsEveryValue) {
    TempDir dir;
    const auto mesh = two_surface_mesh();
    const ToneMap tone = auto_tone_map(mesh);
    write_ply(dir / "a.ply", mesh, tone, {.ascii = true, .comment = ""});
    const Ply ply = read_ply(dir / "a.ply");
    EXPECT_EQ(ply.format, "ascii");
    expect_round_trip(ply, mesh, tone);
}

// --surface-ids vertex: `surface` is the vertices' last property (0 for the floor's four, 1 for
// the wall's three), the faces hold vertex_indices only; a vertex two surfaces share is refused.
TEST(PlyWriter, SurfaceIdsOnVertices) {
    TempDir dir;
    const auto mesh = two_surface_mesh();
    const ToneMap tone{.exposure = 1.0};
    for (const bool ascii : {false, true}) {
        SCOPED_TRACE(ascii ? "ascii" : "binary");
        const fs::path path = dir / (ascii ? "a.ply" : "b.ply");
        write_ply(path, mesh, tone,
                  {.ascii = ascii, .comment = {}, .surface_ids = PlySurfaceIds::Vertex});
        const Ply ply = read_ply(path);
        std::vector<std::string> expected =
            contract_header(ascii ? "ascii" : "binary_little_endian", {}, 7, 3);
        expected.erase(std::find(expected.begin(), expected.end(), "property int surface"));
        expected.insert(std::find(expected.begin(), expected.end(), "element face 3"),
                        "property int surface");
        EXPECT_EQ(ply.header_lines, expected);
        const auto& v = ply.element("vertex");
        ASSERT_EQ(v.count, 7u);
        for (std::size_t i = 0; i < v.count; ++i) {
            EXPECT_EQ(get<std::int32_t>(v, i, "surface"), i < 4 ? 0 : 1) << i;
            EXPECT_EQ(get<double>(v, i, "y"), mesh.positions[i].y) << i;
            EXPECT_EQ(get<float>(v, i, "radiosity_b"), mesh.radiosity[i].b) << i;
        }
        const auto& f = ply.element("face");
        ASSERT_EQ(f.properties.size(), 1u);
        EXPECT_EQ(f.rows[1][0].size(), 3u);
        EXPECT_EQ(std::get<std::int32_t>(f.rows[1][0][2]), 6);
    }
    visdb::BakeMesh shared = mesh;
    shared.triangles[1].x = 0;  // the floor's vertex 0 in a wall triangle
    try {
        write_ply(dir / "s.ply", shared, tone,
                  {.comment = {}, .surface_ids = PlySurfaceIds::Vertex});
        FAIL() << "no error";
    } catch (const ExportError& e) {
        EXPECT_NE(std::string(e.what()).find("vertex 0 is shared by surfaces 0 and 1"),
                  std::string::npos)
            << e.what();
    }
    EXPECT_FALSE(fs::exists(dir / "s.ply"));
}

// --positions float: x y z as float relative to the header's `comment origin` (whole metres
// near the model at survey coordinates), which put back give the millimetres; --up y turns
// positions and normals to (x, z, -y). Everything else as in the contract.
TEST(PlyWriter, FloatPositionsRelativeToOriginAndYUp) {
    TempDir dir;
    const auto mesh = two_surface_mesh();
    const ToneMap tone{.exposure = 1.0};
    for (const bool ascii : {false, true}) {
        SCOPED_TRACE(ascii ? "ascii" : "binary");
        const fs::path path = dir / (ascii ? "a.ply" : "b.ply");
        write_ply(
            path, mesh, tone,
            {.ascii = ascii, .comment = {}, .up = UpAxis::Y, .positions = PlyPositions::Float});
        const Ply ply = read_ply(path);
        // The origin: the box centre (1e6 + 0.501, 2e6 + 0.502, 6.2225) rounded, turned Y up
        ASSERT_GE(ply.header_lines.size(), 3u);
        EXPECT_EQ(ply.header_lines[2], "comment origin 1000001 6 -2000001");
        std::vector<std::string> expected = contract_header(
            ascii ? "ascii" : "binary_little_endian", {"origin 1000001 6 -2000001"}, 7, 3);
        for (auto& line : expected)
            if (line.rfind("property double ", 0) == 0) line.replace(9, 6, "float");
        EXPECT_EQ(ply.header_lines, expected);
        const auto& v = ply.element("vertex");
        ASSERT_EQ(v.count, mesh.positions.size());
        const glm::dvec3 origin(1000001.0, 6.0, -2000001.0);
        for (std::size_t i = 0; i < v.count; ++i) {
            const glm::dvec3 p(get<float>(v, i, "x"), get<float>(v, i, "y"), get<float>(v, i, "z"));
            const glm::dvec3 back = p + origin;  // Y up: (x, z, -y)
            EXPECT_NEAR(back.x, mesh.positions[i].x, 1e-6) << i;
            EXPECT_NEAR(back.y, mesh.positions[i].z, 1e-6) << i;
            EXPECT_NEAR(back.z, -mesh.positions[i].y, 1e-6) << i;
            EXPECT_EQ(get<float>(v, i, "ny"), mesh.normals[i].z) << i;
            EXPECT_EQ(get<float>(v, i, "nz"), -mesh.normals[i].y) << i;
            EXPECT_EQ(get<float>(v, i, "radiosity_g"), mesh.radiosity[i].g) << i;
        }
        EXPECT_EQ(get<std::int32_t>(ply.element("face"), 2, "surface"), 0);
    }
}

TEST(PlyWriter, DisplayColoursAreToneMappedSrgb) {
    TempDir dir;
    const auto mesh = two_surface_mesh();
    write_ply(dir / "b.ply", mesh, ToneMap{.exposure = 1.0});
    const Ply ply = read_ply(dir / "b.ply");
    const auto& v = ply.element("vertex");
    // Vertex 0 has radiosity (ln 2, 0, 1000): 188 by hand, black, saturated
    EXPECT_EQ(get<std::uint8_t>(v, 0, "red"), 188);
    EXPECT_EQ(get<std::uint8_t>(v, 0, "green"), 0);
    EXPECT_EQ(get<std::uint8_t>(v, 0, "blue"), 255);
}

TEST(PlyWriter, InvalidMeshThrowsAndLeavesNoFile) {
    TempDir dir;
    const auto path = dir / "bad.ply";
    const auto expect_rejected = [&](const visdb::BakeMesh& mesh, const std::string& what) {
        SCOPED_TRACE(what);
        try {
            write_ply(path, mesh, ToneMap{});
            ADD_FAILURE() << "no ExportError";
        } catch (const ExportError& e) {
            const std::string msg = e.what();
            EXPECT_NE(msg.find(path.string()), std::string::npos) << msg;
            EXPECT_NE(msg.find(what), std::string::npos) << msg;
        }
        EXPECT_FALSE(fs::exists(path));
        EXPECT_FALSE(fs::exists(path.string() + ".tmp"));
    };

    auto mesh = two_surface_mesh();
    mesh.triangles[2][1] = 7;
    expect_rejected(mesh, "out of range");

    mesh = two_surface_mesh();
    mesh.normals.pop_back();
    expect_rejected(mesh, "normals");

    mesh = two_surface_mesh();
    mesh.radiosity.push_back({});
    expect_rejected(mesh, "radiosity");

    mesh = two_surface_mesh();
    mesh.triangle_surface.pop_back();
    expect_rejected(mesh, "triangle_surface");
    EXPECT_EQ(dir.entry_count(), 0u);
}

TEST(PlyWriter, MissingDirectoryThrowsNamingPath) {
    TempDir dir;
    const auto path = dir / "no/such/dir/b.ply";
    try {
        write_ply(path, two_surface_mesh(), ToneMap{});
        FAIL() << "no ExportError";
    } catch (const ExportError& e) {
        const std::string msg = e.what();
        EXPECT_EQ(msg.rfind(path.string() + ": cannot write: ", 0), 0u) << msg;
    }
}

// ---------------------------------------------------------------------------------------------
// OBJ

struct ObjFile {
    std::vector<std::vector<std::string>> v, vn;
    std::vector<std::string> mtllib;
    /// (object, material, face tokens) per face, in file order
    struct Face {
        std::string object, material;
        std::vector<std::string> corners;
    };
    std::vector<Face> faces;
    std::vector<std::string> objects;
};

ObjFile read_obj(const fs::path& path) {
    std::istringstream in(read_file(path));
    ObjFile obj;
    std::string object, material;
    for (std::string line; std::getline(in, line);) {
        auto tokens = split_ws(line);
        if (tokens.empty() || tokens[0][0] == '#') continue;
        const std::string key = tokens[0];
        tokens.erase(tokens.begin());
        if (key == "v")
            obj.v.push_back(tokens);
        else if (key == "vn")
            obj.vn.push_back(tokens);
        else if (key == "mtllib")
            obj.mtllib = tokens;
        else if (key == "o") {
            object = tokens.at(0);
            obj.objects.push_back(object);
        } else if (key == "usemtl")
            material = tokens.at(0);
        else if (key == "f")
            obj.faces.push_back({object, material, tokens});
        else
            throw std::runtime_error("unexpected OBJ line: " + line);
    }
    return obj;
}

double parse_double(const std::string& token) {
    double value = 0.0;
    const auto res = std::from_chars(token.data(), token.data() + token.size(), value);
    if (res.ec != std::errc{} || res.ptr != token.data() + token.size()) {
        throw std::runtime_error("bad number: " + token);
    }
    return value;
}

// Positions exactly as in the bake (Z up), or turned Y up ((x, y, z) -> (x, z, -y), OBJ's
// convention and the default), with the normals turned alike.
TEST(ObjWriter, VerticesCarryPositionAndColour) {
    TempDir dir;
    const auto mesh = two_surface_mesh();
    const ToneMap tone{.exposure = 1.0};
    write_obj(dir / "y.obj", two_surface_scene(), mesh, tone);
    write_obj(dir / "out.obj", two_surface_scene(), mesh, tone, {.up = UpAxis::Z});
    const ObjFile y_up = read_obj(dir / "y.obj");
    const ObjFile obj = read_obj(dir / "out.obj");

    ASSERT_EQ(obj.v.size(), mesh.positions.size());
    ASSERT_EQ(y_up.v.size(), mesh.positions.size());
    for (std::size_t i = 0; i < obj.v.size(); ++i) {
        SCOPED_TRACE("v " + std::to_string(i));
        ASSERT_EQ(obj.v[i].size(), 6u);
        for (int k = 0; k < 3; ++k) {
            EXPECT_EQ(parse_double(obj.v[i][static_cast<std::size_t>(k)]), mesh.positions[i][k]);
            EXPECT_EQ(y_up.v[i][3 + static_cast<std::size_t>(k)],
                      obj.v[i][3 + static_cast<std::size_t>(k)]);
        }
        const auto& p = mesh.positions[i];
        EXPECT_EQ(parse_double(y_up.v[i][0]), p.x);
        EXPECT_EQ(parse_double(y_up.v[i][1]), p.z);
        EXPECT_EQ(parse_double(y_up.v[i][2]), -p.y);
        for (int k = 0; k < 3; ++k) {
            const std::string& c = obj.v[i][3 + static_cast<std::size_t>(k)];
            EXPECT_EQ(c.size() - c.find('.'), 5u) << c;  // four decimals
            const double expected =
                expected_byte(static_cast<double>(mesh.radiosity[i][k]), tone.exposure) / 255.0;
            EXPECT_NEAR(parse_double(c), expected, 0.5e-4 + 1e-12);
        }
    }
    EXPECT_EQ(obj.v[0][3], "0.7373");  // 188 / 255
    ASSERT_EQ(obj.vn.size(), mesh.normals.size());
    EXPECT_EQ(obj.vn[6], (std::vector<std::string>{"0.6", "0", "0.8"}));
    ASSERT_EQ(y_up.vn.size(), mesh.normals.size());
    EXPECT_EQ(y_up.vn[6], (std::vector<std::string>{"0.6", "0.8", "0"}));
}

TEST(ObjWriter, FacesGroupedBySurfaceWithOneBasedIndices) {
    TempDir dir;
    const auto mesh = two_surface_mesh();
    write_obj(dir / "out.obj", two_surface_scene(), mesh, ToneMap{});
    const ObjFile obj = read_obj(dir / "out.obj");

    EXPECT_EQ(obj.mtllib, std::vector<std::string>{"out.mtl"});
    EXPECT_EQ(obj.objects, (std::vector<std::string>{"floor_slab", "ceiling_light"}));
    ASSERT_EQ(obj.faces.size(), 3u);
    // Surface 0's triangles (mesh triangles 0 and 2) come first, then surface 1's
    const std::size_t expected_triangle[] = {0, 2, 1};
    const char* expected_object[] = {"floor_slab", "floor_slab", "ceiling_light"};
    const char* expected_material[] = {"white_paint", "white_paint", "lamp"};
    for (std::size_t f = 0; f < 3; ++f) {
        SCOPED_TRACE("f " + std::to_string(f));
        EXPECT_EQ(obj.faces[f].object, expected_object[f]);
        EXPECT_EQ(obj.faces[f].material, expected_material[f]);
        ASSERT_EQ(obj.faces[f].corners.size(), 3u);
        for (int k = 0; k < 3; ++k) {
            const auto i = std::to_string(mesh.triangles[expected_triangle[f]][k] + 1);
            EXPECT_EQ(obj.faces[f].corners[static_cast<std::size_t>(k)], i + "//" + i);
        }
    }
}

TEST(ObjWriter, MtlHasUsedMaterials) {
    TempDir dir;
    const auto scene = two_surface_scene();
    write_obj(dir / "out.obj", scene, two_surface_mesh(), ToneMap{});
    ASSERT_TRUE(fs::exists(dir / "out.mtl"));
    EXPECT_EQ(dir.entry_count(), 2u);  // out.obj, out.mtl, no temporaries

    // Read newmtl blocks: name → key → numbers
    std::map<std::string, std::map<std::string, std::vector<double>>> mtl;
    std::istringstream in(read_file(dir / "out.mtl"));
    std::string current;
    for (std::string line; std::getline(in, line);) {
        auto tokens = split_ws(line);
        // The scene's material in a comment: "# abrad material: Kd r g b Ke r g b d a"
        if (tokens.size() == 13 && tokens[1] == "abrad" && tokens[2] == "material:") {
            for (std::size_t i = 3; i < tokens.size(); ++i) {
                if (std::isalpha(static_cast<unsigned char>(tokens[i][0])))
                    tokens[i] = "scene " + tokens[i];
            }
            tokens.erase(tokens.begin(), tokens.begin() + 3);
            ASSERT_FALSE(current.empty()) << line;
            std::string key;
            for (const auto& t : tokens) {
                if (t.rfind("scene ", 0) == 0)
                    key = t;
                else
                    mtl[current][key].push_back(parse_double(t));
            }
            continue;
        }
        if (tokens.empty() || tokens[0][0] == '#') continue;
        if (tokens[0] == "newmtl") {
            current = tokens.at(1);
            ASSERT_EQ(mtl.count(current), 0u) << "duplicate " << current;
            mtl[current];
            continue;
        }
        ASSERT_FALSE(current.empty()) << line;
        auto& values = mtl[current][tokens[0]];
        for (std::size_t i = 1; i < tokens.size(); ++i) values.push_back(parse_double(tokens[i]));
    }
    ASSERT_EQ(mtl.size(), 2u);  // "unused" is not written
    // The scene's materials, in the comment line
    const auto& lamp = mtl.at("lamp");
    EXPECT_EQ(lamp.at("scene Kd"), (std::vector<double>{0.1, 0.2, 0.3}));
    EXPECT_EQ(lamp.at("scene Ke"), (std::vector<double>{100.0, 90.5, 80.25}));
    EXPECT_EQ(lamp.at("scene d"), (std::vector<double>{1.0}));
    const auto& paint = mtl.at("white_paint");
    EXPECT_EQ(paint.at("scene Kd"), (std::vector<double>{0.8, 0.75, 0.7}));
    EXPECT_EQ(paint.at("scene Ke"), (std::vector<double>{0.0, 0.0, 0.0}));
    EXPECT_EQ(paint.at("scene d"), (std::vector<double>{0.9}));
    // What a viewer shows: the vertex colours, white and unlit, with the opacity
    for (const auto* m : {&lamp, &paint}) {
        EXPECT_EQ(m->at("Kd"), (std::vector<double>{1.0, 1.0, 1.0}));
        EXPECT_EQ(m->at("Ka"), (std::vector<double>{0.0, 0.0, 0.0}));
        EXPECT_EQ(m->at("Ks"), (std::vector<double>{0.0, 0.0, 0.0}));
        EXPECT_EQ(m->at("illum"), (std::vector<double>{0.0}));
        EXPECT_EQ(m->count("Ke"), 0u);  // an emissive term would wash the bake out
    }
    EXPECT_EQ(paint.at("d"), (std::vector<double>{0.9}));
    EXPECT_EQ(lamp.at("d"), (std::vector<double>{1.0}));
}

TEST(ObjWriter, MissingDirectoryThrowsNamingPath) {
    TempDir dir;
    const auto path = dir / "missing" / "out.obj";
    try {
        write_obj(path, two_surface_scene(), two_surface_mesh(), ToneMap{});
        FAIL() << "no ExportError";
    } catch (const ExportError& e) {
        EXPECT_NE(std::string(e.what()).find(path.string()), std::string::npos) << e.what();
    }
}

TEST(ObjWriter, SurfaceOutOfRangeThrowsAndLeavesNoFile) {
    TempDir dir;
    auto mesh = two_surface_mesh();
    mesh.triangle_surface[1] = 2;  // the scene has two surfaces
    const auto path = dir / "out.obj";
    try {
        write_obj(path, two_surface_scene(), mesh, ToneMap{});
        FAIL() << "no ExportError";
    } catch (const ExportError& e) {
        const std::string msg = e.what();
        EXPECT_NE(msg.find(path.string()), std::string::npos) << msg;
        EXPECT_NE(msg.find("surface id 2"), std::string::npos) << msg;
    }
    EXPECT_EQ(dir.entry_count(), 0u);
}

}  // namespace
}  // namespace abrad::exporter
