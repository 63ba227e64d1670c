// Tests of the scene file: parsing with every error at its line, and its rules, emitters,
// exclusions, cameras and grids applied to hand-built scenes with known areas.

#include "abrad/convert/scene_file.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <glm/geometric.hpp>
#include <string>
#include <utility>
#include <vector>

#include "temp_dir.h"

namespace abrad::convert {
namespace {

namespace fs = std::filesystem;

using ::abrad::testing::TempDir;

/// Writes `toml` to a temporary scene.toml and reads it.
SceneFile parse(const std::string& toml) {
    const TempDir dir;
    return read_scene_file(dir.write("scene.toml", toml));
}

/// A horizontal quad [x0, x1] x [y0, y1] at height z, front facing +Z (area (x1-x0)(y1-y0)).
visdb::Surface quad(const std::string& name, const std::string& layer, std::uint32_t material,
                    double x0, double y0, double x1, double y1, double z = 0.0) {
    visdb::Surface s;
    s.name = name;
    s.layer = layer;
    s.material = material;
    s.mesh.positions = {{x0, y0, z}, {x1, y0, z}, {x1, y1, z}, {x0, y1, z}};
    s.mesh.triangles = {{0, 1, 2}, {0, 2, 3}};
    return s;
}

visdb::Material material(const std::string& name, double rho,
                         visdb::Rgb emittance = visdb::Rgb(0.0)) {
    visdb::Material m;
    m.name = name;
    m.reflectance = visdb::Rgb(rho);
    m.emittance = emittance;
    return m;
}

/// A room: floor and two walls in "Concrete", a ceiling in "Plaster", a space volume (layer
/// IfcSpace) in "Air", one source.
visdb::Scene room() {
    visdb::Scene scene;
    scene.sources.push_back({"room.ifc", "ifc", "0123456789abcdef", 100, "m", "z", "", ""});
    scene.materials = {material("Concrete", 0.5), material("Plaster", 0.7), material("Air", 0.0)};
    scene.surfaces = {quad("Floor-1", "IfcSlab", 0, 0.0, 0.0, 6.0, 4.0, 0.1),
                      quad("WAND-North", "IfcWall", 0, 0.0, 0.0, 6.0, 3.0),
                      quad("Wand-South", "IfcWall", 0, 0.0, 0.0, 6.0, 3.0),
                      quad("Ceiling", "IfcCovering", 1, 0.0, 0.0, 6.0, 4.0, 3.0),
                      quad("Space 1", "IfcSpace", 2, -1.0, -1.0, 7.0, 5.0, -0.5)};
    return scene;
}

const visdb::Surface* find_surface(const visdb::Scene& scene, const std::string& name) {
    for (const auto& s : scene.surfaces) {
        if (s.name == name) return &s;
    }
    return nullptr;
}

const visdb::Material& material_of(const visdb::Scene& scene, const std::string& surface) {
    const visdb::Surface* s = find_surface(scene, surface);
    EXPECT_NE(s, nullptr) << surface;
    EXPECT_LT(s->material, scene.materials.size());
    return scene.materials.at(s->material);
}

bool has_note(const SceneFileReport& report, const std::string& needle) {
    for (const auto& n : report.notes) {
        if (n.find(needle) != std::string::npos) return true;
    }
    return false;
}

double area(const visdb::TriangleMesh& mesh) {
    double a = 0.0;
    for (const auto& t : mesh.triangles) {
        a += 0.5 * glm::length(glm::cross(mesh.positions[t.y] - mesh.positions[t.x],
                                          mesh.positions[t.z] - mesh.positions[t.x]));
    }
    return a;
}

void expect_rgb(const visdb::Rgb& expected, const visdb::Rgb& actual, double tol = 1e-9) {
    EXPECT_NEAR(expected.x, actual.x, tol);
    EXPECT_NEAR(expected.y, actual.y, tol);
    EXPECT_NEAR(expected.z, actual.z, tol);
}

TEST(SceneFile, ParsesFullExample) {
    const SceneFile f = parse(R"(# office
unit = "mm"
up = "Y"
origin_shift = [2500000.0, 1200000, 0.0]
weld_tolerance = 1e-6

[[rule]]
object = "Wand*"
layer = "IfcWall"
material = "Concrete*"
reflectance = [0.6, 0.5, 0.4]
opacity = 1

[[emitter]]
object = "Lamp*"
flux = 1200.0
color = [1.0, 1.0, 1.0]

[[rule]]
layer = "IfcWindow"
opacity = 0.2
emittance = 5

[[emitter]]
name = "panel-1"
center = [3.0, 2.5, 2.99]
size = [1.2, 0.3]
normal = [0, 0, -2]
flux = 3000.0

[[camera]]
name = "entrance"
position = [1, 1, 1.6]
look_at = [5, 4, 1.2]
fov = 45.0

[[exclude]]
layer = "IfcSpace"

[[grid]]
name = "office work plane"
over = "Floor*"
spacing = 0.25
margin = 0.5

[[grid]]
name = "desk"
min = [1, 2]
max = [3.5, 4]
height = 0.75
)");
    ASSERT_TRUE(f.unit.has_value());
    EXPECT_EQ(*f.unit, "mm");
    EXPECT_EQ(f.up.value_or('?'), 'y');
    ASSERT_TRUE(f.origin_shift.has_value());
    EXPECT_EQ(*f.origin_shift, glm::dvec3(2500000.0, 1200000.0, 0.0));
    EXPECT_EQ(f.weld_tolerance.value_or(-1.0), 1e-6);
    EXPECT_FALSE(f.photometric.has_value());
    EXPECT_TRUE(f.uses_flux());
    EXPECT_TRUE(f.is_photometric());
    EXPECT_EQ(f.checksum.size(), 16u);
    EXPECT_GT(f.size_bytes, 100u);

    // Rules and object emitters interleaved in file order
    ASSERT_EQ(f.rules.size(), 3u);
    EXPECT_EQ(f.rules[0].line, 7u);
    EXPECT_FALSE(f.rules[0].is_emitter);
    EXPECT_EQ(f.rules[0].match.object.value_or(""), "Wand*");
    EXPECT_EQ(f.rules[0].match.layer.value_or(""), "IfcWall");
    EXPECT_EQ(f.rules[0].match.material.value_or(""), "Concrete*");
    expect_rgb({0.6, 0.5, 0.4}, f.rules[0].reflectance.value_or(visdb::Rgb(-1)));
    EXPECT_EQ(f.rules[0].opacity.value_or(-1.0), 1.0);
    EXPECT_EQ(f.rules[1].line, 14u);
    EXPECT_TRUE(f.rules[1].is_emitter);
    EXPECT_EQ(f.rules[1].flux.value_or(-1.0), 1200.0);
    expect_rgb({1.0, 1.0, 1.0}, f.rules[1].color);
    EXPECT_EQ(f.rules[2].line, 19u);
    expect_rgb({5.0, 5.0, 5.0}, f.rules[2].emittance.value_or(visdb::Rgb(-1)));

    ASSERT_EQ(f.rectangles.size(), 1u);
    const SceneRectangle& r = f.rectangles[0];
    EXPECT_EQ(r.line, 24u);
    EXPECT_EQ(r.name, "panel-1");
    EXPECT_EQ(r.center, glm::dvec3(3.0, 2.5, 2.99));
    EXPECT_EQ(r.size, glm::dvec2(1.2, 0.3));
    EXPECT_EQ(r.normal, glm::dvec3(0.0, 0.0, -1.0));  // normalised
    EXPECT_EQ(r.axis, glm::dvec3(1.0, 0.0, 0.0));     // world X by default
    EXPECT_NEAR(r.exitance().y, 3000.0 / 0.36, 1e-9);

    ASSERT_EQ(f.cameras.size(), 1u);
    EXPECT_EQ(f.cameras[0].line, 31u);
    EXPECT_EQ(f.cameras[0].camera.name, "entrance");
    EXPECT_EQ(f.cameras[0].camera.position, glm::dvec3(1.0, 1.0, 1.6));
    EXPECT_EQ(f.cameras[0].camera.look_at, glm::dvec3(5.0, 4.0, 1.2));
    EXPECT_EQ(f.cameras[0].camera.up, glm::dvec3(0.0, 0.0, 1.0));
    EXPECT_EQ(f.cameras[0].camera.fov_y_deg, 45.0);

    ASSERT_EQ(f.excludes.size(), 1u);
    EXPECT_EQ(f.excludes[0].line, 37u);
    EXPECT_EQ(f.excludes[0].match.layer.value_or(""), "IfcSpace");
    EXPECT_FALSE(f.excludes[0].match.object.has_value());

    ASSERT_EQ(f.grids.size(), 2u);
    EXPECT_EQ(f.grids[0].line, 40u);
    EXPECT_EQ(f.grids[0].over.value_or(""), "Floor*");
    EXPECT_EQ(f.grids[0].height, 0.8);  // default above the floor
    EXPECT_EQ(f.grids[0].spacing, 0.25);
    EXPECT_EQ(f.grids[0].margin, 0.5);
    EXPECT_EQ(f.grids[1].name, "desk");
    EXPECT_FALSE(f.grids[1].over.has_value());
    EXPECT_EQ(f.grids[1].min, glm::dvec2(1.0, 2.0));
    EXPECT_EQ(f.grids[1].max, glm::dvec2(3.5, 4.0));
    EXPECT_EQ(f.grids[1].height, 0.75);
    EXPECT_EQ(f.grids[1].spacing, 0.5);  // default
    EXPECT_EQ(f.grids[1].margin, 0.0);

    const std::string text = f.to_string();
    EXPECT_NE(text.find("rule line 7: object 'Wand*', layer 'IfcWall'"), std::string::npos) << text;
    EXPECT_NE(text.find("rectangle 'panel-1'"), std::string::npos) << text;
}

TEST(SceneFile, EmptyFileSetsNothing) {
    const SceneFile f = parse("# nothing\n");
    EXPECT_FALSE(f.unit || f.up || f.origin_shift || f.weld_tolerance || f.photometric);
    EXPECT_TRUE(f.rules.empty() && f.rectangles.empty() && f.cameras.empty() &&
                f.excludes.empty() && f.grids.empty());
    EXPECT_FALSE(f.is_photometric());
}

struct ErrorCase {
    std::string toml;
    std::size_t line;
    std::vector<std::string> needles;  ///< substrings of what()
};

TEST(SceneFile, ErrorsNameLineAndKey) {
    const std::vector<ErrorCase> cases = {
        // Unknown keys at every level, with the allowed keys
        {"unit = \"m\"\ncolour = 1\n", 2, {"unknown key 'colour'", "allowed: unit, up,"}},
        {"[[rule]]\nobject = \"a\"\nreflectance = 0.5\nbogus = 3\n",
         4,
         {"unknown key 'bogus' in [[rule]]", "allowed: object, layer, material, reflectance"}},
        {"[[emitter]]\nobject = \"a\"\nflux = 1\nintensity = 3\n",
         4,
         {"unknown key 'intensity' in [[emitter]]", "center"}},
        {"[[camera]]\nname = \"c\"\nposition = [0,0,0]\nlook_at = [1,0,0]\nfocal = 3\n",
         5,
         {"unknown key 'focal' in [[camera]]", "allowed: name, position, look_at, up, fov"}},
        {"[[exclude]]\nlayer = \"x\"\nreason = \"y\"\n",
         3,
         {"unknown key 'reason' in [[exclude]]"}},
        {"\n[[grid]]\nname = \"g\"\nover = \"F\"\nstep = 1\n",
         5,
         {"unknown key 'step' in [[grid]]"}},
        // Out of range
        {"[[rule]]\nobject = \"a\"\nreflectance = 1.0\n",
         3,
         {"'reflectance' in [[rule]]", "[0, 0.999]"}},
        {"[[rule]]\nobject = \"a\"\nreflectance = [0.5, 1.2, 0.5]\n", 3, {"reflectance", "1.2"}},
        {"[[rule]]\nobject = \"a\"\n\nopacity = 1.5\n", 4, {"'opacity'", "[0, 1]"}},
        {"[[rule]]\nobject = \"a\"\nemittance = -1\n", 3, {"'emittance'", "[0, 1e10]"}},
        {"[[rule]]\nobject = \"a\"\nemittance = 1e300\n", 3, {"'emittance'", "[0, 1e10]"}},
        {"[[rule]]\nobject = \"a\"\nemittance = nan\n", 3, {"'emittance'", "got nan"}},
        {"[[rule]]\nobject = \"a\"\nflux = -5.0\n", 3, {"'flux'", ">= 0"}},
        {"[[grid]]\nname = \"g\"\nover = \"F\"\nspacing = -0.5\n", 4, {"'spacing'", "> 0"}},
        {"[[grid]]\nname = \"g\"\nover = \"F\"\nspacing = 0\n", 4, {"'spacing'", "> 0"}},
        {"[[emitter]]\nname = \"p\"\ncenter = [0,0,3]\nsize = [1,1]\nnormal = [0,0,0]\nflux = 1\n",
         5,
         {"'normal' in [[emitter]] must not be zero"}},
        {"[[emitter]]\nname = \"p\"\ncenter = [0,0,3]\nsize = [1,0]\nnormal = [0,0,1]\nflux = 1\n",
         4,
         {"'size'", "> 0"}},
        {"[[emitter]]\nname = \"p\"\ncenter = [0,0,3]\nsize = [1,1]\nnormal = [0,0,1]\n"
         "axis = [0,0,5]\nflux = 1\n",
         6,
         {"'axis'", "parallel to the normal"}},
        {"[[rule]]\nobject = \"a\"\nemittance = 3\nflux = 100\n",
         4,
         {"both 'emittance' and 'flux'"}},
        {"[[rule]]\nobject = \"a\"\ncolor = [1, 1, 1]\nemittance = 2\n",
         3,
         {"'color'", "needs 'flux'"}},
        {"[[rule]]\nobject = \"a\"\nflux = 3\ncolor = [0, 0, 0]\n", 4, {"'color'", "luminance"}},
        // Rules without condition or effect
        {"unit = \"m\"\n[[rule]]\nreflectance = 0.5\n",
         2,
         {"[[rule]] needs at least one condition"}},
        {"\n\n[[rule]]\nobject = \"a\"\n", 3, {"[[rule]] sets nothing"}},
        {"[[emitter]]\nobject = \"a\"\n", 1, {"[[emitter]] needs 'emittance' or 'flux'"}},
        {"[[emitter]]\nflux = 3\n", 1, {"[[emitter]] needs conditions"}},
        {"[[emitter]]\nname = \"p\"\ncenter = [0,0,3]\nnormal = [0,0,1]\nflux = 1\n",
         1,
         {"rectangle [[emitter]] needs 'size'"}},
        {"[[emitter]]\nname = \"p\"\nobject = \"x\"\nflux = 1\n", 3, {"'object' in [[emitter]]"}},
        {"[[exclude]]\n", 1, {"[[exclude]] needs at least one condition"}},
        // Top-level values
        {"\nunit = \"yd\"\n", 2, {"unknown unit 'yd'", "mm, cm, m, in or ft"}},
        {"up = \"x\"\n", 1, {"unknown up axis 'x'"}},
        {"weld_tolerance = -1e-6\n", 1, {"'weld_tolerance'", ">= 0"}},
        {"origin_shift = [1, 2]\n", 1, {"'origin_shift'", "3 numbers", "got 2 elements"}},
        {"photometric = \"yes\"\n", 1, {"'photometric' must be true or false, got a string"}},
        // Wrong types
        {"[[rule]]\nobject = \"a\"\nreflectance = \"high\"\n",
         3,
         {"'reflectance' in [[rule]]", "got a string"}},
        {"[[rule]]\nobject = 3\nopacity = 1\n",
         2,
         {"'object' in [[rule]] must be a string", "integer"}},
        {"[[rule]]\nobject = \"a\"\nopacity = [1, 2]\n",
         3,
         {"'opacity'", "must be a number", "an array"}},
        {"[[rule]]\nobject = \"a\"\nopacity = nan\n", 3, {"'opacity'", "finite"}},
        {"[rule]\nobject = \"a\"\nopacity = 1\n",
         1,
         {"'rule' must be an array of tables", "[[rule]]"}},
        // Grids
        {"[[grid]]\nname = \"g\"\nheight = 0.8\n", 1, {"grid 'g' needs 'over'", "'min' and 'max'"}},
        {"[[grid]]\nname = \"g\"\nmin = [0, 0]\nheight = 0.8\n", 1, {"grid 'g' needs 'over'"}},
        {"[[grid]]\nname = \"g\"\nmin = [0, 0]\nmax = [4, 0]\nheight = 0.8\n",
         4,
         {"'min' [0, 0] must be less than 'max' [4, 0]"}},
        {"[[grid]]\nname = \"g\"\nmin = [0, 0]\nmax = [4, 3]\n", 1, {"needs 'height'"}},
        {"[[grid]]\nname = \"g\"\nover = \"F\"\nmin = [0, 0]\n", 4, {"not both"}},
        {"[[grid]]\nname = \"g\"\nmin = [0, 0]\nmax = [4, 1]\nheight = 0\nmargin = 0.5\n",
         6,
         {"margin 0.5 leaves nothing"}},
        // Cameras
        {"[[camera]]\nname = \"c\"\nposition = [0,0,0]\nlook_at = [1,0,0]\n"
         "[[camera]]\nname = \"c\"\nposition = [0,0,0]\nlook_at = [1,0,0]\n",
         5,
         {"camera 'c' is already defined at line 1"}},
        {"[[camera]]\nname = \"c\"\nposition = [0,0,0]\nlook_at = [0,0,3]\n", 1, {"parallel"}},
        {"[[camera]]\nname = \"c\"\nposition = [0,0,0]\nlook_at = [1,0,0]\nfov = 180\n",
         5,
         {"'fov'"}},
        {"[[camera]]\nname = \"c\"\nlook_at = [1,0,0]\n", 1, {"[[camera]] needs 'position'"}},
        // Photometric off with a flux
        {"photometric = false\n\n[[emitter]]\nobject = \"L\"\nflux = 100\n",
         3,
         {"needs photometric mode", "photometric = false (line 1)"}},
        // TOML syntax: toml++'s line and message
        {"unit = \"m\"\n[[rule]]\nobject = \"a\nopacity = 1\n", 3, {"string"}},
        {"unit = \"m\"\nunit = \"mm\"\n", 2, {"unit"}},
    };
    for (const ErrorCase& c : cases) {
        const TempDir dir;
        const fs::path path = dir.write("scene.toml", c.toml);
        try {
            (void)read_scene_file(path);
            ADD_FAILURE() << "no error for:\n" << c.toml;
        } catch (const ImportError& e) {
            const std::string what = e.what();
            EXPECT_EQ(e.line(), c.line) << what << "\nfor:\n" << c.toml;
            EXPECT_EQ(what.rfind(path.string() + ":" + std::to_string(c.line) + ": ", 0), 0u)
                << what;
            for (const auto& needle : c.needles) {
                EXPECT_NE(what.find(needle), std::string::npos)
                    << "'" << needle << "' not in: " << what;
            }
        }
    }
}

TEST(SceneFile, MissingFileIsAnImportError) {
    const TempDir dir;
    const fs::path path = dir.write("x.txt", "");
    EXPECT_THROW((void)read_scene_file(path.parent_path() / "absent.toml"), ImportError);
    try {
        (void)read_scene_file(path.parent_path() / "absent.toml");
    } catch (const ImportError& e) {
        EXPECT_NE(std::string(e.what()).find("no such scene file"), std::string::npos) << e.what();
    }
}

TEST(SceneFile, ApplyImportSettingsSetsOnlyWhatTheFileSets) {
    ImportOptions options;
    options.unit = "ft";
    options.up = 'z';
    options.weld_tolerance = 1e-3;
    apply_import_settings(parse("unit = \"mm\"\norigin_shift = [10, 20, 30]\n"), options);
    EXPECT_EQ(options.unit, "mm");
    EXPECT_EQ(options.up, 'z');  // kept
    EXPECT_EQ(options.origin_shift, glm::dvec3(10.0, 20.0, 30.0));
    EXPECT_EQ(options.weld_tolerance, 1e-3);  // kept

    apply_import_settings(parse("up = \"y\"\nweld_tolerance = 0\n"), options);
    EXPECT_EQ(options.unit, "mm");  // kept
    EXPECT_EQ(options.up, 'y');
    EXPECT_EQ(options.origin_shift, glm::dvec3(10.0, 20.0, 30.0));  // kept
    EXPECT_EQ(options.weld_tolerance, 0.0);

    ImportOptions defaults;
    apply_import_settings(parse(""), defaults);
    EXPECT_EQ(defaults.unit, "");
    EXPECT_EQ(defaults.up, 0);
    EXPECT_EQ(defaults.weld_tolerance, ImportOptions{}.weld_tolerance);
}

TEST(SceneFile, GlobsAreCaseInsensitive) {
    visdb::Scene scene = room();
    const SceneFileReport report = apply_scene_file(parse(R"([[rule]]
object = "wand-*"
layer = "IFCWALL"
reflectance = 0.3

[[rule]]
material = "plast?r"
reflectance = [0.8, 0.8, 0.6]

[[rule]]
object = "floor-[0-9]"
opacity = 0.5
)"),
                                                    scene);
    expect_rgb(visdb::Rgb(0.3), material_of(scene, "WAND-North").reflectance);
    expect_rgb(visdb::Rgb(0.3), material_of(scene, "Wand-South").reflectance);
    expect_rgb({0.8, 0.8, 0.6}, material_of(scene, "Ceiling").reflectance);
    EXPECT_EQ(material_of(scene, "Floor-1").opacity, 0.5);
    expect_rgb(visdb::Rgb(0.5), material_of(scene, "Floor-1").reflectance);
    EXPECT_TRUE(report.notes.size() >= 1u);  // the split notes
}

TEST(SceneFile, LaterRulesOverrideEarlierPerProperty) {
    visdb::Scene scene = room();
    const SceneFileReport report = apply_scene_file(parse(R"([[rule]]
layer = "IfcCovering"
reflectance = 0.2
opacity = 0.5

[[rule]]
object = "Ceiling"
reflectance = 0.9
)"),
                                                    scene);
    const visdb::Material& m = material_of(scene, "Ceiling");
    expect_rgb(visdb::Rgb(0.9), m.reflectance);
    EXPECT_EQ(m.opacity, 0.5);
    // Plaster had only the ceiling: changed in place, same name
    EXPECT_EQ(m.name, "Plaster");
    EXPECT_EQ(scene.materials.size(), 3u);
    EXPECT_EQ(report.materials_overridden, 1u);
}

TEST(SceneFile, LightGroupsGoToTheEmittersMaterials) {
    visdb::Scene scene = room();
    const SceneFileReport report = apply_scene_file(parse(R"([[emitter]]
object = "Wand-South"
emittance = 10
group = "wall wash"

[[rule]]
object = "Ceiling"
emittance = 5
group = "office"

[[emitter]]
name = "panel"
center = [3, 2, 2.9]
size = [1, 0.5]
normal = [0, 0, -1]
emittance = 100
group = "office"

[[emitter]]
name = "other"
center = [1, 1, 2.9]
size = [1, 0.5]
normal = [0, 0, -1]
emittance = 100
)"),
                                                    scene);
    EXPECT_EQ(material_of(scene, "Wand-South").group, "wall wash");
    EXPECT_EQ(material_of(scene, "WAND-North").group, "");  // the same model material, split
    EXPECT_NE(material_of(scene, "Wand-South").name, material_of(scene, "WAND-North").name);
    EXPECT_EQ(material_of(scene, "Ceiling").group, "office");
    EXPECT_EQ(material_of(scene, "panel").group, "office");
    EXPECT_EQ(material_of(scene, "other").group, "");  // the default group, "emitters"
    EXPECT_EQ(report.emitters_added, 3u);

    // A group needs a light, and a name a mix can give
    for (const auto& [toml, needle] : std::vector<std::pair<std::string, std::string>>{
             {"[[rule]]\nobject = \"Ceiling\"\nreflectance = 0.5\ngroup = \"a\"\n",
              "scene.toml:4: 'group' in [[rule]] needs 'emittance' or 'flux'"},
             {"[[emitter]]\nobject = \"Ceiling\"\nemittance = 1\ngroup = \"a=1\"\n",
              "scene.toml:4: 'group' in [[emitter]] must be a non-empty name without ',' or "
              "'=', got 'a=1'"},
             {"[[emitter]]\nobject = \"Ceiling\"\nemittance = 1\ngroup = \"\"\n",
              "scene.toml:4: 'group' in [[emitter]] must be a non-empty name"},
             {"[[emitter]]\nobject = \"Ceiling\"\nemittance = 1\ngroup = 3\n", "scene.toml:4:"},
         }) {
        try {
            (void)parse(toml);
            ADD_FAILURE() << "no error for " << toml;
        } catch (const ImportError& e) {
            EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
        }
    }
}

TEST(SceneFile, RuleOnOneOfTwoSurfacesSplitsTheMaterial) {
    visdb::Scene scene = room();
    const std::string toml =
        "unit = \"m\"\n\n[[rule]]\nobject = \"Wand-South\"\nreflectance = 0.2\n";
    const SceneFileReport report = apply_scene_file(parse(toml), scene);
    const visdb::Material& south = material_of(scene, "Wand-South");
    const visdb::Material& north = material_of(scene, "WAND-North");
    EXPECT_EQ(south.name, "Concrete [rule line 3]");
    expect_rgb(visdb::Rgb(0.2), south.reflectance);
    EXPECT_EQ(north.name, "Concrete");
    expect_rgb(visdb::Rgb(0.5), north.reflectance);
    EXPECT_EQ(material_of(scene, "Floor-1").name, "Concrete");
    EXPECT_EQ(scene.materials.size(), 4u);
    EXPECT_EQ(report.materials_overridden, 1u);
    EXPECT_TRUE(has_note(report, "scene.toml:3: material 'Concrete': 1 of 3 surfaces"));
    // Materials that kept their surfaces keep their indices
    EXPECT_EQ(material_of(scene, "Ceiling").name, "Plaster");
    EXPECT_EQ(material_of(scene, "Space 1").name, "Air");
}

TEST(SceneFile, IdenticalCopiesAreSharedAndEmptiedMaterialsDropped) {
    visdb::Scene scene = room();
    // Both walls get the same copy; the floor another; "Concrete" keeps no surface
    const SceneFileReport report = apply_scene_file(parse(R"([[rule]]
layer = "IfcWall"
reflectance = 0.2

[[rule]]
object = "Floor*"
reflectance = 0.3
)"),
                                                    scene);
    ASSERT_EQ(scene.materials.size(), 4u);  // Plaster, Air, two copies
    EXPECT_EQ(find_surface(scene, "WAND-North")->material,
              find_surface(scene, "Wand-South")->material);
    EXPECT_EQ(material_of(scene, "WAND-North").name, "Concrete [rule line 1]");
    EXPECT_EQ(material_of(scene, "Floor-1").name, "Concrete [rule line 5]");
    expect_rgb(visdb::Rgb(0.3), material_of(scene, "Floor-1").reflectance);
    for (const auto& m : scene.materials) EXPECT_NE(m.name, "Concrete");
    EXPECT_EQ(material_of(scene, "Ceiling").name, "Plaster");
    EXPECT_EQ(material_of(scene, "Space 1").name, "Air");
    EXPECT_EQ(report.materials_overridden, 2u);
}

TEST(SceneFile, FluxSpreadsOverTheLuminaireWithNormalisedColour) {
    visdb::Scene scene = room();
    // Luminaire "Lamp": two surfaces of 1 m² each (2 m²); "Lamp-B": one of 0.5 m²
    scene.materials.push_back(material("Diffuser", 0.8));
    scene.surfaces.push_back(quad("Lamp", "Lights", 3, 1.0, 1.0, 2.0, 2.0, 2.9));
    scene.surfaces.push_back(quad("Lamp", "Lights", 3, 3.0, 1.0, 4.0, 2.0, 2.9));
    scene.surfaces.push_back(quad("Lamp-B", "Lights", 3, 3.0, 3.0, 4.0, 3.5, 2.9));
    const SceneFileReport report = apply_scene_file(parse(R"([[emitter]]
object = "Lamp*"
flux = 3000.0
color = [1.0, 0.5, 0.25]
)"),
                                                    scene);
    const double y = 0.2126 * 1.0 + 0.7152 * 0.5 + 0.0722 * 0.25;
    const visdb::Material& lamp = material_of(scene, "Lamp");
    expect_rgb(visdb::Rgb(1.0, 0.5, 0.25) * (1500.0 / y), lamp.emittance, 1e-9);
    EXPECT_NEAR(0.2126 * lamp.emittance.x + 0.7152 * lamp.emittance.y + 0.0722 * lamp.emittance.z,
                1500.0, 1e-9);  // luminous exitance Φ / A
    expect_rgb(visdb::Rgb(0.8), lamp.reflectance);
    const visdb::Material& lamp_b = material_of(scene, "Lamp-B");
    expect_rgb(visdb::Rgb(1.0, 0.5, 0.25) * (6000.0 / y), lamp_b.emittance, 1e-9);
    // Both halves of "Lamp" share one material
    int lamp_surfaces = 0;
    for (const auto& s : scene.surfaces) {
        if (s.name == "Lamp") {
            ++lamp_surfaces;
            EXPECT_EQ(&scene.materials[s.material], &lamp);
        }
    }
    EXPECT_EQ(lamp_surfaces, 2);
    EXPECT_EQ(report.emitters_added, 2u);  // two luminaires
    EXPECT_EQ(scene.emittance_unit, "lm/m2");
}

TEST(SceneFile, LuminairesOfOneFluxShareOneMaterialDespiteRounding) {
    // Three 0.6 × 0.3 m panels placed at coordinates whose areas differ in the last bits:
    // E = Φ / A differs by ~1e-16 relative, which must not split the material three ways
    visdb::Scene scene = room();
    scene.materials.push_back(material("Diffuser", 0.0, visdb::Rgb(60.0)));
    scene.surfaces.push_back(quad("light_1", "", 3, 0.1, 0.2, 0.7, 0.5, 2.9));
    scene.surfaces.push_back(quad("light_2", "", 3, 2.3, 1.7, 2.9, 2.0, 2.9));
    scene.surfaces.push_back(quad("light_3", "", 3, 4.45, 3.35, 5.05, 3.65, 2.9));
    ASSERT_NE(area(scene.surfaces[5].mesh), area(scene.surfaces[7].mesh));
    const SceneFileReport report =
        apply_scene_file(parse("[[rule]]\nobject = \"light_*\"\nflux = 1000.0\n"), scene);
    EXPECT_EQ(report.materials_overridden, 1u);
    for (const char* name : {"light_1", "light_2", "light_3"}) {
        EXPECT_EQ(&material_of(scene, name), &material_of(scene, "light_1"));
        EXPECT_NEAR(material_of(scene, name).emittance.x, 1000.0 / 0.18, 1e-6);
    }
}

TEST(SceneFile, FluxOnZeroAreaLuminaireIsAnError) {
    visdb::Scene scene = room();
    visdb::Surface flat = quad("Lamp", "", 0, 1.0, 1.0, 1.0, 2.0);  // zero width
    scene.surfaces.push_back(flat);
    const visdb::Scene before = scene;
    try {
        apply_scene_file(parse("\n[[rule]]\nobject = \"Lamp\"\nflux = 100\n"), scene);
        ADD_FAILURE() << "no error";
    } catch (const ImportError& e) {
        EXPECT_EQ(e.line(), 2u) << e.what();
        EXPECT_NE(std::string(e.what()).find("luminaire 'Lamp', which has zero area"),
                  std::string::npos)
            << e.what();
    }
    EXPECT_EQ(scene.surfaces.size(), before.surfaces.size());  // unchanged
    EXPECT_EQ(scene.sources.size(), before.sources.size());
}

TEST(SceneFile, PhotometricFlag) {
    {
        // photometric = true with an emittance; the model's own emitter is noted
        visdb::Scene scene = room();
        scene.materials.push_back(material("Glow", 0.0, visdb::Rgb(10.0)));
        scene.surfaces.push_back(quad("Glow", "", 3, 0.0, 0.0, 1.0, 1.0, 2.0));
        const SceneFileReport report = apply_scene_file(
            parse("photometric = true\n[[rule]]\nobject = \"Ceiling\"\nemittance = 20\n"), scene);
        EXPECT_EQ(scene.emittance_unit, "lm/m2");
        EXPECT_TRUE(has_note(report,
                             "scene.toml: photometric: the emittances the model gave 1 "
                             "surface (material 'Glow') are read as lm/m2"))
            << report.to_string();
        expect_rgb(visdb::Rgb(20.0), material_of(scene, "Ceiling").emittance);
    }
    {
        // No flux, no flag: the unit stays; no note
        visdb::Scene scene = room();
        scene.materials.push_back(material("Glow", 0.0, visdb::Rgb(10.0)));
        scene.surfaces.push_back(quad("Glow", "", 3, 0.0, 0.0, 1.0, 1.0, 2.0));
        const SceneFileReport report =
            apply_scene_file(parse("[[rule]]\nobject = \"Ceiling\"\nemittance = 20\n"), scene);
        EXPECT_EQ(scene.emittance_unit, "W/m2");
        EXPECT_FALSE(has_note(report, "photometric"));
    }
    {
        // photometric = false sets the radiometric unit
        visdb::Scene scene = room();
        scene.emittance_unit = "lm/m2";
        apply_scene_file(parse("photometric = false\n"), scene);
        EXPECT_EQ(scene.emittance_unit, "W/m2");
    }
    {
        visdb::Scene scene = room();
        scene.materials.push_back(material("Glow", 0.0, visdb::Rgb(10.0)));
        scene.surfaces.push_back(quad("Glow", "", 3, 0.0, 0.0, 1.0, 1.0, 2.0));
        const SceneFileReport report =
            apply_scene_file(parse("[[emitter]]\nobject = \"Glow\"\nflux = 100\n"), scene);
        EXPECT_EQ(scene.emittance_unit, "lm/m2");
        EXPECT_FALSE(has_note(report, "photometric"));
        expect_rgb(visdb::Rgb(100.0), material_of(scene, "Glow").emittance);  // 1 m²
    }
}

TEST(SceneFile, RectangleEmitterGeometry) {
    visdb::Scene scene = room();
    const SceneFile file = parse(R"([[emitter]]
name = "panel-1"
center = [3.0, 2.5, 2.99]
size = [1.2, 0.3]
normal = [0, 0, -1]
flux = 360.0

[[emitter]]
name = "wall-washer"
center = [0.01, 2.0, 2.0]
size = [2.0, 0.5]
normal = [3, 0, 0]
emittance = [10, 20, 30]
)");
    const SceneFileReport report = apply_scene_file(file, scene);
    EXPECT_EQ(report.emitters_added, 2u);
    ASSERT_EQ(scene.sources.size(), 2u);
    const visdb::Source& src = scene.sources[1];
    EXPECT_EQ(src.format, "scene");
    EXPECT_EQ(src.path, file.path);
    EXPECT_EQ(src.checksum, file.checksum);
    EXPECT_EQ(src.size_bytes, file.size_bytes);
    EXPECT_NE(src.report.find("emitters added: 2"), std::string::npos) << src.report;

    const visdb::Surface* panel = find_surface(scene, "panel-1");
    ASSERT_NE(panel, nullptr);
    EXPECT_EQ(panel->source, 1u);
    EXPECT_NEAR(area(panel->mesh), 1.2 * 0.3, 1e-12);
    glm::dvec3 centre(0.0);
    for (const auto& p : panel->mesh.positions) centre += p / 4.0;
    EXPECT_NEAR(glm::length(centre - glm::dvec3(3.0, 2.5, 2.99)), 0.0, 1e-12);
    for (const auto& t : panel->mesh.triangles) {
        const glm::dvec3 n =
            glm::normalize(glm::cross(panel->mesh.positions[t.y] - panel->mesh.positions[t.x],
                                      panel->mesh.positions[t.z] - panel->mesh.positions[t.x]));
        EXPECT_NEAR(n.z, -1.0, 1e-12);  // front toward the normal
    }
    // Width along world X, height along Y
    const glm::dvec3 edge = panel->mesh.positions[1] - panel->mesh.positions[0];
    EXPECT_NEAR(std::abs(edge.x), 1.2, 1e-12);
    const visdb::Material& pm = scene.materials[panel->material];
    EXPECT_EQ(pm.name, "panel-1");
    expect_rgb(visdb::Rgb(0.0), pm.reflectance);
    EXPECT_EQ(pm.opacity, 1.0);
    expect_rgb(visdb::Rgb(1000.0), pm.emittance, 1e-9);  // 360 lm / 0.36 m²
    EXPECT_EQ(scene.emittance_unit, "lm/m2");

    // Normal along X: width along world Y, front toward +X
    const visdb::Surface* washer = find_surface(scene, "wall-washer");
    ASSERT_NE(washer, nullptr);
    EXPECT_NEAR(area(washer->mesh), 1.0, 1e-12);
    const auto& wp = washer->mesh.positions;
    EXPECT_NEAR(glm::normalize(glm::cross(wp[1] - wp[0], wp[2] - wp[0])).x, 1.0, 1e-12);
    EXPECT_NEAR(std::abs((wp[1] - wp[0]).y), 2.0, 1e-12);
    for (const auto& p : wp) EXPECT_NEAR(p.x, 0.01, 1e-12);
    expect_rgb({10.0, 20.0, 30.0}, scene.materials[washer->material].emittance);
}

TEST(SceneFile, ExclusionsRemoveSurfacesAndTheirMaterials) {
    visdb::Scene scene = room();
    const SceneFileReport report = apply_scene_file(parse(R"([[exclude]]
layer = "ifcspace"

[[exclude]]
object = "Nothing*"
)"),
                                                    scene);
    EXPECT_EQ(report.surfaces_excluded, 1u);
    EXPECT_EQ(scene.surfaces.size(), 4u);
    EXPECT_EQ(find_surface(scene, "Space 1"), nullptr);
    ASSERT_EQ(scene.materials.size(), 2u);  // "Air" dropped with its only surface
    for (const auto& s : scene.surfaces) EXPECT_LT(s.material, scene.materials.size());
    EXPECT_EQ(material_of(scene, "Ceiling").name, "Plaster");
    EXPECT_TRUE(has_note(report,
                         "scene.toml:1: exclude (layer 'ifcspace') removes 1 surface: "
                         "'Space 1'"))
        << report.to_string();
    EXPECT_TRUE(has_note(report, "scene.toml:4: exclude matches no surface (object 'Nothing*')"))
        << report.to_string();

    // A rule that matches only excluded surfaces says so
    visdb::Scene again = room();
    const SceneFileReport r2 = apply_scene_file(
        parse("[[exclude]]\nlayer = \"IfcSpace\"\n[[rule]]\nobject = \"Space*\"\nopacity = 0\n"),
        again);
    EXPECT_TRUE(has_note(r2,
                         "scene.toml:3: rule matches no surface (object 'Space*'); the 1 it "
                         "matches are excluded"))
        << r2.to_string();
}

TEST(SceneFile, ExcludingEverythingIsAnError) {
    visdb::Scene scene = room();
    try {
        apply_scene_file(parse("[[exclude]]\nlayer = \"Ifc*\"\n"), scene);
        ADD_FAILURE() << "no error";
    } catch (const ImportError& e) {
        EXPECT_EQ(e.line(), 1u);
        EXPECT_NE(std::string(e.what()).find("remove every surface"), std::string::npos)
            << e.what();
    }
    EXPECT_EQ(scene.surfaces.size(), 5u);
}

TEST(SceneFile, GridsFromOverAndFromMinMax) {
    visdb::Scene scene = room();
    const SceneFileReport report = apply_scene_file(parse(R"([[grid]]
name = "floor plane"
over = "floor*"
height = 0.8
spacing = 0.25
margin = 0.5

[[grid]]
name = "desk"
min = [1, 2]
max = [3.5, 4]
height = 0.75
margin = 0.25

[[grid]]
name = "space"
over = "Space*"

[[exclude]]
layer = "IfcSpace"

[[grid]]
name = "nothing"
over = "Garden*"
)"),
                                                    scene);
    ASSERT_EQ(scene.grids.size(), 3u);
    EXPECT_EQ(report.grids, 3u);
    const visdb::CalculationGrid& g = scene.grids[0];
    EXPECT_EQ(g.name, "floor plane");
    EXPECT_NEAR(g.min.x, 0.5, 1e-12);
    EXPECT_NEAR(g.min.y, 0.5, 1e-12);
    EXPECT_NEAR(g.max.x, 5.5, 1e-12);
    EXPECT_NEAR(g.max.y, 3.5, 1e-12);
    EXPECT_NEAR(g.z, 0.9, 1e-12);  // floor at 0.1 + 0.8
    EXPECT_EQ(g.spacing, 0.25);
    EXPECT_EQ(g.normal, glm::dvec3(0.0, 0.0, 1.0));
    const visdb::CalculationGrid& d = scene.grids[1];
    EXPECT_EQ(d.min, glm::dvec2(1.25, 2.25));
    EXPECT_EQ(d.max, glm::dvec2(3.25, 3.75));
    EXPECT_EQ(d.z, 0.75);
    EXPECT_EQ(d.spacing, 0.5);
    // Over an excluded volume: resolved before exclusions
    const visdb::CalculationGrid& s = scene.grids[2];
    EXPECT_EQ(s.min, glm::dvec2(-1.0, -1.0));
    EXPECT_EQ(s.max, glm::dvec2(7.0, 5.0));
    EXPECT_NEAR(s.z, 0.3, 1e-12);  // -0.5 + 0.8 by default
    EXPECT_TRUE(has_note(report,
                         "scene.toml:22: grid 'nothing' matches no surface (over "
                         "'Garden*'); grid skipped"))
        << report.to_string();
}

TEST(SceneFile, GridMarginLeavingNothingIsAnError) {
    visdb::Scene scene = room();
    try {
        apply_scene_file(parse("\n[[grid]]\nname = \"g\"\nover = \"Floor-1\"\nmargin = 2.0\n"),
                         scene);
        ADD_FAILURE() << "no error";
    } catch (const ImportError& e) {
        EXPECT_EQ(e.line(), 2u);
        EXPECT_NE(std::string(e.what()).find("margin 2 leaves nothing of the 6 x 4 m rectangle"),
                  std::string::npos)
            << e.what();
    }
    EXPECT_TRUE(scene.grids.empty());
}

TEST(SceneFile, UnmatchedRuleIsANoteWithItsLine) {
    visdb::Scene scene = room();
    const SceneFileReport report = apply_scene_file(parse(R"(unit = "m"

[[rule]]
object = "Tür*"
layer = "IfcDoor"
reflectance = 0.4

[[emitter]]
material = "Neon"
emittance = 3

[[exclude]]
object = "Nothing"
)"),
                                                    scene);
    EXPECT_TRUE(
        has_note(report, "scene.toml:3: rule matches no surface (object 'Tür*', layer 'IfcDoor')"))
        << report.to_string();
    EXPECT_TRUE(has_note(report, "scene.toml:8: emitter matches no surface (material 'Neon')"))
        << report.to_string();
    // In file order, although exclusions are applied first
    ASSERT_EQ(report.notes.size(), 3u);
    EXPECT_NE(report.notes[0].find(":3: rule"), std::string::npos) << report.notes[0];
    EXPECT_NE(report.notes[1].find(":8: emitter"), std::string::npos) << report.notes[1];
    EXPECT_NE(report.notes[2].find(":12: exclude matches no surface (object 'Nothing')"),
              std::string::npos)
        << report.notes[2];
    EXPECT_EQ(report.materials_overridden, 0u);
    EXPECT_EQ(report.emitters_added, 0u);
    EXPECT_EQ(scene.materials.size(), 3u);
    EXPECT_EQ(scene.sources.size(), 2u);  // the scene file is still a source
}

TEST(SceneFile, CamerasAreAppendedAndNamesUnique) {
    visdb::Scene scene = room();
    const SceneFileReport report = apply_scene_file(parse(R"([[camera]]
name = "entrance"
position = [1, 1, 1.6]
look_at = [5, 4, 1.2]
up = [0, 0, 2]
fov = 50
)"),
                                                    scene);
    EXPECT_EQ(report.cameras, 1u);
    ASSERT_EQ(scene.cameras.size(), 1u);
    EXPECT_EQ(scene.cameras[0].name, "entrance");
    EXPECT_EQ(scene.cameras[0].position, glm::dvec3(1.0, 1.0, 1.6));
    EXPECT_EQ(scene.cameras[0].fov_y_deg, 50.0);

    // The same name again (from another scene file or the model) is an error
    try {
        apply_scene_file(parse("[[camera]]\nname = \"entrance\"\nposition = [0, 0, 1]\n"
                               "look_at = [1, 0, 1]\n"),
                         scene);
        ADD_FAILURE() << "no error";
    } catch (const ImportError& e) {
        EXPECT_EQ(e.line(), 1u);
        EXPECT_NE(std::string(e.what()).find("camera 'entrance' already exists"), std::string::npos)
            << e.what();
    }
    EXPECT_EQ(scene.cameras.size(), 1u);
    EXPECT_EQ(scene.sources.size(), 2u);
}

TEST(SceneFile, ReportToString) {
    visdb::Scene scene = room();
    const SceneFileReport report =
        apply_scene_file(parse("[[exclude]]\nobject = \"Space*\"\n"), scene);
    const std::string text = report.to_string();
    EXPECT_NE(text.find("surfaces excluded: 1\n"), std::string::npos) << text;
    EXPECT_NE(text.find("notes: 1\n"), std::string::npos) << text;
}

}  // namespace
}  // namespace abrad::convert
