// Import sanity through the command line: import and info print the bounding box in metres and
// the floor area, and warn (exit 0, the model stored) with a suggested fix when the size is
// implausible for a building (a centimetre OBJ read as metres), when the up axis looks wrong
// (a Y-up room read Z up: its ceiling light faces sideways), or when a light is buried.

#include <gtest/gtest.h>

#include <glm/vec3.hpp>
#include <sstream>
#include <string>

#include "run_abrad.h"
#include "temp_dir.h"

namespace {

using abrad::testing::run_abrad;
using abrad::testing::TempDir;

struct Room {
    glm::dvec3 size{6.0, 4.0, 3.0};  ///< metres, abrad's frame (Z up)
    double scale = 1.0;              ///< file units per metre (100: centimetres)
    bool y_up = false;               ///< write the file Y up: (X, Y, Z) as (X, Z, -Y)
    double light_z = 2.99;           ///< height of the 0.6 m ceiling panel facing down
};

// An OBJ of a closed room (faces inward) with a ceiling panel light.
std::string room_obj(const Room& r) {
    std::ostringstream o;
    o.precision(17);
    o << "mtllib room.mtl\n";
    const auto v = [&](double x, double y, double z) {
        const glm::dvec3 p = r.y_up ? glm::dvec3(x, z, -y) : glm::dvec3(x, y, z);
        o << "v " << p.x * r.scale << " " << p.y * r.scale << " " << p.z * r.scale << "\n";
    };
    const double X = r.size.x, Y = r.size.y, Z = r.size.z;
    // floor, ceiling, x = 0, x = X, y = 0, y = Y: each counter-clockwise seen from inside
    v(0, 0, 0), v(X, 0, 0), v(X, Y, 0), v(0, Y, 0);
    v(0, 0, Z), v(0, Y, Z), v(X, Y, Z), v(X, 0, Z);
    v(0, 0, 0), v(0, Y, 0), v(0, Y, Z), v(0, 0, Z);
    v(X, 0, 0), v(X, 0, Z), v(X, Y, Z), v(X, Y, 0);
    v(0, 0, 0), v(0, 0, Z), v(X, 0, Z), v(X, 0, 0);
    v(0, Y, 0), v(X, Y, 0), v(X, Y, Z), v(0, Y, Z);
    const double cx = X / 2, cy = Y / 2, h = r.light_z;
    v(cx - 0.3, cy - 0.3, h), v(cx - 0.3, cy + 0.3, h), v(cx + 0.3, cy + 0.3, h),
        v(cx + 0.3, cy - 0.3, h);
    o << "o room\nusemtl plaster\n";
    for (int f = 0; f < 6; ++f)
        o << "f " << 4 * f + 1 << " " << 4 * f + 2 << " " << 4 * f + 3 << " " << 4 * f + 4 << "\n";
    o << "o panel\nusemtl lamp\nf 25 26 27 28\n";
    return o.str();
}

struct Imported {
    int status;
    std::string import, info;
};

Imported import_room(const TempDir& dir, const Room& room, const std::string& options) {
    (void)dir.write("room.mtl",
                    "newmtl plaster\nKd 0.7 0.7 0.7\nnewmtl lamp\nKd 0.5 0.5 0.5\n"
                    "Ke 100 100 100\n");
    const std::string obj = dir.write("room.obj", room_obj(room)).string();
    const std::string db = (dir / "room.visdb").string();
    const auto imported = run_abrad("import " + obj + " --db " + db + " " + options);
    const auto info = run_abrad("info --db " + db);
    EXPECT_EQ(info.status, 0) << info.output;
    return {imported.status, imported.output, info.output};
}

constexpr const char* kWarning = "warning:";

// Imported with `options`, the import warns with `text`.
void expect_warned(const Room& room, const std::string& options, const std::string& text) {
    const TempDir dir("import_check");
    const Imported r = import_room(dir, room, options);
    ASSERT_EQ(r.status, 0) << r.import;
    EXPECT_NE(r.import.find(text), std::string::npos) << r.import;
}

// Imported with the fix, the model has `size` and no warning.
void expect_quiet_with(const Room& room, const std::string& fix, const std::string& size) {
    const TempDir dir("import_check");
    const Imported r = import_room(dir, room, fix);
    ASSERT_EQ(r.status, 0) << r.import;
    EXPECT_NE(r.import.find(size), std::string::npos) << r.import;
    EXPECT_EQ(r.import.find(kWarning), std::string::npos) << r.import;
}

TEST(ImportCheck, ARoomInMetresPrintsItsBoxAndFloorAreaWithoutWarnings) {
    const TempDir dir("import_check");
    const Imported r = import_room(dir, {}, "");
    ASSERT_EQ(r.status, 0) << r.import;
    for (const std::string& out : {r.import, r.info}) {
        EXPECT_NE(out.find("bounding box: (0, 0, 0) .. (6, 4, 3) m, size 6 x 4 x 3 m"),
                  std::string::npos)
            << out;
        // The floor (24 m2) faces up; of 24 + 24 + 2 (18 + 12) + 0.36 m2
        EXPECT_NE(out.find("floor area (faces within 30 degrees of facing up): 24 m2 of 108.4 m2"),
                  std::string::npos)
            << out;
        EXPECT_EQ(out.find(kWarning), std::string::npos) << out;
    }
}

// A 30 x 20 x 6 m hall drawn in centimetres read as metres: 3 km. The fix: --unit cm.
TEST(ImportCheck, ACentimetreModelReadAsMetresIsWarnedWithTheUnit) {
    const TempDir dir("import_check");
    const Room hall{.size = {30, 20, 6}, .scale = 100.0, .light_z = 5.99};
    const Imported r = import_room(dir, hall, "");
    ASSERT_EQ(r.status, 0) << r.import;
    const std::string expected =
        "abrad import: warning: the model's largest side is 3000 m (read in m): over 2 km, "
        "implausible for a building; if the file is in cm, import it with --unit cm (30 m)";
    EXPECT_NE(r.import.find(expected), std::string::npos) << r.import;
    EXPECT_NE(r.info.find("abrad info: warning: the model's largest side is 3000 m"),
              std::string::npos)
        << r.info;
    expect_quiet_with(hall, "--unit cm", "size 30 x 20 x 6 m");
}

// A 16 x 10 x 3 m house drawn in centimetres read as metres is 1.6 km, under the 2 km of the
// size check; its storey height (300 m, floor to ceiling) gives it away. The fix: --unit cm.
TEST(ImportCheck, ACentimetreHouseUnder2KmIsWarnedByItsStoreyHeight) {
    const Room house{.size = {16, 10, 3}, .scale = 100.0, .light_z = 2.99};
    expect_warned(house, "",
                  "abrad import: warning: the typical floor-to-ceiling height is 300 m (read in "
                  "m): over 50 m, implausible for a building; if the file is in cm, import it "
                  "with --unit cm (3 m)");
    expect_quiet_with(house, "--unit cm",
                      "size 16 x 10 x 3 m\nfloor area (faces within 30 degrees of facing up): "
                      "160 m2 of 476.4 m2\nstorey height (median, up-facing faces to the face "
                      "above): 3 m\n");
}

// A 13 mm model (a Collada file in metres declared as millimetres, say): under 0.5 m.
TEST(ImportCheck, ATinyModelIsWarned) {
    expect_warned({.size = {6, 4, 3}, .light_z = 2.99}, "--unit mm",
                  "abrad import: warning: the model's largest side is 0.006 m (read in mm): under "
                  "0.5 m, implausible for a building; if the file is in m, import it with --unit m "
                  "(6 m)");
}

// The room written Y up and read Z up: its ceiling light faces sideways. --up y fixes it.
TEST(ImportCheck, AYUpModelReadZUpIsWarnedWithTheUpAxis) {
    expect_warned({.y_up = true}, "",
                  "abrad import: warning: every light faces sideways (ceiling lights face down, "
                  "-Z): the up axis may be wrong; the file was read z up; try importing with --up "
                  "y");
    expect_quiet_with({.y_up = true}, "--up y", "size 6 x 4 x 3 m");
}

// A panel 5 mm above the ceiling, facing down into it: its light stops in the slab.
TEST(ImportCheck, ABuriedLightIsWarned) {
    const TempDir dir("import_check");
    const Imported r = import_room(dir, {.light_z = 3.005}, "");
    ASSERT_EQ(r.status, 0) << r.import;
    EXPECT_NE(r.import.find("abrad import: warning: light 'panel"), std::string::npos) << r.import;
    EXPECT_NE(r.import.find("of its emission is stopped within 1 cm"), std::string::npos)
        << r.import;
}

}  // namespace
