// [[luminaire]] through the command line: the import reports each luminaire's flux against its
// lamps and stores it (abrad info lists it), the bake refuses a scene with luminaires until it
// can shoot them, and a malformed photometric file fails the import (exit 2) naming its line
// and field with the database unchanged.

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "run_abrad.h"
#include "temp_dir.h"

namespace {

namespace fs = std::filesystem;

using abrad::testing::file_bytes;
using abrad::testing::run_abrad;
using abrad::testing::TempDir;

// A 4 x 4 m floor facing up
const char* const kFloor = "v 0 0 0\nv 4 0 0\nv 4 4 0\nv 0 4 0\nf 1 2 3 4\n";

// A uniform lower hemisphere of 100 cd (2π·100 = 628.3 lm), lamps 1000 lm
const char* const kIes =
    "IESNA:LM-63-2002\nTILT=NONE\n1 1000 1 3 1 1 2 0 0 0\n1 1 10\n0 45 90\n0\n100 100 100\n";

TEST(LuminaireCli, ImportReportsStoresAndBakeRefuses) {
    const TempDir dir("luminaire");
    fs::create_directories(dir / "model");
    const fs::path floor = dir.write("model/floor.obj", kFloor);
    dir.write("model/lamp.ies", kIes);
    const fs::path scene =
        dir.write("model/scene.toml",
                  "[[luminaire]]\nfile = \"lamp.ies\"\nname = \"L\"\nposition = [2, 2, 3]\n");
    const std::string db = dir.file("room.visdb");
    const auto imported =
        run_abrad("import " + floor.string() + " --scene " + scene.string() + " --db " + db);
    ASSERT_EQ(imported.status, 0) << imported.output;
    EXPECT_NE(imported.output.find(":1: luminaire 'L': "), std::string::npos) << imported.output;
    EXPECT_NE(imported.output.find("web 628.319 lm, lamps 1000 lm: LOR 0.628"), std::string::npos)
        << imported.output;

    const auto info = run_abrad("info --db " + db);
    ASSERT_EQ(info.status, 0) << info.output;
    EXPECT_NE(info.output.find("luminaires (1):\n  L: "), std::string::npos) << info.output;
    EXPECT_NE(info.output.find("628.3"), std::string::npos) << info.output;

    const std::string before = file_bytes(db);
    const auto bake = run_abrad("bake --db " + db);
    EXPECT_EQ(bake.status, 2) << bake.output;
    EXPECT_NE(bake.output.find("1 luminaire(s) from photometric files (first 'L')"),
              std::string::npos)
        << bake.output;
    EXPECT_EQ(file_bytes(db), before);
}

TEST(LuminaireCli, MalformedPhotometricFileFailsTheImport) {
    const TempDir dir("luminaire");
    fs::create_directories(dir / "model");
    const fs::path floor = dir.write("model/floor.obj", kFloor);
    ASSERT_EQ(run_abrad("import " + floor.string() + " --db " + dir.file("room.visdb")).status, 0);
    const std::string before = file_bytes(dir / "room.visdb");
    std::string bad = kIes;
    bad.replace(bad.rfind("100"), 3, "-100");  // a negative candela on line 7
    const fs::path ies = dir.write("model/bad.ies", bad);
    const fs::path scene =
        dir.write("model/scene.toml", "[[luminaire]]\nfile = \"bad.ies\"\nposition = [2, 2, 3]\n");
    const fs::path other = dir.write("model/other.obj", kFloor);
    const auto r = run_abrad("import " + other.string() + " --scene " + scene.string() + " --db " +
                             dir.file("room.visdb"));
    EXPECT_EQ(r.status, 2) << r.output;
    EXPECT_NE(r.output.find(ies.string() + ":7: candela at horizontal 0, vertical 90: must be "
                                           "a number >= 0, got '-100'"),
              std::string::npos)
        << r.output;
    EXPECT_EQ(file_bytes(dir / "room.visdb"), before);
}

// A point source of 1000 cd in every direction (an IES file with a uniform web, as CIE 171
// case 5.2's source) 3 m over the floor: `abrad probe` without a bake gives the exact direct
// illuminance E = I h / d³ (d the distance to the source).
TEST(LuminaireCli, ProbeGivesThePointSourceClosedForm) {
    const TempDir dir("luminaire");
    fs::create_directories(dir / "model");
    const fs::path floor = dir.write("model/floor.obj", kFloor);
    dir.write("model/iso.ies",
              "IES:LM-63-2019\nTILT=NONE\n1 -1 1 5 1 1 2 0 0 0\n1 1 10\n0 45 90 135 180\n0\n"
              "1000 1000 1000 1000 1000\n");
    const fs::path scene =
        dir.write("model/scene.toml", "[[luminaire]]\nfile = \"iso.ies\"\nposition = [0, 0, 3]\n");
    const std::string db = dir.file("room.visdb");
    ASSERT_EQ(
        run_abrad("import " + floor.string() + " --scene " + scene.string() + " --db " + db).status,
        0);
    const std::vector<double> xs = {0.0, 0.5, 1.0, 2.0, 4.0};
    std::string csv = "x,y,z,nx,ny,nz\n";
    for (const double x : xs) csv += std::to_string(x) + ",0,0,0,0,1\n";
    const fs::path points = dir.write("points.csv", csv);
    const auto r = run_abrad("probe --db " + db + " --points " + points.string());
    ASSERT_EQ(r.status, 0) << r.output;
    EXPECT_NE(r.output.find("direct light only (no bake yet), unit lux"), std::string::npos)
        << r.output;
    std::istringstream lines(r.output);
    std::size_t checked = 0;
    for (std::string line; std::getline(lines, line);) {
        std::vector<double> f;
        std::istringstream fields(line);
        for (std::string v; std::getline(fields, v, ',');) {
            try {
                f.push_back(std::stod(v));
            } catch (const std::exception&) {
                break;
            }
        }
        if (f.size() != 9) continue;
        const double d = std::sqrt(9.0 + f[0] * f[0]);
        const double expected = 1000.0 * 3.0 / (d * d * d);
        EXPECT_NEAR(f[7], expected, 1e-6 * expected) << line;
        ++checked;
    }
    EXPECT_EQ(checked, xs.size()) << r.output;
}

}  // namespace
