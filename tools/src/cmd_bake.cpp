// abrad bake: the database's scene baked and stored, summarised, and its calculation grids
// evaluated.

#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <sstream>

#include "abrad/atomic_file.h"
#include "abrad/export/image.h"
#include "abrad/radiosity/cluster.h"
#include "abrad/radiosity/grid.h"
#include "cli_common.h"

namespace fs = std::filesystem;

namespace abrad::tools::cli {
namespace {

struct State {
    BakeArgs bake;
    std::string db;
};

State& state() {
    static State s;
    return s;
}

// Progress on stderr: each step's work done out of work to do, the time since the bake
// started and, once some is done, the step's ETA (from its rate so far). On a terminal a
// rewritten line; otherwise (a log file) a line every 2 seconds of long work, and the end of
// every step that took 2 seconds or more.
class Progress {
  public:
    Progress() : m_tty(isatty(STDERR_FILENO) != 0) {}

    void operator()(std::string_view stage, std::size_t done, std::size_t total) {
        const auto now = std::chrono::steady_clock::now();
        const bool new_step = stage != m_stage;
        if (new_step) {
            m_stage = std::string(stage);
            m_step_start = now;
        }
        const bool ends = total && done >= total;
        const double since_line = seconds(m_last_line, now);
        if (m_tty ? !new_step && !ends && since_line < 0.2
                  : since_line < 2.0 && !(ends && seconds(m_step_start, now) >= 2.0))
            return;
        m_last_line = now;
        char line[320];
        const double elapsed = seconds(m_start, now);
        if (total) {
            const int percent = static_cast<int>(100 * std::min(done, total) / total);
            char eta[48] = "";
            const double step = seconds(m_step_start, now);
            if (done > 0 && !ends && step > 1.0)
                std::snprintf(eta, sizeof eta, ", ETA %s",
                              duration(step * double(total - done) / double(done)).c_str());
            std::snprintf(line, sizeof line, "%s: %zu/%zu (%d%%) %.1f s%s", m_stage.c_str(), done,
                          total, percent, elapsed, eta);
        } else {
            std::snprintf(line, sizeof line, "%s: %zu %.1f s", m_stage.c_str(), done, elapsed);
        }
        if (m_tty)
            std::fprintf(stderr, "\r%-110s%s", line, ends ? "\n" : "");
        else
            std::fprintf(stderr, "%s\n", line);
    }

  private:
    static double seconds(std::chrono::steady_clock::time_point from,
                          std::chrono::steady_clock::time_point to) {
        return std::chrono::duration<double>(to - from).count();
    }
    // "42 s", "3 min 20 s", "2 h 05 min"
    static std::string duration(double s) {
        char text[32];
        if (s < 60.0)
            std::snprintf(text, sizeof text, "%.0f s", s);
        else if (s < 3600.0)
            std::snprintf(text, sizeof text, "%d min %02d s", int(s / 60.0), int(s) % 60);
        else
            std::snprintf(text, sizeof text, "%d h %02d min", int(s / 3600.0), int(s / 60.0) % 60);
        return text;
    }
    bool m_tty;
    std::string m_stage;
    std::chrono::steady_clock::time_point m_start = std::chrono::steady_clock::now();
    std::chrono::steady_clock::time_point m_step_start = m_start, m_last_line = m_start;
};

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
              << " vertices, " << st.light_triangles << " light triangles, ";
    if (!scene.luminaires.empty()) std::cout << scene.luminaires.size() << " luminaires, ";
    std::cout << st.seconds_total << " s\n";
    if (n)
        std::cout << "  receiver irradiance (luminance) min " << lo << " / mean " << sum / double(n)
                  << " / max " << hi << " " << b.unit << "\n";
    if (st.contact_faces_cut > 0)
        std::cout << "  hidden contacts: " << st.contact_hidden_m2 << " m2 cut from "
                  << st.contact_faces_cut << " faces pressed against or inside another solid\n";
    if (const auto& dm = st.dm) {
        const bool coarsened = dm->triangles_meshed > 0;
        std::cout << "  discontinuity mesh: " << dm->triangles_before << " -> "
                  << (coarsened ? dm->triangles_meshed : st.triangles) << " triangles, "
                  << dm->segments << " shadow segments, " << dm->refine_points
                  << " refinement points in " << dm->rounds << " rounds, " << dm->seconds << " s\n";
        if (coarsened)
            std::cout << "  coarsened: " << dm->triangles_meshed << " -> " << st.triangles
                      << " triangles, area-weighted change " << 100.0 * dm->coarsen_change
                      << "% of the mean irradiance, " << dm->seconds_coarsen << " s\n";
    }
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
        if (i->gathered_vertices > 0)
            std::cout << "  edge gather: " << i->gathered_vertices << " vertices, "
                      << i->seconds_gather << " s\n";
    }
}

// A file-name-safe form of a grid name.
std::string file_safe(const std::string& name) {
    std::string out;
    for (const char c : name)
        out += std::isalnum(static_cast<unsigned char>(c)) || c == '-' ? c : '_';
    return out;
}

// Each calculation grid of the scene evaluated on the bake (radiosity/grid.h): E_avg, E_min,
// E_max and U0 = E_min/E_avg printed, the values written as CSV (`<prefix>grid-<name>.csv`,
// one line per point) and as a false-colour image beside it (from 0 to the grid's maximum).
// Values are illuminance (photometric bakes) or irradiance as luminance-weighted RGB, like the
// bake summary.
void evaluate_grids(const std::string& db, const visdb::Scene& scene, const visdb::Bake& bake,
                    const fs::path& prefix) {
    if (scene.grids.empty()) return;
    const radiosity::PointIrradiance field = point_irradiance_of(db, scene, &bake);
    for (const visdb::CalculationGrid& g : scene.grids) {
        const auto t0 = std::chrono::steady_clock::now();
        const radiosity::GridValues v = radiosity::evaluate_grid(field, g);
        const fs::path csv = prefix.string() + "grid-" + file_safe(g.name) + ".csv";
        try {
            radiosity::write_grid_csv(csv, v);
        } catch (const std::runtime_error& x) {
            failure(x.what());
        }
        const fs::path png = prefix.string() + "grid-" + file_safe(g.name) + ".png";
        try {
            exporter::write_false_colour_image(png, v.nx, v.ny, v.image(), 0.0,
                                               v.e_max > 0.0 ? v.e_max : 1.0,
                                               bake.unit == "lux" ? "lux" : "W/m²");
        } catch (const std::exception& x) {
            failure(x.what());  // names the file
        }
        std::printf(
            "  grid '%s': %d x %d points at z %.3g m: E_avg %.4g, E_min %.4g, E_max %.4g %s, "
            "U0 %.3f (%s, %s, %.2f s)\n",
            g.name.c_str(), v.nx, v.ny, g.z, v.e_avg, v.e_min, v.e_max, bake.unit.c_str(), v.u0(),
            csv.filename().string().c_str(), png.filename().string().c_str(), seconds_since(t0));
    }
}

// Stores `bake` under its name or, without one, as the next bake-N (numbered inside the
// store's write transaction), and keeps the name it got.
void store_bake(visdb::Store& store, visdb::Bake& bake) {
    if (bake.name.empty())
        bake.name = store.add_numbered_bake(bake);
    else
        store.add_bake(bake);
}

// A bake computed but not stored because its database stayed busy (another process's lock
// or open read held past the busy timeout) is not thrown away: it is stored with its scene
// in a new database beside the first, `<db stem>.unstored-<pid>.visdb`, and the command fails
// (exit 1) naming both files.
[[noreturn]] void keep_unstored_bake(const std::string& db, const visdb::Scene& scene,
                                     visdb::Bake bake, const visdb::StoreError& busy) {
    const std::string why = std::string(busy.what()) +
                            " (another process held it past the busy timeout, "
                            "ABRAD_BUSY_TIMEOUT_MS, default 10 s): the bake is not stored there";
    const fs::path kept = fs::path(db).replace_extension("").string() + ".unstored-" +
                          std::to_string(::getpid()) + ".visdb";
    try {
        visdb::Store side = visdb::Store::open(kept.string(), visdb::OpenMode::CreateOrOpen);
        side.add_import(scene);
        store_bake(side, bake);
    } catch (const std::exception& e) {
        std::error_code ec;
        fs::remove(kept, ec);
        failure(why + ", and it could not be kept elsewhere: " + e.what());
    }
    failure(why + "; it is kept, with its scene, as bake '" + bake.name + "' in " + kept.string() +
            " (export or render it from there with --db)");
}

}  // namespace

void coarsen_bake(visdb::Bake& b, double budget, double tolerance,
                  const radiosity::ProgressFn& progress) {
    if (!(budget > 0.0) || !b.statistics.dm || b.mesh.triangles.empty()) return;
    const auto start = std::chrono::steady_clock::now();
    const exporter::SimplifyOptions options{.error = std::min(tolerance, 1.0),
                                            .floor = kCoarsenFloor,
                                            .refit = false,
                                            .budget = budget,
                                            .exact_budget = false,
                                            .keep_shared = true,
                                            .max_held = kCoarsenMaxHeld};
    exporter::SimplifyProgress decimation_progress;
    if (progress)
        decimation_progress = [&progress](std::size_t done, std::size_t) {
            // The thousandths of the budget spent, without an ETA: the cheapest collapses go
            // first, so the budget goes ever faster (100k floor: 3 % spent 2 s into the
            // decimation, 42 % at 4 s, all at 4.5 s) and a rate would promise minutes
            progress("coarsen: thousandths of the budget spent", done, 0);
        };
    exporter::SimplifyStats st;
    std::vector<std::uint32_t> kept;
    visdb::BakeMesh light = exporter::simplify(b.mesh, options, &st, &kept, decimation_progress);
    for (visdb::LightGroupShades& g : b.light_groups) {
        std::vector<glm::vec3> h(kept.size()), r(kept.size());
        for (std::size_t v = 0; v < kept.size(); ++v) {
            h[v] = g.irradiance[kept[v]];
            r[v] = g.radiosity[kept[v]];
        }
        g.irradiance = std::move(h);
        g.radiosity = std::move(r);
    }
    b.mesh = std::move(light);
    visdb::DiscontinuityStats& dm = *b.statistics.dm;
    dm.triangles_meshed = b.statistics.triangles;
    dm.coarsen_change = st.mean_change;
    dm.seconds_coarsen = seconds_since(start);
    b.statistics.triangles = b.mesh.triangles.size();
    b.statistics.vertices = b.mesh.positions.size();
    b.statistics.seconds_total += dm.seconds_coarsen;
    char value[32];
    std::snprintf(value, sizeof value, "%g", budget);
    b.parameters.emplace_back("coarsen", value);
}

visdb::Bake bake_into(const std::string& db, const radiosity::BakeOptions& options_in,
                      const BakeArgs& args, const std::string& grid_prefix) {
    const std::string& convergence_csv = args.convergence_csv;
    visdb::Store store = open_db(db);
    store.check_writable();  // before the work, not after it
    const visdb::Scene scene = store.load_scene();
    // Without --name the store numbers the bake (bake-N) when it stores it
    radiosity::BakeOptions options = options_in;
    Progress progress;
    visdb::Bake b;
    std::vector<radiosity::ConvergenceSample> curve;
    if (!convergence_csv.empty()) options.convergence = &curve;
    try {
        b = radiosity::bake(scene, options, std::ref(progress));
        coarsen_bake(b, coarsen_budget(args), options.refine_tolerance, std::ref(progress));
    } catch (const radiosity::InputError& e) {
        bad_input(db + ": " + e.what());
    }
    if (!convergence_csv.empty()) {
        std::ostringstream out;
        out << "shots,seconds,unshot_fraction\n";
        for (const auto& c : curve)
            out << c.shots << "," << c.seconds << "," << c.unshot_fraction << "\n";
        write_file_atomically(convergence_csv, out.view());  // OutputError naming the file
    }
    b.created_at = utc_now();
    try {
        store_bake(store, b);
    } catch (const visdb::StoreError& e) {
        if (!e.busy()) throw;
        keep_unstored_bake(db, scene, b, e);
    }
    print_bake_summary(b, scene);
    std::cout << std::flush;
    evaluate_grids(db, scene, b,
                   grid_prefix.empty()
                       ? fs::path(db).replace_extension("").string() + "." + b.name + "."
                       : grid_prefix);
    return b;
}

void add_bake(CLI::App& app) {
    State& s = state();
    app.add_option("--db", s.db, "Visual database")->required();
    add_bake_options(app, s.bake);
}

namespace {

// abrad bake as one rank of an MPI job (mpirun, srun; docs/design.md#the-distributed-bake):
// every rank reads the database (on a file system all the nodes share) and shoots its share of
// the lights; rank 0 finishes the bake and stores it in its one transaction. A rank that fails
// ends the whole job with its exit status (MPI_Abort), naming itself, so that no rank waits
// for it; when a rank dies, mpirun terminates the others and rank 0 says nothing was stored.
int bake_as_rank(const std::string& db, radiosity::BakeOptions options, const BakeArgs& args) {
    radiosity::Cluster cluster = radiosity::Cluster::join(
        "abrad bake: rank 0 was terminated by the launcher (another rank failed; mpirun names "
        "it): the bake is not stored, " +
        db + " is as it was\n");
    options.cluster = &cluster;
    try {
        if (cluster.rank() == 0) {
            bake_into(db, options, args);
            std::string sent;
            for (const auto& [stage, bytes] : cluster.sent_by_all())
                sent += " " + stage + " " + std::to_string(bytes);
            std::cerr << "abrad bake: shared over " << cluster.size()
                      << " ranks; bytes the ranks sent, per stage:" << sent << "\n";
        } else {
            const visdb::Scene scene = open_db(db, visdb::OpenMode::ReadOnly).load_scene();
            radiosity::bake(scene, options);
        }
    } catch (...) {
        const std::string rank = "rank " + std::to_string(cluster.rank()) + ": ";
        cluster.abort(report_failure("bake", rank, std::current_exception()));
    }
    return kExitOk;
}

}  // namespace

int run_bake(const Invocation& call) {
    const State& s = state();
    const radiosity::BakeOptions options = to_options(s.bake, call.app);
    if (radiosity::Cluster::launched_as_ranks()) return bake_as_rank(s.db, options, s.bake);
    bake_into(s.db, options, s.bake);
    return kExitOk;
}

}  // namespace abrad::tools::cli
