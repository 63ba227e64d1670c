// The scene file: a TOML reader that validates every key and value with its line (toml++ source
// regions), and its application to the merged, healed scene. The format is documented in
// scene_file.h. Only this file sees toml++.

#include "abrad/convert/scene_file.h"

#include <fnmatch.h>
#include <toml++/toml.h>

#include <algorithm>
#include <array>
#include <climits>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <glm/trigonometric.hpp>
#include <initializer_list>
#include <map>
#include <set>
#include <stdexcept>
#include <string_view>
#include <tuple>
#include <utility>

#include "abrad/convert/photometry.h"
#include "abrad/visdb/material_check.h"
#include "child_process.h"
#include "raw_model.h"

namespace abrad::convert {
namespace {

using visdb::luminance;

using detail::located;

// ---------------------------------------------------------------------------------------------
// Formatting

std::string fmt(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%g", v);
    return buf;
}

std::string fmt(const glm::dvec3& v) {
    return "[" + fmt(v.x) + ", " + fmt(v.y) + ", " + fmt(v.z) + "]";
}

std::string fmt(const glm::dvec2& v) { return "[" + fmt(v.x) + ", " + fmt(v.y) + "]"; }

std::string in_quotes(const std::string& s) { return "'" + s + "'"; }

/// "'a', 'b', 'c' and 4 more" for the first `shown` of `names`.
std::string name_list(const std::vector<std::string>& names, std::size_t shown = 3) {
    std::string s;
    for (std::size_t i = 0; i < names.size() && i < shown; ++i) {
        if (i > 0) s += ", ";
        s += in_quotes(names[i]);
    }
    if (names.size() > shown) s += " and " + std::to_string(names.size() - shown) + " more";
    return s;
}

bool glob_match(const std::string& pattern, const std::string& name) {
    return ::fnmatch(pattern.c_str(), name.c_str(), FNM_CASEFOLD) == 0;
}

double triangle_area(const visdb::TriangleMesh& mesh) {
    double area = 0.0;
    for (const auto& t : mesh.triangles) {
        area += visdb::triangle_area(mesh.positions[t.x], mesh.positions[t.y], mesh.positions[t.z]);
    }
    return area;
}

// ---------------------------------------------------------------------------------------------
// Reading: typed values with their lines

const char* type_name(const toml::node& node) {
    switch (node.type()) {
        case toml::node_type::table:
            return "a table";
        case toml::node_type::array:
            return "an array";
        case toml::node_type::string:
            return "a string";
        case toml::node_type::integer:
            return "an integer";
        case toml::node_type::floating_point:
            return "a number";
        case toml::node_type::boolean:
            return "a boolean";
        case toml::node_type::date:
            return "a date";
        case toml::node_type::time:
            return "a time";
        case toml::node_type::date_time:
            return "a date-time";
        case toml::node_type::none:
            break;
    }
    return "nothing";
}

std::size_t line_of(const toml::node& node) { return node.source().begin.line; }

/// Reads one TOML table of a section, checking keys and value types; every failure is an
/// ImportError at the offending line.
class TableReader {
  public:
    /// `section` names the table in messages: "[[rule]]", or "" for the top level.
    TableReader(const std::string& file, const toml::table& table, std::string section,
                std::initializer_list<std::string_view> allowed)
        : m_file(file), m_table(table), m_section(std::move(section)) {
        // Unknown keys, the first in the file first
        const toml::key* unknown = nullptr;
        for (auto&& [key, node] : table) {
            const bool known =
                std::find(allowed.begin(), allowed.end(), key.str()) != allowed.end();
            if (!known &&
                (unknown == nullptr || key.source().begin.line < unknown->source().begin.line)) {
                unknown = &key;
            }
        }
        if (unknown != nullptr) {
            std::string list;
            for (const std::string_view a : allowed) {
                if (!list.empty()) list += ", ";
                list += a;
            }
            throw ImportError(m_file, unknown->source().begin.line,
                              "unknown key '" + std::string(unknown->str()) + "'" + where() +
                                  " (allowed: " + list + ")");
        }
    }

    std::size_t line() const { return line_of(m_table); }
    bool has(std::string_view key) const { return m_table.contains(key); }
    std::size_t line(std::string_view key) const { return line_of(*m_table.get(key)); }

    [[noreturn]] void fail(std::size_t line, const std::string& message) const {
        throw ImportError(m_file, line, message);
    }
    /// "'key' in [[rule]]" or "'key'".
    std::string name(std::string_view key) const { return "'" + std::string(key) + "'" + where(); }

    std::optional<std::string> string(std::string_view key) const {
        const toml::node* node = m_table.get(key);
        if (node == nullptr) return std::nullopt;
        if (!node->is_string()) wrong_type(key, *node, "a string");
        return node->as_string()->get();
    }

    std::optional<bool> boolean(std::string_view key) const {
        const toml::node* node = m_table.get(key);
        if (node == nullptr) return std::nullopt;
        if (!node->is_boolean()) wrong_type(key, *node, "true or false");
        return node->as_boolean()->get();
    }

    std::optional<double> number(std::string_view key) const {
        const toml::node* node = m_table.get(key);
        if (node == nullptr) return std::nullopt;
        return number_of(key, *node, "a number");
    }

    /// A fixed-length array of numbers.
    template <std::size_t N>
    std::optional<std::array<double, N>> numbers(std::string_view key) const {
        const toml::node* node = m_table.get(key);
        if (node == nullptr) return std::nullopt;
        const std::string expected = "an array of " + std::to_string(N) + " numbers";
        const toml::array* array = node->as_array();
        if (array == nullptr) wrong_type(key, *node, expected.c_str());
        if (array->size() != N) {
            fail(line_of(*node), name(key) + " must be " + expected + ", got " +
                                     std::to_string(array->size()) + " elements");
        }
        std::array<double, N> values{};
        for (std::size_t i = 0; i < N; ++i) values[i] = number_of(key, *array->get(i), expected);
        return values;
    }

    std::optional<glm::dvec3> vec3(std::string_view key) const {
        const auto v = numbers<3>(key);
        if (!v) return std::nullopt;
        return glm::dvec3((*v)[0], (*v)[1], (*v)[2]);
    }

    std::optional<glm::dvec2> vec2(std::string_view key) const {
        const auto v = numbers<2>(key);
        if (!v) return std::nullopt;
        return glm::dvec2((*v)[0], (*v)[1]);
    }

    /// A number (grey) or [r, g, b].
    std::optional<visdb::Rgb> rgb(std::string_view key) const {
        const toml::node* node = m_table.get(key);
        if (node == nullptr) return std::nullopt;
        if (node->is_array()) return vec3(key);
        const double v = number_of(key, *node, "a number or [r, g, b]");
        return visdb::Rgb(v);
    }

    /// Checks lo <= each component <= hi.
    void check_range(std::string_view key, const visdb::Rgb& v, double lo, double hi,
                     const char* what) const {
        for (int i = 0; i < 3; ++i) check_range(key, v[i], lo, hi, what);
    }
    void check_range(std::string_view key, double v, double lo, double hi, const char* what) const {
        if (!(v >= lo && v <= hi)) {  // NaN fails too
            fail(line(key), name(key) + " must be " + what + ", got " + fmt(v));
        }
    }

  private:
    std::string where() const { return m_section.empty() ? "" : " in " + m_section; }

    [[noreturn]] void wrong_type(std::string_view key, const toml::node& node,
                                 const char* expected) const {
        fail(line_of(node), name(key) + " must be " + expected + ", got " + type_name(node));
    }

    double number_of(std::string_view key, const toml::node& node,
                     const std::string& expected) const {
        double v = 0.0;
        if (node.is_integer()) {
            v = static_cast<double>(node.as_integer()->get());
        } else if (node.is_floating_point()) {
            v = node.as_floating_point()->get();
        } else {
            wrong_type(key, node, expected.c_str());
        }
        if (!std::isfinite(v)) fail(line_of(node), name(key) + " must be finite, got " + fmt(v));
        return v;
    }

    const std::string& m_file;
    const toml::table& m_table;
    std::string m_section;
};

/// The tables of a top-level array-of-tables section ([[rule]] ...).
std::vector<const toml::table*> section_tables(const std::string& file, const toml::table& root,
                                               std::string_view key) {
    std::vector<const toml::table*> tables;
    const toml::node* node = root.get(key);
    if (node == nullptr) return tables;
    const toml::array* array = node->as_array();
    if (array == nullptr) {
        throw ImportError(file, line_of(*node),
                          "'" + std::string(key) + "' must be an array of tables: write [[" +
                              std::string(key) + "]], got " + type_name(*node));
    }
    for (const toml::node& element : *array) {
        const toml::table* table = element.as_table();
        if (table == nullptr) {
            throw ImportError(file, line_of(element),
                              "'" + std::string(key) + "' must be an array of tables: write [[" +
                                  std::string(key) + "]], got an element that is " +
                                  type_name(element));
        }
        tables.push_back(table);
    }
    return tables;
}

SurfaceMatch read_match(const TableReader& reader) {
    SurfaceMatch match;
    match.object = reader.string("object");
    match.layer = reader.string("layer");
    match.material = reader.string("material");
    return match;
}

bool has_condition(const SurfaceMatch& m) { return m.object || m.layer || m.material; }

/// emittance | flux (+ color), shared by rules and emitters.
struct Emission {
    std::optional<visdb::Rgb> emittance;
    std::optional<double> flux;
    visdb::Rgb color{1.0, 1.0, 1.0};
};

/// `color`: each channel >= 0, scaled to luminance 1; white when absent.
visdb::Rgb read_color(const TableReader& reader, const std::string& section) {
    const auto color = reader.vec3("color");
    if (!color) return visdb::Rgb(1.0);
    reader.check_range("color", *color, 0.0, HUGE_VAL, ">= 0");
    const double y = luminance(*color);
    if (!(y > 0.0)) {
        reader.fail(
            reader.line("color"),
            "'color' in " + section + " must have a positive luminance, got " + fmt(*color));
    }
    return *color / y;
}

Emission read_emission(const TableReader& reader, const std::string& section) {
    Emission e;
    e.emittance = reader.rgb("emittance");
    if (e.emittance) {
        reader.check_range("emittance", *e.emittance, 0.0, visdb::kMaxEmittance,
                           "in [0, 1e10] (the sun's surface is 6.3e7)");
    }
    e.flux = reader.number("flux");
    if (e.flux) reader.check_range("flux", *e.flux, 0.0, HUGE_VAL, ">= 0 (lumens)");
    if (e.emittance && e.flux) {
        reader.fail(reader.line("flux"), section + " gives both 'emittance' and 'flux' (line " +
                                             std::to_string(reader.line("emittance")) +
                                             "); give one");
    }
    if (reader.has("color") && !e.flux) {
        reader.fail(reader.line("color"), "'color' in " + section + " needs 'flux'");
    }
    e.color = read_color(reader, section);
    return e;
}

/// `group`: a light group's name (not empty, no ',' or '=': light scenes name groups as
/// "NAME=FACTOR,..."); nullopt when absent.
std::optional<std::string> read_group(const TableReader& reader, const std::string& section) {
    auto group = reader.string("group");
    if (group && (group->empty() || group->find_first_of(",=") != std::string::npos)) {
        reader.fail(reader.line("group"), "'group' in " + section +
                                              " must be a non-empty name without ',' or '=', "
                                              "got " +
                                              in_quotes(*group));
    }
    return group;
}

SceneRule read_rule(const std::string& file, const toml::table& table) {
    const std::string section = "[[rule]]";
    const TableReader reader(file, table, section,
                             {"object", "layer", "material", "reflectance", "opacity", "emittance",
                              "flux", "color", "group"});
    SceneRule rule;
    rule.line = reader.line();
    rule.match = read_match(reader);
    if (!has_condition(rule.match)) {
        reader.fail(rule.line,
                    section + " needs at least one condition: object, layer or material");
    }
    rule.reflectance = reader.rgb("reflectance");
    if (rule.reflectance) {
        reader.check_range("reflectance", *rule.reflectance, 0.0, 0.999, "in [0, 0.999]");
    }
    rule.opacity = reader.number("opacity");
    if (rule.opacity) reader.check_range("opacity", *rule.opacity, 0.0, 1.0, "in [0, 1]");
    const Emission e = read_emission(reader, section);
    rule.emittance = e.emittance;
    rule.flux = e.flux;
    rule.color = e.color;
    rule.group = read_group(reader, section);
    if (rule.group && !rule.emittance && !rule.flux) {
        reader.fail(reader.line("group"),
                    "'group' in " + section + " needs 'emittance' or 'flux' (a light group)");
    }
    if (!rule.reflectance && !rule.opacity && !rule.emittance && !rule.flux) {
        reader.fail(rule.line,
                    section + " sets nothing: give reflectance, opacity, emittance or flux");
    }
    return rule;
}

/// An [[emitter]]: a SceneRule (object emitter) or a SceneRectangle.
void read_emitter(const std::string& file, const toml::table& table, SceneFile& scene) {
    const std::string section = "[[emitter]]";
    const TableReader reader(file, table, section,
                             {"object", "layer", "material", "name", "center", "size", "normal",
                              "axis", "emittance", "flux", "color", "group"});
    const std::size_t line = reader.line();
    const SurfaceMatch match = read_match(reader);
    const Emission e = read_emission(reader, section);
    if (!e.emittance && !e.flux) reader.fail(line, section + " needs 'emittance' or 'flux'");

    const bool rectangle = reader.has("name") || reader.has("center") || reader.has("size") ||
                           reader.has("normal") || reader.has("axis");
    if (!rectangle) {
        if (!has_condition(match)) {
            reader.fail(line, section +
                                  " needs conditions (object, layer, material) or a rectangle "
                                  "(name, center, size, normal)");
        }
        SceneRule rule;
        rule.line = line;
        rule.is_emitter = true;
        rule.match = match;
        rule.emittance = e.emittance;
        rule.flux = e.flux;
        rule.color = e.color;
        rule.group = read_group(reader, section);
        scene.rules.push_back(rule);
        return;
    }

    // A rectangle: no conditions; name, center, size and normal required
    for (const char* key : {"object", "layer", "material"}) {
        if (reader.has(key)) {
            reader.fail(reader.line(key), reader.name(key) +
                                              " cannot be combined with a rectangle (name, "
                                              "center, size, normal)");
        }
    }
    for (const char* key : {"name", "center", "size", "normal"}) {
        if (!reader.has(key)) {
            reader.fail(line, "rectangle " + section + " needs '" + key +
                                  "' (name, center, size and normal are required)");
        }
    }
    SceneRectangle rect;
    rect.line = line;
    rect.group = read_group(reader, section).value_or("");
    rect.name = *reader.string("name");
    if (rect.name.empty()) reader.fail(reader.line("name"), reader.name("name") + " is empty");
    for (const SceneRectangle& other : scene.rectangles) {
        if (other.name == rect.name) {
            reader.fail(reader.line("name"), "emitter name " + in_quotes(rect.name) +
                                                 " is already used at line " +
                                                 std::to_string(other.line));
        }
    }
    rect.center = *reader.vec3("center");
    rect.size = *reader.vec2("size");
    if (!(rect.size.x > 0.0 && rect.size.y > 0.0)) {
        reader.fail(reader.line("size"),
                    reader.name("size") + " must be > 0, got " + fmt(rect.size));
    }
    const glm::dvec3 normal = *reader.vec3("normal");
    const double normal_length = glm::length(normal);
    if (!(normal_length > 0.0)) {
        reader.fail(reader.line("normal"), reader.name("normal") + " must not be zero");
    }
    rect.normal = normal / normal_length;

    // Axis: given or world X (world Y for a normal along X), projected into the plane
    glm::dvec3 axis{1.0, 0.0, 0.0};
    if (const auto given = reader.vec3("axis")) {
        axis = *given;
    } else if (std::abs(rect.normal.x) > 0.9) {
        axis = {0.0, 1.0, 0.0};
    }
    const glm::dvec3 in_plane = axis - glm::dot(axis, rect.normal) * rect.normal;
    const double in_plane_length = glm::length(in_plane);
    if (!(in_plane_length > 1e-9 * glm::length(axis))) {
        reader.fail(reader.line("axis"), reader.name("axis") + " " + fmt(axis) +
                                             " must not be zero or parallel to the normal " +
                                             fmt(normal));
    }
    rect.axis = in_plane / in_plane_length;
    rect.emittance = e.emittance;
    rect.flux = e.flux;
    rect.color = e.color;
    scene.rectangles.push_back(rect);
}

/// The photometric frame of a luminaire turned by `degrees` about world x, then y, then z.
void set_rotation(visdb::Luminaire& l, const glm::dvec3& degrees) {
    const glm::dvec3 r = glm::radians(degrees);
    const auto rotate = [&r](glm::dvec3 v) {
        v = {v.x, std::cos(r.x) * v.y - std::sin(r.x) * v.z,
             std::sin(r.x) * v.y + std::cos(r.x) * v.z};
        v = {std::cos(r.y) * v.x + std::sin(r.y) * v.z, v.y,
             -std::sin(r.y) * v.x + std::cos(r.y) * v.z};
        return glm::dvec3{std::cos(r.z) * v.x - std::sin(r.z) * v.y,
                          std::sin(r.z) * v.x + std::cos(r.z) * v.y, v.z};
    };
    l.axis_x = rotate({1.0, 0.0, 0.0});
    l.axis_y = rotate({0.0, 1.0, 0.0});
    l.axis_z = rotate({0.0, 0.0, 1.0});
}

/// The photometric frame of a luminaire whose nadir (-z) points along the unit `aim`: x is
/// world x projected into the plane across the aim (world y when aiming along x).
void set_aim(visdb::Luminaire& l, const glm::dvec3& aim) {
    l.axis_z = -aim;
    const glm::dvec3 x = std::abs(aim.x) > 0.9 ? glm::dvec3(0, 1, 0) : glm::dvec3(1, 0, 0);
    l.axis_x = glm::normalize(x - glm::dot(x, l.axis_z) * l.axis_z);
    l.axis_y = glm::cross(l.axis_z, l.axis_x);
}

/// The opening a [[luminaire]] asks for: the file's, a point, or a rectangle or disc of
/// `opening_size`.
visdb::LuminousOpening read_opening(const TableReader& reader, const visdb::LuminousOpening& file) {
    using Shape = visdb::LuminousOpening::Shape;
    const std::string kind = reader.string("opening").value_or("file");
    const auto size = reader.vec2("opening_size");
    const bool sized = kind == "rectangle" || kind == "disc";
    if (kind != "file" && kind != "point" && !sized) {
        reader.fail(reader.line("opening"), reader.name("opening") +
                                                " must be file, point, rectangle or disc, got " +
                                                in_quotes(kind));
    }
    if (size && !sized) {
        reader.fail(reader.line("opening_size"),
                    reader.name("opening_size") + " needs opening = \"rectangle\" or \"disc\"");
    }
    if (kind == "file") return file;
    visdb::LuminousOpening o;
    if (!sized) return o;
    if (!size)
        reader.fail(reader.line("opening"), "opening " + in_quotes(kind) + " needs 'opening_size'");
    if (!(size->x > 0.0 && size->y > 0.0)) {
        reader.fail(reader.line("opening_size"),
                    reader.name("opening_size") + " must be > 0, got " + fmt(*size));
    }
    o.shape = kind == "disc" ? Shape::Disc : Shape::Rectangle;
    o.length = size->x;
    o.width = size->y;
    return o;
}

/// The keys of a [[luminaire]] placed by the model (object/layer), read into `p`; those of a
/// luminaire at a position (position, count, step) are refused.
void read_placement_keys(const TableReader& reader, SceneLuminairePlacement& p) {
    const std::string section = "[[luminaire]]";
    for (const char* key : {"position", "count", "step"}) {
        if (reader.has(key)) {
            reader.fail(reader.line(key), reader.name(key) +
                                              " cannot be combined with 'object' or 'layer' (the "
                                              "model's instances place the luminaires)");
        }
    }
    p.match.object = reader.string("object");
    p.match.layer = reader.string("layer");
    p.match_key = p.match.object ? "object" : "layer";
    p.match_line = reader.line(p.match_key);
    for (const char* key : {"object", "layer"}) {
        const auto glob = reader.string(key);
        if (glob && glob->empty()) reader.fail(reader.line(key), reader.name(key) + " is empty");
    }
    if (const auto instances = reader.string("instances")) {
        if (*instances != "pieces" && *instances != "objects") {
            reader.fail(reader.line("instances"), reader.name("instances") +
                                                      " must be pieces or objects, got " +
                                                      in_quotes(*instances));
        }
        p.per_object = *instances == "objects";
    }
    if (const auto mounting = reader.string("mounting")) {
        if (*mounting != "center" && *mounting != "surface") {
            reader.fail(reader.line("mounting"), reader.name("mounting") +
                                                     " must be center or surface, got " +
                                                     in_quotes(*mounting));
        }
        p.mounting = *mounting == "surface" ? SceneLuminairePlacement::Mounting::Surface
                                            : SceneLuminairePlacement::Mounting::Center;
    }
    p.keep_geometry = reader.boolean("keep_geometry").value_or(false);
}

/// A [[luminaire]]: its photometric file read (relative to the scene file's folder), its frame
/// resolved, one SceneLuminaire for each of its `count`; or, placed by the model (object/layer),
/// one SceneLuminairePlacement resolved later by apply_scene_file.
void read_luminaire(const std::string& file, const toml::table& table, bool allow_outside_refs,
                    SceneFile& scene) {
    const std::string section = "[[luminaire]]";
    const TableReader reader(
        file, table, section,
        {"file", "name", "position", "rotation", "target", "count", "step", "flux_scale",
         "maintenance_factor", "color", "opening", "opening_size", "group", "object", "layer",
         "instances", "mounting", "keep_geometry"});
    const std::size_t line = reader.line();
    const bool placed = reader.has("object") || reader.has("layer");
    if (!reader.has("file")) reader.fail(line, section + " needs 'file'");
    if (!placed && !reader.has("position")) {
        reader.fail(line, section +
                              " needs 'position', or 'object' or 'layer' to place it at "
                              "the model's instances");
    }
    if (!placed) {
        for (const char* key : {"instances", "mounting", "keep_geometry"}) {
            if (reader.has(key)) {
                reader.fail(reader.line(key), reader.name(key) + " needs 'object' or 'layer'");
            }
        }
    }
    SceneLuminairePlacement placement;
    placement.line = line;
    if (placed) read_placement_keys(reader, placement);
    const std::string ref = *reader.string("file");
    if (ref.empty()) reader.fail(reader.line("file"), reader.name("file") + " is empty");
    visdb::Luminaire l;
    if (!placed) l.position = *reader.vec3("position");
    const auto rotation = reader.vec3("rotation");
    const auto target = reader.vec3("target");
    if (rotation && target) {
        reader.fail(reader.line("target"), section + " gives both 'rotation' (line " +
                                               std::to_string(reader.line("rotation")) +
                                               ") and 'target'; give one");
    }
    if (rotation) set_rotation(l, *rotation);
    if (target && placed) placement.target = target;
    if (target && !placed) {
        const glm::dvec3 aim = *target - l.position;
        if (!(glm::length(aim) > 0.0)) {
            reader.fail(reader.line("target"), reader.name("target") + " equals 'position'");
        }
        set_aim(l, glm::normalize(aim));
    }
    const double count = reader.number("count").value_or(1.0);
    if (!(count >= 1.0 && count <= 10000.0 && count == std::floor(count))) {
        reader.fail(
            reader.line("count"),
            reader.name("count") + " must be a whole number from 1 to 10000, got " + fmt(count));
    }
    const auto step = reader.vec3("step");
    if (count > 1.0 && !step) reader.fail(reader.line("count"), "'count' > 1 needs 'step'");
    if (step && count == 1.0) reader.fail(reader.line("step"), "'step' needs 'count' > 1");
    if (const auto f = reader.number("flux_scale")) {
        if (!(*f > 0.0)) {
            reader.fail(reader.line("flux_scale"),
                        reader.name("flux_scale") + " must be > 0, got " + fmt(*f));
        }
        l.flux_scale = *f;
    }
    if (const auto m = reader.number("maintenance_factor")) {
        if (!(*m > 0.0 && *m <= 1.0)) {
            reader.fail(reader.line("maintenance_factor"),
                        reader.name("maintenance_factor") + " must be in (0, 1], got " + fmt(*m));
        }
        l.maintenance_factor = *m;
    }
    l.color = read_color(reader, section);
    l.group = read_group(reader, section).value_or("");

    // The photometric file, inside the scene file's folder
    const std::filesystem::path scene_path(file);
    const std::filesystem::path resolved = std::filesystem::path(ref).is_absolute()
                                               ? std::filesystem::path(ref)
                                               : scene_path.parent_path() / ref;
    if (!allow_outside_refs) {
        detail::check_reference_inside(resolved, scene_path, file, reader.line("file"),
                                       "photometric file");
    }
    const PhotometricFile photometry = read_photometric_file(resolved);
    // TILT=INCLUDE: the lamp-tilt multiplier at the luminaire's tilt as placed (an aimed
    // placement's instances: each at its own aim, in apply_scene_file)
    l.tilt_factor = photometry.tilt_multiplier(l.tilt_degrees());
    if (!(l.tilt_factor > 0.0) && !placement.target) {
        reader.fail(line, section + " tilted " + fmt(l.tilt_degrees()) +
                              " degrees gives no light: " + ref +
                              "'s tilt table gives the factor 0 there");
    }
    l.opening = read_opening(reader, photometry.opening);
    l.file = resolved.string();
    l.checksum = photometry.checksum;
    l.web = photometry.web;
    const std::string name = reader.string("name").value_or(
        std::filesystem::path(ref).stem().string() + " (line " + std::to_string(line) + ")");
    if (name.empty()) reader.fail(reader.line("name"), reader.name("name") + " is empty");
    if (placed) {
        l.name = name;
        placement.luminaire = std::move(l);
        placement.flux_report = photometry.flux_report();
        placement.tilt_angles = photometry.tilt_angles;
        placement.tilt_factors = photometry.tilt_factors;
        scene.placements.push_back(std::move(placement));
        return;
    }
    const auto n = static_cast<int>(count);
    for (int i = 0; i < n; ++i) {
        SceneLuminaire sl;
        sl.line = line;
        sl.luminaire = l;
        sl.luminaire.name = n == 1 ? name : name + " " + std::to_string(i + 1);
        if (step) sl.luminaire.position += static_cast<double>(i) * *step;
        sl.flux_report = photometry.flux_report();
        for (const SceneLuminaire& other : scene.luminaires) {
            if (other.luminaire.name == sl.luminaire.name) {
                reader.fail(line, "luminaire " + in_quotes(sl.luminaire.name) +
                                      " is already defined at line " + std::to_string(other.line));
            }
        }
        scene.luminaires.push_back(std::move(sl));
    }
}

SceneCamera read_camera(const std::string& file, const toml::table& table) {
    const TableReader reader(file, table, "[[camera]]",
                             {"name", "position", "look_at", "up", "fov"});
    SceneCamera cam;
    cam.line = reader.line();
    for (const char* key : {"name", "position", "look_at"}) {
        if (!reader.has(key)) reader.fail(cam.line, std::string("[[camera]] needs '") + key + "'");
    }
    cam.camera.name = *reader.string("name");
    if (cam.camera.name.empty())
        reader.fail(reader.line("name"), reader.name("name") + " is empty");
    cam.camera.position = *reader.vec3("position");
    cam.camera.look_at = *reader.vec3("look_at");
    const glm::dvec3 view = cam.camera.look_at - cam.camera.position;
    if (!(glm::length(view) > 0.0)) {
        reader.fail(reader.line("look_at"), reader.name("look_at") + " equals 'position'");
    }
    if (const auto up = reader.vec3("up")) cam.camera.up = *up;
    const double cross = glm::length(glm::cross(view, cam.camera.up));
    if (!(cross > 1e-9 * glm::length(view) * glm::length(cam.camera.up))) {
        reader.fail(reader.has("up") ? reader.line("up") : cam.line,
                    "camera " + in_quotes(cam.camera.name) + ": 'up' " + fmt(cam.camera.up) +
                        " is zero or parallel to the view direction " + fmt(view));
    }
    if (const auto fov = reader.number("fov")) {
        if (!(*fov > 0.0 && *fov < 180.0)) {
            reader.fail(reader.line("fov"),
                        reader.name("fov") + " must be in (0, 180) degrees, got " + fmt(*fov));
        }
        cam.camera.fov_y_deg = *fov;
    }
    return cam;
}

SceneExclude read_exclude(const std::string& file, const toml::table& table) {
    const TableReader reader(file, table, "[[exclude]]", {"object", "layer", "material"});
    SceneExclude ex;
    ex.line = reader.line();
    ex.match = read_match(reader);
    if (!has_condition(ex.match)) {
        reader.fail(ex.line, "[[exclude]] needs at least one condition: object, layer or material");
    }
    return ex;
}

SceneGrid read_grid(const std::string& file, const toml::table& table) {
    const TableReader reader(file, table, "[[grid]]",
                             {"name", "over", "min", "max", "height", "spacing", "margin"});
    SceneGrid grid;
    grid.line = reader.line();
    if (!reader.has("name")) reader.fail(grid.line, "[[grid]] needs 'name'");
    grid.name = *reader.string("name");
    if (grid.name.empty()) reader.fail(reader.line("name"), reader.name("name") + " is empty");
    grid.over = reader.string("over");
    const bool has_min = reader.has("min");
    const bool has_max = reader.has("max");
    if (grid.over && (has_min || has_max)) {
        reader.fail(reader.line(has_min ? "min" : "max"),
                    "grid " + in_quotes(grid.name) + ": give 'over' or 'min'/'max', not both");
    }
    if (!grid.over && !(has_min && has_max)) {
        reader.fail(grid.line, "grid " + in_quotes(grid.name) +
                                   " needs 'over' (an object glob) or both 'min' and 'max'");
    }
    if (const auto h = reader.number("height")) {
        grid.height = *h;
    } else if (!grid.over) {
        reader.fail(grid.line, "grid " + in_quotes(grid.name) +
                                   " needs 'height' (the absolute z of the plane) with min/max");
    }
    if (const auto s = reader.number("spacing")) {
        if (!(*s > 0.0)) {
            reader.fail(reader.line("spacing"),
                        reader.name("spacing") + " must be > 0, got " + fmt(*s));
        }
        grid.spacing = *s;
    }
    if (const auto m = reader.number("margin")) {
        reader.check_range("margin", *m, 0.0, HUGE_VAL, ">= 0");
        grid.margin = *m;
    }
    if (!grid.over) {
        grid.min = *reader.vec2("min");
        grid.max = *reader.vec2("max");
        if (!(grid.min.x < grid.max.x && grid.min.y < grid.max.y)) {
            reader.fail(reader.line("max"), "grid " + in_quotes(grid.name) + ": 'min' " +
                                                fmt(grid.min) + " must be less than 'max' " +
                                                fmt(grid.max) + " in x and y");
        }
        const glm::dvec2 inner = grid.max - grid.min - 2.0 * grid.margin;
        if (!(inner.x > 0.0 && inner.y > 0.0)) {
            reader.fail(reader.has("margin") ? reader.line("margin") : grid.line,
                        "grid " + in_quotes(grid.name) + ": margin " + fmt(grid.margin) +
                            " leaves nothing of the " + fmt(grid.max.x - grid.min.x) + " x " +
                            fmt(grid.max.y - grid.min.y) + " m rectangle");
        }
    }
    return grid;
}

// ---------------------------------------------------------------------------------------------
// Applying: per-surface overrides, then new materials

/// What the rules set on one surface; unset properties keep the model's.
struct SurfaceOverride {
    std::optional<visdb::Rgb> reflectance;
    std::optional<double> opacity;
    std::optional<visdb::Rgb> emittance;
    std::optional<std::string> group;
    std::size_t line = 0;  ///< the last rule that set something
};

visdb::Material overridden(const visdb::Material& m, const SurfaceOverride& o) {
    visdb::Material r = m;
    if (o.reflectance) r.reflectance = *o.reflectance;
    if (o.opacity) r.opacity = *o.opacity;
    if (o.emittance) r.emittance = *o.emittance;
    if (o.group) r.group = *o.group;
    return r;
}

/// Equal properties; emittances within 1e-9 relative count as equal, so that luminaires of
/// one flux whose areas differ only by rounding share one material.
bool same_properties(const visdb::Material& a, const visdb::Material& b) {
    const auto close = [](const visdb::Rgb& x, const visdb::Rgb& y) {
        for (int k = 0; k < 3; ++k)
            if (std::abs(x[k] - y[k]) > 1e-9 * std::max(std::abs(x[k]), std::abs(y[k])))
                return false;
        return true;
    };
    return a.reflectance == b.reflectance && close(a.emittance, b.emittance) &&
           a.opacity == b.opacity && a.group == b.group;
}

/// `name`, or "name (2)", "name (3)"... when taken; records the result as taken.
std::string unique_name(const std::string& name, std::set<std::string>& taken) {
    std::string candidate = name;
    for (int i = 2; taken.count(candidate) > 0; ++i)
        candidate = name + " (" + std::to_string(i) + ")";
    taken.insert(candidate);
    return candidate;
}

std::string what_matches_nothing(const char* section, const SurfaceMatch& match) {
    return std::string(section) + " matches no surface (" + match.to_string() + ")";
}

/// Refuses luminaires whose names the scene already has.
void check_luminaire_names(const SceneFile& file, const visdb::Scene& scene) {
    for (const SceneLuminaire& l : file.luminaires) {
        for (const auto& existing : scene.luminaires) {
            if (existing.name == l.luminaire.name) {
                throw ImportError(
                    file.path, l.line,
                    "luminaire " + in_quotes(l.luminaire.name) + " already exists in the scene");
            }
        }
    }
}

/// Appends the file's luminaires to the scene, with a note for each [[luminaire]] table: its
/// file's flux against its lamps and the flux placed.
template <class Note>
void add_luminaires(const SceneFile& file, visdb::Scene& scene, const Note& note) {
    for (std::size_t i = 0; i < file.luminaires.size(); ++i) {
        const SceneLuminaire& l = file.luminaires[i];
        scene.luminaires.push_back(l.luminaire);
        if (i > 0 && file.luminaires[i - 1].line == l.line) continue;  // one note a table
        std::size_t n = 1;
        while (i + n < file.luminaires.size() && file.luminaires[i + n].line == l.line) ++n;
        note(l.line, "luminaire " + in_quotes(l.luminaire.name) +
                         (n > 1 ? " and " + std::to_string(n - 1) + " more" : std::string()) +
                         ": " + l.luminaire.file + ": " + l.flux_report + "; placed " +
                         fmt(l.luminaire.flux()) + " lm each (scale " + fmt(l.luminaire.scale()) +
                         (l.luminaire.tilt_factor != 1.0
                              ? ", lamp tilt factor " + fmt(l.luminaire.tilt_factor) + " at " +
                                    fmt(l.luminaire.tilt_degrees()) + " degrees"
                              : std::string()) +
                         ")");
    }
}

/// The luminaires of one [[luminaire]] placed by the model, resolved against the scene.
struct PlacedLuminaires {
    const SceneLuminairePlacement* placement = nullptr;
    std::vector<LuminaireInstance> instances;
    std::vector<visdb::Luminaire> luminaires;  ///< one per instance, same order
};

/// Where the unit `aim` from the centre of the box [lo, hi] leaves it.
glm::dvec3 box_exit(const glm::dvec3& lo, const glm::dvec3& hi, const glm::dvec3& aim) {
    const glm::dvec3 half = 0.5 * (hi - lo);
    double t = HUGE_VAL;
    for (int k = 0; k < 3; ++k) {
        if (aim[k] != 0.0) t = std::min(t, half[k] / std::abs(aim[k]));
    }
    return 0.5 * (lo + hi) + t * aim;
}

/// The luminaire of one instance: the placement's luminaire at the instance's reference point,
/// aimed by its target (each instance its own frame and tilt factor) or its rotation.
visdb::Luminaire place_at(const SceneLuminairePlacement& p, const LuminaireInstance& instance,
                          const std::string& path) {
    visdb::Luminaire l = p.luminaire;
    const glm::dvec3 centre = 0.5 * (instance.min + instance.max);
    const auto fail = [&](const std::string& why) {
        throw ImportError(path, p.line,
                          "[[luminaire]] instance of " + in_quotes(instance.object) + " at " +
                              fmt(centre) + ": " + why);
    };
    glm::dvec3 aim = -l.axis_z;  // the nadir of the rotation, straight down without one
    if (p.target) {
        if (!(glm::length(*p.target - centre) > 0.0)) fail("'target' is its centre");
        aim = glm::normalize(*p.target - centre);
    }
    l.position = p.mounting == SceneLuminairePlacement::Mounting::Surface
                     ? box_exit(instance.min, instance.max, aim)
                     : centre;
    if (p.target) {
        if (!(glm::length(*p.target - l.position) > 0.0)) fail("'target' is its reference point");
        set_aim(l, glm::normalize(*p.target - l.position));
        PhotometricFile tilt;
        tilt.tilt_angles = p.tilt_angles;
        tilt.tilt_factors = p.tilt_factors;
        l.tilt_factor = tilt.tilt_multiplier(l.tilt_degrees());
        if (!(l.tilt_factor > 0.0)) {
            fail("tilted " + fmt(l.tilt_degrees()) + " degrees it gives no light: " + l.file +
                 "'s tilt table gives the factor 0 there");
        }
    }
    return l;
}

/// Resolves every placement of `file` against the surfaces as imported; throws ImportError at
/// the key of a glob that matches nothing.
std::vector<PlacedLuminaires> place_luminaires(const SceneFile& file, const visdb::Scene& scene) {
    std::vector<PlacedLuminaires> placed;
    for (const SceneLuminairePlacement& p : file.placements) {
        PlacedLuminaires r;
        r.placement = &p;
        r.instances = placed_instances(p, scene);
        if (r.instances.empty()) {
            throw ImportError(file.path, p.match_line,
                              "'" + p.match_key + "' in [[luminaire]] matches no surface (" +
                                  p.match.to_string() + ")");
        }
        const std::size_t n = r.instances.size();
        for (std::size_t i = 0; i < n; ++i) {
            r.luminaires.push_back(place_at(p, r.instances[i], file.path));
            if (n > 1) r.luminaires.back().name += " " + std::to_string(i + 1);
        }
        placed.push_back(std::move(r));
    }
    return placed;
}

/// Refuses placed luminaires whose names another luminaire of the scene or the file has.
void check_placed_names(const SceneFile& file, const visdb::Scene& scene,
                        const std::vector<PlacedLuminaires>& placed) {
    std::map<std::string, std::size_t> lines;  // name -> line of the file that gives it
    for (const SceneLuminaire& l : file.luminaires) lines.emplace(l.luminaire.name, l.line);
    std::set<std::string> existing;
    for (const auto& l : scene.luminaires) existing.insert(l.name);
    for (const PlacedLuminaires& r : placed) {
        for (const visdb::Luminaire& l : r.luminaires) {
            if (existing.count(l.name) > 0) {
                throw ImportError(
                    file.path, r.placement->line,
                    "luminaire " + in_quotes(l.name) + " already exists in the scene");
            }
            const auto [it, added] = lines.emplace(l.name, r.placement->line);
            if (!added) {
                throw ImportError(file.path, r.placement->line,
                                  "luminaire " + in_quotes(l.name) +
                                      " is already defined at line " + std::to_string(it->second));
            }
        }
    }
}

/// Marks the surfaces of placed luminaires that do not keep their geometry as excluded; returns
/// how many were not excluded already, and sets `first_line` (when 0) to the first such table's.
std::size_t exclude_placed_geometry(const std::vector<PlacedLuminaires>& placed,
                                    std::vector<bool>& excluded, std::size_t& first_line) {
    std::size_t count = 0;
    for (const PlacedLuminaires& r : placed) {
        if (r.placement->keep_geometry) continue;
        for (const LuminaireInstance& in : r.instances) {
            for (const std::size_t i : in.surfaces) {
                if (excluded[i]) continue;
                excluded[i] = true;
                ++count;
                if (first_line == 0) first_line = r.placement->line;
            }
        }
    }
    return count;
}

/// Appends the placed luminaires to the scene with a note for each table (how many instances of
/// what, the flux, and what became of their geometry); returns how many.
template <class Note>
std::size_t add_placed_luminaires(const std::vector<PlacedLuminaires>& placed, visdb::Scene& scene,
                                  const Note& note) {
    std::size_t added = 0;
    for (const PlacedLuminaires& r : placed) {
        added += r.luminaires.size();
        const SceneLuminairePlacement& p = *r.placement;
        std::set<std::string> objects;
        std::set<std::size_t> surface_set;
        for (const LuminaireInstance& in : r.instances) {
            objects.insert(in.object);
            surface_set.insert(in.surfaces.begin(), in.surfaces.end());
        }
        const std::size_t surfaces = surface_set.size();
        const visdb::Luminaire& first = r.luminaires.front();
        const std::size_t n = r.luminaires.size();
        note(p.line, "luminaire " + in_quotes(first.name) +
                         (n > 1 ? " and " + std::to_string(n - 1) + " more" : std::string()) +
                         " placed at " + std::to_string(n) + " instance" + (n == 1 ? "" : "s") +
                         " (" + p.match.to_string() + ": " + std::to_string(objects.size()) +
                         " object" + (objects.size() == 1 ? "" : "s") + ", " +
                         std::to_string(surfaces) + " surface" + (surfaces == 1 ? "" : "s") +
                         (p.keep_geometry ? ", kept" : ", removed") + "): " + first.file + ": " +
                         p.flux_report + "; placed " + fmt(first.flux()) + " lm each (scale " +
                         fmt(first.scale()) + ")");
        for (const visdb::Luminaire& l : r.luminaires) scene.luminaires.push_back(l);
    }
    return added;
}

/// Union-find over indices, for the pieces of placed_instances.
class DisjointSets {
  public:
    explicit DisjointSets(std::size_t n) : m_parent(n) {
        for (std::size_t i = 0; i < n; ++i) m_parent[i] = i;
    }
    std::size_t find(std::size_t i) {
        while (m_parent[i] != i) {
            m_parent[i] = m_parent[m_parent[i]];
            i = m_parent[i];
        }
        return i;
    }
    void join(std::size_t a, std::size_t b) {
        a = find(a);
        b = find(b);
        if (a != b) m_parent[std::max(a, b)] = std::min(a, b);
    }

  private:
    std::vector<std::size_t> m_parent;
};

/// The pieces of the surfaces `of` (one object): triangles sharing a vertex, one piece each.
std::vector<LuminaireInstance> pieces_of(const visdb::Scene& scene,
                                         const std::vector<std::size_t>& of) {
    std::vector<LuminaireInstance> pieces;
    for (const std::size_t s : of) {
        const visdb::TriangleMesh& mesh = scene.surfaces[s].mesh;
        DisjointSets sets(mesh.positions.size());
        for (const auto& t : mesh.triangles) {
            sets.join(t.x, t.y);
            sets.join(t.x, t.z);
        }
        std::map<std::size_t, std::size_t> piece_of_root;  // root vertex -> index in pieces
        for (const auto& t : mesh.triangles) {
            const auto [it, added] = piece_of_root.try_emplace(sets.find(t.x), pieces.size());
            if (added) {
                pieces.push_back(
                    {scene.surfaces[s].name, glm::dvec3(HUGE_VAL), glm::dvec3(-HUGE_VAL), {s}, 0});
            }
            LuminaireInstance& piece = pieces[it->second];
            for (int k = 0; k < 3; ++k) {
                piece.min = glm::min(piece.min, mesh.positions[t[k]]);
                piece.max = glm::max(piece.max, mesh.positions[t[k]]);
            }
            ++piece.triangles;
        }
    }
    return pieces;
}

/// Joins pieces whose closed boxes intersect (transitively), or all of them (`all`).
std::vector<LuminaireInstance> join_pieces(std::vector<LuminaireInstance> pieces, bool all) {
    const std::size_t n = pieces.size();
    DisjointSets sets(n);
    if (all) {
        for (std::size_t i = 1; i < n; ++i) sets.join(0, i);
    } else {
        // Sweep along the axis the pieces spread most: sort by the box's low end, test the
        // boxes that start before one ends
        glm::dvec3 lo(HUGE_VAL);
        glm::dvec3 hi(-HUGE_VAL);
        for (const auto& p : pieces) {
            lo = glm::min(lo, p.min);
            hi = glm::max(hi, p.min);
        }
        const glm::dvec3 spread = hi - lo;
        const int axis = spread.x >= spread.y && spread.x >= spread.z ? 0
                         : spread.y >= spread.z                       ? 1
                                                                      : 2;
        std::vector<std::size_t> order(n);
        for (std::size_t i = 0; i < n; ++i) order[i] = i;
        std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
            return pieces[a].min[axis] < pieces[b].min[axis];
        });
        for (std::size_t a = 0; a < n; ++a) {
            const LuminaireInstance& p = pieces[order[a]];
            for (std::size_t b = a + 1; b < n && pieces[order[b]].min[axis] <= p.max[axis]; ++b) {
                const LuminaireInstance& q = pieces[order[b]];
                bool meet = true;
                for (int k = 0; k < 3; ++k)
                    meet = meet && q.min[k] <= p.max[k] && p.min[k] <= q.max[k];
                if (meet) sets.join(order[a], order[b]);
            }
        }
    }
    std::vector<LuminaireInstance> joined;
    std::map<std::size_t, std::size_t> index_of_root;
    for (std::size_t i = 0; i < n; ++i) {
        const auto [it, added] = index_of_root.try_emplace(sets.find(i), joined.size());
        if (added) {
            joined.push_back(std::move(pieces[i]));
            continue;
        }
        LuminaireInstance& in = joined[it->second];
        in.min = glm::min(in.min, pieces[i].min);
        in.max = glm::max(in.max, pieces[i].max);
        in.triangles += pieces[i].triangles;
        in.surfaces.insert(in.surfaces.end(), pieces[i].surfaces.begin(), pieces[i].surfaces.end());
    }
    for (LuminaireInstance& in : joined) {
        std::sort(in.surfaces.begin(), in.surfaces.end());
        in.surfaces.erase(std::unique(in.surfaces.begin(), in.surfaces.end()), in.surfaces.end());
    }
    return joined;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Section types

bool SurfaceMatch::matches(const visdb::Surface& surface, const std::string& material_name) const {
    if (object && !glob_match(*object, surface.name)) return false;
    if (layer && !glob_match(*layer, surface.layer)) return false;
    if (material && !glob_match(*material, material_name)) return false;
    return true;
}

std::string SurfaceMatch::to_string() const {
    std::string s;
    const auto add = [&s](const char* key, const std::optional<std::string>& glob) {
        if (!glob) return;
        if (!s.empty()) s += ", ";
        s += key;
        s += " '" + *glob + "'";
    };
    add("object", object);
    add("layer", layer);
    add("material", material);
    return s;
}

std::vector<LuminaireInstance> placed_instances(const SceneLuminairePlacement& placement,
                                                const visdb::Scene& scene) {
    // The matched surfaces by object name (a map: instances come out in name order)
    std::map<std::string, std::vector<std::size_t>> by_object;
    for (std::size_t i = 0; i < scene.surfaces.size(); ++i) {
        if (placement.match.matches(scene.surfaces[i], std::string()))
            by_object[scene.surfaces[i].name].push_back(i);
    }
    std::vector<LuminaireInstance> instances;
    for (const auto& [object, surfaces] : by_object) {
        std::vector<LuminaireInstance> joined =
            join_pieces(pieces_of(scene, surfaces), placement.per_object);
        std::sort(joined.begin(), joined.end(),
                  [](const LuminaireInstance& a, const LuminaireInstance& b) {
                      const glm::dvec3 ca = a.min + a.max;
                      const glm::dvec3 cb = b.min + b.max;
                      return std::tie(ca.x, ca.y, ca.z) < std::tie(cb.x, cb.y, cb.z);
                  });
        for (auto& in : joined) instances.push_back(std::move(in));
    }
    return instances;
}

std::string SceneLuminairePlacement::to_string() const {
    const visdb::Luminaire& l = luminaire;
    std::string s = "luminaire line " + std::to_string(line) + ": " + in_quotes(l.name) + " " +
                    l.file + " at the " + (per_object ? "objects" : "pieces") + " of " +
                    match.to_string() + " (mounting " +
                    (mounting == Mounting::Surface ? "surface" : "center") +
                    (keep_geometry ? ", geometry kept)" : ", geometry removed)");
    s += target ? " aimed at " + fmt(*target) : " nadir toward " + fmt(-l.axis_z);
    return s + " scale " + fmt(l.flux_scale) + " x " + fmt(l.maintenance_factor) + " opening " +
           visdb::to_string(l.opening.shape) + "; " + flux_report;
}

std::string SceneRule::to_string() const {
    std::string s = std::string(is_emitter ? "emitter" : "rule") + " line " + std::to_string(line) +
                    ": " + match.to_string() + " ->";
    if (reflectance) s += " reflectance " + fmt(*reflectance);
    if (opacity) s += " opacity " + fmt(*opacity);
    if (emittance) s += " emittance " + fmt(*emittance);
    if (flux) s += " flux " + fmt(*flux) + " lm color " + fmt(color);
    return s;
}

visdb::Rgb SceneRectangle::exitance() const {
    if (emittance) return *emittance;
    return (flux.value_or(0.0) / (size.x * size.y)) * color;
}

visdb::TriangleMesh SceneRectangle::mesh() const {
    // Corners counter-clockwise about the normal: (axis, normal x axis, normal) is right-handed
    const glm::dvec3 u = axis * (0.5 * size.x);
    const glm::dvec3 v = glm::cross(normal, axis) * (0.5 * size.y);
    visdb::TriangleMesh m;
    m.positions = {center - u - v, center + u - v, center + u + v, center - u + v};
    m.triangles = {{0, 1, 2}, {0, 2, 3}};
    return m;
}

std::string SceneRectangle::to_string() const {
    std::string s = "emitter line " + std::to_string(line) + ": rectangle " + in_quotes(name) +
                    " center " + fmt(center) + " size " + fmt(size) + " normal " + fmt(normal) +
                    " axis " + fmt(axis);
    if (emittance) s += " emittance " + fmt(*emittance);
    if (flux) s += " flux " + fmt(*flux) + " lm color " + fmt(color);
    return s;
}

std::string SceneGrid::to_string() const {
    std::string s = "grid line " + std::to_string(line) + ": " + in_quotes(name);
    if (over) {
        s += " over '" + *over + "' height " + fmt(height) + " above its lowest z";
    } else {
        s += " min " + fmt(min) + " max " + fmt(max) + " z " + fmt(height);
    }
    return s + " spacing " + fmt(spacing) + " margin " + fmt(margin);
}

bool SceneFile::uses_flux() const {
    for (const auto& r : rules) {
        if (r.flux) return true;
    }
    for (const auto& r : rectangles) {
        if (r.flux) return true;
    }
    return !luminaires.empty() || !placements.empty();
}

bool SceneFile::is_photometric() const { return photometric.value_or(uses_flux()); }

std::string SceneFile::to_string() const {
    std::string s =
        "scene file " + path + " (" + checksum + ", " + std::to_string(size_bytes) + " bytes)\n";
    if (unit) s += "unit: " + *unit + "\n";
    if (up) s += std::string("up: ") + *up + "\n";
    if (origin_shift) s += "origin_shift: " + fmt(*origin_shift) + "\n";
    if (weld_tolerance) s += "weld_tolerance: " + fmt(*weld_tolerance) + "\n";
    s += std::string("photometric: ") + (is_photometric() ? "true" : "false") +
         (photometric ? "\n" : " (default)\n");
    for (const auto& r : rules) s += r.to_string() + "\n";
    for (const auto& r : rectangles) s += r.to_string() + "\n";
    for (const auto& c : cameras) {
        s += "camera line " + std::to_string(c.line) + ": " + in_quotes(c.camera.name) + " at " +
             fmt(c.camera.position) + " looking at " + fmt(c.camera.look_at) + " fov " +
             fmt(c.camera.fov_y_deg) + "\n";
    }
    for (const auto& e : excludes) {
        s += "exclude line " + std::to_string(e.line) + ": " + e.match.to_string() + "\n";
    }
    for (const auto& g : grids) s += g.to_string() + "\n";
    for (const auto& l : luminaires) s += l.to_string() + "\n";
    for (const auto& p : placements) s += p.to_string() + "\n";
    return s;
}

std::string SceneLuminaire::to_string() const {
    const visdb::Luminaire& l = luminaire;
    return "luminaire line " + std::to_string(line) + ": " + in_quotes(l.name) + " " + l.file +
           " at " + fmt(l.position) + " nadir toward " + fmt(-l.axis_z) + " C0 along " +
           fmt(l.axis_x) + " scale " + fmt(l.flux_scale) + " x " + fmt(l.maintenance_factor) +
           " x tilt " + fmt(l.tilt_factor) + " opening " + visdb::to_string(l.opening.shape) +
           "; " + flux_report;
}

std::string SceneFileReport::to_string() const {
    std::string s;
    const auto row = [&s](const char* label, std::size_t value) {
        s += label;
        s += ": ";
        s += std::to_string(value);
        s += '\n';
    };
    row("surfaces excluded", surfaces_excluded);
    row("materials overridden", materials_overridden);
    row("emitters added", emitters_added);
    row("cameras", cameras);
    row("grids", grids);
    row("luminaires", luminaires);
    row("notes", notes.size());
    for (const std::string& note : notes) {
        s += "  ";
        s += note;
        s += '\n';
    }
    return s;
}

// ---------------------------------------------------------------------------------------------
// read_scene_file

SceneFile read_scene_file(const std::filesystem::path& path, bool allow_outside_refs) {
    SceneFile scene;
    scene.path = path.string();
    const std::string& file = scene.path;
    const std::string bytes = detail::read_file_bytes(path, file, "scene file");
    scene.checksum = detail::fnv1a64_hex(bytes);
    scene.size_bytes = bytes.size();

    // Parse the TOML document
    toml::table root;
    detail::check_toml_in_child(bytes, file);  // toml++ can crash: first in a child process
    try {
        root = toml::parse(std::string_view(bytes), std::string_view(file));
    } catch (const toml::parse_error& e) {
        throw ImportError(file, e.source().begin.line, std::string(e.description()));
    }

    // Top-level settings
    const TableReader top(file, root, "",
                          {"unit", "up", "origin_shift", "weld_tolerance", "photometric", "rule",
                           "emitter", "camera", "exclude", "grid", "luminaire"});
    if (const auto unit = top.string("unit")) {
        try {
            (void)metres_per_unit(*unit);
        } catch (const std::invalid_argument&) {
            top.fail(top.line("unit"),
                     "unknown unit '" + *unit + "' in 'unit' (expected mm, cm, m, in or ft)");
        }
        scene.unit = *unit;
    }
    if (const auto up = top.string("up")) {
        if (*up == "y" || *up == "Y") {
            scene.up = 'y';
        } else if (*up == "z" || *up == "Z") {
            scene.up = 'z';
        } else {
            top.fail(top.line("up"), "unknown up axis '" + *up + "' in 'up' (expected y or z)");
        }
    }
    scene.origin_shift = top.vec3("origin_shift");
    scene.weld_tolerance = top.number("weld_tolerance");
    if (scene.weld_tolerance) {
        top.check_range("weld_tolerance", *scene.weld_tolerance, 0.0, HUGE_VAL, ">= 0");
    }
    scene.photometric = top.boolean("photometric");

    // Sections; [[rule]] and object [[emitter]] share one list in file order
    for (const toml::table* t : section_tables(file, root, "rule")) {
        scene.rules.push_back(read_rule(file, *t));
    }
    for (const toml::table* t : section_tables(file, root, "emitter"))
        read_emitter(file, *t, scene);
    std::stable_sort(scene.rules.begin(), scene.rules.end(),
                     [](const SceneRule& a, const SceneRule& b) { return a.line < b.line; });
    for (const toml::table* t : section_tables(file, root, "camera")) {
        SceneCamera cam = read_camera(file, *t);
        for (const SceneCamera& other : scene.cameras) {
            if (other.camera.name == cam.camera.name) {
                throw ImportError(file, cam.line,
                                  "camera " + in_quotes(cam.camera.name) +
                                      " is already defined at line " + std::to_string(other.line));
            }
        }
        scene.cameras.push_back(std::move(cam));
    }
    for (const toml::table* t : section_tables(file, root, "exclude")) {
        scene.excludes.push_back(read_exclude(file, *t));
    }
    for (const toml::table* t : section_tables(file, root, "grid")) {
        SceneGrid grid = read_grid(file, *t);
        for (const SceneGrid& other : scene.grids) {
            if (other.name == grid.name) {
                throw ImportError(file, grid.line,
                                  "grid " + in_quotes(grid.name) + " is already defined at line " +
                                      std::to_string(other.line));
            }
        }
        scene.grids.push_back(std::move(grid));
    }

    for (const toml::table* t : section_tables(file, root, "luminaire")) {
        read_luminaire(file, *t, allow_outside_refs, scene);
    }

    // A flux needs photometric mode
    if (scene.photometric && !*scene.photometric) {
        std::size_t flux_line = 0;
        for (const auto& r : scene.rules) {
            if (r.flux && (flux_line == 0 || r.line < flux_line)) flux_line = r.line;
        }
        for (const auto& r : scene.rectangles) {
            if (r.flux && (flux_line == 0 || r.line < flux_line)) flux_line = r.line;
        }
        for (const auto& l : scene.luminaires) {
            if (flux_line == 0 || l.line < flux_line) flux_line = l.line;
        }
        for (const auto& p : scene.placements) {
            if (flux_line == 0 || p.line < flux_line) flux_line = p.line;
        }
        if (flux_line > 0) {
            throw ImportError(file, flux_line,
                              "'flux' (lumens) or a luminaire needs photometric mode, but the "
                              "file sets "
                              "photometric = false (line " +
                                  std::to_string(top.line("photometric")) + ")");
        }
    }
    return scene;
}

void apply_import_settings(const SceneFile& file, ImportOptions& options) {
    if (file.unit) options.unit = *file.unit;
    if (file.up) options.up = *file.up;
    if (file.origin_shift) options.origin_shift = *file.origin_shift;
    if (file.weld_tolerance) options.weld_tolerance = *file.weld_tolerance;
}

// ---------------------------------------------------------------------------------------------
// apply_scene_file. Everything that can fail is checked before the scene is touched.

SceneFileReport apply_scene_file(const SceneFile& file, visdb::Scene& scene) {
    SceneFileReport report;
    const std::string& path = file.path;
    const std::size_t n_surfaces = scene.surfaces.size();
    std::vector<std::pair<std::size_t, std::string>> notes;  // (line, note); sorted at the end
    const auto note = [&](std::size_t line, const std::string& message) {
        notes.emplace_back(line == 0 ? SIZE_MAX : line, located(path, line, message));
    };
    for (const auto& s : scene.surfaces) {
        if (s.material >= scene.materials.size()) {
            throw std::invalid_argument("apply_scene_file: surface '" + s.name +
                                        "' has material index " + std::to_string(s.material) +
                                        " of " + std::to_string(scene.materials.size()));
        }
    }
    const auto material_name = [&](std::size_t i) -> const std::string& {
        return scene.materials[scene.surfaces[i].material].name;
    };

    // Resolve grids against the surfaces as imported (before exclusions)
    std::vector<visdb::CalculationGrid> grids;
    for (const SceneGrid& g : file.grids) {
        for (const auto& existing : scene.grids) {
            if (existing.name == g.name) {
                throw ImportError(path, g.line,
                                  "grid " + in_quotes(g.name) + " already exists in the scene");
            }
        }
        visdb::CalculationGrid grid;
        grid.name = g.name;
        grid.spacing = g.spacing;
        grid.normal = {0.0, 0.0, 1.0};
        glm::dvec2 lo = g.min;
        glm::dvec2 hi = g.max;
        double z = g.height;
        if (g.over) {
            // Bounding box of the covered surfaces' triangles
            glm::dvec3 bmin(HUGE_VAL);
            glm::dvec3 bmax(-HUGE_VAL);
            bool any = false;
            for (const auto& s : scene.surfaces) {
                if (!glob_match(*g.over, s.name)) continue;
                for (const auto& t : s.mesh.triangles) {
                    for (int k = 0; k < 3; ++k) {
                        const glm::dvec3& p = s.mesh.positions[t[k]];
                        bmin = glm::min(bmin, p);
                        bmax = glm::max(bmax, p);
                        any = true;
                    }
                }
            }
            if (!any) {
                note(g.line, "grid " + in_quotes(g.name) + " matches no surface (over '" + *g.over +
                                 "'); grid skipped");
                continue;
            }
            lo = {bmin.x, bmin.y};
            hi = {bmax.x, bmax.y};
            z = bmin.z + g.height;
        }
        grid.min = lo + g.margin;
        grid.max = hi - g.margin;
        grid.z = z;
        if (!(grid.min.x < grid.max.x && grid.min.y < grid.max.y)) {
            throw ImportError(path, g.line,
                              "grid " + in_quotes(g.name) + ": margin " + fmt(g.margin) +
                                  " leaves nothing of the " + fmt(hi.x - lo.x) + " x " +
                                  fmt(hi.y - lo.y) + " m rectangle" +
                                  (g.over ? " covered by '" + *g.over + "'" : std::string()));
        }
        grids.push_back(grid);
    }

    // Cameras: names unique in the scene
    for (const SceneCamera& c : file.cameras) {
        for (const auto& existing : scene.cameras) {
            if (existing.name == c.camera.name) {
                throw ImportError(
                    path, c.line,
                    "camera " + in_quotes(c.camera.name) + " already exists in the scene");
            }
        }
    }

    check_luminaire_names(file, scene);
    // Luminaires placed by the model, at instances of the surfaces as imported
    const std::vector<PlacedLuminaires> placed = place_luminaires(file, scene);
    check_placed_names(file, scene, placed);

    // Exclusions
    std::vector<bool> excluded(n_surfaces, false);
    std::size_t first_exclude_line = 0;
    for (const SceneExclude& ex : file.excludes) {
        std::vector<std::string> names;
        bool matched_any = false;
        for (std::size_t i = 0; i < n_surfaces; ++i) {
            if (!ex.match.matches(scene.surfaces[i], material_name(i))) continue;
            matched_any = true;
            if (excluded[i]) continue;
            excluded[i] = true;
            names.push_back(scene.surfaces[i].name);
        }
        if (!matched_any) {
            note(ex.line, what_matches_nothing("exclude", ex.match));
            continue;
        }
        if (first_exclude_line == 0) first_exclude_line = ex.line;
        report.surfaces_excluded += names.size();
        note(ex.line, "exclude (" + ex.match.to_string() + ") removes " +
                          std::to_string(names.size()) + " surface" +
                          (names.size() == 1 ? "" : "s") +
                          (names.empty() ? std::string() : ": " + name_list(names)));
    }
    report.surfaces_excluded += exclude_placed_geometry(placed, excluded, first_exclude_line);
    if (n_surfaces > 0 && report.surfaces_excluded == n_surfaces) {
        throw ImportError(path, first_exclude_line,
                          "the exclusions remove every surface of the scene (" +
                              std::to_string(n_surfaces) + ")");
    }

    // Rules and object emitters, in file order: per-surface overrides
    std::vector<SurfaceOverride> overrides(n_surfaces);
    for (const SceneRule& rule : file.rules) {
        const char* section = rule.is_emitter ? "emitter" : "rule";
        std::vector<std::size_t> matched;
        std::size_t matched_excluded = 0;
        for (std::size_t i = 0; i < n_surfaces; ++i) {
            if (!rule.match.matches(scene.surfaces[i], material_name(i))) continue;
            if (excluded[i]) {
                ++matched_excluded;
            } else {
                matched.push_back(i);
            }
        }
        if (matched.empty()) {
            std::string message = what_matches_nothing(section, rule.match);
            if (matched_excluded > 0) {
                message += "; the " + std::to_string(matched_excluded) + " it matches are excluded";
            }
            note(rule.line, message);
            continue;
        }

        // Luminaires: the matched surfaces of one object name; E = flux / their area
        std::map<std::string, double> luminaire_area;
        for (const std::size_t i : matched) {
            luminaire_area[scene.surfaces[i].name] += triangle_area(scene.surfaces[i].mesh);
        }
        if (rule.flux) {
            for (const auto& [name, area] : luminaire_area) {
                if (!(area > 0.0)) {
                    throw ImportError(path, rule.line,
                                      std::string(section) + " gives flux " + fmt(*rule.flux) +
                                          " lm to luminaire " + in_quotes(name) +
                                          ", which has zero area");
                }
            }
        }
        if (rule.is_emitter) report.emitters_added += luminaire_area.size();

        for (const std::size_t i : matched) {
            SurfaceOverride& o = overrides[i];
            if (rule.reflectance) o.reflectance = rule.reflectance;
            if (rule.opacity) o.opacity = rule.opacity;
            if (rule.emittance) o.emittance = rule.emittance;
            if (rule.group) o.group = rule.group;
            if (rule.flux)
                o.emittance = (*rule.flux / luminaire_area[scene.surfaces[i].name]) * rule.color;
            o.line = rule.line;
        }
    }

    // ----- From here on nothing throws: change the scene -----

    // Group the changed surfaces by (model material, resulting properties)
    struct Group {
        std::uint32_t model_material = 0;
        visdb::Material material;
        std::size_t line = 0;
        std::vector<std::size_t> surfaces;
    };
    std::vector<Group> groups;
    std::vector<std::vector<std::size_t>> groups_of_material(scene.materials.size());
    std::vector<std::size_t> surface_group(n_surfaces, SIZE_MAX);
    std::vector<std::size_t> users_before(scene.materials.size(), 0);
    std::vector<std::size_t> users_after(scene.materials.size(), 0);  // kept surfaces
    for (std::size_t i = 0; i < n_surfaces; ++i) {
        const std::uint32_t m = scene.surfaces[i].material;
        ++users_before[m];
        if (excluded[i]) continue;
        ++users_after[m];
        const visdb::Material result = overridden(scene.materials[m], overrides[i]);
        if (same_properties(result, scene.materials[m])) continue;
        // Join a group of this model material with the same result (see same_properties)
        std::size_t g = SIZE_MAX;
        for (const std::size_t candidate : groups_of_material[m])
            if (same_properties(groups[candidate].material, result)) g = candidate;
        if (g == SIZE_MAX) {
            g = groups.size();
            groups.push_back({m, result, overrides[i].line, {}});
            groups_of_material[m].push_back(g);
        }
        groups[g].surfaces.push_back(i);
        surface_group[i] = g;
    }

    // Photometric note: emitters whose emittance came from the model files
    const bool set_unit = file.photometric.has_value() || file.uses_flux();
    if (set_unit && file.is_photometric()) {
        std::size_t count = 0;
        std::vector<std::string> names;
        for (std::size_t i = 0; i < n_surfaces; ++i) {
            if (excluded[i] || overrides[i].emittance) continue;
            const visdb::Material& m = scene.materials[scene.surfaces[i].material];
            if (!m.is_emitter()) continue;
            ++count;
            if (std::find(names.begin(), names.end(), m.name) == names.end())
                names.push_back(m.name);
        }
        if (count > 0) {
            note(0, "photometric: the emittances the model gave " + std::to_string(count) +
                        " surface" + (count == 1 ? "" : "s") + " (material " + name_list(names) +
                        ") are read as lm/m2");
        }
    }

    // New material list: the model materials still in use (or never used), in order, changed in
    // place when one group covers all their kept surfaces; then the split-off copies
    std::vector<std::size_t> in_place(scene.materials.size(), SIZE_MAX);  // group index
    for (std::size_t g = 0; g < groups.size(); ++g) {
        if (groups[g].surfaces.size() == users_after[groups[g].model_material]) {
            in_place[groups[g].model_material] = g;
        }
    }
    std::vector<bool> keeps_unchanged(scene.materials.size(), false);
    for (std::size_t i = 0; i < n_surfaces; ++i) {
        if (!excluded[i] && surface_group[i] == SIZE_MAX) {
            keeps_unchanged[scene.surfaces[i].material] = true;
        }
    }
    std::vector<visdb::Material> materials;
    std::vector<std::uint32_t> remap(scene.materials.size(), UINT32_MAX);
    std::vector<std::uint32_t> group_material(groups.size(), UINT32_MAX);
    std::set<std::string> taken;
    for (std::size_t m = 0; m < scene.materials.size(); ++m) {
        const bool unused_before = users_before[m] == 0;
        if (!unused_before && in_place[m] == SIZE_MAX && !keeps_unchanged[m]) continue;
        const auto index = static_cast<std::uint32_t>(materials.size());
        if (in_place[m] != SIZE_MAX) {
            materials.push_back(groups[in_place[m]].material);
            group_material[in_place[m]] = index;
            ++report.materials_overridden;
        } else {
            materials.push_back(scene.materials[m]);
        }
        remap[m] = index;
        taken.insert(materials.back().name);
    }
    std::size_t split_notes = 0;
    constexpr std::size_t kMaxSplitNotes = 10;
    for (std::size_t g = 0; g < groups.size(); ++g) {
        if (group_material[g] != UINT32_MAX) continue;  // changed in place
        Group& group = groups[g];
        const std::string& model_name = scene.materials[group.model_material].name;
        group.material.name =
            unique_name(model_name + " [rule line " + std::to_string(group.line) + "]", taken);
        group_material[g] = static_cast<std::uint32_t>(materials.size());
        materials.push_back(group.material);
        ++report.materials_overridden;
        if (split_notes++ < kMaxSplitNotes) {
            note(group.line, "material " + in_quotes(model_name) + ": " +
                                 std::to_string(group.surfaces.size()) + " of " +
                                 std::to_string(users_after[group.model_material]) +
                                 " surfaces get their own copy " + in_quotes(group.material.name));
        }
    }
    if (split_notes > kMaxSplitNotes) {
        note(0, std::to_string(split_notes - kMaxSplitNotes) + " more material copies not listed");
    }

    // Surfaces: drop the excluded, remap the kept
    std::vector<visdb::Surface> surfaces;
    surfaces.reserve(n_surfaces - report.surfaces_excluded + file.rectangles.size());
    for (std::size_t i = 0; i < n_surfaces; ++i) {
        if (excluded[i]) continue;
        visdb::Surface s = std::move(scene.surfaces[i]);
        s.material =
            surface_group[i] != SIZE_MAX ? group_material[surface_group[i]] : remap[s.material];
        surfaces.push_back(std::move(s));
    }

    // Emitter rectangles: a surface and a material each, owned by the scene file's source
    const auto source_index = static_cast<std::uint32_t>(scene.sources.size());
    for (const SceneRectangle& rect : file.rectangles) {
        visdb::Material m;
        m.name = unique_name(rect.name, taken);
        m.reflectance = visdb::Rgb(0.0);
        m.opacity = 1.0;
        m.emittance = rect.exitance();
        m.group = rect.group;
        visdb::Surface s;
        s.name = rect.name;
        s.material = static_cast<std::uint32_t>(materials.size());
        s.source = source_index;
        s.mesh = rect.mesh();
        materials.push_back(std::move(m));
        surfaces.push_back(std::move(s));
        ++report.emitters_added;
    }

    scene.materials = std::move(materials);
    scene.surfaces = std::move(surfaces);
    for (const SceneCamera& c : file.cameras) scene.cameras.push_back(c.camera);
    report.cameras = file.cameras.size();
    for (auto& g : grids) scene.grids.push_back(std::move(g));
    report.grids = grids.size();
    add_luminaires(file, scene, note);
    report.luminaires = file.luminaires.size() + add_placed_luminaires(placed, scene, note);
    if (set_unit) scene.emittance_unit = file.is_photometric() ? "lm/m2" : "W/m2";

    // Notes in file order (those about the whole file last)
    std::stable_sort(notes.begin(), notes.end(),
                     [](const auto& a, const auto& b) { return a.first < b.first; });
    for (auto& n : notes) report.notes.push_back(std::move(n.second));

    // The scene file as a source
    visdb::Source source;
    source.path = file.path;
    source.format = "scene";
    source.checksum = file.checksum;
    source.size_bytes = file.size_bytes;
    source.unit = "m";
    source.up_axis = "z";
    source.imported_at = detail::utc_now_iso8601();
    source.report = report.to_string();
    scene.sources.push_back(std::move(source));
    return report;
}

}  // namespace abrad::convert
