// Tests of [[luminaire]] in the scene file: the photometric file found beside the scene file,
// frames from rotations and targets, rows by count and step, factors, opening overrides, the
// luminaires applied to a scene with their flux notes, and every mistake at its line and key.

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <glm/geometric.hpp>
#include <numbers>
#include <string>
#include <vector>

#include "abrad/convert/scene_file.h"
#include "temp_dir.h"

namespace abrad::convert {
namespace {

namespace fs = std::filesystem;
using ::abrad::testing::TempDir;

/// A rotationally symmetric type C downlight: I(γ) = 1000 cos γ cd below the horizon (flux
/// π·1000 lm within 0.3 %: the bilinear web at 10° steps), lamps 4000 lm.
const char* const kDownlight =
    "IESNA:LM-63-2002\n[MANUFAC] Test\nTILT=NONE\n1 4000 1 10 1 1 2 0.2 0.2 0\n1 1 30\n"
    "0 10 20 30 40 50 60 70 80 90\n0\n"
    "1000 984.807753 939.692621 866.025404 766.044443 642.787610 500 342.020143 173.648178 0\n";

void expect_vec(const glm::dvec3& expected, const glm::dvec3& actual, double tol = 1e-12) {
    EXPECT_NEAR(expected.x, actual.x, tol);
    EXPECT_NEAR(expected.y, actual.y, tol);
    EXPECT_NEAR(expected.z, actual.z, tol);
}

TEST(SceneLuminaire, RowAimedAndScaled) {
    const TempDir dir;
    fs::create_directories(dir.path() / "ies");
    dir.write("ies/down.ies", kDownlight);
    const fs::path scene_path = dir.write("scene.toml", R"(
[[luminaire]]
file = "ies/down.ies"
name = "DL"
position = [1.0, 2.0, 3.0]
target = [1.0, 2.0, 0.0]
count = 3
step = [1.5, 0, 0]
flux_scale = 2.0
maintenance_factor = 0.8
color = [1.0, 1.0, 1.0]
)");
    const SceneFile f = read_scene_file(scene_path);
    ASSERT_EQ(f.luminaires.size(), 3U);
    EXPECT_TRUE(f.is_photometric());
    const visdb::Luminaire& l = f.luminaires[2].luminaire;
    EXPECT_EQ(l.name, "DL 3");
    expect_vec({4.0, 2.0, 3.0}, l.position);
    expect_vec({0.0, 0.0, 1.0}, l.axis_z);  // nadir straight down: the frame unturned
    expect_vec({1.0, 0.0, 0.0}, l.axis_x);
    EXPECT_EQ(l.opening.shape, visdb::LuminousOpening::Shape::Rectangle);
    EXPECT_EQ(l.file, (dir.path() / "ies/down.ies").string());
    // Straight down: 1000 cd × 2 × 0.8
    EXPECT_NEAR(l.intensity({0.0, 0.0, -1.0}).y, 1600.0, 1e-9);
    EXPECT_NEAR(l.flux(), 1600.0 * std::numbers::pi, 0.003 * 1600.0 * std::numbers::pi);

    visdb::Scene scene;
    const SceneFileReport report = apply_scene_file(f, scene);
    EXPECT_EQ(report.luminaires, 3U);
    ASSERT_EQ(scene.luminaires.size(), 3U);
    EXPECT_EQ(scene.emittance_unit, "lm/m2");
    ASSERT_EQ(report.notes.size(), 1U);
    const std::string& note = report.notes[0];
    EXPECT_NE(note.find(":2: luminaire 'DL 1' and 2 more"), std::string::npos) << note;
    EXPECT_NE(note.find("lamps 4000 lm: LOR 0.78"), std::string::npos) << note;
    EXPECT_NE(note.find("lm each (scale 1.6)"), std::string::npos) << note;
}

TEST(SceneLuminaire, RotationAndTargetFrames) {
    const TempDir dir;
    dir.write("down.ies", kDownlight);
    const fs::path scene_path = dir.write("scene.toml", R"(
[[luminaire]]
file = "down.ies"
position = [0, 0, 3]
rotation = [0, 90, 0]

[[luminaire]]
file = "down.ies"
position = [0, 0, 3]
target = [3, 0, 0]
opening = "disc"
opening_size = [0.3, 0.3]
)");
    const SceneFile f = read_scene_file(scene_path);
    ASSERT_EQ(f.luminaires.size(), 2U);
    // Ry(90°) takes the luminaire's z to world x: its light goes to -x
    const visdb::Luminaire& turned = f.luminaires[0].luminaire;
    EXPECT_EQ(turned.name, "down (line 2)");
    expect_vec({1.0, 0.0, 0.0}, turned.axis_z);
    expect_vec({0.0, 1.0, 0.0}, turned.axis_y);
    EXPECT_NEAR(turned.intensity({-1.0, 0.0, 0.0}).x, 1000.0, 1e-9);
    EXPECT_NEAR(turned.intensity({0.0, 0.0, -1.0}).x, 0.0, 1e-9);
    // Aimed 45° down toward +x: the nadir there, a right-handed frame
    const visdb::Luminaire& aimed = f.luminaires[1].luminaire;
    const double h = std::sqrt(0.5);
    expect_vec({-h, 0.0, h}, aimed.axis_z);
    expect_vec(glm::cross(aimed.axis_x, aimed.axis_y), aimed.axis_z);
    EXPECT_NEAR(aimed.intensity({h, 0.0, -h}).x, 1000.0, 1e-9);
    EXPECT_EQ(aimed.opening.shape, visdb::LuminousOpening::Shape::Disc);
    EXPECT_EQ(aimed.opening.length, 0.3);
}

/// kDownlight with a lamp-tilt table (geometry 1): 1 upright, 0.5 at 45°, 0.25 at 90°.
const char* const kTiltedLamp =
    "IESNA:LM-63-2002\n[MANUFAC] Test\nTILT=INCLUDE\n1\n3\n0 45 90\n1 0.5 0.25\n"
    "1 4000 1 10 1 1 2 0.2 0.2 0\n1 1 30\n"
    "0 10 20 30 40 50 60 70 80 90\n0\n"
    "1000 984.807753 939.692621 866.025404 766.044443 642.787610 500 342.020143 173.648178 0\n";

TEST(SceneLuminaire, TiltTableScalesTheLightAtTheMountedTilt) {
    const TempDir dir;
    dir.write("tilt.ies", kTiltedLamp);
    dir.write("down.ies", kDownlight);
    const fs::path scene_path = dir.write("scene.toml", R"(
[[luminaire]]
file = "tilt.ies"
position = [0, 0, 3]
rotation = [0, 0, 30]

[[luminaire]]
file = "tilt.ies"
position = [0, 0, 3]
rotation = [0, 45, 0]

[[luminaire]]
file = "tilt.ies"
position = [0, 0, 3]
target = [3, 0, 1.5]

[[luminaire]]
file = "tilt.ies"
position = [0, 0, 3]
rotation = [120, 0, 0]

[[luminaire]]
file = "down.ies"
position = [0, 0, 3]
rotation = [0, 45, 0]
)");
    const SceneFile f = read_scene_file(scene_path);
    ASSERT_EQ(f.luminaires.size(), 5U);
    const double pi = std::numbers::pi;
    // Turned about the vertical only: no tilt, the table's 1
    EXPECT_NEAR(f.luminaires[0].luminaire.tilt_degrees(), 0.0, 1e-9);
    EXPECT_EQ(f.luminaires[0].luminaire.tilt_factor, 1.0);
    // Tilted 45 degrees: the table halves the output, in every direction and in its flux
    const visdb::Luminaire& half = f.luminaires[1].luminaire;
    EXPECT_NEAR(half.tilt_degrees(), 45.0, 1e-9);
    EXPECT_NEAR(half.tilt_factor, 0.5, 1e-12);
    const double h = std::sqrt(0.5);
    EXPECT_NEAR(half.intensity({-h, 0.0, -h}).y, 500.0, 1e-9);  // its nadir
    const visdb::Luminaire& same = f.luminaires[4].luminaire;   // TILT=NONE, tilted alike
    EXPECT_EQ(same.tilt_factor, 1.0);
    EXPECT_NEAR(half.flux(), 0.5 * same.flux(), 1e-9 * same.flux());
    // Aimed at a point 3 m away and 1.5 m down: tilt atan(2) = 63.43 degrees, between the
    // table's 45 (0.5) and 90 (0.25)
    const double tilt = std::atan(2.0) * 180.0 / pi;
    EXPECT_NEAR(f.luminaires[2].luminaire.tilt_degrees(), tilt, 1e-9);
    EXPECT_NEAR(f.luminaires[2].luminaire.tilt_factor, 0.5 - 0.25 * (tilt - 45.0) / 45.0, 1e-12);
    // Beyond the table's last angle (120 degrees about x): its last factor
    EXPECT_NEAR(f.luminaires[3].luminaire.tilt_degrees(), 120.0, 1e-9);
    EXPECT_EQ(f.luminaires[3].luminaire.tilt_factor, 0.25);
    // The import's note says so
    visdb::Scene scene;
    const SceneFileReport report = apply_scene_file(f, scene);
    bool noted = false;
    for (const std::string& note : report.notes)
        noted = noted || note.find("lamp tilt factor 0.5 at 45 degrees") != std::string::npos;
    EXPECT_TRUE(noted);

    // A table whose factor is 0 at the mounted tilt: no light, refused at the luminaire's line
    dir.write("dark.ies",
              std::string(kTiltedLamp)
                  .replace(std::string(kTiltedLamp).find("1 0.5 0.25"), 10, "1 0.5 0.00"));
    const fs::path dark = dir.write("dark.toml",
                                    "\n[[luminaire]]\nfile = \"dark.ies\"\n"
                                    "position = [0, 0, 3]\nrotation = [90, 0, 0]\n");
    try {
        (void)read_scene_file(dark);
        FAIL() << "no error";
    } catch (const ImportError& e) {
        const std::string what = e.what();
        EXPECT_NE(what.find("dark.toml:2:"), std::string::npos) << what;
        EXPECT_NE(what.find("tilted 90 degrees gives no light"), std::string::npos) << what;
    }
}

struct LuminaireError {
    std::string toml;
    std::size_t line;
    std::string needle;
};

TEST(SceneLuminaire, MistakesAreRefusedAtTheirLine) {
    const std::string head = "[[luminaire]]\nfile = \"down.ies\"\nposition = [0, 0, 3]\n";
    const std::vector<LuminaireError> cases = {
        {"[[luminaire]]\nposition = [0, 0, 3]\n", 1, "[[luminaire]] needs 'file'"},
        {"[[luminaire]]\nfile = \"down.ies\"\n", 1, "[[luminaire]] needs 'position'"},
        {head + "watts = 3\n", 4, "unknown key 'watts' in [[luminaire]]"},
        {head + "rotation = [0, 0, 0]\ntarget = [0, 0, 0]\n", 5, "both 'rotation' (line 4)"},
        {head + "target = [0, 0, 3]\n", 4, "'target' in [[luminaire]] equals 'position'"},
        {head + "count = 2\n", 4, "'count' > 1 needs 'step'"},
        {head + "count = 2.5\nstep = [1, 0, 0]\n", 4, "whole number"},
        {head + "step = [1, 0, 0]\n", 4, "'step' needs 'count' > 1"},
        {head + "flux_scale = 0\n", 4, "'flux_scale' in [[luminaire]] must be > 0"},
        {head + "maintenance_factor = 1.2\n", 4, "must be in (0, 1]"},
        {head + "opening = \"hexagon\"\n", 4, "must be file, point, rectangle or disc"},
        {head + "opening_size = [1, 1]\n", 4, "needs opening = \"rectangle\" or \"disc\""},
        {head + "opening = \"rectangle\"\n", 4, "needs 'opening_size'"},
        {head + "name = \"A\"\n" + head + "name = \"A\"\n", 5, "'A' is already defined at line 1"},
        {"photometric = false\n" + head, 2, "or a luminaire needs photometric mode"},
        {"[[luminaire]]\nfile = \"../down.ies\"\nposition = [0, 0, 3]\n", 2,
         "is outside the model's folder"},
        {"[[luminaire]]\nfile = \"absent.ies\"\nposition = [0, 0, 3]\n", 0,
         "no such photometric file"},
    };
    for (const LuminaireError& c : cases) {
        const TempDir dir;
        fs::create_directories(dir.path() / "scene");
        dir.write("down.ies", kDownlight);
        dir.write("scene/down.ies", kDownlight);
        const fs::path path = dir.write("scene/scene.toml", c.toml);
        try {
            (void)read_scene_file(path);
            ADD_FAILURE() << "no error for:\n" << c.toml;
        } catch (const ImportError& e) {
            EXPECT_EQ(e.line(), c.line) << e.what() << "\nfor:\n" << c.toml;
            EXPECT_NE(std::string(e.what()).find(c.needle), std::string::npos) << e.what();
        }
    }
}

TEST(SceneLuminaire, OutsideFileWithPermissionAndMalformedFileNamed) {
    const TempDir dir;
    fs::create_directories(dir.path() / "scene");
    dir.write("down.ies", kDownlight);
    const fs::path path = dir.write(
        "scene/scene.toml", "[[luminaire]]\nfile = \"../down.ies\"\nposition = [0, 0, 3]\n");
    EXPECT_EQ(read_scene_file(path, true).luminaires.size(), 1U);

    // A malformed photometric file: its own name, line and field
    std::string bad = kDownlight;
    bad.replace(bad.find("500 "), 3, "nan");
    dir.write("scene/bad.ies", bad);
    const fs::path bad_scene =
        dir.write("scene/bad.toml", "[[luminaire]]\nfile = \"bad.ies\"\nposition = [0, 0, 3]\n");
    try {
        (void)read_scene_file(bad_scene);
        ADD_FAILURE() << "bad.ies accepted";
    } catch (const ImportError& e) {
        EXPECT_EQ(e.file(), (dir.path() / "scene/bad.ies").string());
        EXPECT_EQ(e.line(), 8U);
        EXPECT_NE(std::string(e.what()).find("candela at horizontal 0, vertical 60"),
                  std::string::npos)
            << e.what();
    }
}

TEST(SceneLuminaire, NamesStayUniqueInTheScene) {
    const TempDir dir;
    dir.write("down.ies", kDownlight);
    const fs::path path = dir.write(
        "scene.toml", "[[luminaire]]\nfile = \"down.ies\"\nname = \"L\"\nposition = [0, 0, 3]\n");
    const SceneFile f = read_scene_file(path);
    visdb::Scene scene;
    apply_scene_file(f, scene);
    try {
        apply_scene_file(f, scene);
        ADD_FAILURE() << "the same luminaire twice";
    } catch (const ImportError& e) {
        EXPECT_EQ(e.line(), 1U);
        EXPECT_NE(std::string(e.what()).find("luminaire 'L' already exists"), std::string::npos);
    }
    EXPECT_EQ(scene.luminaires.size(), 1U);
}

}  // namespace
}  // namespace abrad::convert
