// abrad: the command line. Subcommands import, bake, export, render, compare, info, probe,
// field-error, run, generate, bench.
//
// Exit status: 0 success; 1 failure (I/O, internal); 2 bad input or usage (a malformed model,
// an unknown option, a scene that cannot be baked). Errors go to stderr as
// "abrad <cmd>: <file>:<line>: <message>".

#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cctype>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <glm/geometric.hpp>
#include <iostream>
#include <map>
#include <numeric>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "abrad/convert/import.h"
#include "abrad/convert/scene_file.h"
#include "abrad/export/image.h"
#include "abrad/export/render.h"
#include "abrad/export/writers.h"
#include "abrad/radiosity/bake.h"
#include "abrad/radiosity/direct.h"
#include "abrad/radiosity/field_error.h"
#include "abrad/radiosity/indirect.h"
#include "abrad/tools/bench.h"
#include "abrad/tools/floor_gen.h"
#include "abrad/visdb/store.h"

namespace fs = std::filesystem;

namespace abrad::tools {
namespace {

constexpr int kExitOk = 0;
constexpr int kExitFailure = 1;
constexpr int kExitBadInput = 2;

// An error already phrased for the user, with the exit status it calls for.
struct CommandError {
    int status;
    std::string message;
};

[[noreturn]] void bad_input(const std::string& message) {
    throw CommandError{kExitBadInput, message};
}

// ---------------------------------------------------------------------------------------
// Options shared by several subcommands

struct ImportArgs {
    std::vector<std::string> models;
    std::string unit;  ///< empty: the scene file's, else the file's own, else metres
    std::string up;    ///< empty: the scene file's, else the format's convention
    std::optional<double> weld;
    std::string scene;
};

struct BakeArgs {
    std::string name;
    std::string method = "abuffer";
    int resolution = 50;
    int subpixels = 8;
    std::string bounces = "0";
    double converge = 0.005;
    double element_size = 0.5;
    double overrelax = 1.0;
    std::string ambient = "on";
    std::string convergence_csv;
    std::string shading = "exact";
    int threads = 0;
    std::string dm = "on";
    std::string lights = "area";
    double dm_angle = 0.0;
    int refine_rounds = 4;
    double refine_tolerance = 0.1;
    double refine_min_edge = 0.05;
    double reach = 0.0;
};

void add_import_options(CLI::App& app, ImportArgs& a) {
    app.add_option("--unit", a.unit,
                   "Length unit of the model files (default: the scene file's, else the unit the "
                   "file declares, else m)")
        ->check(CLI::IsMember({"mm", "cm", "m", "in", "ft"}));
    app.add_option("--up", a.up,
                   "Up axis of the model files, y is rotated to Z up (default: the scene file's, "
                   "else the format's: glTF y, Collada/FBX as declared, others z)")
        ->check(CLI::IsMember({"y", "z"}));
    app.add_option("--weld", a.weld,
                   "Weld vertices closer than this fraction of the model's bounding-box diagonal "
                   "(default 1e-6; 0 welds only identical positions)")
        ->check(CLI::Range(0.0, 1e-2));
    app.add_option("--scene", a.scene,
                   "Scene file (TOML): unit, up axis, origin shift, material and light rules by "
                   "object/layer/material name, emitter rectangles, cameras, exclusions, grids");
}

void add_bake_options(CLI::App& app, BakeArgs& a) {
    app.add_option("--name", a.name,
                   "Name of the stored bake (default bake-<n>; an existing bake "
                   "of that name is replaced)");
    app.add_option("--method", a.method,
                   "Hemicube visibility: abuffer (fragment lists, coverage "
                   "masks, translucency) or zbuffer (point-sampled item buffer)")
        ->check(CLI::IsMember({"abuffer", "zbuffer"}))
        ->capture_default_str();
    app.add_option("--resolution", a.resolution, "Hemicube resolution R (even, 2..4096)")
        ->capture_default_str();
    app.add_option("--subpixels", a.subpixels,
                   "A-buffer mask side: 4, 8 or 16 (8 = 8x8 = one uint64)")
        ->capture_default_str();
    app.add_option("--bounces", a.bounces,
                   "Interreflection: 0 (direct light only, the paper's "
                   "setting), converge (shoot from reflecting surfaces until "
                   "--converge) or a number of bounces")
        ->capture_default_str();
    app.add_option("--converge", a.converge,
                   "Stop interreflection when the unshot power is below "
                   "this fraction of the emitted power")
        ->capture_default_str();
    app.add_option("--element-size", a.element_size,
                   "Side of the interreflection elements, metres "
                   "(each planar region is cut into such cells)")
        ->capture_default_str();
    app.add_option("--overrelax", a.overrelax,
                   "Over-relaxation factor ω in [1, 2) of the "
                   "converging solution (1 = classic progressive "
                   "refinement)")
        ->capture_default_str();
    app.add_option("--ambient", a.ambient,
                   "Spread what is left unshot at convergence as the "
                   "ambient term")
        ->check(CLI::IsMember({"on", "off"}))
        ->capture_default_str();
    app.add_option("--convergence-csv", a.convergence_csv,
                   "Write the convergence curve (shots, "
                   "seconds, unshot fraction) to this CSV");
    app.add_option("--shading", a.shading,
                   "Vertex shades: exact (exact direct irradiance past the "
                   "occluders) or patch (area-weighted hemicube patches)")
        ->check(CLI::IsMember({"exact", "patch"}))
        ->capture_default_str();
    app.add_option("--threads", a.threads, "Worker threads (0 = all cores)")->capture_default_str();
    app.add_option("--dm", a.dm,
                   "Discontinuity meshing: re-mesh receivers along shadow edges and "
                   "refine where the light changes")
        ->check(CLI::IsMember({"on", "off"}))
        ->capture_default_str();
    app.add_option("--lights", a.lights,
                   "Light model for shadow edges: centroid (one point, hard "
                   "edges), vertices (umbra and penumbra) or area (also the "
                   "light-edge/occluder-vertex wedges)")
        ->check(CLI::IsMember({"centroid", "vertices", "area"}))
        ->capture_default_str();
    app.add_option("--dm-angle", a.dm_angle,
                   "Ruppert/Chew minimum triangle angle in degrees "
                   "(0 = no quality refinement, at most 20.7)")
        ->capture_default_str();
    app.add_option("--refine-rounds", a.refine_rounds,
                   "Rounds of refinement where the exact "
                   "irradiance departs from linear (0 = none)")
        ->capture_default_str();
    app.add_option("--refine-tolerance", a.refine_tolerance,
                   "Split an edge when its midpoint's exact irradiance differs from the "
                   "interpolated value by more than this fraction")
        ->capture_default_str();
    app.add_option("--refine-min-edge", a.refine_min_edge,
                   "Shortest edge refinement splits, metres")
        ->capture_default_str();
    app.add_option("--reach", a.reach,
                   "Light reach in metres: a light lights, shades and shadows only "
                   "what lies within this distance (per axis) of it (0 = unlimited)")
        ->capture_default_str();
}

radiosity::BakeOptions to_options(const BakeArgs& a) {
    radiosity::BakeOptions o;
    o.name = a.name;
    o.method =
        a.method == "zbuffer" ? radiosity::Visibility::ZBuffer : radiosity::Visibility::ABuffer;
    o.resolution = a.resolution;
    o.subpixels = a.subpixels;
    if (a.bounces == "converge") {
        o.bounces = -1;
    } else {
        const auto [end, ec] =
            std::from_chars(a.bounces.data(), a.bounces.data() + a.bounces.size(), o.bounces);
        if (ec != std::errc() || end != a.bounces.data() + a.bounces.size() || o.bounces < 0)
            bad_input("--bounces must be 'converge' or a number of bounces >= 0, got '" +
                      a.bounces + "'");
    }
    o.converge = a.converge;
    o.element_size = a.element_size;
    o.overrelaxation = a.overrelax;
    o.ambient = a.ambient == "on";
    o.shading = a.shading == "patch" ? radiosity::Shading::Patch : radiosity::Shading::Exact;
    o.threads = a.threads;
    o.dm = a.dm == "on";
    o.lights = *radiosity::parse_light_model(a.lights);
    o.dm_min_angle = a.dm_angle;
    o.refine_rounds = a.refine_rounds;
    o.refine_tolerance = a.refine_tolerance;
    o.refine_min_edge = a.refine_min_edge;
    o.reach = a.reach;
    try {
        radiosity::validate(o);
    } catch (const radiosity::BakeError& e) {
        bad_input(e.what());
    }
    return o;
}

// ---------------------------------------------------------------------------------------
// Progress on stderr: a rewritten line on a terminal; otherwise a line per 10% (or, when the
// total is open, as the interreflection's shots are, one every two seconds).
class Progress {
  public:
    Progress() : m_tty(isatty(STDERR_FILENO) != 0), m_start(std::chrono::steady_clock::now()) {}

    void operator()(std::string_view stage, std::size_t done, std::size_t total) {
        const double s = seconds();
        const std::string_view what = stage.starts_with("shoot")  ? "light triangles"
                                      : stage.starts_with("mesh") ? "rounds"
                                                                  : "";
        char line[256];
        if (total) {
            const int percent = static_cast<int>(100 * done / total);
            std::snprintf(line, sizeof line, "%.*s: %zu/%zu %.*s (%d%%) %.1f s", int(stage.size()),
                          stage.data(), done, total, int(what.size()), what.data(), percent, s);
            if (!m_tty && percent / 10 == m_last_decile && done != total && stage == m_stage)
                return;
            m_last_decile = percent / 10;
        } else {
            std::snprintf(line, sizeof line, "%.*s: %zu %.1f s", int(stage.size()), stage.data(),
                          done, s);
            if (!m_tty && s - m_last_line < 2.0 && done != 0) return;
        }
        m_stage = std::string(stage);
        m_last_line = s;
        if (m_tty)
            std::fprintf(stderr, "\r%-100s%s", line, total && done == total ? "\n" : "");
        else
            std::fprintf(stderr, "%s\n", line);
    }

  private:
    double seconds() const {
        return std::chrono::duration<double>(std::chrono::steady_clock::now() - m_start).count();
    }
    bool m_tty;
    int m_last_decile = -1;
    double m_last_line = -1e9;
    std::string m_stage;
    std::chrono::steady_clock::time_point m_start;
};

// ---------------------------------------------------------------------------------------
// The steps

visdb::Scene read_models(const ImportArgs& a) {
    visdb::Scene all;
    convert::ImportOptions options;
    std::optional<convert::SceneFile> scene_file;
    if (!a.scene.empty()) {
        try {
            scene_file = convert::read_scene_file(a.scene);
        } catch (const convert::ImportError& e) {
            bad_input(e.what());
        }
        convert::apply_import_settings(*scene_file, options);
    }
    if (!a.unit.empty()) options.unit = a.unit;
    if (!a.up.empty()) options.up = a.up.front();
    if (a.weld) options.weld_tolerance = *a.weld;
    for (const std::string& model : a.models) {
        convert::ImportResult r;
        try {
            const auto start = std::chrono::steady_clock::now();
            r = convert::import_model(model, options);
            std::fprintf(
                stderr, "import: %s read and healed in %.2f s\n", model.c_str(),
                std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
        } catch (const convert::ImportError& e) {
            bad_input(e.what());
        }
        std::cout << "imported " << model << "\n" << r.report.to_string();
        // Append, remapping material and source indices
        const auto material_base = static_cast<std::uint32_t>(all.materials.size());
        const auto source_base = static_cast<std::uint32_t>(all.sources.size());
        for (auto& m : r.scene.materials) all.materials.push_back(std::move(m));
        for (auto& s : r.scene.sources) all.sources.push_back(std::move(s));
        for (auto& c : r.scene.cameras) all.cameras.push_back(std::move(c));
        for (auto& s : r.scene.surfaces) {
            s.material += material_base;
            s.source += source_base;
            all.surfaces.push_back(std::move(s));
        }
    }
    if (scene_file) {
        try {
            const convert::SceneFileReport report = convert::apply_scene_file(*scene_file, all);
            std::cout << "applied " << a.scene << "\n" << report.to_string();
        } catch (const convert::ImportError& e) {
            bad_input(e.what());
        }
    }
    return all;
}

void import_into(const visdb::Scene& scene, const std::string& db) {
    visdb::Store store = visdb::Store::open(db, visdb::OpenMode::CreateOrOpen);
    // The same file twice would put every face on top of itself (coplanar overlaps)
    for (const visdb::Source& have : store.load_scene().sources)
        for (const visdb::Source& add : scene.sources)
            if (have.checksum == add.checksum)
                bad_input(add.path + ": already imported into " + db + " as " + have.path +
                          " (same FNV-1a checksum " + have.checksum + "); nothing written");
    store.add_import(scene);
    std::cout << "stored " << scene.surfaces.size() << " surfaces, " << scene.triangle_count()
              << " triangles in " << db << "\n";
}

// Irradiance range over the vertices of receivers (surfaces that do not emit).
void print_bake_summary(const visdb::Bake& b, const visdb::Scene& scene) {
    double lo = 1e300, hi = 0.0, sum = 0.0;
    std::size_t n = 0;
    std::vector<bool> seen(b.mesh.positions.size(), false);
    for (std::size_t t = 0; t < b.mesh.triangles.size(); ++t) {
        const auto& s = scene.surfaces[b.mesh.triangle_surface[t]];
        if (scene.materials[s.material].is_emitter()) continue;
        for (int k = 0; k < 3; ++k) {
            const auto v = b.mesh.triangles[t][k];
            if (seen[v]) continue;
            seen[v] = true;
            const glm::vec3 h = b.mesh.irradiance[v];
            const double y = visdb::luminance(h);
            lo = std::min(lo, y);
            hi = std::max(hi, y);
            sum += y;
            ++n;
        }
    }
    const visdb::BakeStats& st = b.statistics;
    std::cout << "bake '" << b.name << "': " << st.triangles << " triangles, " << st.vertices
              << " vertices, " << st.light_triangles << " light triangles, " << st.seconds_total
              << " s\n";
    if (n)
        std::cout << "  receiver irradiance (luminance) min " << lo << " / mean " << sum / double(n)
                  << " / max " << hi << " " << b.unit << "\n";
    if (st.dm)
        std::cout << "  discontinuity mesh: " << st.dm->triangles_before << " -> " << st.triangles
                  << " triangles, " << st.dm->segments << " shadow segments, "
                  << st.dm->refine_points << " refinement points in " << st.dm->rounds
                  << " rounds, " << st.dm->seconds << " s\n";
    // Power is in W for radiometric bakes, lm for photometric ones (lux bakes)
    const char* power = b.unit == "lux" ? " lm" : " W";
    std::cout << "  emitted " << st.emitted_power_w << power << ", reaching receivers "
              << st.received_power_w << power << " (mean over RGB)\n";
    if (const auto& i = st.indirect) {
        std::cout << "  interreflection: " << i->elements << " elements, " << i->shots << " shots ("
                  << i->rows << " hemicubes), unshot " << 100.0 * i->unshot_fraction
                  << "%, ambient " << i->ambient << " " << b.unit << ", " << i->seconds << " s\n"
                  << "  energy: emitted " << i->energy_emitted_w << power << " = absorbed "
                  << i->energy_absorbed_w << power << " + escaped " << i->energy_escaped_w << power
                  << " + unshot " << i->energy_unshot_w << power << "\n";
    }
}

std::string utc_now() {
    const std::time_t t = std::time(nullptr);
    std::tm tm{};
    gmtime_r(&t, &tm);
    char buf[32];
    std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
    return buf;
}

// Direct plus gathered indirect irradiance at points; a scene without lights is bad input.
radiosity::PointIrradiance point_irradiance_of(const std::string& db, const visdb::Scene& scene,
                                               const visdb::Bake* bake) {
    try {
        return radiosity::PointIrradiance(scene, bake);
    } catch (const radiosity::BakeError& e) {
        bad_input(db + ": " + e.what());
    }
}

// A file-name-safe form of a grid name.
std::string file_safe(const std::string& name) {
    std::string out;
    for (const char c : name)
        out += std::isalnum(static_cast<unsigned char>(c)) || c == '-' ? c : '_';
    return out;
}

// Each calculation grid of the scene evaluated on the bake: points at the centres of cells no
// larger than the spacing; E_avg, E_min, E_max and U0 = E_min/E_avg printed and written as CSV
// (`<prefix>grid-<name>.csv`, one line per point). Values are illuminance (photometric bakes)
// or irradiance as luminance-weighted RGB, like the bake summary.
void evaluate_grids(const std::string& db, const visdb::Scene& scene, const visdb::Bake& bake,
                    const fs::path& prefix) {
    if (scene.grids.empty()) return;
    const radiosity::PointIrradiance field = point_irradiance_of(db, scene, &bake);
    for (const visdb::CalculationGrid& g : scene.grids) {
        const auto t0 = std::chrono::steady_clock::now();
        const int nx =
            std::max(1, static_cast<int>(std::ceil((g.max.x - g.min.x) / g.spacing - 1e-9)));
        const int ny =
            std::max(1, static_cast<int>(std::ceil((g.max.y - g.min.y) / g.spacing - 1e-9)));
        std::vector<radiosity::ProbePoint> points;
        for (int j = 0; j < ny; ++j)
            for (int i = 0; i < nx; ++i)
                points.push_back({{g.min.x + (i + 0.5) * (g.max.x - g.min.x) / nx,
                                   g.min.y + (j + 0.5) * (g.max.y - g.min.y) / ny, g.z},
                                  g.normal});
        const std::vector<visdb::Rgb> h = field.at(points);
        std::vector<double> e(h.size());
        for (std::size_t k = 0; k < h.size(); ++k)
            e[k] = 0.2126 * h[k].x + 0.7152 * h[k].y + 0.0722 * h[k].z;
        const double lo = *std::min_element(e.begin(), e.end());
        const double hi = *std::max_element(e.begin(), e.end());
        const double avg = std::accumulate(e.begin(), e.end(), 0.0) / double(e.size());
        const fs::path csv = prefix.string() + "grid-" + file_safe(g.name) + ".csv";
        {
            std::ofstream out(csv);
            out << "x,y,z,illuminance,irradiance_r,irradiance_g,irradiance_b\n";
            out.precision(9);
            for (std::size_t k = 0; k < h.size(); ++k)
                out << points[k].x.x << "," << points[k].x.y << "," << points[k].x.z << "," << e[k]
                    << "," << h[k].x << "," << h[k].y << "," << h[k].z << "\n";
            if (!out)
                throw CommandError{kExitFailure, csv.string() + ": cannot write the grid values"};
        }
        // False colour, top row = largest y, from 0 to the grid's maximum
        const fs::path png = prefix.string() + "grid-" + file_safe(g.name) + ".png";
        std::vector<double> image(e.size());
        for (int j = 0; j < ny; ++j)
            for (int i = 0; i < nx; ++i)
                image[std::size_t(j) * nx + i] = e[std::size_t(ny - 1 - j) * nx + i];
        try {
            exporter::write_false_colour_image(png, nx, ny, image, 0.0, hi > 0.0 ? hi : 1.0,
                                               bake.unit == "lux" ? "lux" : "W/m²");
        } catch (const std::exception& x) {
            throw CommandError{kExitFailure, png.string() + ": " + x.what()};
        }
        const double seconds =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        std::printf(
            "  grid '%s': %d x %d points at z %.3g m: E_avg %.4g, E_min %.4g, E_max %.4g %s, "
            "U0 %.3f (%s, %s, %.2f s)\n",
            g.name.c_str(), nx, ny, g.z, avg, lo, hi, bake.unit.c_str(), avg > 0.0 ? lo / avg : 0.0,
            csv.string().c_str(), png.filename().string().c_str(), seconds);
    }
}

visdb::Bake bake_into(const std::string& db, const radiosity::BakeOptions& options_in,
                      const std::string& convergence_csv = {},
                      const std::string& grid_prefix = {}) {
    visdb::Store store = visdb::Store::open(db, visdb::OpenMode::ReadWrite);
    const visdb::Scene scene = store.load_scene();
    radiosity::BakeOptions options = options_in;
    if (options.name.empty())
        options.name = "bake-" + std::to_string(store.list_bakes().size() + 1);
    Progress progress;
    visdb::Bake b;
    std::vector<radiosity::ConvergenceSample> curve;
    if (!convergence_csv.empty()) options.convergence = &curve;
    try {
        b = radiosity::bake(scene, options, std::ref(progress));
    } catch (const radiosity::BakeError& e) {
        bad_input(db + ": " + e.what());
    }
    if (!convergence_csv.empty()) {
        std::ofstream out(convergence_csv);
        out << "shots,seconds,unshot_fraction\n";
        for (const auto& c : curve)
            out << c.shots << "," << c.seconds << "," << c.unshot_fraction << "\n";
        if (!out)
            throw CommandError{kExitFailure,
                               convergence_csv + ": cannot write the convergence curve"};
    }
    b.created_at = utc_now();
    store.add_bake(b);
    print_bake_summary(b, scene);
    std::cout << std::flush;
    evaluate_grids(db, scene, b,
                   grid_prefix.empty()
                       ? fs::path(db).replace_extension("").string() + "." + b.name + "."
                       : grid_prefix);
    return b;
}

// The named bake (empty = the latest) for a command that needs one: an empty database or an
// unknown name is bad input.
visdb::Bake load_bake_for(visdb::Store& store, const std::string& db, const std::string& bake_name,
                          const std::string& purpose) {
    if (store.list_bakes().empty())
        bad_input(db + ": no bake to " + purpose + " (run abrad bake first)");
    try {
        return store.load_bake(bake_name);
    } catch (const visdb::StoreError& e) {
        bad_input(e.what());
    }
}

// The exact direct field of the database's scene; a scene without lights is bad input.
radiosity::DirectField direct_field_of(const std::string& db, const visdb::Scene& scene) {
    try {
        return radiosity::DirectField(scene);
    } catch (const radiosity::BakeError& e) {
        bad_input(db + ": " + e.what());
    }
}

// Options of the image-making exports and of render.
struct ViewArgs {
    std::string camera;  ///< empty: the scene's first camera, else the default camera
    int width = 640;
    int height = 480;
    std::optional<double> exposure;  ///< empty: auto_tone_map of the bake
    int light_samples = 256;
    int reference_bounces = 0;
    std::string quality = "medium";
};

void add_view_options(CLI::App& app, ViewArgs& v) {
    app.add_option("--camera", v.camera,
                   "Camera name from the scene file or model (default: the "
                   "first one; 'default' or none: inside the largest room "
                   "looking at its centre)");
    app.add_option("--width", v.width, "Image width in pixels")
        ->capture_default_str()
        ->check(CLI::Range(1, 16384));
    app.add_option("--height", v.height, "Image height in pixels")
        ->capture_default_str()
        ->check(CLI::Range(1, 16384));
    app.add_option("--exposure", v.exposure,
                   "Exposure k per W/m2 (or lm/m2): image value k*B, "
                   "display 1-exp(-k*B) (default: the bake's, 95th "
                   "percentile radiosity luminance -> 0.8)")
        ->check(CLI::PositiveNumber);
}

visdb::Camera camera_for(const visdb::Scene& scene, const ViewArgs& v) {
    try {
        const visdb::Camera c = exporter::select_camera(scene, v.camera);
        (void)exporter::camera_frame(c, v.width, v.height);  // a degenerate camera is bad input
        return c;
    } catch (const std::invalid_argument& e) {
        bad_input(e.what());
    }
}

void export_bake(const std::string& db, const std::string& bake_name, const std::string& format,
                 const std::string& output, bool ascii, const ViewArgs& view = {}) {
    visdb::Store store = visdb::Store::open(db, visdb::OpenMode::ReadWrite);
    const visdb::Scene scene = store.load_scene();
    if (format == "pov-reference") {
        // The reference needs the scene only; the bake (when there is one) sets the exposure
        const auto bakes = store.list_bakes();
        double exposure = view.exposure.value_or(1.0);
        std::string from = "given";
        if (!view.exposure) {
            if (bakes.empty())
                bad_input(db + ": no bake to take the exposure from (give --exposure)");
            exposure = exporter::auto_tone_map(load_bake_for(store, db, bake_name, "export").mesh)
                           .exposure;
            from = "of the bake";
        }
        exporter::PovReferenceOptions o;
        o.view = {.camera = camera_for(scene, view),
                  .width = view.width,
                  .height = view.height,
                  .exposure = exposure};
        o.light_samples = view.light_samples;
        o.bounces = view.reference_bounces;
        o.quality = view.quality == "low"    ? exporter::PovQuality::Low
                    : view.quality == "high" ? exporter::PovQuality::High
                                             : exporter::PovQuality::Medium;
        exporter::write_pov_reference(output, scene, o);
        std::cout << "wrote " << output << " (pov-reference, camera '" << o.view.camera.name
                  << "', "
                  << (o.bounces ? std::to_string(o.bounces) + " POV-Ray radiosity bounces"
                                : std::string("direct light only"))
                  << ", exposure " << exposure << " " << from << ")\n";
        return;
    }
    const visdb::Bake b = load_bake_for(store, db, bake_name, "export");
    const exporter::ToneMap tone = view.exposure ? exporter::ToneMap{.exposure = *view.exposure}
                                                 : exporter::auto_tone_map(b.mesh);
    if (format == "ply") {
        exporter::write_ply(output, b.mesh, tone,
                            {.ascii = ascii, .comment = "abrad bake " + b.name});
    } else if (format == "obj") {
        exporter::write_obj(output, scene, b.mesh, tone);
    } else if (format == "gltf") {
        exporter::write_gltf(output, scene, b.mesh, tone);
    } else {
        const exporter::PovView v{.camera = camera_for(scene, view),
                                  .width = view.width,
                                  .height = view.height,
                                  .exposure = tone.exposure};
        exporter::write_pov(output, scene, b.mesh, v);
        std::cout << "camera '" << v.camera.name << "'\n";
    }
    std::cout << "wrote " << output << " (" << format << ", bake '" << b.name << "', "
              << b.mesh.positions.size() << " vertices, " << b.mesh.triangles.size()
              << " triangles, exposure " << tone.exposure << " per " << b.unit << ")\n";
}

// abrad's own image of a bake: Gouraud-rasterized radiosity (EXR: exposure x B, linear; PNG:
// the tone curve 1 - exp(-exposure B), sRGB), or false-colour irradiance with a legend.
void render_image(const std::string& db, const std::string& bake_name, const std::string& output,
                  const ViewArgs& view, bool false_colour, std::optional<double> vmin,
                  std::optional<double> vmax) {
    std::string ext = fs::path(output).extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    if (ext != ".png" && ext != ".exr" && ext != ".hdr" && ext != ".jpg" && ext != ".jpeg" &&
        ext != ".tif" && ext != ".tiff")
        bad_input(output + ": unknown image type '" + ext + "' (png, exr, hdr, jpg, tif)");
    visdb::Store store = visdb::Store::open(db, visdb::OpenMode::ReadWrite);
    const visdb::Bake b = load_bake_for(store, db, bake_name, "render");
    const visdb::Scene scene = store.load_scene();
    const visdb::Camera camera = camera_for(scene, view);
    const exporter::ToneMap tone = view.exposure ? exporter::ToneMap{.exposure = *view.exposure}
                                                 : exporter::auto_tone_map(b.mesh);
    const auto t0 = std::chrono::steady_clock::now();
    const exporter::Raster r =
        exporter::render_bake(b.mesh, camera,
                              {.width = view.width,
                               .height = view.height,
                               .quantity = false_colour ? exporter::RenderQuantity::Irradiance
                                                        : exporter::RenderQuantity::Radiosity});
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (false_colour) {
        // Irradiance luminance, no data where nothing was hit
        std::vector<double> values(r.value.size());
        double hi = 0.0;
        for (std::size_t i = 0; i < values.size(); ++i) {
            const glm::vec3& h = r.value[i];
            const double y = 0.2126 * h.r + 0.7152 * h.g + 0.0722 * h.b;
            values[i] = r.covered[i] == 1 ? y : std::nan("");  // backs of faces: no data
            if (r.covered[i] == 1 && std::isfinite(y)) hi = std::max(hi, y);
        }
        const double lo_v = vmin.value_or(0.0), hi_v = vmax.value_or(hi > lo_v ? hi : lo_v + 1.0);
        if (!(hi_v > lo_v))
            bad_input("--vmax (" + std::to_string(hi_v) + ") must exceed --vmin (" +
                      std::to_string(lo_v) + ")");
        const std::string unit = b.unit == "lux" ? "lux" : "W/m\u00b2";
        exporter::write_false_colour_image(output, r.width, r.height, values, lo_v, hi_v, unit);
        std::cout << "wrote " << output << " (false-colour irradiance, " << lo_v << " .. " << hi_v
                  << " " << (b.unit == "lux" ? "lux" : "W/m2") << ", camera '" << camera.name
                  << "', " << r.width << "x" << r.height << ", " << seconds << " s)\n";
        return;
    }
    const bool linear = ext == ".exr" || ext == ".hdr";
    std::vector<float> rgb(r.value.size() * 3);
    for (std::size_t i = 0; i < r.value.size(); ++i)
        for (int c = 0; c < 3; ++c) {
            const double v = static_cast<double>(r.value[i][c]);
            rgb[3 * i + static_cast<std::size_t>(c)] =
                static_cast<float>(linear ? tone.exposure * v : exporter::tone_value(v, tone));
        }
    exporter::write_image(output, r.width, r.height, rgb);
    std::cout << "wrote " << output << " (bake '" << b.name << "', camera '" << camera.name << "', "
              << r.width << "x" << r.height << ", exposure " << tone.exposure << " per " << b.unit
              << (linear ? ", linear" : ", tone-mapped sRGB") << ", " << seconds << " s)\n";
}

struct CompareArgs {
    std::string a, b;
    std::string diff;
    std::string side_by_side;
    double diff_gain = 4.0;
    std::optional<double> max_rmse, min_psnr, max_error;
    std::optional<double> clip;
};

// `abrad compare`: metrics in linear light, a difference image, exit 1 past a threshold.
int compare_images(const CompareArgs& c) {
    exporter::Image a, b;
    try {
        a = exporter::read_image(c.a);
        b = exporter::read_image(c.b);
    } catch (const exporter::ExportError& e) {
        bad_input(e.what());
    }
    if (a.width != b.width || a.height != b.height)
        bad_input(c.b + ": image is " + std::to_string(b.width) + "x" + std::to_string(b.height) +
                  ", " + c.a + " is " + std::to_string(a.width) + "x" + std::to_string(a.height));
    if (c.clip) {
        // Emitters are tens of times brighter than what they light: clipped, their edge pixels
        // no longer swamp the metrics of the lit scene
        for (auto* img : {&a, &b})
            for (float& v : img->rgb) v = std::clamp(v, 0.0f, static_cast<float>(*c.clip));
    }
    const exporter::ImageDifference d = exporter::compare_images(a, b);
    std::printf(
        "a: %s\nb: %s\nsize: %dx%d\nrmse: %.6g\npsnr_db: %.4g\nmax_error: %.6g\n"
        "max_error_pixel: %d,%d\nmean_a: %.6g\nmean_b: %.6g\n",
        c.a.c_str(), c.b.c_str(), a.width, a.height, d.rmse, d.psnr_db, d.max_error, d.max_x,
        d.max_y, d.mean_a, d.mean_b);
    if (!c.diff.empty()) {
        const exporter::Image diff = exporter::difference_image(a, b, c.diff_gain);
        exporter::write_image(c.diff, diff.width, diff.height, diff.rgb);
        std::printf("diff: %s (|a - b| x %g)\n", c.diff.c_str(), c.diff_gain);
    }
    if (!c.side_by_side.empty()) {
        // A | B | gain x |A - B|, each through the tone curve 1 - exp(-v)
        const exporter::Image diff = exporter::difference_image(a, b, c.diff_gain);
        const int w = a.width, h = a.height;
        std::vector<float> rgb(static_cast<std::size_t>(3 * w) * static_cast<std::size_t>(h) * 3);
        const exporter::Image* parts[3] = {&a, &b, &diff};
        for (int p = 0; p < 3; ++p)
            for (int y = 0; y < h; ++y)
                for (int x = 0; x < w; ++x)
                    for (int k = 0; k < 3; ++k)
                        rgb[(static_cast<std::size_t>(y) * static_cast<std::size_t>(3 * w) +
                             static_cast<std::size_t>(p * w + x)) *
                                3 +
                            static_cast<std::size_t>(k)] =
                            static_cast<float>(
                                exporter::tone_value(static_cast<double>(parts[p]->at(x, y, k)),
                                                     exporter::ToneMap{.exposure = 1.0}));
        exporter::write_image(c.side_by_side, 3 * w, h, rgb);
        std::printf("side_by_side: %s (a | b | |a - b| x %g, display 1 - exp(-v))\n",
                    c.side_by_side.c_str(), c.diff_gain);
    }
    std::vector<std::string> failed;
    auto fmt = [](double v) {
        std::ostringstream s;
        s << v;
        return s.str();
    };
    if (c.max_rmse && !(d.rmse <= *c.max_rmse))
        failed.push_back("rmse " + fmt(d.rmse) + " > " + fmt(*c.max_rmse));
    if (c.min_psnr && !(d.psnr_db >= *c.min_psnr))
        failed.push_back("psnr " + fmt(d.psnr_db) + " dB < " + fmt(*c.min_psnr) + " dB");
    if (c.max_error && !(d.max_error <= *c.max_error))
        failed.push_back("max error " + fmt(d.max_error) + " > " + fmt(*c.max_error));
    if (failed.empty()) {
        std::printf("result: pass\n");
        return kExitOk;
    }
    std::string msg;
    for (const auto& f : failed) msg += (msg.empty() ? "" : "; ") + f;
    std::printf("result: fail\n");
    std::fflush(stdout);
    std::cerr << "abrad compare: " << c.a << " vs " << c.b << ": " << msg << "\n";
    return kExitFailure;
}

void print_info(const std::string& db) {
    visdb::Store store = visdb::Store::open(db, visdb::OpenMode::ReadWrite);
    const visdb::Scene scene = store.load_scene();
    std::cout << db << ": abrad visual database, schema " << store.schema_version() << "\n";
    std::cout << "sources (" << scene.sources.size() << "):\n";
    for (const auto& s : scene.sources)
        std::cout << "  " << s.path << "  [" << s.format << ", " << s.size_bytes << " bytes, fnv1a "
                  << s.checksum << ", unit " << s.unit << ", up " << s.up_axis << ", imported "
                  << s.imported_at << "]\n";
    std::size_t light_tris = 0;
    double light_area = 0.0, light_power = 0.0;
    std::cout << "surfaces (" << scene.surfaces.size() << "), triangles " << scene.triangle_count()
              << ":\n";
    for (const auto& s : scene.surfaces) {
        const auto& m = scene.materials[s.material];
        std::cout << "  " << s.name << (s.layer.empty() ? "" : " (layer " + s.layer + ")") << ": "
                  << s.mesh.triangles.size() << " triangles, material " << m.name << " rho ("
                  << m.reflectance.x << " " << m.reflectance.y << " " << m.reflectance.z
                  << ") alpha " << m.opacity;
        if (m.is_emitter()) {
            double area = 0.0;
            for (const auto& t : s.mesh.triangles)
                area +=
                    0.5 * glm::length(glm::cross(s.mesh.positions[t.y] - s.mesh.positions[t.x],
                                                 s.mesh.positions[t.z] - s.mesh.positions[t.x]));
            light_tris += s.mesh.triangles.size();
            light_area += area;
            light_power += area * (m.emittance.x + m.emittance.y + m.emittance.z) / 3.0;
            std::cout << ", emits E (" << m.emittance.x << " " << m.emittance.y << " "
                      << m.emittance.z << ") " << scene.emittance_unit << " over " << area << " m2";
        }
        std::cout << "\n";
    }
    const bool photometric = scene.emittance_unit == "lm/m2";
    std::cout << "lights: " << light_tris << " triangles, " << light_area << " m2, " << light_power
              << (photometric ? " lm" : " W") << " (mean over RGB)\n";
    std::cout << "cameras (" << scene.cameras.size() << ")";
    for (const auto& c : scene.cameras) std::cout << " " << c.name;
    std::cout << "\n";
    std::cout << "grids (" << scene.grids.size() << "):\n";
    for (const auto& g : scene.grids)
        std::cout << "  " << g.name << ": x " << g.min.x << ".." << g.max.x << ", y " << g.min.y
                  << ".." << g.max.y << ", z " << g.z << ", spacing " << g.spacing << " m\n";
    const auto bakes = store.list_bakes();
    std::cout << "bakes (" << bakes.size() << "):\n";
    for (const auto& b : bakes) {
        std::cout << "  " << b.name << "  [" << b.created_at << ", " << b.vertex_count
                  << " vertices, " << b.triangle_count << " triangles, unit " << b.unit
                  << "]\n    parameters:";
        for (const auto& [k, v] : b.parameters) std::cout << " " << k << "=" << v;
        std::cout << "\n    statistics:";
        for (const auto& [k, v] : visdb::to_pairs(b.statistics)) std::cout << " " << k << "=" << v;
        std::cout << "\n";
    }
}

// Irradiance at the points of a CSV file (x,y,z,nx,ny,nz per line, metres; a header line and
// blank lines allowed), written as CSV to stdout.
void probe(const std::string& db, const std::string& points_path, const std::string& bake_name) {
    std::ifstream in(points_path);
    if (!in) bad_input(points_path + ": cannot open points file");
    struct Point {
        glm::dvec3 x, n;
    };
    std::vector<Point> points;
    std::string line;
    for (std::size_t number = 1; std::getline(in, line); ++number) {
        if (!line.empty() && line.back() == '\r') line.pop_back();
        if (line.find_first_not_of(" \t") == std::string::npos) continue;
        double v[6];
        int count = 0;
        const char* p = line.data();
        const char* end = line.data() + line.size();
        bool ok = true;
        while (ok && p < end) {
            while (p < end && (*p == ' ' || *p == '\t')) ++p;
            const auto [next, ec] = std::from_chars(p, end, count < 6 ? v[count] : v[5]);
            ok = ec == std::errc() && count < 6 && std::isfinite(v[count]);
            p = next;
            ++count;
            while (p < end && (*p == ' ' || *p == '\t')) ++p;
            if (p < end) ok = ok && *p++ == ',';
        }
        if (!ok || count != 6) {
            // A header: the first line, without any digit (a malformed first row is an error)
            if (number == 1 && line.find_first_of("0123456789") == std::string::npos) continue;
            bad_input(points_path + ":" + std::to_string(number) +
                      ": expected six finite numbers x,y,z,nx,ny,nz");
        }
        const glm::dvec3 n(v[3], v[4], v[5]);
        if (!(glm::length(n) > 0.0))
            bad_input(points_path + ":" + std::to_string(number) + ": normal is zero");
        points.push_back({{v[0], v[1], v[2]}, glm::normalize(n)});
    }
    if (points.empty()) bad_input(points_path + ": no points");

    visdb::Store store = visdb::Store::open(db, visdb::OpenMode::ReadWrite);
    // The indirect part comes from a bake: the named one, else the latest, else none
    std::optional<visdb::Bake> bake;
    if (!bake_name.empty() || !store.list_bakes().empty()) {
        try {
            bake = store.load_bake(bake_name);
        } catch (const visdb::StoreError& e) {
            bad_input(e.what());
        }
    }
    const visdb::Scene scene = store.load_scene();
    const std::string unit = bake ? bake->unit : scene.emittance_unit == "lm/m2" ? "lux" : "W/m2";
    const radiosity::PointIrradiance field =
        point_irradiance_of(db, scene, bake ? &*bake : nullptr);
    std::fprintf(
        stderr, "probe: %zu points, %s, unit %s\n", points.size(),
        field.has_indirect()
            ? ("exact direct + indirect gathered from bake '" + bake->name + "'").c_str()
        : bake ? ("direct light only (bake '" + bake->name + "' has no interreflection)").c_str()
               : "direct light only (no bake yet)",
        unit.c_str());
    std::vector<radiosity::ProbePoint> where;
    for (const Point& pt : points) where.push_back({pt.x, pt.n});
    const std::vector<visdb::Rgb> h = field.at(where);
    std::printf("x,y,z,nx,ny,nz,irradiance_r,irradiance_g,irradiance_b\n");
    for (std::size_t i = 0; i < points.size(); ++i) {
        const Point& pt = points[i];
        std::printf("%.17g,%.17g,%.17g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g\n", pt.x.x, pt.x.y, pt.x.z,
                    pt.n.x, pt.n.y, pt.n.z, h[i].x, h[i].y, h[i].z);
    }
}

// The field error of a bake (ALGORITHMS.md section 8): its Gouraud-interpolated irradiance
// against the exact direct irradiance inside every receiver triangle, as `key: value` lines.
void field_error(const std::string& db, const std::string& bake_name, int subdivisions) {
    if (subdivisions < 1 || subdivisions > 64)
        bad_input("--subdivisions must be in [1, 64], got " + std::to_string(subdivisions));
    visdb::Store store = visdb::Store::open(db, visdb::OpenMode::ReadWrite);
    const visdb::Bake b = load_bake_for(store, db, bake_name, "measure");
    for (const auto& [key, value] : b.parameters)
        if (key == "bounces" && value != "0")
            bad_input(db + ": bake '" + b.name + "' has interreflection (bounces " + value +
                      "); the field error measures direct light against its exact field: measure a "
                      "--bounces 0 bake");
    const visdb::Scene scene = store.load_scene();
    const radiosity::DirectField field = direct_field_of(db, scene);
    const auto t0 = std::chrono::steady_clock::now();
    const radiosity::FieldError e = radiosity::field_error(
        scene, b.mesh,
        [&](const glm::dvec3& x, const glm::dvec3& n) { return field.irradiance(x, n); },
        {.subdivisions = subdivisions});
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::printf(
        "bake: %s\ntriangles: %zu\nreceiver_triangles: %zu\nreceiver_area_m2: %.6g\n"
        "samples: %zu\nrelative_l1: %.6g\nabsolute_l1_w_m2: %.6g\nmean_exact_w_m2: %.6g\n"
        "bake_seconds: %.6g\nmeasure_seconds: %.3g\n",
        b.name.c_str(), b.mesh.triangles.size(), e.triangles, e.area_m2, e.samples, e.relative_l1,
        e.absolute_l1, e.mean_exact, b.statistics.seconds_total, seconds);
}

// ---------------------------------------------------------------------------------------
// Generated floors and the benchmark (tools/src/floor_gen.cpp, tools/src/bench.cpp)

struct FloorArgs {
    std::vector<int> rooms{1, 1};
    double cell = 0.5;
    int furniture = 2;
    int lights = 1;
    std::size_t triangles = 0;  ///< > 0: choose rooms and cell for about this many triangles
};

void add_floor_options(CLI::App& app, FloorArgs& a) {
    app.add_option("--rooms", a.rooms, "Rooms along x and y (5 x 4 x 3 m each)")
        ->expected(2)
        ->capture_default_str();
    app.add_option("--cell", a.cell,
                   "Largest triangle leg on floors, ceilings, walls, furniture (m)")
        ->capture_default_str();
    app.add_option("--furniture", a.furniture, "Pieces of furniture per room (0..16)")
        ->capture_default_str();
    app.add_option("--lights", a.lights, "Ceiling panels per room (0..16, two triangles each)")
        ->capture_default_str();
    app.add_option("--triangles", a.triangles,
                   "Choose rooms and cell for about this many triangles "
                   "(overrides --rooms and --cell)");
}

tools::FloorOptions to_floor(const FloorArgs& a) {
    tools::FloorOptions o;
    if (a.triangles > 0) {
        if (a.triangles > 50'000'000) bad_input("--triangles must be at most 50000000");
        o = tools::floor_for_triangles(a.triangles, std::clamp(a.lights, 0, 16));
    } else {
        o.rooms_x = a.rooms.at(0);
        o.rooms_y = a.rooms.at(1);
        o.cell = a.cell;
    }
    o.furniture = a.furniture;
    o.lights = a.lights;
    try {
        tools::validate(o);
    } catch (const std::invalid_argument& e) {
        bad_input(e.what());
    }
    return o;
}

void generate(const FloorArgs& a, const std::string& db) {
    const tools::FloorOptions o = to_floor(a);
    const visdb::Scene scene = tools::generate_floor(o);
    std::cout << "generated " << tools::to_string(o) << "\n";
    import_into(scene, db);
}

struct BenchArgs {
    std::string out;
    std::vector<std::string> models;
    std::string scene;
    std::vector<std::string> sizes;
    std::vector<int> light_counts;
    std::size_t lights_at = 30000;
    bool quick = false;
    bool no_room = false;
    int subdivisions = 2;
    std::size_t field_error_max = 200000;
    BakeArgs bake;
};

void add_bench_options(CLI::App& app, BenchArgs& a) {
    app.add_option("--out", a.out,
                   "Output directory: bench.csv, scaling.csv, speed_error.png, "
                   "scaling.png, summary.md")
        ->required();
    app.add_option("--model", a.models,
                   "Model files baked over the settings grid besides the "
                   "generated room (imported as by abrad import)");
    app.add_option("--scene", a.scene, "Scene file (TOML) applied to the --model files");
    app.add_flag("--no-room", a.no_room, "Leave out the generated one-room scene from the grid");
    app.add_flag("--quick", a.quick,
                 "A small grid (Z-buffer R50, A-buffer R26 4x4 and R50 8x8; DM off "
                 "and area) instead of the full one");
    app.add_option("--sizes", a.sizes,
                   "Scaling: generated floors of about these many triangles "
                   "(e.g. 3k 30k 300k 1M), baked with the bake options")
        ->delimiter(',');
    app.add_option("--light-counts", a.light_counts,
                   "Light scaling: ceiling panels per room, on a floor "
                   "of --lights-at triangles")
        ->delimiter(',');
    app.add_option("--lights-at", a.lights_at, "Triangles of the light-scaling floor")
        ->capture_default_str();
    app.add_option("--subdivisions", a.subdivisions,
                   "Field error: k x k sample points per triangle")
        ->capture_default_str();
    app.add_option("--field-error-max", a.field_error_max,
                   "Measure the field error only for bakes of "
                   "at most this many triangles")
        ->capture_default_str();
    add_bake_options(app, a.bake);
}

std::size_t parse_count(const std::string& text) {
    std::size_t mult = 1;
    std::string digits = text;
    if (!digits.empty() && (digits.back() == 'k' || digits.back() == 'K'))
        mult = 1000, digits.pop_back();
    else if (!digits.empty() && (digits.back() == 'm' || digits.back() == 'M'))
        mult = 1000000, digits.pop_back();
    std::size_t v = 0;
    const auto [p, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), v);
    if (ec != std::errc() || p != digits.data() + digits.size() || v == 0 || v > 50'000'000 / mult)
        bad_input("--sizes: '" + text +
                  "' is not a triangle count in [1, 50M] (digits with an optional k or M)");
    return v * mult;
}

void bench(const BenchArgs& a, int argc, char** argv) {
    if (a.subdivisions < 1 || a.subdivisions > 16)
        bad_input("--subdivisions must be in [1, 16], got " + std::to_string(a.subdivisions));
    for (int n : a.light_counts)
        if (n < 1 || n > 16)
            bad_input("--light-counts must be in [1, 16], got " + std::to_string(n));
    if (a.lights_at < 100 || a.lights_at > 50'000'000)
        bad_input("--lights-at must be in [100, 50000000]");
    tools::BenchOptions o;
    o.out = a.out;
    o.quick = a.quick;
    o.subdivisions = a.subdivisions;
    o.field_error_max = a.field_error_max;
    o.scaling = to_options(a.bake);
    o.threads = o.scaling.threads;
    for (const std::string& s : a.sizes) o.sizes.push_back(parse_count(s));
    o.light_counts = a.light_counts;
    o.lights_at = a.lights_at;
    for (int i = 0; i < argc; ++i) o.command += (i ? " " : "") + std::string(i ? argv[i] : "abrad");
    if (!a.no_room) {
        tools::FloorOptions room;
        room.cell = 0.5;
        room.furniture = 3;
        room.lights = 2;
        o.scenes.push_back(
            {"generated room (" + tools::to_string(room) + ")", tools::generate_floor(room)});
    }
    for (const std::string& m : a.models) {
        ImportArgs ia;
        ia.models = {m};
        ia.scene = a.scene;
        std::ostringstream discard;
        auto* old =
            std::cout.rdbuf(discard.rdbuf());  // the import report is not the bench's output
        visdb::Scene scene;
        try {
            scene = read_models(ia);
        } catch (...) {
            std::cout.rdbuf(old);
            throw;
        }
        std::cout.rdbuf(old);
        o.scenes.push_back({fs::path(m).filename().string(), std::move(scene)});
    }
    if (o.scenes.empty() && o.sizes.empty() && o.light_counts.empty())
        bad_input("nothing to run: give --model, --sizes or --light-counts, or drop --no-room");
    std::vector<tools::BenchRun> runs;
    try {
        runs = tools::run_bench(o);
    } catch (const radiosity::BakeError& e) {
        bad_input(e.what());
    }
    std::cout << "wrote " << (o.out / "bench.csv").string() << ", "
              << (o.out / "scaling.csv").string() << ", " << (o.out / "summary.md").string() << " ("
              << runs.size() << " runs)\n";
}

// ---------------------------------------------------------------------------------------

int run_cli(int argc, char** argv) {
    CLI::App app{"abrad: lighting bakes for buildings with an A-buffer hemicube radiosity"};
    app.require_subcommand(1);
    app.set_version_flag("--version", "abrad 0.1.0");
    app.footer("Exit status: 0 ok, 1 failure, 2 bad input or usage.");

    ImportArgs import_args;
    std::string db;
    auto* import_cmd = app.add_subcommand("import", "Import model files into a visual database");
    import_cmd
        ->add_option("MODEL", import_args.models,
                     "Model files: obj, gltf, glb, 3ds, dae, fbx, dxf, ifc, stl, ply, off")
        ->required();
    import_cmd->add_option("--db", db, "Visual database (.visdb), created when missing")
        ->required();
    add_import_options(*import_cmd, import_args);

    BakeArgs bake_args;
    auto* bake_cmd = app.add_subcommand("bake", "Bake direct light into the database's scene");
    bake_cmd->add_option("--db", db, "Visual database")->required();
    add_bake_options(*bake_cmd, bake_args);

    std::string format, output, bake_name;
    bool ascii = false;
    ViewArgs view;
    auto* export_cmd =
        app.add_subcommand("export",
                           "Export a bake as shaded PLY, OBJ, glTF or a "
                           "POV-Ray scene, or the model as a POV-Ray reference scene");
    export_cmd->add_option("--db", db, "Visual database")->required();
    export_cmd
        ->add_option("--format", format,
                     "ply, obj, gltf (.gltf or .glb), pov (the bake, unlit) "
                     "or pov-reference (the model lit by POV-Ray)")
        ->required()
        ->check(CLI::IsMember({"ply", "obj", "gltf", "pov", "pov-reference"}));
    export_cmd->add_option("--output", output, "Output path")->required();
    export_cmd->add_option("--bake", bake_name, "Bake name (default: the latest)");
    export_cmd->add_flag("--ascii", ascii, "PLY as ASCII instead of binary little endian");
    add_view_options(*export_cmd, view);
    export_cmd
        ->add_option("--light-samples", view.light_samples,
                     "pov-reference: point lights sampling the emitters (cos-weighted spotlights)")
        ->capture_default_str()
        ->check(CLI::Range(1, 1000000));
    export_cmd
        ->add_option("--reference-bounces", view.reference_bounces,
                     "pov-reference: POV-Ray radiosity bounces (0 = off, direct light only)")
        ->capture_default_str()
        ->check(CLI::Range(0, 20));
    export_cmd->add_option("--quality", view.quality, "pov-reference: POV-Ray radiosity quality")
        ->capture_default_str()
        ->check(CLI::IsMember({"low", "medium", "high"}));

    bool false_colour = false;
    std::optional<double> vmin, vmax;
    auto* render_cmd =
        app.add_subcommand("render",
                           "Render a bake with abrad's Gouraud rasterizer "
                           "(PNG tone-mapped, EXR linear), or false-colour irradiance");
    render_cmd->add_option("--db", db, "Visual database")->required();
    render_cmd->add_option("--bake", bake_name, "Bake name (default: the latest)");
    render_cmd
        ->add_option("--output", output,
                     "Image path: .png (sRGB, tone-mapped) or .exr (linear, "
                     "exposure x radiosity)")
        ->required();
    add_view_options(*render_cmd, view);
    render_cmd->add_flag("--false-colour", false_colour,
                         "Irradiance luminance in false colour with a "
                         "legend (W/m2 or lux) instead of radiosity");
    render_cmd->add_option("--vmin", vmin,
                           "False colour: value at the bottom of the scale (default 0)");
    render_cmd->add_option("--vmax", vmax,
                           "False colour: value at the top (default: the image's maximum)");

    CompareArgs compare_args;
    auto* compare_cmd = app.add_subcommand("compare",
                                           "Compare two images in linear light (RMSE, PSNR, "
                                           "max error); exit 1 past a threshold");
    compare_cmd
        ->add_option("A", compare_args.a, "First image (PNG is decoded from sRGB, EXR is linear)")
        ->required();
    compare_cmd->add_option("B", compare_args.b, "Second image, same size")->required();
    compare_cmd->add_option("--diff", compare_args.diff, "Write |A - B| x gain here (PNG or EXR)");
    compare_cmd->add_option("--side-by-side", compare_args.side_by_side,
                            "Write A | B | gain x |A - B| here, tone-mapped for a person (PNG)");
    compare_cmd->add_option("--diff-gain", compare_args.diff_gain, "Gain of the difference images")
        ->capture_default_str()
        ->check(CLI::PositiveNumber);
    compare_cmd
        ->add_option("--clip", compare_args.clip,
                     "Clamp both images' linear values to [0, "
                     "CLIP] first (e.g. 4: emitters stop dominating)")
        ->check(CLI::PositiveNumber);
    compare_cmd->add_option("--max-rmse", compare_args.max_rmse,
                            "Fail (exit 1) when the RMSE is larger");
    compare_cmd->add_option("--min-psnr", compare_args.min_psnr,
                            "Fail (exit 1) when the PSNR (dB, peak 1) is lower");
    compare_cmd->add_option("--max-error", compare_args.max_error,
                            "Fail (exit 1) when a channel differs by more");

    auto* info_cmd = app.add_subcommand("info", "List what a visual database holds");
    info_cmd->add_option("--db", db, "Visual database")->required();

    std::string points_path;
    auto* probe_cmd = app.add_subcommand("probe",
                                         "Irradiance at points from a CSV file: exact direct light "
                                         "plus the indirect part gathered from a bake");
    probe_cmd->add_option("--db", db, "Visual database")->required();
    probe_cmd
        ->add_option("--points", points_path,
                     "CSV of x,y,z,nx,ny,nz per line (metres; a header "
                     "line allowed)")
        ->required();
    probe_cmd->add_option("--bake", bake_name,
                          "Bake whose interreflection to gather and unit to "
                          "report (default: the latest; none: direct light)");

    int subdivisions = 3;
    auto* error_cmd = app.add_subcommand("field-error",
                                         "Gouraud-interpolated irradiance of a bake "
                                         "against the exact direct irradiance");
    error_cmd->add_option("--db", db, "Visual database")->required();
    error_cmd->add_option("--bake", bake_name, "Bake name (default: the latest)");
    error_cmd
        ->add_option("--subdivisions", subdivisions,
                     "Each triangle is sampled at the centroids "
                     "of its k x k sub-triangles")
        ->capture_default_str();

    std::string out_dir;
    auto* run_cmd = app.add_subcommand("run", "Import, bake and export in one go");
    run_cmd
        ->add_option("MODEL", import_args.models,
                     "Model files: obj, gltf, glb, 3ds, dae, fbx, dxf, ifc, stl, ply, off")
        ->required();
    run_cmd
        ->add_option("--out", out_dir,
                     "Output directory (STEM.visdb, STEM.ply, STEM.obj, STEM.png)")
        ->required();
    add_import_options(*run_cmd, import_args);
    add_bake_options(*run_cmd, bake_args);

    FloorArgs floor_args;
    auto* generate_cmd = app.add_subcommand("generate",
                                            "Generate a building floor (rooms, doors, "
                                            "furniture, ceiling lights) into a visual database");
    generate_cmd->add_option("--db", db, "Visual database, created when missing")->required();
    add_floor_options(*generate_cmd, floor_args);

    BenchArgs bench_args;
    auto* bench_cmd = app.add_subcommand("bench",
                                         "Speed against error over a grid of bake settings, "
                                         "and scaling on generated floors");
    add_bench_options(*bench_cmd, bench_args);

    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        if (e.get_exit_code() == 0) return app.exit(e);
        const auto* sub = app.get_subcommands().empty() ? nullptr : app.get_subcommands().front();
        std::cerr << "abrad" << (sub ? " " + sub->get_name() : std::string()) << ": " << e.what()
                  << "\n(see abrad" << (sub ? " " + sub->get_name() : std::string())
                  << " --help)\n";
        return kExitBadInput;
    }
    const std::string cmd = app.get_subcommands().front()->get_name();

    try {
        if (cmd == "import") {
            const visdb::Scene scene = read_models(import_args);
            import_into(scene, db);
        } else if (cmd == "bake") {
            bake_into(db, to_options(bake_args), bake_args.convergence_csv);
        } else if (cmd == "export") {
            // An option given but not used by the format is an error, never ignored
            const bool pov = format == "pov" || format == "pov-reference";
            for (const char* name : {"--light-samples", "--reference-bounces", "--quality"})
                if (export_cmd->count(name) && format != "pov-reference")
                    bad_input(std::string(name) + " applies to --format pov-reference only");
            for (const char* name : {"--camera", "--width", "--height"})
                if (export_cmd->count(name) && !pov)
                    bad_input(std::string(name) +
                              " applies to --format pov and pov-reference only");
            if (ascii && format != "ply") bad_input("--ascii applies to --format ply only");
            export_bake(db, bake_name, format, output, ascii, view);
        } else if (cmd == "render") {
            for (const char* name : {"--vmin", "--vmax"})
                if (render_cmd->count(name) && !false_colour)
                    bad_input(std::string(name) + " applies to --false-colour only");
            render_image(db, bake_name, output, view, false_colour, vmin, vmax);
        } else if (cmd == "compare") {
            return compare_images(compare_args);
        } else if (cmd == "probe") {
            probe(db, points_path, bake_name);
        } else if (cmd == "field-error") {
            field_error(db, bake_name, subdivisions);
        } else if (cmd == "info") {
            print_info(db);
        } else if (cmd == "generate") {
            generate(floor_args, db);
        } else if (cmd == "bench") {
            bench(bench_args, argc, argv);
        } else if (cmd == "run") {
            const radiosity::BakeOptions options = to_options(bake_args);
            const visdb::Scene scene = read_models(import_args);
            fs::create_directories(out_dir);
            const std::string stem = fs::path(import_args.models.front()).stem().string();
            const fs::path final_db = fs::path(out_dir) / (stem + ".visdb");
            // Build the database beside its final name; replace only when everything worked
            const fs::path tmp_db = fs::path(out_dir) / (stem + ".visdb.partial");
            fs::remove(tmp_db);
            try {
                import_into(scene, tmp_db.string());
                bake_into(tmp_db.string(), options, bake_args.convergence_csv,
                          (fs::path(out_dir) / (stem + ".")).string());
            } catch (...) {
                fs::remove(tmp_db);
                throw;
            }
            fs::rename(tmp_db, final_db);
            export_bake(final_db.string(), "", "ply",
                        (fs::path(out_dir) / (stem + ".ply")).string(), false);
            export_bake(final_db.string(), "", "obj",
                        (fs::path(out_dir) / (stem + ".obj")).string(), false);
            // A first look through the scene's first camera (or the default one)
            render_image(final_db.string(), "", (fs::path(out_dir) / (stem + ".png")).string(),
                         ViewArgs{}, false, std::nullopt, std::nullopt);
            std::cout << "database " << final_db.string() << "\n";
        }
    } catch (const CommandError& e) {
        std::cerr << "abrad " << cmd << ": " << e.message << "\n";
        return e.status;
    } catch (const visdb::StoreError& e) {
        std::cerr << "abrad " << cmd << ": " << e.what() << "\n";
        return kExitBadInput;
    } catch (const exporter::ExportError& e) {
        std::cerr << "abrad " << cmd << ": " << e.what() << "\n";
        return kExitFailure;
    } catch (const std::exception& e) {
        std::cerr << "abrad " << cmd << ": " << e.what() << "\n";
        return kExitFailure;
    }
    return kExitOk;
}

}  // namespace
}  // namespace abrad::tools

int main(int argc, char** argv) { return abrad::tools::run_cli(argc, argv); }
