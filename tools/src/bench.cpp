// The benchmark: speed against error over a grid of bake settings, and scaling on generated
// building floors (docs/design.md#tests-and-measurements, docs/algorithms.md#field-error).

#include "abrad/tools/bench.h"

#include <malloc.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <glm/geometric.hpp>
#include <iomanip>
#include <map>
#include <optional>
#include <queue>
#include <sstream>
#include <stdexcept>
#include <thread>
#include <utility>

#include "abrad/atomic_file.h"
#include "abrad/radiosity/direct.h"
#include "abrad/radiosity/field_error.h"
#include "abrad/radiosity/form_factor.h"
#include "abrad/radiosity/hemicube.h"
#include "abrad/radiosity/shoot.h"
#include "abrad/tools/floor_gen.h"
#include "abrad/visdb/store.h"

extern char** environ;

namespace abrad::tools {

namespace fs = std::filesystem;
using radiosity::BakeOptions;
using radiosity::Visibility;

namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) {
    return std::chrono::duration<double>(Clock::now() - t0).count();
}

// CPU seconds (user + system) of the whole process so far, all threads.
double cpu_seconds() {
    rusage u{};
    getrusage(RUSAGE_SELF, &u);
    const auto sec = [](const timeval& t) { return double(t.tv_sec) + 1e-6 * double(t.tv_usec); };
    return sec(u.ru_utime) + sec(u.ru_stime);
}

// Resident memory now, MB (/proc/self/statm: size resident ... in pages).
double resident_mb() {
    std::ifstream f("/proc/self/statm");
    double size = 0.0, resident = 0.0;
    f >> size >> resident;
    return resident * double(sysconf(_SC_PAGESIZE)) / (1024.0 * 1024.0);
}

// Peak resident memory over a stretch of work: a thread samples /proc/self/statm every 2 ms
// (Linux's VmHWM cannot be reset everywhere: clear_refs is not always honoured), and the
// process peak (VmHWM) is kept as an upper bound.
class PeakMemory {
  public:
    PeakMemory()
        : m_peak(resident_mb()), m_thread([this] {
              while (!m_stop.load()) {
                  const double r = resident_mb();
                  double p = m_peak.load();
                  while (r > p && !m_peak.compare_exchange_weak(p, r)) {
                  }
                  std::this_thread::sleep_for(std::chrono::milliseconds(2));
              }
          }) {}
    ~PeakMemory() { stop(); }
    double stop() {
        if (m_thread.joinable()) {
            m_stop = true;
            m_thread.join();
        }
        const double r = resident_mb();
        return std::max(m_peak.load(), r);
    }

  private:
    std::atomic<double> m_peak;
    std::atomic<bool> m_stop{false};
    std::thread m_thread;
};

std::string first_line_of(const std::string& path, const std::string& key) {
    std::ifstream f(path);
    std::string line;
    while (std::getline(f, line))
        if (line.rfind(key, 0) == 0) {
            const auto colon = line.find(':');
            std::string v = colon == std::string::npos ? line : line.substr(colon + 1);
            v.erase(0, v.find_first_not_of(" \t"));
            return v;
        }
    return "unknown";
}

std::string fmt(double v, int precision = 4) {
    std::ostringstream s;
    s << std::setprecision(precision) << v;
    return s.str();
}

// CPU seconds of the stages a bake ran (0 for those it did not run).
double shade_cpu(const visdb::BakeStats& s) {
    return s.exact_shade ? s.exact_shade->seconds_cpu : 0.0;
}
double edges_cpu(const visdb::BakeStats& s) { return s.dm ? s.dm->shadow.seconds_cpu : 0.0; }
double mesh_seconds(const visdb::BakeStats& s) { return s.dm ? s.dm->seconds_mesh : 0.0; }
double dm_seconds(const visdb::BakeStats& s) { return s.dm ? s.dm->seconds : 0.0; }

// Runs a program without a shell; returns its exit status, or -1 when it could not start.
int run_program(const std::vector<std::string>& args) {
    std::vector<char*> argv;
    argv.reserve(args.size() + 1);
    for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    pid_t pid = 0;
    if (posix_spawnp(&pid, argv[0], nullptr, nullptr, argv.data(), environ) != 0) return -1;
    int status = 0;
    if (waitpid(pid, &status, 0) < 0) return -1;
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

const char* kCsvHeader =
    "scene,kind,triangles_in,light_triangles,method,resolution,subpixels,dm,lights,shading,"
    "triangles_out,seconds_wall,seconds_shoot_cpu,seconds_occlusion_cpu,seconds_shade_cpu,"
    "seconds_shadow_edges_cpu,seconds_mesh,seconds_dm,seconds_store,peak_rss_mb,ff_error,"
    "field_error_rel_l1,mean_form_factor_sum,occluders_tested,seconds_cpu,seconds_indirect,"
    "indirect_elements,indirect_rows,energy_emitted_w,energy_absorbed_w,energy_escaped_w,"
    "energy_unshot_w,refine_tolerance";

std::string csv_row(const BenchRun& r) {
    const BakeOptions& o = r.options;
    std::ostringstream s;
    s << '"' << r.scene << "\"," << r.kind << ',' << r.triangles_in << ',' << r.light_triangles
      << ',' << radiosity::to_string(o.method) << ',' << o.resolution << ','
      << (o.method == Visibility::ABuffer ? o.subpixels : 1) << ',' << (o.dm ? "on" : "off") << ','
      << (o.dm ? radiosity::to_string(o.lights) : std::string("-")) << ','
      << radiosity::to_string(o.shading) << ',' << r.triangles_out << ',' << fmt(r.seconds_wall, 6)
      << ',' << fmt(r.statistics.shoot.seconds_cpu, 6) << ','
      << fmt(r.statistics.shoot.seconds_occlusion_cpu, 6) << ',' << fmt(shade_cpu(r.statistics), 6)
      << ',' << fmt(edges_cpu(r.statistics), 6) << ',' << fmt(mesh_seconds(r.statistics), 6) << ','
      << fmt(dm_seconds(r.statistics), 6) << ',' << fmt(r.seconds_store, 6) << ','
      << fmt(r.peak_rss_mb, 6) << ',' << fmt(r.ff_error, 6) << ',' << fmt(r.field_error, 6) << ','
      << fmt(r.statistics.mean_form_factor_sum, 9) << ','
      << (r.statistics.exact_shade ? r.statistics.exact_shade->occluders_tested : 0) << ','
      << fmt(r.seconds_cpu, 6);
    if (const auto& i = r.statistics.indirect)
        s << ',' << fmt(i->seconds, 6) << ',' << i->elements << ',' << i->rows << ','
          << fmt(i->energy_emitted_w, 9) << ',' << fmt(i->energy_absorbed_w, 9) << ','
          << fmt(i->energy_escaped_w, 9) << ',' << fmt(i->energy_unshot_w, 9);
    else
        s << ",,,,,,,";
    s << ',' << (o.dm ? fmt(o.refine_tolerance, 6) : std::string("-"));
    return s.str();
}

bool same_settings(const BakeOptions& a, const BakeOptions& b) {
    return a.method == b.method && a.resolution == b.resolution &&
           (a.method == Visibility::ZBuffer || a.subpixels == b.subpixels) && a.dm == b.dm &&
           (!a.dm || a.lights == b.lights) && a.shading == b.shading;
}

// Bakes one scene with one setting, stores it, and measures it.
BenchRun run_one(const BenchScene& s, const std::string& kind, const BakeOptions& options,
                 visdb::Store& store, const radiosity::DirectField* field,
                 const BenchOptions& bench, std::map<std::string, double>& ff_cache) {
    BenchRun r;
    r.scene = s.name;
    r.kind = kind;
    r.options = options;
    r.options.name = "bench";
    r.triangles_in = s.scene.triangle_count();
    malloc_trim(0);  // hand memory freed by earlier runs back, so the peak is this run's
    PeakMemory peak;
    const auto t0 = Clock::now();
    const double cpu0 = cpu_seconds();
    visdb::Bake b = radiosity::bake(s.scene, r.options);
    if (bench.finish) bench.finish(b, r.options);
    r.seconds_wall = seconds_since(t0);
    r.seconds_cpu = cpu_seconds() - cpu0;
    const auto t1 = Clock::now();
    store.add_bake(b);
    r.seconds_store = seconds_since(t1);
    r.peak_rss_mb = peak.stop();
    r.statistics = b.statistics;
    r.triangles_out = b.mesh.triangles.size();
    r.light_triangles = b.statistics.light_triangles;

    // Form-factor error of the hemicube setting (cached: it does not depend on the scene)
    const int sub = options.method == Visibility::ABuffer ? options.subpixels : 1;
    const std::string key = radiosity::to_string(options.method) +
                            std::to_string(options.resolution) + "x" + std::to_string(sub);
    auto it = ff_cache.find(key);
    if (it == ff_cache.end())
        it =
            ff_cache.emplace(key, hemicube_ff_error(options.method, options.resolution, sub)).first;
    r.ff_error = it->second;

    // The reference is the exact direct irradiance: bakes with interreflection are not measured
    if (field && options.bounces == 0 && r.triangles_out <= bench.field_error_max) {
        const radiosity::FieldError e = radiosity::field_error(
            s.scene, b.mesh,
            [&](const glm::dvec3& x, const glm::dvec3& n) { return field->irradiance(x, n); },
            {.subdivisions = bench.subdivisions});
        r.field_error = e.relative_l1;
    }
    return r;
}

void write_csv(const fs::path& path, const std::vector<BenchRun>& runs, const std::string& kind) {
    std::ostringstream f;
    f << kCsvHeader << "\n";
    for (const BenchRun& r : runs)
        if (r.kind == kind) f << csv_row(r) << "\n";
    write_file_atomically(path, f.view());
}

// A family of settings for the plot's colours.
int family(const BakeOptions& o) {
    const int shading = o.shading == radiosity::Shading::Exact ? 1 : 0;
    const int dm = o.dm ? 1 : 0;
    const int method = o.method == Visibility::ABuffer ? 1 : 0;
    return shading * 4 + dm * 2 + method;
}

const char* kFamilyNames[8] = {"zbuffer, patch",     "abuffer, patch",    "zbuffer, DM, patch",
                               "abuffer, DM, patch", "zbuffer, exact",    "abuffer, exact",
                               "zbuffer, DM, exact", "abuffer, DM, exact"};

// gnuplot scripts and their data; returns the PNGs made (empty when gnuplot is missing).
std::vector<std::string> plot(const BenchOptions& bench, const std::vector<BenchRun>& runs,
                              const std::vector<std::string>& scene_names) {
    const fs::path& out = bench.out;
    std::vector<std::string> made;
    // Speed against error: one panel per scene, colour by family, the Pareto front as a line
    {
        std::ostringstream gp;
        gp << "set terminal pngcairo size " << 640 * std::max<std::size_t>(1, scene_names.size())
           << ",520 font 'sans,10'\nset output '" << (out / "speed_error.png").string() << "'\n"
           << "set multiplot layout 1," << std::max<std::size_t>(1, scene_names.size()) << "\n"
           << "set logscale xy\nset xlabel 'bake wall time (s)'\nset ylabel 'field error (relative "
              "L1)'\n"
           << "set key bottom left font 'sans,8'\nset grid\n";
        for (std::size_t si = 0; si < scene_names.size(); ++si) {
            std::vector<BenchRun> mine;
            for (const BenchRun& r : runs)
                if (r.kind == "grid" && r.scene == scene_names[si] && r.field_error > 0.0)
                    mine.push_back(r);
            const fs::path data = out / ("speed_error_" + std::to_string(si) + ".dat");
            std::ostringstream d;
            for (int fam = 0; fam < 8; ++fam) {
                d << "# " << kFamilyNames[fam] << "\n";
                for (const BenchRun& r : mine)
                    if (family(r.options) == fam)
                        d << r.seconds_wall << " " << r.field_error << "\n";
                d << "\n\n";
            }
            d << "# pareto\n";
            std::vector<std::size_t> front = pareto_front(mine);
            std::sort(front.begin(), front.end(), [&](std::size_t a, std::size_t b) {
                return mine[a].seconds_wall < mine[b].seconds_wall;
            });
            for (std::size_t i : front)
                d << mine[i].seconds_wall << " " << mine[i].field_error << "\n";
            write_file_atomically(data, d.view());
            gp << "set title '" << scene_names[si] << "' noenhanced\nplot ";
            for (int fam = 0; fam < 8; ++fam)
                gp << "'" << data.string() << "' index " << fam
                   << " with points pt 7 ps 0.8 title '" << kFamilyNames[fam] << "', ";
            gp << "'" << data.string()
               << "' index 8 with linespoints lw 2 pt 6 ps 1.5 lc 'black' title 'Pareto front'\n";
        }
        gp << "unset multiplot\n";
        write_file_atomically(out / "speed_error.gp", gp.view());
    }
    // Scaling: time and peak memory against triangles, and time against light triangles
    bool scaling = false;
    {
        std::ostringstream d;
        d << "# triangles_in seconds_wall peak_rss_mb light_triangles\n";
        for (const BenchRun& r : runs)
            if (r.kind == "scaling") {
                d << r.triangles_in << " " << r.seconds_wall << " " << r.peak_rss_mb << " "
                  << r.light_triangles << "\n";
                scaling = true;
            }
        d << "\n\n";
        for (const BenchRun& r : runs)
            if (r.kind == "lights")
                d << r.triangles_in << " " << r.seconds_wall << " " << r.peak_rss_mb << " "
                  << r.light_triangles << "\n";
        write_file_atomically(out / "scaling.dat", d.view());
    }
    const bool lights =
        std::any_of(runs.begin(), runs.end(), [](const BenchRun& r) { return r.kind == "lights"; });
    if (scaling || lights) {
        std::ostringstream gp;
        const std::string data = (out / "scaling.dat").string();
        const int panels = (scaling ? 1 : 0) + (lights ? 1 : 0);
        gp << "set terminal pngcairo size " << 640 * panels << ",520 font 'sans,10'\nset output '"
           << (out / "scaling.png").string() << "'\nset multiplot layout 1," << panels
           << "\nset logscale xy\nset grid\nset key top left\n"
           << "set ylabel 'seconds'\nset y2label 'peak memory (MB)'\nset y2tics\nset logscale y2\n";
        if (scaling)
            gp << "set xlabel 'input triangles'\nset title 'Generated floors: "
               << label(bench.scaling) << "' noenhanced\nplot '" << data
               << "' index 0 using 1:2 with linespoints pt 7 title 'bake wall time', '" << data
               << "' index 0 using 1:3 axes x1y2 with linespoints pt 5 title 'peak memory'\n";
        if (lights)
            gp << "set xlabel 'light triangles'\nset title 'Light triangles (fixed floor)'\nplot '"
               << data << "' index 1 using 4:2 with linespoints pt 7 title 'bake wall time', '"
               << data
               << "' index 1 using 4:3 axes x1y2 with linespoints pt 5 title 'peak memory'\n";
        gp << "unset multiplot\n";
        write_file_atomically(out / "scaling.gp", gp.view());
    }
    if (!bench.plot) return made;
    for (const char* name : {"speed_error", "scaling"}) {
        const fs::path script = out / (std::string(name) + ".gp");
        if (!fs::exists(script)) continue;
        const int status = run_program({"gnuplot", script.string()});
        if (status == 0 && fs::exists(out / (std::string(name) + ".png"))) {
            made.push_back(std::string(name) + ".png");
        } else {
            std::fprintf(
                stderr,
                "bench: gnuplot %s (status %d): %s.png not made; the script and data are in %s\n",
                status < 0 ? "not found" : "failed", status, name, out.string().c_str());
        }
    }
    return made;
}

bool is_default(const BakeOptions& o) {
    BakeOptions d;
    return same_settings(o, d);
}

// The building and scaling tables of the summary: one row per run, time per stage, energy.
void write_run_tables(std::ostream& md, const std::vector<BenchRun>& runs) {
    bool any_scaling = false;
    for (const char* kind : {"building", "scaling", "lights"}) {
        std::vector<const BenchRun*> rs;
        for (const BenchRun& r : runs)
            if (r.kind == kind) rs.push_back(&r);
        if (rs.empty()) continue;
        any_scaling = true;
        const std::string k = kind;
        md << (k == "building"  ? "## Whole buildings\n\n"
               : k == "scaling" ? "## Scaling on generated floors\n\n"
                                : "## Scaling with light triangles\n\n")
           << "Settings: " << label(rs.front()->options) << ", interreflection "
           << (rs.front()->options.bounces < 0 ? std::string("converged")
               : rs.front()->options.bounces == 0
                   ? std::string("off")
                   : std::to_string(rs.front()->options.bounces) + " bounces")
           << ". Energy: (absorbed + escaped + unshot) / emitted.\n\n"
           << "| scene | triangles in | light triangles | triangles out | wall s | CPU s | "
              "shoot cpu s | DM s | interreflection s | elements | hemicubes | store s | "
              "peak MB | energy | field error |\n"
           << "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
        for (const BenchRun* r : rs) {
            const auto& in = r->statistics.indirect;
            const double closure = energy_closure(r->statistics);
            md << "| " << r->scene << " | " << r->triangles_in << " | " << r->light_triangles
               << " | " << r->triangles_out << " | " << fmt(r->seconds_wall, 3) << " | "
               << fmt(r->seconds_cpu, 3) << " | " << fmt(r->statistics.shoot.seconds_cpu, 3)
               << " | " << (r->statistics.dm ? fmt(dm_seconds(r->statistics), 3) : "-") << " | "
               << (in ? fmt(in->seconds, 3) : "-") << " | "
               << (in ? std::to_string(in->elements) : "-") << " | "
               << (in ? std::to_string(in->rows) : "-") << " | " << fmt(r->seconds_store, 3)
               << " | " << fmt(r->peak_rss_mb, 4) << " | "
               << (closure >= 0.0 ? fmt(closure, 6) : std::string("-")) << " | "
               << (r->field_error >= 0.0 ? fmt(r->field_error, 3) : std::string("-")) << " |\n";
        }
        md << "\n";
    }
    if (!any_scaling) md << "No scaling or building runs (none asked for).\n";
}

// The mesh trade-off table: each DM run beside the uniform mesh of its size (runs in pairs).
void write_tradeoff_table(std::ostream& md, const std::vector<BenchRun>& runs) {
    std::vector<const BenchRun*> rs;
    for (const BenchRun& r : runs)
        if (r.kind == "tradeoff") rs.push_back(&r);
    if (rs.empty()) return;
    md << "## Mesh trade-off: discontinuity mesh against a uniform mesh of the same size\n\n"
       << "Direct light, exact vertex values either way; the uniform mesh splits the scene's "
          "longest edges until it has the DM mesh's triangles, baked with DM off.\n\n"
       << "| scene | refine tolerance | DM triangles | DM field error | DM CPU s | uniform "
          "triangles | uniform field error | uniform CPU s | DM / uniform error |\n"
       << "|---|---|---|---|---|---|---|---|---|\n";
    for (std::size_t i = 0; i + 1 < rs.size(); i += 2) {
        const BenchRun &d = *rs[i], &u = *rs[i + 1];
        md << "| " << d.scene << " | " << fmt(d.options.refine_tolerance, 3) << " | "
           << d.triangles_out << " | " << fmt(d.field_error, 3) << " | " << fmt(d.seconds_cpu, 3)
           << " | " << u.triangles_out << " | " << fmt(u.field_error, 3) << " | "
           << fmt(u.seconds_cpu, 3) << " | "
           << (u.field_error > 0.0 ? fmt(d.field_error / u.field_error, 3) : std::string("-"))
           << " |\n";
    }
    md << "\n";
}

void write_summary(const BenchOptions& bench, const std::vector<BenchRun>& runs,
                   const std::vector<std::string>& scene_names,
                   const std::vector<std::string>& pngs) {
    std::ostringstream md;
    md << "# Benchmark summary\n\n";
    if (!bench.command.empty()) md << "Command: `" << bench.command << "`\n\n";
    md << "Machine: " << first_line_of("/proc/cpuinfo", "model name") << ", "
       << std::thread::hardware_concurrency() << " hardware threads, "
       << first_line_of("/proc/meminfo", "MemTotal") << " memory; threads used: "
       << (bench.threads > 0 ? std::to_string(bench.threads) : std::string("all")) << ".\n\n";
    md << "Times are wall-clock seconds of the bake call (stage columns in bench.csv are CPU "
          "seconds "
          "summed over threads); field error is the area-weighted relative L1 of the Gouraud-"
          "interpolated irradiance against the exact direct irradiance at "
       << bench.subdivisions * bench.subdivisions
       << " points per triangle; form-factor error is the hemicube's relative L1 against Lambert's "
          "closed "
          "form in an unoccluded 4 x 4 x 3 m box of 0.25 m patches.\n\n";
    for (const std::string& png : pngs) md << "![" << png << "](" << png << ")\n\n";
    for (const std::string& name : scene_names) {
        std::vector<BenchRun> mine;
        for (const BenchRun& r : runs)
            if (r.kind == "grid" && r.scene == name) mine.push_back(r);
        if (mine.empty()) continue;
        md << "## " << name << " (" << mine.front().triangles_in << " triangles, "
           << mine.front().light_triangles << " light triangles)\n\n";
        std::vector<std::size_t> front = pareto_front(mine);
        std::sort(front.begin(), front.end(), [&](std::size_t a, std::size_t b) {
            return mine[a].seconds_wall < mine[b].seconds_wall;
        });
        md << "Pareto-best settings (no other run both faster and more accurate):\n\n"
           << "| settings | wall s | field error | form-factor error | triangles out | peak MB |\n"
           << "|---|---|---|---|---|---|\n";
        bool default_on_front = false;
        for (std::size_t i : front) {
            const BenchRun& r = mine[i];
            default_on_front = default_on_front || is_default(r.options);
            md << "| " << label(r.options) << (is_default(r.options) ? " **(default)**" : "")
               << " | " << fmt(r.seconds_wall, 3) << " | " << fmt(r.field_error, 3) << " | "
               << fmt(r.ff_error, 3) << " | " << r.triangles_out << " | " << fmt(r.peak_rss_mb, 4)
               << " |\n";
        }
        for (const BenchRun& r : mine)
            if (is_default(r.options) && !default_on_front)
                md << "\nThe default (" << label(r.options) << ") took " << fmt(r.seconds_wall, 3)
                   << " s with field error " << fmt(r.field_error, 3)
                   << ": not on the front for this scene.\n";
        md << "\n";
    }
    write_tradeoff_table(md, runs);
    write_run_tables(md, runs);
    write_file_atomically(bench.out / "summary.md", md.view());
}

}  // namespace

std::string label(const BakeOptions& o) {
    std::string s = radiosity::to_string(o.method) + " R" + std::to_string(o.resolution);
    if (o.method == Visibility::ABuffer)
        s += " " + std::to_string(o.subpixels) + "x" + std::to_string(o.subpixels);
    s += o.dm ? ", DM " + radiosity::to_string(o.lights) : std::string(", no DM");
    s += ", " + radiosity::to_string(o.shading);
    return s;
}

std::vector<BakeOptions> settings_grid(bool quick, int threads) {
    struct Hc {
        Visibility method;
        int resolution, subpixels;
    };
    std::vector<Hc> hemicubes;
    if (quick) {
        hemicubes = {{Visibility::ZBuffer, 50, 8},
                     {Visibility::ABuffer, 26, 4},
                     {Visibility::ABuffer, 50, 8}};
    } else {
        for (int r : {50, 100, 200, 400}) hemicubes.push_back({Visibility::ZBuffer, r, 8});
        for (int r : {26, 50, 100})  // R must be even: 26 stands for the issue's 25
            for (int s : {4, 8, 16}) hemicubes.push_back({Visibility::ABuffer, r, s});
    }
    std::vector<std::pair<bool, radiosity::LightModel>> dms = {
        {false, radiosity::LightModel::Area}};
    if (quick)
        dms.push_back({true, radiosity::LightModel::Area});
    else
        for (auto m : {radiosity::LightModel::Centroid, radiosity::LightModel::Vertices,
                       radiosity::LightModel::Area})
            dms.push_back({true, m});
    std::vector<BakeOptions> grid;
    for (const Hc& h : hemicubes)
        for (const auto& [dm, model] : dms)
            for (auto shading : {radiosity::Shading::Patch, radiosity::Shading::Exact}) {
                BakeOptions o;
                o.method = h.method;
                o.resolution = h.resolution;
                o.subpixels = h.subpixels;
                o.dm = dm;
                o.lights = model;
                o.shading = shading;
                o.threads = threads;
                o.bounces = 0;  // direct light: the field error's reference is exact direct light
                grid.push_back(o);
            }
    return grid;
}

double hemicube_ff_error(Visibility method, int resolution, int subpixels) {
    using radiosity::Patch;
    // The box [-2, 2]² × [0, 3] seen from the middle of its floor, patches of 0.25 m
    std::vector<Patch> patches;
    const double cell = 0.25;
    auto rect = [&](glm::dvec3 o, glm::dvec3 u, glm::dvec3 v) {
        const int nu = static_cast<int>(std::lround(glm::length(u) / cell));
        const int nv = static_cast<int>(std::lround(glm::length(v) / cell));
        for (int j = 0; j < nv; ++j)
            for (int i = 0; i < nu; ++i) {
                const glm::dvec3 a = o + u * (double(i) / nu) + v * (double(j) / nv);
                const glm::dvec3 b = a + u / double(nu), d = a + v / double(nv),
                                 c = b + v / double(nv);
                patches.push_back({{a, b, c}, 1.0});
                patches.push_back({{a, c, d}, 1.0});
            }
    };
    rect({-2, -2, 3}, {0, 4, 0}, {4, 0, 0});  // ceiling, facing down
    rect({-2, -2, 0}, {4, 0, 0}, {0, 0, 3});  // wall y = -2, facing +y
    rect({2, 2, 0}, {-4, 0, 0}, {0, 0, 3});   // wall y = 2
    rect({2, -2, 0}, {0, 4, 0}, {0, 0, 3});   // wall x = 2
    rect({-2, 2, 0}, {0, -4, 0}, {0, 0, 3});  // wall x = -2
    const radiosity::ShooterFrame frame = radiosity::ShooterFrame::at({0.1, 0.05, 0.0}, {0, 0, 1});
    const radiosity::Hemicube hc(resolution);
    const radiosity::ShootResult shot =
        radiosity::shoot(frame, patches, hc,
                         {.method = method,
                          .subpixels = method == Visibility::ABuffer ? subpixels : 8,
                          .occlusion = false});
    double err = 0.0, total = 0.0;
    for (std::size_t i = 0; i < patches.size(); ++i) {
        const double exact =
            radiosity::point_polygon_form_factor(frame.origin, frame.n, patches[i].p);
        err += std::abs(shot.form_factor[i] - exact);
        total += exact;
    }
    return err / total;
}

double energy_closure(const visdb::BakeStats& statistics) {
    const auto& i = statistics.indirect;
    if (!i || !(i->energy_emitted_w > 0.0)) return -1.0;
    return (i->energy_absorbed_w + i->energy_escaped_w + i->energy_unshot_w) / i->energy_emitted_w;
}

std::vector<std::size_t> pareto_front(const std::vector<BenchRun>& runs) {
    std::vector<std::size_t> front;
    for (std::size_t i = 0; i < runs.size(); ++i) {
        if (runs[i].field_error < 0.0) continue;
        bool dominated = false;
        for (std::size_t j = 0; j < runs.size() && !dominated; ++j) {
            if (j == i || runs[j].field_error < 0.0 || runs[j].scene != runs[i].scene) continue;
            dominated = runs[j].seconds_wall <= runs[i].seconds_wall &&
                        runs[j].field_error <= runs[i].field_error &&
                        (runs[j].seconds_wall < runs[i].seconds_wall ||
                         runs[j].field_error < runs[i].field_error);
        }
        if (!dominated) front.push_back(i);
    }
    return front;
}

visdb::Scene subdivide_uniformly(const visdb::Scene& scene, std::size_t triangles) {
    visdb::Scene out = scene;
    // Edges of every receiver surface, longest first; an edge's triangles by (surface, edge)
    using Key = std::pair<std::uint32_t, std::uint32_t>;  // vertex ids, smaller first
    struct Edge {
        double length2;
        std::size_t surface;
        Key key;
        bool operator<(const Edge& o) const { return length2 < o.length2; }
    };
    std::vector<std::map<Key, std::vector<std::uint32_t>>> incident(out.surfaces.size());
    std::priority_queue<Edge> queue;
    const auto key = [](std::uint32_t a, std::uint32_t b) {
        return Key{std::min(a, b), std::max(a, b)};
    };
    const auto add = [&](std::size_t s, std::uint32_t a, std::uint32_t b, std::uint32_t t) {
        auto& list = incident[s][key(a, b)];
        if (list.empty()) {
            const auto& p = out.surfaces[s].mesh.positions;
            const glm::dvec3 d = p[b] - p[a];
            queue.push({glm::dot(d, d), s, key(a, b)});
        }
        list.push_back(t);
    };
    std::size_t count = 0;
    for (std::size_t s = 0; s < out.surfaces.size(); ++s) {
        const auto& mesh = out.surfaces[s].mesh;
        count += mesh.triangles.size();
        if (out.materials[out.surfaces[s].material].is_emitter()) continue;
        for (std::uint32_t t = 0; t < mesh.triangles.size(); ++t)
            for (int k = 0; k < 3; ++k)
                add(s, mesh.triangles[t][k], mesh.triangles[t][(k + 1) % 3], t);
    }
    while (count < triangles && !queue.empty()) {
        const Edge e = queue.top();
        queue.pop();
        auto& mesh = out.surfaces[e.surface].mesh;
        auto& edges = incident[e.surface];
        const auto it = edges.find(e.key);
        if (it == edges.end()) continue;  // split already
        const std::vector<std::uint32_t> tris = it->second;
        edges.erase(it);
        const auto m = static_cast<std::uint32_t>(mesh.positions.size());
        mesh.positions.push_back(0.5 *
                                 (mesh.positions[e.key.first] + mesh.positions[e.key.second]));
        for (const std::uint32_t t : tris) {
            // Triangle (u, v, w) with uv the edge: (u, m, w) keeps t, (m, v, w) is new
            glm::u32vec3 tri = mesh.triangles[t];
            int k = 0;
            while (key(tri[k], tri[(k + 1) % 3]) != e.key) ++k;
            const std::uint32_t u = tri[k], v = tri[(k + 1) % 3], w = tri[(k + 2) % 3];
            const auto t2 = static_cast<std::uint32_t>(mesh.triangles.size());
            mesh.triangles[t] = {u, m, w};
            mesh.triangles.push_back({m, v, w});
            auto& vw = edges[key(v, w)];
            std::replace(vw.begin(), vw.end(), t, t2);
            add(e.surface, u, m, t);
            add(e.surface, m, w, t);
            add(e.surface, m, v, t2);
            add(e.surface, w, m, t2);
            ++count;
        }
    }
    return out;
}

std::vector<BenchRun> mesh_tradeoff(const BenchScene& scene, const BakeOptions& base,
                                    const std::vector<double>& tolerances,
                                    const BenchOptions& bench) {
    std::vector<BenchRun> runs;
    std::map<std::string, double> ff_cache;
    const radiosity::DirectField field(scene.scene);
    const fs::path db = bench.out / "tradeoff.visdb";
    auto fresh_store = [&](const visdb::Scene& s) {
        fs::remove(db);
        visdb::Store store = visdb::Store::open(db.string(), visdb::OpenMode::CreateOrOpen);
        store.add_import(s);
        return store;
    };
    BakeOptions o = base;
    o.bounces = 0;  // the field error's reference is the exact direct light
    o.threads = bench.threads;
    for (const double tolerance : tolerances) {
        o.dm = true;
        o.refine_tolerance = tolerance;
        {
            visdb::Store store = fresh_store(scene.scene);
            runs.push_back(run_one(scene, "tradeoff", o, store, &field, bench, ff_cache));
        }
        const std::size_t target = runs.back().triangles_out;
        const BenchScene uniform{scene.name, subdivide_uniformly(scene.scene, target)};
        o.dm = false;
        visdb::Store store = fresh_store(uniform.scene);
        runs.push_back(run_one(uniform, "tradeoff", o, store, &field, bench, ff_cache));
        const BenchRun &d = runs[runs.size() - 2], &u = runs.back();
        std::fprintf(stderr,
                     "bench: %s, mesh trade-off at refine tolerance %g: DM %zu triangles, field "
                     "error %.4g; uniform %zu triangles, field error %.4g\n",
                     scene.name.c_str(), tolerance, d.triangles_out, d.field_error, u.triangles_out,
                     u.field_error);
    }
    fs::remove(db);
    return runs;
}

std::vector<BenchRun> run_bench(const BenchOptions& bench) {
    fs::create_directories(bench.out);
    const fs::path db = bench.out / "bench.visdb";
    std::vector<BenchRun> runs;
    std::vector<std::string> scene_names;
    std::map<std::string, double> ff_cache;
    auto fresh_store = [&](const visdb::Scene& scene) {
        fs::remove(db);
        visdb::Store store = visdb::Store::open(db.string(), visdb::OpenMode::CreateOrOpen);
        store.add_import(scene);
        return store;
    };

    // The settings grid on every scene
    const std::vector<BakeOptions> grid = settings_grid(bench.quick, bench.threads);
    for (const BenchScene& s : bench.scenes) {
        scene_names.push_back(s.name);
        visdb::Store store = fresh_store(s.scene);
        const radiosity::DirectField field(s.scene);
        std::size_t k = 0;
        for (const BakeOptions& o : grid) {
            runs.push_back(run_one(s, "grid", o, store, &field, bench, ff_cache));
            const BenchRun& r = runs.back();
            std::fprintf(stderr,
                         "bench: %s [%zu/%zu] %s: %.3f s, field error %.4g, %zu triangles\n",
                         s.name.c_str(), ++k, grid.size(), label(o).c_str(), r.seconds_wall,
                         r.field_error, r.triangles_out);
        }
    }

    // The mesh trade-off: DM against uniform meshes of the same size
    if (!bench.tradeoff_tolerances.empty())
        for (const BenchScene& s : bench.scenes) {
            std::vector<BenchRun> t =
                mesh_tradeoff(s, bench.scaling, bench.tradeoff_tolerances, bench);
            runs.insert(runs.end(), t.begin(), t.end());
        }

    // Scaling on generated floors with the given settings
    BakeOptions scaling = bench.scaling;
    scaling.threads = bench.threads;
    auto scale_run = [&](const FloorOptions& fo, const std::string& kind) {
        BenchScene s{"floor " + to_string(fo), generate_floor(fo)};
        visdb::Store store = fresh_store(s.scene);
        std::optional<radiosity::DirectField> field;
        if (s.scene.triangle_count() <= bench.field_error_max / 4) field.emplace(s.scene);
        runs.push_back(
            run_one(s, kind, scaling, store, field ? &*field : nullptr, bench, ff_cache));
        const BenchRun& r = runs.back();
        std::fprintf(stderr,
                     "bench: %s: %zu -> %zu triangles, %zu light triangles, %.3f s, peak %.0f MB\n",
                     s.name.c_str(), r.triangles_in, r.triangles_out, r.light_triangles,
                     r.seconds_wall, r.peak_rss_mb);
    };
    // Whole buildings with the same settings
    for (const BenchScene& b : bench.buildings) {
        visdb::Store store = fresh_store(b.scene);
        std::optional<radiosity::DirectField> field;
        if (b.scene.triangle_count() <= bench.field_error_max / 4) field.emplace(b.scene);
        runs.push_back(
            run_one(b, "building", scaling, store, field ? &*field : nullptr, bench, ff_cache));
        const BenchRun& r = runs.back();
        std::fprintf(stderr,
                     "bench: %s: %zu -> %zu triangles, %.3f s wall, %.3f s CPU, peak %.0f MB\n",
                     b.name.c_str(), r.triangles_in, r.triangles_out, r.seconds_wall, r.seconds_cpu,
                     r.peak_rss_mb);
    }
    // Small before large: the process's resident memory is what is measured
    for (int lights : bench.light_counts)
        scale_run(floor_for_triangles(bench.lights_at, lights), "lights");
    std::vector<std::size_t> sizes = bench.sizes;
    std::sort(sizes.begin(), sizes.end());
    for (std::size_t size : sizes) scale_run(floor_for_triangles(size, 1), "scaling");
    fs::remove(db);

    write_csv(bench.out / "bench.csv", runs, "grid");
    {
        std::ostringstream f;
        f << kCsvHeader << "\n";
        for (const BenchRun& r : runs)
            if (r.kind != "grid" && r.kind != "tradeoff") f << csv_row(r) << "\n";
        write_file_atomically(bench.out / "scaling.csv", f.view());
    }
    if (!bench.tradeoff_tolerances.empty()) write_csv(bench.out / "tradeoff.csv", runs, "tradeoff");
    const std::vector<std::string> pngs = plot(bench, runs, scene_names);
    write_summary(bench, runs, scene_names, pngs);
    return runs;
}

}  // namespace abrad::tools
