// `abrad report`'s page (export/include/abrad/export/report.h): HTML with inline CSS and SVG,
// the grids' plans drawn from their values with isolux contours (contours.h), the tables of
// the scene and the bake, and the 3D view: the bake's GLB handed to the bundled three.js viewer
// (export/viewer/) as a base64 script, since a page opened from file:// may not fetch files.

#include "abrad/export/report.h"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <map>
#include <sstream>

#include "abrad/export/contours.h"
#include "abrad/export/image.h"
#include "abrad/visdb/bake_stats.h"
#include "output.h"

namespace abrad::exporter {

namespace {

namespace fs = std::filesystem;

// ---------------------------------------------------------------------------------------
// Text

// `text` with the characters HTML gives a meaning escaped (for element text and attributes)
std::string escape(std::string_view text) {
    std::string out;
    out.reserve(text.size());
    for (const char c : text) {
        switch (c) {
            case '&':
                out += "&amp;";
                break;
            case '<':
                out += "&lt;";
                break;
            case '>':
                out += "&gt;";
                break;
            case '"':
                out += "&quot;";
                break;
            case '\'':
                out += "&#39;";
                break;
            default:
                out += c;
        }
    }
    return out;
}

// The shortest text that reads back as `v`
std::string exact(double v) {
    std::string out;
    detail::append_exact(out, v);
    return out;
}

// `v` rounded to four significant digits in fixed notation, without trailing zeros ("523.4",
// "12.35", "0.5123", "1235", "0.75")
std::string shown(double v) {
    if (!std::isfinite(v)) return exact(v);
    if (v == 0.0) return "0";
    const int magnitude = static_cast<int>(std::floor(std::log10(std::abs(v))));
    std::string out;
    detail::append_fixed(out, v, std::clamp(3 - magnitude, 0, 8));
    if (out.find('.') != std::string::npos) {
        out.erase(out.find_last_not_of('0') + 1);
        if (out.back() == '.') out.pop_back();
    }
    return out;
}

// A table cell with a number: shown with `decimals` (or four significant digits when
// negative) and its exact value in data-value; `field` names it for readers of the page
std::string number_cell(double v, const std::string& field = {}, int decimals = -1) {
    std::string text;
    if (decimals >= 0)
        detail::append_fixed(text, v, decimals);
    else
        text = shown(v);
    std::string out = "<td class=\"num\"";
    if (!field.empty()) out += " data-field=\"" + field + "\"";
    return out + " data-value=\"" + exact(v) + "\">" + text + "</td>";
}

std::string text_cell(std::string_view text) { return "<td>" + escape(text) + "</td>"; }

// The base64 text of `bytes` (RFC 4648, padded)
std::string base64(std::string_view bytes) {
    static constexpr char kDigits[] =
        "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::string out;
    out.reserve((bytes.size() + 2) / 3 * 4);
    std::size_t i = 0;
    for (; i + 2 < bytes.size(); i += 3) {
        const auto n = static_cast<unsigned>(static_cast<unsigned char>(bytes[i])) << 16 |
                       static_cast<unsigned>(static_cast<unsigned char>(bytes[i + 1])) << 8 |
                       static_cast<unsigned>(static_cast<unsigned char>(bytes[i + 2]));
        for (const int shift : {18, 12, 6, 0}) out += kDigits[(n >> shift) & 63U];
    }
    if (i < bytes.size()) {
        unsigned n = static_cast<unsigned>(static_cast<unsigned char>(bytes[i])) << 16;
        const bool two = i + 1 < bytes.size();
        if (two) n |= static_cast<unsigned>(static_cast<unsigned char>(bytes[i + 1])) << 8;
        out += kDigits[(n >> 18) & 63U];
        out += kDigits[(n >> 12) & 63U];
        out += two ? kDigits[(n >> 6) & 63U] : '=';
        out += '=';
    }
    return out;
}

std::string read_bytes(const fs::path& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) detail::fail(path, "cannot read");
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void write_text(const fs::path& path, std::string_view text) {
    detail::AtomicFile file(path);
    file.write(text);
    file.commit();
}

// "#rrggbb" of a linear colour
std::string hex_colour(const glm::vec3& linear) {
    char buf[8];
    std::snprintf(buf, sizeof buf, "#%02x%02x%02x",
                  static_cast<unsigned>(std::lround(srgb_encode(linear.x) * 255.0)),
                  static_cast<unsigned>(std::lround(srgb_encode(linear.y) * 255.0)),
                  static_cast<unsigned>(std::lround(srgb_encode(linear.z) * 255.0)));
    return buf;
}

// ---------------------------------------------------------------------------------------
// A grid's plan: its cells as an image, isolux contours and a legend, as inline SVG

constexpr double kPlanSize = 520.0;  // pixels of the plan's longer side
constexpr double kMargin = 28.0;     // around the plan, for the axis labels
constexpr double kLegendWidth = 90.0;

// Where lattice point (i, j) of `g` lies in the SVG (pixels)
struct PlanFrame {
    double scale;  // pixels per metre
    double left, top;
    const ReportGrid* g;
    double x_of(double i) const {
        const double dx = (g->max_x - g->min_x) / g->nx;
        return left + (i + 0.5) * dx * scale;
    }
    double y_of(double j) const {
        const double dy = (g->max_y - g->min_y) / g->ny;
        return top + (g->max_y - g->min_y - (j + 0.5) * dy) * scale;
    }
};

std::string svg_number(double v) {
    std::string out;
    detail::append_fixed(out, v, 1);
    return out;
}

// The contour lines of `level` as one SVG path, labelled at the segment nearest the point
// `at` of the lattice (the levels' labels spread along a diagonal, not stacked on one row)
std::string contour_svg(const ReportGrid& g, const PlanFrame& f, double level, LatticePoint at) {
    const std::vector<IsoSegment> segments = isoline(g.value, g.nx, g.ny, level);
    if (segments.empty()) return {};
    std::string d;
    for (const IsoSegment& s : segments) {
        // Appended piece by piece ("M" + std::string made GCC 12 warn -Wrestrict at -O3)
        d += 'M';
        d += svg_number(f.x_of(s.a.i));
        d += ' ';
        d += svg_number(f.y_of(s.a.j));
        d += 'L';
        d += svg_number(f.x_of(s.b.i));
        d += ' ';
        d += svg_number(f.y_of(s.b.j));
    }
    const auto distance = [&](const IsoSegment& s) {
        return std::hypot(0.5 * (s.a.i + s.b.i) - at.i, 0.5 * (s.a.j + s.b.j) - at.j);
    };
    const IsoSegment& mid = *std::min_element(
        segments.begin(), segments.end(),
        [&](const IsoSegment& x, const IsoSegment& y) { return distance(x) < distance(y); });
    const double lx = f.x_of(0.5 * (mid.a.i + mid.b.i));
    const double ly = f.y_of(0.5 * (mid.a.j + mid.b.j));
    return "<g class=\"contour\" data-level=\"" + exact(level) + "\"><path d=\"" + d +
           "\"/><text x=\"" + svg_number(lx) + "\" y=\"" + svg_number(ly) + "\">" + shown(level) +
           "</text></g>\n";
}

// The legend bar from 0 (bottom) to e_max (top) with ticks at the contour levels
std::string legend_svg(double x, double top, double height, double e_max,
                       const std::vector<double>& levels, const std::string& unit, int id) {
    const std::string gradient = "legend-" + std::to_string(id);
    std::string out =
        "<defs><linearGradient id=\"" + gradient + "\" x1=\"0\" y1=\"1\" x2=\"0\" y2=\"0\">";
    for (int k = 0; k <= 10; ++k) {
        const double t = k / 10.0;
        out += "<stop offset=\"" + svg_number(100.0 * t) + "%\" stop-color=\"" +
               hex_colour(false_colour(t)) + "\"/>";
    }
    out += "</linearGradient></defs>";
    out += "<text class=\"unit\" x=\"" + svg_number(x) + "\" y=\"" + svg_number(top - 8.0) + "\">" +
           escape(unit) + "</text>";
    out += "<rect x=\"" + svg_number(x) + "\" y=\"" + svg_number(top) +
           "\" width=\"16\" height=\"" + svg_number(height) + "\" fill=\"url(#" + gradient +
           ")\" stroke=\"#444\"/>";
    std::vector<double> ticks{0.0};
    ticks.insert(ticks.end(), levels.begin(), levels.end());
    ticks.push_back(e_max);
    for (const double v : ticks) {
        const double y = top + height * (1.0 - (e_max > 0.0 ? v / e_max : 0.0));
        out += "<line x1=\"" + svg_number(x + 16.0) + "\" x2=\"" + svg_number(x + 21.0) +
               "\" y1=\"" + svg_number(y) + "\" y2=\"" + svg_number(y) + "\" stroke=\"#444\"/>";
        out += "<text class=\"tick\" x=\"" + svg_number(x + 24.0) + "\" y=\"" +
               svg_number(y + 4.0) + "\">" + shown(v) + "</text>";
    }
    return out;
}

// The plan of grid number `index` (its cells in grid-<index>.png, written here)
std::string grid_plan(const fs::path& dir, const ReportGrid& g, int index, const std::string& unit,
                      std::vector<fs::path>& files) {
    // The cells, one pixel per point, top row at the largest y, coloured from 0 to E_max
    const std::string png = "grid-" + std::to_string(index) + ".png";
    const double e_max = g.e_max > 0.0 ? g.e_max : 1.0;
    std::vector<float> rgb;
    rgb.reserve(g.value.size() * 3);
    for (int j = g.ny - 1; j >= 0; --j) {
        for (int i = 0; i < g.nx; ++i) {
            const double v = g.value[static_cast<std::size_t>(j) * static_cast<std::size_t>(g.nx) +
                                     static_cast<std::size_t>(i)];
            const glm::vec3 c = false_colour(v / e_max);
            rgb.insert(rgb.end(), {c.x, c.y, c.z});
        }
    }
    write_image(dir / png, g.nx, g.ny, rgb);
    files.push_back(dir / png);

    // The frame: the longer side of the grid kPlanSize pixels
    const double w_m = std::max(g.max_x - g.min_x, 1e-9);
    const double h_m = std::max(g.max_y - g.min_y, 1e-9);
    const double scale = kPlanSize / std::max(w_m, h_m);
    const PlanFrame f{scale, kMargin, kMargin, &g};
    const double w = w_m * scale;
    const double h = h_m * scale;
    const double svg_h = std::max(h, 80.0) + 2 * kMargin;  // room for the legend
    const std::vector<double> levels = contour_levels(g.e_min, g.e_max, 6);
    std::string out = "<svg class=\"plan\" data-grid-plan=\"" + std::to_string(index) +
                      "\" xmlns=\"http://www.w3.org/2000/svg\" width=\"" +
                      svg_number(w + 2 * kMargin + kLegendWidth) + "\" height=\"" +
                      svg_number(svg_h) + "\" role=\"img\" aria-label=\"" + escape(g.name) +
                      " in false colour with isolux contours\">\n";
    out += "<image href=\"" + png + "\" x=\"" + svg_number(kMargin) + "\" y=\"" +
           svg_number(kMargin) + "\" width=\"" + svg_number(w) + "\" height=\"" + svg_number(h) +
           "\" preserveAspectRatio=\"none\" style=\"image-rendering:pixelated\"/>\n";
    out += "<rect x=\"" + svg_number(kMargin) + "\" y=\"" + svg_number(kMargin) + "\" width=\"" +
           svg_number(w) + "\" height=\"" + svg_number(h) + "\" fill=\"none\" stroke=\"#444\"/>\n";
    for (std::size_t k = 0; k < levels.size(); ++k) {
        // Labels on the diagonal from the lattice's first point to its last
        const double t =
            (static_cast<double>(k) + 1.0) / (static_cast<double>(levels.size()) + 1.0);
        out += contour_svg(g, f, levels[k], {t * (g.nx - 1), t * (g.ny - 1)});
    }
    // The corners in metres: (min x, min y) below on the left, (max x, max y) above on the right
    out += "<text class=\"axis\" x=\"" + svg_number(kMargin) + "\" y=\"" +
           svg_number(kMargin + h + 18.0) + "\">(" + shown(g.min_x) + ", " + shown(g.min_y) +
           ") m</text>";
    out += "<text class=\"axis\" text-anchor=\"end\" x=\"" + svg_number(kMargin + w) + "\" y=\"" +
           svg_number(kMargin - 8.0) + "\">(" + shown(g.max_x) + ", " + shown(g.max_y) +
           ") m</text>\n";
    out += legend_svg(kMargin + w + 20.0, kMargin + 14.0, std::max(h - 14.0, 40.0), e_max, levels,
                      unit, index);
    return out + "</svg>\n";
}

// ---------------------------------------------------------------------------------------
// Sections

const char* kStyle = R"css(
body { font-family: "DejaVu Sans", Arial, sans-serif; margin: 1.5em auto; max-width: 72em;
       padding: 0 1em; color: #222; }
h1 { font-size: 1.5em; margin-bottom: 0.2em; } h2 { margin-top: 1.6em; border-bottom: 1px solid #ccc; }
.sub { color: #666; margin-top: 0; }
table { border-collapse: collapse; margin: 0.5em 0 1em; }
th, td { border: 1px solid #ccc; padding: 0.25em 0.6em; text-align: left; vertical-align: top; }
th { background: #f3f3f3; } td.num { text-align: right; font-variant-numeric: tabular-nums; }
.plan text { font-size: 12px; fill: #222; }
.plan .contour path { fill: none; stroke: #000; stroke-opacity: 0.75; stroke-width: 1.2; }
.plan .contour text { font-size: 11px; paint-order: stroke; stroke: #fff; stroke-width: 3px;
                      text-anchor: middle; dominant-baseline: middle; }
#view3d canvas { width: 100%; height: 32em; background: #202020; display: block; }
.note { background: #fff6d8; border: 1px solid #e5c75a; padding: 0.6em 0.8em; }
code { background: #f3f3f3; padding: 0 0.2em; }
details { margin: 0.5em 0; }
)css";

std::string grids_section(const fs::path& dir, const ReportInput& in, const std::string& unit,
                          std::vector<fs::path>& files) {
    std::string out = "<section id=\"grids\"><h2>Calculation grids</h2>\n";
    if (in.grids.empty()) {
        return out +
               "<p>The scene has no calculation grid (a <code>[[grid]]</code> table of the "
               "scene file adds one).</p></section>\n";
    }
    out +=
        "<table id=\"grid-table\"><tr><th>grid</th><th>points</th><th>height (m)</th>"
        "<th>E<sub>avg</sub> (" +
        escape(unit) + ")</th><th>E<sub>min</sub> (" + escape(unit) +
        ")</th><th>E<sub>max</sub> (" + escape(unit) +
        ")</th><th>U<sub>0</sub> = "
        "E<sub>min</sub>/E<sub>avg</sub></th><th>values</th></tr>\n";
    for (std::size_t k = 0; k < in.grids.size(); ++k) {
        const ReportGrid& g = in.grids[k];
        const double u0 = g.e_avg > 0.0 ? g.e_min / g.e_avg : 0.0;
        out += "<tr data-grid=\"" + escape(g.name) + "\">" + text_cell(g.name) +
               "<td class=\"num\" data-field=\"points\">" + std::to_string(g.nx) + " × " +
               std::to_string(g.ny) + "</td>" + number_cell(g.z, "z") +
               number_cell(g.e_avg, "e_avg") + number_cell(g.e_min, "e_min") +
               number_cell(g.e_max, "e_max") + number_cell(u0, "u0", 3) + "<td>" +
               (g.csv.empty() ? std::string("—")
                              : "<a href=\"" + escape(g.csv) + "\">" + escape(g.csv) + "</a>") +
               "</td></tr>\n";
    }
    out += "</table>\n";
    for (std::size_t k = 0; k < in.grids.size(); ++k) {
        const ReportGrid& g = in.grids[k];
        out += "<h3>" + escape(g.name) + "</h3>\n<p>" + std::to_string(g.nx) + " × " +
               std::to_string(g.ny) + " points at " + shown(g.z) +
               " m; each square is one point's value, from 0 (dark blue) to E<sub>max</sub> "
               "(yellow); the lines are isolux contours, labelled in " +
               escape(unit) + ".</p>\n";
        out += grid_plan(dir, g, static_cast<int>(k + 1), unit, files);
    }
    return out + "</section>\n";
}

std::string luminaires_section(const visdb::Scene& scene, const ReportInput& in) {
    std::string out = "<section id=\"luminaires\"><h2>Luminaires and light sources</h2>\n";
    if (in.luminaires.empty()) {
        out += "<p>No luminaires from photometric files.</p>\n";
    } else {
        out +=
            "<table id=\"luminaire-table\"><tr><th>photometric file</th><th>count</th>"
            "<th>luminaires</th><th>lamp flux in the file (lm)</th><th>web flux × "
            "factors (lm each)</th><th>factors (flux scale × maintenance)</th>"
            "<th>power (W each)</th><th>total flux (lm)</th></tr>\n";
        double total_flux = 0.0, total_power = 0.0;
        bool all_power = true;
        for (const ReportLuminaireType& t : in.luminaires) {
            const auto count = static_cast<double>(t.names.size());
            std::string names;
            for (const std::string& n : t.names) names += (names.empty() ? "" : ", ") + n;
            std::string file = escape(t.file);
            if (!t.description.empty()) file += "<br><small>" + escape(t.description) + "</small>";
            if (!t.file_note.empty()) file += "<br><small>(" + escape(t.file_note) + ")</small>";
            out += "<tr data-file=\"" + escape(t.file) + "\"><td>" + file + "</td>" +
                   "<td class=\"num\" data-field=\"count\">" + std::to_string(t.names.size()) +
                   "</td>" + text_cell(names) +
                   (t.lamp_lumens > 0.0 ? number_cell(t.lamp_lumens, "lamp_lumens")
                                        : std::string("<td>—</td>")) +
                   number_cell(t.web_flux, "web_flux") + number_cell(t.scale, "scale") +
                   (t.input_watts > 0.0 ? number_cell(t.input_watts, "watts")
                                        : std::string("<td>—</td>")) +
                   number_cell(t.web_flux * count, "total_flux") + "</tr>\n";
            total_flux += t.web_flux * count;
            total_power += t.input_watts * count;
            all_power = all_power && t.input_watts > 0.0;
        }
        out += "</table>\n<p>In all " + shown(total_flux) + " lm";
        if (all_power && total_power > 0.0)
            out +=
                " from " + shown(total_power) + " W (" + shown(total_flux / total_power) + " lm/W)";
        out += ".</p>\n";
    }
    // Emitting surfaces: area and exitance
    std::string rows;
    for (const visdb::Surface& s : scene.surfaces) {
        const visdb::Material& m = scene.materials[s.material];
        if (!m.is_emitter()) continue;
        double area = 0.0;
        for (const auto& t : s.mesh.triangles)
            area += visdb::triangle_area(s.mesh.positions[t.x], s.mesh.positions[t.y],
                                         s.mesh.positions[t.z]);
        const double exitance = visdb::channel_mean(m.emittance);
        rows += "<tr>" + text_cell(s.name) + text_cell(m.name) + number_cell(area, "area") +
                number_cell(exitance, "exitance") + number_cell(exitance * area, "power") +
                "</tr>\n";
    }
    const std::string e_unit = scene.emittance_unit == "lm/m2" ? "lm/m²" : "W/m²";
    const std::string p_unit = scene.emittance_unit == "lm/m2" ? "lm" : "W";
    if (rows.empty()) return out + "<p>No emitting surfaces.</p></section>\n";
    return out +
           "<h3>Emitting surfaces</h3><table id=\"emitter-table\"><tr><th>surface</th>"
           "<th>material</th><th>area (m²)</th><th>exitance (" +
           e_unit + ", mean over RGB)</th><th>emitted (" + p_unit + ")</th></tr>\n" + rows +
           "</table></section>\n";
}

std::string bake_section(const visdb::Bake& bake) {
    const visdb::BakeStats& st = bake.statistics;
    const std::string power = bake.unit == "lux" ? "lm" : "W";
    std::string out = "<section id=\"bake\"><h2>The bake</h2>\n<table id=\"bake-table\">";
    out += "<tr><th>name</th>" + text_cell(bake.name) + "</tr><tr><th>created</th>" +
           text_cell(bake.created_at) + "</tr><tr><th>unit</th>" + text_cell(bake.unit) +
           "</tr><tr><th>mesh</th><td>" + std::to_string(st.vertices) + " vertices, " +
           std::to_string(st.triangles) + " triangles</td></tr><tr><th>time (s)</th>" +
           number_cell(st.seconds_total, "seconds") + "</tr></table>\n";
    out += "<h3>Energy balance</h3><table id=\"energy-table\"><tr><th>emitted (" + power +
           ")</th>" + number_cell(st.emitted_power_w, "emitted") +
           "</tr><tr><th>reaching "
           "receivers directly (" +
           power + ")</th>" + number_cell(st.received_power_w, "received") + "</tr>";
    if (const auto& i = st.indirect) {
        out += "<tr><th>with interreflection: emitted (" + power + ")</th>" +
               number_cell(i->energy_emitted_w, "energy_emitted") + "</tr><tr><th>absorbed</th>" +
               number_cell(i->energy_absorbed_w, "energy_absorbed") +
               "</tr><tr><th>escaped "
               "(openings)</th>" +
               number_cell(i->energy_escaped_w, "energy_escaped") +
               "</tr><tr><th>unshot (spread as the ambient term)</th>" +
               number_cell(i->energy_unshot_w, "energy_unshot") +
               "</tr><tr><th>elements, "
               "shots</th><td>" +
               std::to_string(i->elements) + ", " + std::to_string(i->shots) + "</td></tr>";
    } else {
        out += "<tr><th>interreflection</th><td>none (direct light only)</td></tr>";
    }
    out += "</table>\n<h3>Settings</h3><table id=\"settings-table\">";
    for (const auto& [k, v] : bake.parameters)
        out += "<tr><th>" + escape(k) + "</th>" + text_cell(v) + "</tr>";
    out += "</table>\n<details><summary>All statistics</summary><table id=\"stats-table\">";
    for (const auto& [k, v] : visdb::to_pairs(st))
        out += "<tr><th>" + escape(k) + "</th>" + number_cell(v) + "</tr>";
    return out + "</table></details></section>\n";
}

// The camera as the 3D view's JSON, in the glTF frame (Y up: (x, y, z) -> (x, z, -y))
std::string view_json(const std::optional<ReportView>& view) {
    if (!view) return "null";
    const auto vec = [](const glm::dvec3& p) {
        return "[" + exact(p.x) + "," + exact(p.z) + "," + exact(0.0 - p.y) + "]";
    };
    return "{\"eye\":" + vec(view->camera.position) + ",\"target\":" + vec(view->camera.look_at) +
           ",\"fovDeg\":" + exact(view->camera.fov_y_deg) + "}";
}

// The 3D view: the viewer and the model when the viewer is there, else how to get it
std::string view_section(const fs::path& dir, const visdb::Scene& scene, const visdb::Bake& bake,
                         const ReportInput& in, bool viewer, ReportFiles& files) {
    write_gltf(dir / "model.glb", scene, bake.mesh, in.tone);
    files.files.push_back(dir / "model.glb");
    std::string out = "<section id=\"view3d\"><h2>3D view</h2>\n";
    std::error_code ec;
    if (!viewer) {
        return out +
               "<p class=\"note\" id=\"viewer-missing\">The 3D viewer is not installed, so "
               "this page has no 3D view. " +
               escape(in.viewer_hint) +
               " The bake's glTF is <a href=\"model.glb\">model.glb</a> beside this page; any glTF "
               "viewer opens it.</p></section>\n";
    }
    fs::create_directory(dir / "viewer");
    write_text(dir / "viewer" / "abrad-viewer.js", read_bytes(in.viewer_script));
    files.files.push_back(dir / "viewer" / "abrad-viewer.js");
    const fs::path licence = in.viewer_script.parent_path() / "LICENSE-three.txt";
    if (fs::is_regular_file(licence, ec)) {
        write_text(dir / "viewer" / "LICENSE-three.txt", read_bytes(licence));
        files.files.push_back(dir / "viewer" / "LICENSE-three.txt");
    }
    write_text(dir / "model.js",
               "window.abradModel = \"" + base64(read_bytes(dir / "model.glb")) + "\";\n");
    files.files.push_back(dir / "model.js");
    files.has_3d_view = true;
    out += "<canvas id=\"abrad-3d\"></canvas>\n<p><button id=\"view-camera\">" +
           escape(in.view ? "camera " + in.view->camera.name : std::string("camera")) +
           "</button> <button id=\"view-overview\">whole model</button> Drag to turn, "
           "right-drag to move, scroll to zoom. The colours are the bake's radiosity through the "
           "tone curve 1 − exp(−k·B), k = " +
           shown(in.tone.exposure) + " per " + escape(bake.unit == "lux" ? "lux" : "W/m²") +
           " (the glTF export's, <a href=\"model.glb\">model.glb</a>); faces are drawn from the "
           "front only, as the bake shades them. <span id=\"viewer-status\"></span> Drawn with "
           "three.js (<a href=\"viewer/LICENSE-three.txt\">MIT licence</a>).</p>\n";
    out +=
        "<script src=\"viewer/abrad-viewer.js\"></script>\n<script "
        "src=\"model.js\"></script>\n";
    out +=
        "<script>\n(function () {\n"
        "  const status = document.getElementById('viewer-status');\n"
        "  // A browser without WebGL throws in show(): that too ends in the error branch\n"
        "  Promise.resolve().then(function () {\n"
        "    return window.abradViewer.show(document.getElementById('abrad-3d'), {model: "
        "window.abradModel, camera: " +
        view_json(in.view) +
        "});\n  }).then(function (view) {\n"
        "    status.textContent = view.triangles + ' triangles.';\n"
        "    document.getElementById('view-camera').onclick = view.camera;\n"
        "    document.getElementById('view-overview').onclick = view.overview;\n"
        "    document.body.dataset.viewer = 'ready';\n"
        "  }, function (error) {\n"
        "    document.body.dataset.viewer = 'error';\n"
        "    status.textContent = 'The 3D view could not be drawn (' + error + '); the browser "
        "may lack WebGL.';\n"
        "    console.error('abrad report: the 3D view failed: ' + error);\n  });\n})();\n"
        "</script>\n";
    return out + "</section>\n";
}

}  // namespace

ReportFiles write_report(const fs::path& dir, const visdb::Scene& scene, const visdb::Bake& bake,
                         const ReportInput& in) {
    ReportFiles files;
    files.files.push_back(dir / "index.html");
    std::error_code ec;
    const bool viewer = !in.viewer_script.empty() && fs::is_regular_file(in.viewer_script, ec);
    const std::string unit = bake.unit == "lux" ? "lux" : "W/m²";
    const std::string title =
        "abrad report: " + fs::path(in.database).filename().string() + ", bake " + bake.name;
    std::string html =
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\n"
        "<meta name=\"generator\" content=\"abrad report\">\n<title>" +
        escape(title) + "</title>\n<style>" + kStyle + "</style></head>\n" +
        "<body data-viewer=\"" + (viewer ? "loading" : "absent") + "\">\n<h1>" + escape(title) +
        "</h1>\n" + "<p class=\"sub\">" + escape(in.database) + " · bake " + escape(bake.name) +
        " of " + escape(bake.created_at) + " · values in " + escape(unit) + "</p>\n";
    html += grids_section(dir, in, unit, files.files);
    html += view_section(dir, scene, bake, in, viewer, files);
    html += luminaires_section(scene, in);
    html += bake_section(bake);
    html += "</body></html>\n";
    write_text(dir / "index.html", html);
    return files;
}

}  // namespace abrad::exporter
