// abrad report through the command line: the page of a luminaire bake with a grid (its
// numbers against the grid CSV the bake wrote, the schedule's figures from the IES file), an
// earlier report replaced whole, the page without the viewer (a note on the page and on
// stderr), and the refusals: no bake, an unknown bake (exit 2), OUT a file or a folder of other
// files (exit 2, left as it was), OUT where nothing can be written (exit 1, nothing left).

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "run_abrad.h"
#include "temp_dir.h"

namespace {

namespace fs = std::filesystem;

using abrad::testing::run_abrad;
using abrad::testing::TempDir;

// A 4 x 4 m floor facing up
const char* const kFloor = "v 0 0 0\nv 4 0 0\nv 4 4 0\nv 0 4 0\nf 1 2 3 4\n";

// A uniform lower hemisphere of 100 cd, lamps 1000 lm, 12.5 W input
const char* const kIes =
    "IESNA:LM-63-2002\n[LUMINAIRE] test downlight\nTILT=NONE\n1 1000 1 3 1 1 2 0 0 0\n1 1 "
    "12.5\n0 45 90\n0\n100 100 100\n";

std::string read_text(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
}

// The number in `data-value="..."` of the cell with data-field="FIELD" in `html`'s row `row`
double field_value(const std::string& html, const std::string& row, const std::string& field) {
    const std::size_t r = html.find(row);
    if (r == std::string::npos) return std::nan("");
    const std::string key = "data-field=\"" + field + "\" data-value=\"";
    const std::size_t f = html.find(key, r);
    if (f == std::string::npos) return std::nan("");
    return std::stod(html.substr(f + key.size()));
}

// A database of the floor lit by two luminaires, a grid over it, and with `bake` a bake 'b'
struct LitFloor {
    explicit LitFloor(const TempDir& dir, bool bake = true) {
        fs::create_directories(dir / "model");
        const fs::path floor = dir.write("model/floor.obj", kFloor);
        dir.write("model/lamp.ies", kIes);
        const fs::path scene = dir.write(
            "model/scene.toml",
            "[[luminaire]]\nfile = \"lamp.ies\"\nname = \"L\"\nposition = [1, 2, 2]\ncount = 2\n"
            "step = [2, 0, 0]\nmaintenance_factor = 0.8\n"
            "[[grid]]\nname = \"floor\"\nmin = [0, 0]\nmax = [4, 4]\nheight = 0\nspacing = 0.5\n");
        db = dir.file("floor.visdb");
        const auto imported =
            run_abrad("import " + floor.string() + " --scene " + scene.string() + " --db " + db);
        EXPECT_EQ(imported.status, 0) << imported.output;
        if (!bake) return;
        const auto baked = run_abrad("bake --db " + db + " --name b --dm off --bounces 0");
        EXPECT_EQ(baked.status, 0) << baked.output;
        csv = dir / "floor.b.grid-floor.csv";
    }
    std::string db;
    fs::path csv;
};

TEST(ReportCli, PageShowsTheGridCsvsNumbersAndTheSchedule) {
    const TempDir dir("report");
    const LitFloor lit(dir);
    const fs::path out = dir / "report";
    const auto r = run_abrad("report --db " + lit.db + " --out " + out.string());
    ASSERT_EQ(r.status, 0) << r.output;
    const std::string html = read_text(out / "index.html");
    ASSERT_FALSE(html.empty());

    // The grid's statistics from the bake's CSV, independently
    std::ifstream csv(lit.csv);
    std::string line;
    std::getline(csv, line);
    double sum = 0.0, lo = 1e300, hi = -1e300;
    int n = 0;
    while (std::getline(csv, line)) {
        std::stringstream s(line);
        std::string cell;
        for (int k = 0; k < 4; ++k) std::getline(s, cell, ',');
        const double v = std::stod(cell);
        sum += v;
        lo = std::min(lo, v);
        hi = std::max(hi, v);
        ++n;
    }
    ASSERT_EQ(n, 64);
    const std::string row = "data-grid=\"floor\"";
    EXPECT_NEAR(field_value(html, row, "e_avg"), sum / n, 1e-7 * sum / n);
    EXPECT_NEAR(field_value(html, row, "e_min"), lo, 1e-7 * lo);
    EXPECT_NEAR(field_value(html, row, "e_max"), hi, 1e-7 * hi);
    EXPECT_NEAR(field_value(html, row, "u0"), lo / (sum / n), 1e-6);
    // The report's own copy of the values and the plan with its contours
    EXPECT_TRUE(fs::is_regular_file(out / "grid-1.csv"));
    EXPECT_TRUE(fs::is_regular_file(out / "grid-1.png"));
    EXPECT_NE(html.find("class=\"contour\""), std::string::npos);

    // The schedule: one line of two luminaires, the lamp flux and power from the file, the web
    // 2π · 100 lm × 0.8 each
    const std::string lum = "data-file=";
    EXPECT_NEAR(field_value(html, lum, "lamp_lumens"), 1000.0, 1e-9);
    EXPECT_NEAR(field_value(html, lum, "watts"), 12.5, 1e-9);
    EXPECT_NEAR(field_value(html, lum, "web_flux"), 0.8 * 200.0 * M_PI, 1e-6);
    EXPECT_NEAR(field_value(html, lum, "total_flux"), 2 * 0.8 * 200.0 * M_PI, 1e-6);
    EXPECT_NE(html.find("data-field=\"count\">2<"), std::string::npos);
    EXPECT_NE(html.find("test downlight"), std::string::npos);
    // The bake's settings and energy balance
    EXPECT_NE(html.find("id=\"energy-table\""), std::string::npos);
    EXPECT_NE(html.find("<th>dm</th><td>off</td>"), std::string::npos) << html;
    EXPECT_TRUE(fs::is_regular_file(out / "model.glb"));
    // Nothing is left beside OUT
    std::size_t entries = 0;
    for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir.path())) ++entries;
    EXPECT_EQ(entries, 5U);  // model/, floor.visdb, its grid CSV and PNG, report/
}

TEST(ReportCli, WithoutTheViewerThePageSaysHowToGetIt) {
    const TempDir dir("report");
    const LitFloor lit(dir);
    const fs::path out = dir / "report";
    ::setenv("ABRAD_VIEWER", (dir / "no-viewer.js").c_str(), 1);
    const auto r = run_abrad("report --db " + lit.db + " --out " + out.string());
    ::unsetenv("ABRAD_VIEWER");
    ASSERT_EQ(r.status, 0) << r.output;
    EXPECT_NE(r.output.find("the 3D viewer is not installed"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("--target abrad_viewer"), std::string::npos) << r.output;
    const std::string html = read_text(out / "index.html");
    EXPECT_NE(html.find("id=\"viewer-missing\""), std::string::npos);
    EXPECT_NE(html.find("data-viewer=\"absent\""), std::string::npos);
    EXPECT_FALSE(fs::exists(out / "model.js"));
    EXPECT_TRUE(fs::is_regular_file(out / "model.glb"));

    // A second report replaces the first whole: a file only the first had is gone, and so is
    // the staging folder of a killed report (its process gone), not that of a live one
    std::ofstream(out / "stale.txt") << "x";
    const fs::path killed = dir / ".report.abrad-report-2147483";
    const fs::path live = dir / (".report.abrad-report-" + std::to_string(::getpid()));
    fs::create_directories(killed / "viewer");
    fs::create_directories(live);
    const auto again = run_abrad("report --db " + lit.db + " --out " + out.string());
    ASSERT_EQ(again.status, 0) << again.output;
    EXPECT_FALSE(fs::exists(out / "stale.txt"));
    EXPECT_TRUE(fs::is_regular_file(out / "index.html"));
    EXPECT_FALSE(fs::exists(killed));
    EXPECT_TRUE(fs::is_directory(live));
}

TEST(ReportCli, RefusesMissingBakesAndForeignOutputs) {
    const TempDir dir("report");
    const LitFloor unbaked(dir, false);
    const fs::path out = dir / "report";
    auto r = run_abrad("report --db " + unbaked.db + " --out " + out.string());
    EXPECT_EQ(r.status, 2) << r.output;
    EXPECT_NE(r.output.find("no bake to report"), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(out));

    const auto baked = run_abrad("bake --db " + unbaked.db + " --name b --dm off --bounces 0");
    ASSERT_EQ(baked.status, 0) << baked.output;
    r = run_abrad("report --db " + unbaked.db + " --bake nope --out " + out.string());
    EXPECT_EQ(r.status, 2) << r.output;
    EXPECT_NE(r.output.find("nope"), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(out));

    // OUT a file, or a folder of other files: refused, left as they were
    const fs::path file = dir.write("notes.txt", "keep me");
    r = run_abrad("report --db " + unbaked.db + " --out " + file.string());
    EXPECT_EQ(r.status, 2) << r.output;
    EXPECT_NE(r.output.find("is not a folder"), std::string::npos) << r.output;
    EXPECT_EQ(read_text(file), "keep me");
    r = run_abrad("report --db " + unbaked.db + " --out " + (dir / "model").string());
    EXPECT_EQ(r.status, 2) << r.output;
    EXPECT_NE(r.output.find("not an earlier abrad report"), std::string::npos) << r.output;
    EXPECT_TRUE(fs::is_regular_file(dir / "model" / "floor.obj"));

    // Nowhere to write (a folder under a file): exit 1, nothing left
    r = run_abrad("report --db " + unbaked.db + " --out " + (file / "report").string());
    EXPECT_EQ(r.status, 1) << r.output;
    EXPECT_NE(r.output.find("cannot write"), std::string::npos) << r.output;
    EXPECT_EQ(read_text(file), "keep me");

    // Not a database
    r = run_abrad("report --db " + file.string() + " --out " + out.string());
    EXPECT_EQ(r.status, 2) << r.output;
    EXPECT_FALSE(fs::exists(out));
}

}  // namespace
