// Tests of [[luminaire]] tables placed by the model (`object`/`layer` instead of `position`):
// one luminaire per instance of a DXF block INSERTed on a layer, of an OBJ group and of pieces
// of one object, at the instance's bounding-box centre or where the aim leaves its box, aimed
// by rotation or target; the instances' geometry removed or kept; and every mistake at its line
// and key.

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <glm/geometric.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "abrad/convert/import.h"
#include "abrad/convert/scene_file.h"
#include "obj_text.h"
#include "temp_dir.h"

namespace abrad::convert {
namespace {

namespace fs = std::filesystem;
using ::abrad::testing::TempDir;

/// A uniform lower hemisphere of 100 cd, lamps 1000 lm.
const char* const kIes =
    "IESNA:LM-63-2002\nTILT=NONE\n1 1000 1 3 1 1 2 0 0 0\n1 1 10\n0 45 90\n0\n100 100 100\n";

void expect_vec(const glm::dvec3& expected, const glm::dvec3& actual, double tol = 1e-9) {
    EXPECT_NEAR(expected.x, actual.x, tol);
    EXPECT_NEAR(expected.y, actual.y, tol);
    EXPECT_NEAR(expected.z, actual.z, tol);
}

/// DXF group codes of a 3DFACE on `layer` with corners `pts`.
std::string dxf_face(const std::string& layer, const std::vector<glm::dvec3>& pts) {
    std::string s = "0\n3DFACE\n8\n" + layer + "\n";
    for (std::size_t i = 0; i < pts.size(); ++i) {
        std::ostringstream v;
        v << "1" << i << "\n"
          << pts[i].x << "\n2" << i << "\n"
          << pts[i].y << "\n3" << i << "\n"
          << pts[i].z << "\n";
        s += v.str();
    }
    return s;
}

/// The six faces of the box [lo, hi] on `layer`, as DXF 3DFACEs.
std::string dxf_box(const std::string& layer, const glm::dvec3& lo, const glm::dvec3& hi) {
    const double x0 = lo.x, y0 = lo.y, z0 = lo.z, x1 = hi.x, y1 = hi.y, z1 = hi.z;
    return dxf_face(layer, {{x0, y0, z0}, {x0, y1, z0}, {x1, y1, z0}, {x1, y0, z0}}) +
           dxf_face(layer, {{x0, y0, z1}, {x1, y0, z1}, {x1, y1, z1}, {x0, y1, z1}}) +
           dxf_face(layer, {{x0, y0, z0}, {x1, y0, z0}, {x1, y0, z1}, {x0, y0, z1}}) +
           dxf_face(layer, {{x0, y1, z0}, {x0, y1, z1}, {x1, y1, z1}, {x1, y1, z0}}) +
           dxf_face(layer, {{x0, y0, z0}, {x0, y0, z1}, {x0, y1, z1}, {x0, y1, z0}}) +
           dxf_face(layer, {{x1, y0, z0}, {x1, y1, z0}, {x1, y1, z1}, {x1, y0, z1}});
}

/// Millimetres: a 4 x 4 m floor on layer FLOOR and block DL (a 200 x 200 x 100 mm box on layer
/// 0, its base point at the middle of its underside) INSERTed on layer LIGHTS at `inserts`.
std::string lights_dxf(const std::vector<glm::dvec3>& inserts) {
    std::string s = "0\nSECTION\n2\nHEADER\n9\n$INSUNITS\n70\n4\n0\nENDSEC\n";
    s += "0\nSECTION\n2\nBLOCKS\n";
    s += "0\nBLOCK\n8\n0\n2\nDL\n70\n0\n10\n0\n20\n0\n30\n0\n3\nDL\n";
    s += dxf_box("0", {-100, -100, 0}, {100, 100, 100});
    s += "0\nENDBLK\n8\n0\n0\nENDSEC\n";
    s += "0\nSECTION\n2\nENTITIES\n";
    s += dxf_face("FLOOR", {{0, 0, 0}, {4000, 0, 0}, {4000, 4000, 0}, {0, 4000, 0}});
    for (const glm::dvec3& p : inserts) {
        std::ostringstream v;
        v << "0\nINSERT\n8\nLIGHTS\n2\nDL\n10\n"
          << p.x << "\n20\n"
          << p.y << "\n30\n"
          << p.z << "\n";
        s += v.str();
    }
    return s + "0\nENDSEC\n0\nEOF\n";
}

using abrad::testing::obj_box;

visdb::Scene import(const fs::path& model, const SceneFile& file, SceneFileReport* report) {
    ImportOptions options;
    apply_import_settings(file, options);
    visdb::Scene scene = import_model(model, options).scene;
    const SceneFileReport r = apply_scene_file(file, scene);
    if (report != nullptr) *report = r;
    return scene;
}

std::size_t surfaces_named(const visdb::Scene& scene, const std::string& name) {
    return static_cast<std::size_t>(
        std::count_if(scene.surfaces.begin(), scene.surfaces.end(),
                      [&name](const visdb::Surface& s) { return s.name == name; }));
}

TEST(LuminairePlacement, DxfBlocksOnALayerGiveOneLuminaireEach) {
    const TempDir dir;
    dir.write("dl.ies", kIes);
    const std::vector<glm::dvec3> inserts = {
        {3000, 1000, 2500}, {1000, 1000, 2500}, {1000, 3000, 2500}};
    const fs::path model = dir.write("lights.dxf", lights_dxf(inserts));
    const fs::path scene_path = dir.write("scene.toml", R"(
[[luminaire]]
file = "dl.ies"
name = "DL"
layer = "lights"
)");
    const SceneFile f = read_scene_file(scene_path);
    ASSERT_EQ(f.placements.size(), 1U);
    EXPECT_TRUE(f.luminaires.empty());
    EXPECT_TRUE(f.is_photometric());

    SceneFileReport report;
    const visdb::Scene scene = import(model, f, &report);
    // One luminaire per INSERT, named in x, y, z order of the box centres
    ASSERT_EQ(scene.luminaires.size(), inserts.size());
    EXPECT_EQ(report.luminaires, inserts.size());
    const std::vector<glm::dvec3> centres = {{1, 1, 2.55}, {1, 3, 2.55}, {3, 1, 2.55}};
    for (std::size_t i = 0; i < centres.size(); ++i) {
        const visdb::Luminaire& l = scene.luminaires[i];
        EXPECT_EQ(l.name, "DL " + std::to_string(i + 1));
        expect_vec(centres[i], l.position);
        expect_vec({0, 0, 1}, l.axis_z);  // hanging straight down
    }
    // The blocks' geometry is gone (keep_geometry = false); the floor stays
    EXPECT_EQ(surfaces_named(scene, "LIGHTS"), 0U);
    EXPECT_EQ(surfaces_named(scene, "FLOOR"), 1U);
    EXPECT_EQ(report.surfaces_excluded, 1U);
    bool noted = false;
    for (const std::string& note : report.notes) {
        noted = noted || note.find(
                             ":2: luminaire 'DL 1' and 2 more placed at 3 instances "
                             "(layer 'lights': 1 object, 1 surface, removed)") != std::string::npos;
    }
    EXPECT_TRUE(noted) << report.to_string();

    // mounting = "surface": the middle of each box's underside; the geometry kept
    const fs::path surface_path = dir.write("surface.toml", R"(
[[luminaire]]
file = "dl.ies"
layer = "LIGHTS"
mounting = "surface"
keep_geometry = true
)");
    const visdb::Scene kept = import(model, read_scene_file(surface_path), nullptr);
    ASSERT_EQ(kept.luminaires.size(), 3U);
    EXPECT_EQ(kept.luminaires[0].name, "dl (line 2) 1");
    for (std::size_t i = 0; i < centres.size(); ++i) {
        expect_vec(centres[i] - glm::dvec3(0, 0, 0.05), kept.luminaires[i].position);
    }
    EXPECT_EQ(surfaces_named(kept, "LIGHTS"), 1U);
}

/// IFC2X3, metres: a 4 x 4 x 0.2 m slab (IfcSlab 'Floor', top at z = 0) and three light fixtures
/// (IfcFlowTerminal 'Downlight' typed by an IfcLightFixtureType: IFC2X3 has no IfcLightFixture
/// entity), each a 0.25 x 0.25 x 0.125 m box extruded up from the middle of its underside at
/// (1, 1, 2.5), (3, 1, 2.5) and (2, 3, 2.5). One shape shared by the three, as CAD tools write.
std::string lights_ifc() {
    std::string s =
        "ISO-10303-21;\nHEADER;\nFILE_DESCRIPTION(('ViewDefinition [CoordinationView]'),'2;1');\n"
        "FILE_NAME('lights.ifc','2026-12-01T00:00:00',('abrad'),('abrad'),'abrad test','abrad "
        "test','');\nFILE_SCHEMA(('IFC2X3'));\nENDSEC;\nDATA;\n"
        "#1=IFCPERSON($,$,'Test',$,$,$,$,$);\n#2=IFCORGANIZATION($,'abrad',$,$,$);\n"
        "#3=IFCPERSONANDORGANIZATION(#1,#2,$);\n#4=IFCAPPLICATION(#2,'1','abrad test','abrad');\n"
        "#5=IFCOWNERHISTORY(#3,#4,$,.ADDED.,$,$,$,0);\n"
        "#10=IFCSIUNIT(*,.LENGTHUNIT.,$,.METRE.);\n#11=IFCUNITASSIGNMENT((#10));\n"
        "#20=IFCCARTESIANPOINT((0.,0.,0.));\n#21=IFCDIRECTION((0.,0.,1.));\n"
        "#22=IFCDIRECTION((1.,0.,0.));\n#23=IFCAXIS2PLACEMENT3D(#20,#21,#22);\n"
        "#24=IFCGEOMETRICREPRESENTATIONCONTEXT($,'Model',3,1.E-05,#23,$);\n"
        "#30=IFCPROJECT('0abradProject000000001',#5,'Project',$,$,$,$,(#24),#11);\n"
        "#31=IFCLOCALPLACEMENT($,#23);\n"
        "#32=IFCSITE('0abradSite000000000001',#5,'Site',$,$,#31,$,$,.ELEMENT.,$,$,$,$,$);\n"
        "#33=IFCLOCALPLACEMENT(#31,#23);\n"
        "#34=IFCBUILDING('0abradBuilding00000001',#5,'Building',$,$,#33,$,$,.ELEMENT.,$,$,$);\n"
        "#35=IFCLOCALPLACEMENT(#33,#23);\n"
        "#36=IFCBUILDINGSTOREY('0abradStorey0000000001',#5,'Storey',$,$,#35,$,$,.ELEMENT.,0.);\n"
        "#37=IFCRELAGGREGATES('0abradAggregates000001',#5,$,$,#30,(#32));\n"
        "#38=IFCRELAGGREGATES('0abradAggregates000002',#5,$,$,#32,(#34));\n"
        "#39=IFCRELAGGREGATES('0abradAggregates000003',#5,$,$,#34,(#36));\n"
        "#40=IFCCARTESIANPOINT((0.,0.));\n#41=IFCAXIS2PLACEMENT2D(#40,$);\n"
        "#42=IFCCARTESIANPOINT((2.,2.,-0.2));\n#43=IFCAXIS2PLACEMENT3D(#42,#21,#22);\n"
        "#44=IFCLOCALPLACEMENT(#35,#43);\n#45=IFCRECTANGLEPROFILEDEF(.AREA.,$,#41,4.,4.);\n"
        "#46=IFCEXTRUDEDAREASOLID(#45,#23,#21,0.2);\n"
        "#47=IFCSHAPEREPRESENTATION(#24,'Body','SweptSolid',(#46));\n"
        "#48=IFCPRODUCTDEFINITIONSHAPE($,$,(#47));\n"
        "#49=IFCSLAB('0abradSlab000000000001',#5,'Floor',$,$,#44,#48,$,.FLOOR.);\n"
        "#50=IFCRECTANGLEPROFILEDEF(.AREA.,$,#41,0.25,0.25);\n"
        "#51=IFCEXTRUDEDAREASOLID(#50,#23,#21,0.125);\n"
        "#52=IFCSHAPEREPRESENTATION(#24,'Body','SweptSolid',(#51));\n"
        "#53=IFCPRODUCTDEFINITIONSHAPE($,$,(#52));\n"
        "#60=IFCCARTESIANPOINT((1.,1.,2.5));\n#61=IFCAXIS2PLACEMENT3D(#60,#21,#22);\n"
        "#62=IFCLOCALPLACEMENT(#35,#61);\n"
        "#63=IFCFLOWTERMINAL('0abradLight00000000001',#5,'Downlight',$,$,#62,#53,$);\n"
        "#64=IFCCARTESIANPOINT((3.,1.,2.5));\n#65=IFCAXIS2PLACEMENT3D(#64,#21,#22);\n"
        "#66=IFCLOCALPLACEMENT(#35,#65);\n"
        "#67=IFCFLOWTERMINAL('0abradLight00000000002',#5,'Downlight',$,$,#66,#53,$);\n"
        "#68=IFCCARTESIANPOINT((2.,3.,2.5));\n#69=IFCAXIS2PLACEMENT3D(#68,#21,#22);\n"
        "#70=IFCLOCALPLACEMENT(#35,#69);\n"
        "#71=IFCFLOWTERMINAL('0abradLight00000000003',#5,'Downlight',$,$,#70,#53,$);\n"
        "#80=IFCLIGHTFIXTURETYPE('0abradLightType0000001',#5,'DL',$,$,$,$,$,$,"
        ".DIRECTIONSOURCE.);\n"
        "#81=IFCRELDEFINESBYTYPE('0abradDefinesByType001',#5,$,$,(#63,#67,#71),#80);\n"
        "#90=IFCRELCONTAINEDINSPATIALSTRUCTURE('0abradContained0000001',#5,$,$,"
        "(#49,#63,#67,#71),#36);\n"
        "ENDSEC;\nEND-ISO-10303-21;\n";
    return s;
}

TEST(LuminairePlacement, IfcLightFixturesGiveOneLuminaireEach) {
    const TempDir dir;
    dir.write("dl.ies", kIes);
    const fs::path model = dir.write("lights.ifc", lights_ifc());
    // Assimp's IFC reader: the fixtures are objects 'Downlight' on layer 'IfcFlowTerminal'
    const visdb::Scene imported = import_model(model, {}).scene;
    std::size_t fixture_surfaces = 0;
    for (const visdb::Surface& s : imported.surfaces) {
        if (s.layer == "IfcFlowTerminal") {
            EXPECT_EQ(s.name, "Downlight");
            ++fixture_surfaces;
        }
    }
    EXPECT_GE(fixture_surfaces, 1U);

    const fs::path scene_path = dir.write("scene.toml", R"(
[[luminaire]]
file = "dl.ies"
name = "DL"
layer = "IfcFlowTerminal"
object = "Down*"
mounting = "surface"
)");
    SceneFileReport report;
    const visdb::Scene scene = import(model, read_scene_file(scene_path), &report);
    ASSERT_EQ(scene.luminaires.size(), 3U) << report.to_string();
    const std::vector<glm::dvec3> expected = {{1, 1, 2.5}, {2, 3, 2.5}, {3, 1, 2.5}};
    for (std::size_t i = 0; i < expected.size(); ++i) {
        EXPECT_EQ(scene.luminaires[i].name, "DL " + std::to_string(i + 1));
        expect_vec(expected[i], scene.luminaires[i].position, 1e-6);  // Assimp's floats
    }
    for (const visdb::Surface& s : scene.surfaces) EXPECT_NE(s.layer, "IfcFlowTerminal");
}

TEST(LuminairePlacement, ObjGroupsPiecesAndObjects) {
    const TempDir dir;
    dir.write("lamp.ies", kIes);
    // Groups: two lamps; a panel whose diffuser (a quad inside its housing's box, sharing no
    // vertex) is one instance with it; a pair of separate boxes in one group
    std::string obj = "g floor\nv 0 0 0\nv 4 0 0\nv 4 4 0\nv 0 4 0\nf 1 2 3 4\n";
    obj += "g lamp_a\n" + obj_box({1.25, 1.75, 2.75}, {1.75, 2.25, 3.0}, 4);
    obj += "g lamp_b\n" + obj_box({2.25, 1.75, 2.75}, {2.75, 2.25, 3.0}, 12);
    obj += "g panel\n" + obj_box({0.5, 0.5, 2.5}, {1.5, 1.0, 3.0}, 20);
    obj += "v 0.6 0.6 2.55\nv 1.4 0.6 2.55\nv 1.4 0.9 2.55\nv 0.6 0.9 2.55\nf 29 32 31 30\n";
    obj += "g pair\n" + obj_box({3.0, 3.0, 2.5}, {3.5, 3.5, 3.0}, 32) +
           obj_box({3.0, 0.5, 2.5}, {3.5, 1.0, 3.0}, 40);
    const fs::path model = dir.write("room.obj", obj);

    const fs::path scene_path = dir.write("scene.toml", R"(
[[luminaire]]
file = "lamp.ies"
name = "L"
object = "lamp_*"
mounting = "surface"

[[luminaire]]
file = "lamp.ies"
name = "P"
object = "panel"

[[luminaire]]
file = "lamp.ies"
name = "Two"
object = "pair"
keep_geometry = true

[[luminaire]]
file = "lamp.ies"
name = "One"
object = "pair"
instances = "objects"
keep_geometry = true
)");
    const visdb::Scene scene = import(model, read_scene_file(scene_path), nullptr);
    ASSERT_EQ(scene.luminaires.size(), 2U + 1U + 2U + 1U);
    EXPECT_EQ(scene.luminaires[0].name, "L 1");
    expect_vec({1.5, 2.0, 2.75}, scene.luminaires[0].position);  // lamp_a's underside
    expect_vec({2.5, 2.0, 2.75}, scene.luminaires[1].position);
    EXPECT_EQ(scene.luminaires[2].name, "P");  // the housing and its diffuser: one
    expect_vec({1.0, 0.75, 2.75}, scene.luminaires[2].position);
    EXPECT_EQ(scene.luminaires[3].name, "Two 1");  // two pieces apart: two, in y order
    expect_vec({3.25, 0.75, 2.75}, scene.luminaires[3].position);
    expect_vec({3.25, 3.25, 2.75}, scene.luminaires[4].position);
    EXPECT_EQ(scene.luminaires[5].name, "One");  // instances = "objects": the box of both
    expect_vec({3.25, 2.0, 2.75}, scene.luminaires[5].position);
    EXPECT_EQ(surfaces_named(scene, "lamp_a") + surfaces_named(scene, "lamp_b") +
                  surfaces_named(scene, "panel"),
              0U);
    EXPECT_EQ(surfaces_named(scene, "pair"), 1U);
    EXPECT_EQ(surfaces_named(scene, "floor"), 1U);
}

TEST(LuminairePlacement, AimedByRotationOrTarget) {
    const TempDir dir;
    dir.write("lamp.ies", kIes);
    std::string obj = "g floor\nv 0 0 0\nv 4 0 0\nv 4 4 0\nv 0 4 0\nf 1 2 3 4\n";
    obj += "g spot1\n" + obj_box({0.75, 1.75, 2.5}, {1.25, 2.25, 3.0}, 4);
    obj += "g spot2\n" + obj_box({2.75, 1.75, 2.5}, {3.25, 2.25, 3.0}, 12);
    const fs::path model = dir.write("room.obj", obj);
    const fs::path scene_path = dir.write("scene.toml", R"(
[[luminaire]]
file = "lamp.ies"
name = "T"
object = "spot*"
target = [2.0, 2.0, 0.0]
mounting = "surface"
keep_geometry = true

[[luminaire]]
file = "lamp.ies"
name = "R"
object = "spot*"
rotation = [0, 90, 0]
mounting = "surface"
)");
    const visdb::Scene scene = import(model, read_scene_file(scene_path), nullptr);
    ASSERT_EQ(scene.luminaires.size(), 4U);
    // Target: each nadir from its own reference point at the target
    for (int i = 0; i < 2; ++i) {
        const visdb::Luminaire& l = scene.luminaires[static_cast<std::size_t>(i)];
        const glm::dvec3 centre(i == 0 ? 1.0 : 3.0, 2.0, 2.75);
        const glm::dvec3 aim0 = glm::normalize(glm::dvec3(2, 2, 0) - centre);
        // Where the aim leaves the 0.5 x 0.5 x 0.5 box: through its underside (|z| largest)
        const glm::dvec3 exit = centre + (0.25 / std::abs(aim0.z)) * aim0;
        expect_vec(exit, l.position);
        expect_vec(glm::normalize(glm::dvec3(2, 2, 0) - exit), -l.axis_z);
    }
    // Rotation 90° about y: the nadir (-z) turns to -x; it leaves each box through its -x side
    expect_vec({-1, 0, 0}, -scene.luminaires[2].axis_z);
    expect_vec({0.75, 2.0, 2.75}, scene.luminaires[2].position);
    expect_vec({2.75, 2.0, 2.75}, scene.luminaires[3].position);
}

struct PlacementError {
    std::string toml;
    std::size_t line;
    std::string needle;
};

TEST(LuminairePlacement, MistakesAreRefusedAtTheirLineAndKey) {
    const std::string head = "[[luminaire]]\nfile = \"lamp.ies\"\n";
    const std::vector<PlacementError> read_cases = {
        {head + "object = \"lamp\"\nposition = [0, 0, 3]\n", 4,
         "'position' in [[luminaire]] cannot be combined with 'object' or 'layer'"},
        {head + "layer = \"L\"\ncount = 2\nstep = [1, 0, 0]\n", 4, "'count' in [[luminaire]]"},
        {head + "position = [0, 0, 3]\nmounting = \"surface\"\n", 4,
         "'mounting' in [[luminaire]] needs 'object' or 'layer'"},
        {head + "position = [0, 0, 3]\nkeep_geometry = true\n", 4, "'keep_geometry'"},
        {head + "object = \"lamp\"\nmounting = \"ceiling\"\n", 4, "must be center or surface"},
        {head + "object = \"lamp\"\ninstances = \"blocks\"\n", 4, "must be pieces or objects"},
        {head + "object = \"lamp\"\nkeep_geometry = 1\n", 4, "must be true or false"},
        {head + "layer = \"\"\n", 3, "'layer' in [[luminaire]] is empty"},
        {head + "object = \"lamp\"\nmaterial = \"x\"\n", 4, "unknown key 'material'"},
        {"photometric = false\n" + head + "object = \"lamp\"\n", 2,
         "or a luminaire needs photometric mode"},
    };
    const TempDir dir;
    dir.write("lamp.ies", kIes);
    for (const PlacementError& c : read_cases) {
        const fs::path path = dir.write("scene.toml", c.toml);
        try {
            (void)read_scene_file(path);
            ADD_FAILURE() << "no error for:\n" << c.toml;
        } catch (const ImportError& e) {
            EXPECT_EQ(e.line(), c.line) << e.what() << "\nfor:\n" << c.toml;
            EXPECT_NE(std::string(e.what()).find(c.needle), std::string::npos) << e.what();
        }
    }

    // Against the model: a glob that matches nothing (at its key's line), a name taken
    const fs::path model =
        dir.write("room.obj", "g floor\nv 0 0 0\nv 4 0 0\nv 4 4 0\nv 0 4 0\nf 1 2 3 4\ng lamp\n" +
                                  obj_box({1, 1, 2.5}, {1.5, 1.5, 3}, 4));
    const std::vector<PlacementError> apply_cases = {
        {head + "name = \"X\"\nlayer = \"LIGHTS\"\n", 4,
         "'layer' in [[luminaire]] matches no surface (layer 'LIGHTS')"},
        {head + "name = \"X\"\nlayer = \"*\"\nobject = \"lamps\"\n", 5,
         "'object' in [[luminaire]] matches no surface (object 'lamps', layer '*')"},
        {head + "name = \"X\"\nposition = [0, 0, 3]\n" + head + "name = \"X\"\nobject = \"lamp\"\n",
         5, "luminaire 'X' is already defined at line 1"},
        {head + "object = \"lamp\"\ntarget = [1.25, 1.25, 2.75]\n", 1, "'target' is its centre"},
    };
    for (const PlacementError& c : apply_cases) {
        const fs::path path = dir.write("scene.toml", c.toml);
        const SceneFile f = read_scene_file(path);
        visdb::Scene scene = import_model(model, {}).scene;
        const std::size_t surfaces = scene.surfaces.size();
        try {
            apply_scene_file(f, scene);
            ADD_FAILURE() << "no error for:\n" << c.toml;
        } catch (const ImportError& e) {
            EXPECT_EQ(e.line(), c.line) << e.what() << "\nfor:\n" << c.toml;
            EXPECT_NE(std::string(e.what()).find(c.needle), std::string::npos) << e.what();
        }
        EXPECT_EQ(scene.surfaces.size(), surfaces);  // unchanged
        EXPECT_TRUE(scene.luminaires.empty());
    }
}

}  // namespace
}  // namespace abrad::convert
