// [[luminaire]] through the command line: the import reports each luminaire's flux against its
// lamps and stores it (abrad info lists it), the bake lights with it (a scene lit only by
// luminaires), a malformed photometric file fails the import (exit 2) naming its line and
// field with the database unchanged, the furnished room sample lit by downlights from an
// IES file imports, bakes, exports and probes to the closed form, and light scenes mix the
// bake's light groups without re-baking.

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <glm/geometric.hpp>
#include <numbers>
#include <optional>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "../radiosity/mesh_checks.h"
#include "abrad/visdb/store.h"
#include "bake_readers.h"
#include "obj_text.h"
#include "run_abrad.h"
#include "temp_dir.h"

namespace {

namespace fs = std::filesystem;

using abrad::testing::file_bytes;
using abrad::testing::probe_rows;
using abrad::testing::read_ply;
using abrad::testing::run_abrad;
using abrad::testing::TempDir;

// A 4 x 4 m floor facing up
const char* const kFloor = "v 0 0 0\nv 4 0 0\nv 4 4 0\nv 0 4 0\nf 1 2 3 4\n";

// A uniform lower hemisphere of 100 cd (2π·100 = 628.3 lm), lamps 1000 lm
const char* const kIes =
    "IESNA:LM-63-2002\nTILT=NONE\n1 1000 1 3 1 1 2 0 0 0\n1 1 10\n0 45 90\n0\n100 100 100\n";

// Two light groups over the floor, one lamp each (kIes beside the scene file)
const char* const kOffice =
    "[[luminaire]]\nfile = \"lamp.ies\"\nposition = [1, 1, 2]\ngroup = \"office\"\n";
const char* const kCorridor =
    "[[luminaire]]\nfile = \"lamp.ies\"\nposition = [3, 2.5, 2.5]\ngroup = \"corridor\"\n";

// Writes the floor, its lamp and a scene file of both light groups (kOffice, kCorridor) into
// dir/model; returns the floor's and the scene file's paths.
std::pair<fs::path, fs::path> write_two_groups(const TempDir& dir) {
    fs::create_directories(dir / "model");
    const fs::path floor = dir.write("model/floor.obj", kFloor);
    dir.write("model/lamp.ies", kIes);
    return {floor, dir.write("model/both.toml", std::string(kOffice) + "\n" + kCorridor)};
}

TEST(LuminaireCli, ImportReportsStoresAndBakes) {
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

    // The floor has no emitting surface: the luminaire alone lights the bake
    const auto bake = run_abrad("bake --db " + db + " --bounces 0");
    EXPECT_EQ(bake.status, 0) << bake.output;
    const auto baked = run_abrad("info --db " + db);
    EXPECT_NE(baked.output.find("bake-1"), std::string::npos) << baked.output;
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

using abrad::testing::obj_box;

// Luminaires placed by the model (two lamp boxes of one OBJ group, mounted at their
// undersides, their geometry removed) bake exactly as the same luminaires given by position
// with the lamp boxes excluded: the same vertices with the same exact irradiance, through the
// discontinuity mesh of a box's shadow. A glob matching nothing fails the import (exit 2) at its
// line and key.
TEST(LuminaireCli, PlacedByTheModelBakesAsGivenByPositions) {
    const TempDir dir("luminaire");
    fs::create_directories(dir / "model");
    const fs::path model =
        dir.write("model/room.obj", std::string("g floor\n") + kFloor + "g box\n" +
                                        obj_box({1.5, 1.5, 0}, {2.5, 2.5, 0.5}, 4) + "g lamp\n" +
                                        obj_box({1.25, 1.75, 2.75}, {1.75, 2.25, 3.0}, 12) +
                                        obj_box({2.25, 1.75, 2.75}, {2.75, 2.25, 3.0}, 20));
    dir.write("model/lamp.ies", kIes);
    const fs::path placed = dir.write("model/placed.toml",
                                      "[[luminaire]]\nfile = \"lamp.ies\"\nname = \"L\"\n"
                                      "object = \"lamp\"\nmounting = \"surface\"\n");
    const fs::path given = dir.write("model/given.toml",
                                     "[[exclude]]\nobject = \"lamp\"\n\n"
                                     "[[luminaire]]\nfile = \"lamp.ies\"\nname = \"L\"\n"
                                     "position = [1.5, 2, 2.75]\ncount = 2\nstep = [1, 0, 0]\n");
    std::vector<abrad::visdb::BakeMesh> meshes;
    for (const fs::path& scene : {placed, given}) {
        const std::string db = dir.file(scene.stem().string() + ".visdb");
        const auto imported =
            run_abrad("import " + model.string() + " --scene " + scene.string() + " --db " + db);
        ASSERT_EQ(imported.status, 0) << imported.output;
        const auto info = run_abrad("info --db " + db);
        EXPECT_NE(info.output.find("luminaires (2):\n  L 1: "), std::string::npos) << info.output;
        const auto baked = run_abrad("bake --db " + db + " --bounces 0");
        ASSERT_EQ(baked.status, 0) << baked.output;
        const fs::path ply = dir / (scene.stem().string() + ".ply");
        ASSERT_EQ(run_abrad("export --db " + db + " --output " + ply.string()).status, 0);
        meshes.push_back(read_ply(file_bytes(ply)));
    }
    const abrad::visdb::BakeMesh& a = meshes[0];
    const abrad::visdb::BakeMesh& b = meshes[1];
    ASSERT_FALSE(a.positions.empty());
    ASSERT_EQ(a.positions.size(), b.positions.size());
    ASSERT_EQ(a.triangles.size(), b.triangles.size());
    std::size_t lit = 0;
    for (std::size_t v = 0; v < a.positions.size(); ++v) {
        EXPECT_EQ(a.positions[v], b.positions[v]) << v;
        EXPECT_EQ(a.irradiance[v], b.irradiance[v]) << v;
        if (a.irradiance[v].y > 0.0F) ++lit;
    }
    EXPECT_GT(lit, a.positions.size() / 2);

    // A glob matching nothing: exit 2 naming the file, line and key; nothing stored
    const fs::path wrong = dir.write("model/wrong.toml",
                                     "[[luminaire]]\nfile = \"lamp.ies\"\nlayer = \"*\"\n"
                                     "object = \"lamps\"\n");
    const auto r = run_abrad("import " + model.string() + " --scene " + wrong.string() + " --db " +
                             dir.file("wrong.visdb"));
    EXPECT_EQ(r.status, 2) << r.output;
    EXPECT_NE(
        r.output.find(wrong.string() + ":4: 'object' in [[luminaire]] matches no surface (object "
                                       "'lamps', layer '*')"),
        std::string::npos)
        << r.output;
    EXPECT_FALSE(fs::exists(dir / "wrong.visdb"));
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

// The web of an IES file with one horizontal angle (a rotationally symmetric type C web):
// its vertical angles and candela, read from the file's last three lines.
struct SymmetricWeb {
    std::vector<double> gamma, cd;
    /// Linear in γ (degrees), 0 past the last angle.
    double at(double g) const {
        for (std::size_t i = 0; i + 1 < gamma.size(); ++i)
            if (g <= gamma[i + 1])
                return cd[i] + (cd[i + 1] - cd[i]) * (g - gamma[i]) / (gamma[i + 1] - gamma[i]);
        return 0.0;
    }
};

SymmetricWeb read_symmetric_ies(const std::string& text) {
    std::vector<std::string> lines;
    std::istringstream in(text);
    for (std::string l; std::getline(in, l);)
        if (!l.empty()) lines.push_back(l);
    auto numbers = [](const std::string& l) {
        std::vector<double> v;
        std::istringstream f(l);
        for (double x; f >> x;) v.push_back(x);
        return v;
    };
    return {numbers(lines.at(lines.size() - 3)), numbers(lines.at(lines.size() - 1))};
}

// The furnished room sample lit by three downlights (samples/furnished_room/downlights.toml,
// downlight.ies) instead of its panels: import, a direct-light bake whose exported vertices
// carry the closed form I(γ)·cos θ/d², the default bake (interreflection: the probe gets more
// than the direct light), and probes against the closed form.
// Light scenes: two groups of luminaires over the floor; the bake stores both, and
// --scene-mix with the corridor off gives what a bake of the office alone gives (probe and
// export), the bake's own mix the bake itself, and an unknown group exit 2.
TEST(LuminaireCli, SceneMixWithoutReBaking) {
    const TempDir dir("luminaire");
    const auto [floor, both] = write_two_groups(dir);
    const fs::path alone = dir.write("model/office.toml", kOffice);
    const std::string db = dir.file("both.visdb"), db_office = dir.file("office.visdb");
    for (const auto& [scene, file] : {std::pair{both, db}, std::pair{alone, db_office}}) {
        ASSERT_EQ(
            run_abrad("import " + floor.string() + " --scene " + scene.string() + " --db " + file)
                .status,
            0);
        const auto baked = run_abrad("bake --db " + file + " --bounces 0 --dm off --name b");
        ASSERT_EQ(baked.status, 0) << baked.output;
    }
    const auto info = run_abrad("info --db " + db);
    EXPECT_NE(info.output.find("light_groups=office,corridor"), std::string::npos) << info.output;
    EXPECT_NE(info.output.find(", group corridor"), std::string::npos) << info.output;

    // Probe: the corridor off is the office alone
    const fs::path csv = dir.write("points.csv", "0.5,0.5,0,0,0,1\n2,2,0,0,0,1\n3.5,3,0,0,0,1\n");
    const auto mixed =
        run_abrad("probe --db " + db + " --points " + csv.string() + " --scene-mix corridor=0");
    const auto office_only = run_abrad("probe --db " + db_office + " --points " + csv.string());
    ASSERT_EQ(mixed.status, 0) << mixed.output;
    ASSERT_EQ(office_only.status, 0) << office_only.output;
    const std::vector<double> a = probe_rows(mixed.output), b = probe_rows(office_only.output);
    ASSERT_EQ(a.size(), 3u);
    ASSERT_EQ(b.size(), 3u);
    for (std::size_t i = 0; i < a.size(); ++i) EXPECT_NEAR(a[i], b[i], 1e-6 * b[i]) << i;

    // Export: every vertex as the office's own bake; the bake's own mix is the bake, byte for
    // byte
    const fs::path off = dir / "off.ply", ref = dir / "ref.ply";
    const fs::path own = dir / "own.ply", plain = dir / "plain.ply";
    ASSERT_EQ(run_abrad("export --db " + db + " --output " + off.string() +
                        " --scene-mix \"office=1, corridor=0\"")
                  .status,
              0);
    ASSERT_EQ(run_abrad("export --db " + db_office + " --output " + ref.string()).status, 0);
    const abrad::visdb::BakeMesh m = read_ply(file_bytes(off)), r = read_ply(file_bytes(ref));
    ASSERT_EQ(m.positions.size(), r.positions.size());
    ASSERT_FALSE(m.positions.empty());
    for (std::size_t v = 0; v < m.positions.size(); ++v)
        EXPECT_NEAR(m.irradiance[v].y, r.irradiance[v].y, 1e-6 * r.irradiance[v].y) << v;
    ASSERT_EQ(run_abrad("export --db " + db + " --output " + own.string() +
                        " --scene-mix office=1,corridor=1")
                  .status,
              0);
    ASSERT_EQ(run_abrad("export --db " + db + " --output " + plain.string()).status, 0);
    EXPECT_EQ(file_bytes(own), file_bytes(plain));

    // Mistakes: exit 2 naming the option and what is wrong
    const auto unknown = run_abrad("render --db " + db + " --output " + (dir / "x.png").string() +
                                   " --scene-mix kitchen=0.5");
    EXPECT_EQ(unknown.status, 2) << unknown.output;
    EXPECT_NE(unknown.output.find("--scene-mix 'kitchen=0.5': bake 'b' has no light group "
                                  "'kitchen' (its groups: 'office', 'corridor')"),
              std::string::npos)
        << unknown.output;
    const auto malformed =
        run_abrad("probe --db " + db + " --points " + csv.string() + " --scene-mix office=-1");
    EXPECT_EQ(malformed.status, 2) << malformed.output;
    EXPECT_NE(malformed.output.find("the factor must be a finite number >= 0"), std::string::npos)
        << malformed.output;
}

// A bake with light groups and discontinuity meshing (the default, coarsened): every group
// keeps a shade for each vertex of the coarsened mesh, and the groups add up to the bake.
TEST(LuminaireCli, LightGroupsFollowTheCoarsenedMesh) {
    const TempDir dir("luminaire");
    const auto [floor, scene] = write_two_groups(dir);
    const std::string db = dir.file("both.visdb");
    ASSERT_EQ(
        run_abrad("import " + floor.string() + " --scene " + scene.string() + " --db " + db).status,
        0);
    const auto baked = run_abrad("bake --db " + db + " --bounces 0");
    ASSERT_EQ(baked.status, 0) << baked.output;
    auto store = abrad::visdb::Store::open(db, abrad::visdb::OpenMode::ReadOnly);
    const abrad::visdb::Bake b = store.load_bake();
    ASSERT_TRUE(b.statistics.dm.has_value());
    EXPECT_GT(b.statistics.dm->triangles_meshed, b.mesh.triangles.size());
    ASSERT_EQ(b.light_groups.size(), 2u);
    for (const auto& g : b.light_groups) {
        ASSERT_EQ(g.irradiance.size(), b.mesh.positions.size()) << g.name;
        ASSERT_EQ(g.radiosity.size(), b.mesh.positions.size()) << g.name;
    }
    for (std::size_t v = 0; v < b.mesh.positions.size(); ++v) {
        const glm::vec3 sum = b.light_groups[0].irradiance[v] + b.light_groups[1].irradiance[v];
        EXPECT_NEAR(sum.y, b.mesh.irradiance[v].y, 1e-5 * b.mesh.irradiance[v].y) << v;
        // Each lamp's own light at this vertex: the groups are not shuffled
        const glm::dvec3 x = b.mesh.positions[v];
        for (const auto& [group, lamp] :
             {std::pair{0, glm::dvec3(1, 1, 2)}, std::pair{1, glm::dvec3(3, 2.5, 2.5)}}) {
            const double d = glm::length(lamp - x), cos_t = lamp.z / d;
            const double e = 100.0 * cos_t / (d * d);  // 100 cd in the lower hemisphere
            EXPECT_NEAR(b.light_groups[group].irradiance[v].y, e, 1e-4 * e) << v;
        }
    }
}

TEST(LuminaireCli, RoomLitByDownlightsImportsBakesExportsAndProbes) {
    const TempDir dir("luminaire");
    const std::string samples = ABRAD_SAMPLES;
    const std::string db = dir.file("room.visdb");
    const auto imported =
        run_abrad("import " + samples + "/furnished_room/furnished_room.obj --scene " + samples +
                  "/furnished_room/downlights.toml --db " + db);
    ASSERT_EQ(imported.status, 0) << imported.output;
    EXPECT_NE(imported.output.find("luminaire 'downlight"), std::string::npos) << imported.output;
    const SymmetricWeb web =
        read_symmetric_ies(file_bytes(samples + "/furnished_room/downlight.ies"));
    ASSERT_EQ(web.gamma.size(), web.cd.size());

    // The closed form at a point facing up, from the three downlights (maintenance factor 0.8)
    const std::vector<glm::dvec3> lights = {{1.5, 2.5, 2.99}, {3.0, 2.5, 2.99}, {4.5, 2.5, 2.99}};
    auto direct = [&](const glm::dvec3& x) {
        double e = 0.0;
        for (const glm::dvec3& l : lights) {
            const double d = glm::length(l - x), cos_t = (l.z - x.z) / d;
            e += 0.8 * web.at(std::acos(cos_t) * 180.0 / std::numbers::pi) * cos_t / (d * d);
        }
        return e;
    };
    // The table top's centre and a floor point clear of the furniture's shadows
    const std::vector<glm::dvec3> points = {{3.0, 2.5, 0.75}, {5.0, 1.0, 0.0}};
    const fs::path csv = dir.write("points.csv", "x,y,z,nx,ny,nz\n3,2.5,0.75,0,0,1\n5,1,0,0,0,1\n");

    // Direct light only: the probe and every exported vertex of the table top, exact
    ASSERT_EQ(run_abrad("bake --db " + db + " --bounces 0 --name direct").status, 0);
    const auto probed = run_abrad("probe --db " + db + " --bake direct --points " + csv.string());
    ASSERT_EQ(probed.status, 0) << probed.output;
    const std::vector<double> probe = probe_rows(probed.output);
    ASSERT_EQ(probe.size(), points.size()) << probed.output;
    for (std::size_t i = 0; i < points.size(); ++i)
        EXPECT_NEAR(probe[i], direct(points[i]), 1e-6 * direct(points[i])) << i;
    const fs::path ply = dir / "direct.ply";
    ASSERT_EQ(run_abrad("export --db " + db + " --bake direct --output " + ply.string()).status, 0);
    const abrad::visdb::BakeMesh mesh = read_ply(file_bytes(ply));
    std::size_t on_table = 0;
    for (std::size_t v = 0; v < mesh.positions.size(); ++v) {
        const glm::dvec3 x = mesh.positions[v];
        if (std::abs(x.z - 0.75) > 1e-9 || mesh.normals[v].z < 0.99 || x.x < 2.2 || x.x > 3.8 ||
            x.y < 2.1 || x.y > 2.9)
            continue;
        ++on_table;
        EXPECT_NEAR(mesh.irradiance[v].y, direct(x), 1e-5 * direct(x)) << x.x << " " << x.y;
    }
    EXPECT_GE(on_table, 4u);
    const std::optional<double> centre = abrad::testing::gouraud_at(mesh, points[0], {0, 0, 1});
    ASSERT_TRUE(centre.has_value());
    EXPECT_NEAR(*centre, direct(points[0]), 0.02 * direct(points[0]));

    // The default bake: the room's reflections add to the direct light
    const auto full = run_abrad("bake --db " + db + " --name full");
    ASSERT_EQ(full.status, 0) << full.output;
    EXPECT_NE(full.output.find(" 0 light triangles, 3 luminaires, "), std::string::npos)
        << full.output;
    const auto with_indirect =
        run_abrad("probe --db " + db + " --bake full --points " + csv.string());
    ASSERT_EQ(with_indirect.status, 0) << with_indirect.output;
    const std::vector<double> total = probe_rows(with_indirect.output);
    ASSERT_EQ(total.size(), points.size());
    for (std::size_t i = 0; i < points.size(); ++i) {
        EXPECT_GT(total[i], 1.05 * direct(points[i])) << i;
        EXPECT_LT(total[i], 2.0 * direct(points[i])) << i;
    }
}

}  // namespace
