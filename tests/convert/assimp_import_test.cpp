// Tests of the Assimp reader (read_assimp): geometry, frames and units per format, names of
// objects and layers, materials and cameras, DXF INSERT placement, and bad input that must
// end in an ImportError naming the file (never a crash: the suite runs under ASan).

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "hostile_files.h"
#include "raw_model.h"
#include "shared_data.h"
#include "temp_dir.h"

/// Assimp 5.2 leaks its partial scene when some readers (PLY among them) throw on a malformed
/// file; that is not our memory, so LeakSanitizer ignores leaks allocated inside libassimp.
extern "C" const char* __lsan_default_suppressions() { return "leak:libassimp.so\n"; }

namespace abrad::convert::detail {
namespace {

namespace fs = std::filesystem;

const fs::path kSharedData = abrad::testing::shared_data();

using ::abrad::testing::TempDir;

std::string read_bytes(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
}

struct Box {
    glm::dvec3 lo{std::numeric_limits<double>::max()};
    glm::dvec3 hi{std::numeric_limits<double>::lowest()};
    void add(const glm::dvec3& p) {
        lo = glm::min(lo, p);
        hi = glm::max(hi, p);
    }
};

/// Bounding box of the corners of the faces whose slot passes `keep`.
template <typename Keep>
Box face_box(const RawModel& m, Keep keep) {
    Box b;
    for (const RawFace& f : m.faces) {
        if (!keep(m.slots[f.slot])) continue;
        for (std::size_t k = 0; k < f.count; ++k) b.add(m.positions[m.corners[f.first + k]]);
    }
    return b;
}

Box face_box(const RawModel& m) {
    return face_box(m, [](const RawSlot&) { return true; });
}

/// Newell normal (length = 2 × area) of a face.
glm::dvec3 newell(const RawModel& m, const RawFace& f) {
    glm::dvec3 n{0.0};
    for (std::size_t k = 0; k < f.count; ++k) {
        const glm::dvec3& a = m.positions[m.corners[f.first + k]];
        const glm::dvec3& b = m.positions[m.corners[f.first + (k + 1) % f.count]];
        n += glm::cross(a, b);
    }
    return n;
}

glm::dvec3 corner(const RawModel& m, const RawFace& f, std::size_t k) {
    return m.positions[m.corners[f.first + k]];
}

const visdb::Material* material(const RawModel& m, const std::string& name) {
    for (const visdb::Material& mat : m.materials) {
        if (mat.name == name) return &mat;
    }
    return nullptr;
}

bool any_note(const std::vector<std::string>& notes, const std::string& part) {
    return std::any_of(notes.begin(), notes.end(),
                       [&](const std::string& n) { return n.find(part) != std::string::npos; });
}

std::string joined(const std::vector<std::string>& notes) {
    std::string s;
    for (const std::string& n : notes) s += n + "\n";
    return s;
}

#define EXPECT_VEC_NEAR(expected, actual, tol)           \
    do {                                                 \
        const glm::dvec3 e_ = (expected);                \
        const glm::dvec3 a_ = (actual);                  \
        EXPECT_NEAR(e_.x, a_.x, tol) << "x of " #actual; \
        EXPECT_NEAR(e_.y, a_.y, tol) << "y of " #actual; \
        EXPECT_NEAR(e_.z, a_.z, tol) << "z of " #actual; \
    } while (0)

/// Expects read_assimp to throw an ImportError whose message names `file` and contains `part`.
void expect_import_error(const fs::path& file, const std::string& part,
                         const ImportOptions& options = {}) {
    std::vector<std::string> notes;
    try {
        (void)read_assimp(file, options, notes);
        ADD_FAILURE() << file << ": expected ImportError containing '" << part << "'";
    } catch (const ImportError& e) {
        const std::string what = e.what();
        EXPECT_NE(what.find(file.string()), std::string::npos) << what;
        EXPECT_NE(what.find(part), std::string::npos) << what;
        EXPECT_EQ(e.file(), file.string());
    }
}

// ---------------------------------------------------------------------------------------------
// Synthetic files

/// A glTF scene with one triangle (0,0,0) (1,0,0) (0,1,0) in glTF coordinates, used by three
/// nodes (one mirrored), a points primitive, a camera and a point light.
std::string synthetic_gltf(const std::string& bin_name) {
    return R"({
  "asset": {"version": "2.0"},
  "extensionsUsed": ["KHR_lights_punctual"],
  "extensions": {"KHR_lights_punctual": {"lights": [
      {"type": "point", "name": "Bulb", "color": [1, 1, 1], "intensity": 10}]}},
  "scene": 0,
  "scenes": [{"nodes": [0, 1, 2, 3, 4, 5]}],
  "nodes": [
    {"mesh": 0, "name": "TriA", "translation": [10, 0, 0]},
    {"mesh": 0, "name": "TriB", "translation": [0, 0, -3]},
    {"mesh": 0, "name": "Mirror", "translation": [-5, 0, 0], "scale": [-1, 1, 1]},
    {"mesh": 1, "name": "Dots"},
    {"camera": 0, "name": "Cam", "translation": [0, 2, 5]},
    {"name": "Lamp", "extensions": {"KHR_lights_punctual": {"light": 0}}}
  ],
  "cameras": [{"type": "perspective",
               "perspective": {"yfov": 0.8, "aspectRatio": 1.5, "znear": 0.1}}],
  "meshes": [
    {"name": "TriMesh", "primitives": [{"attributes": {"POSITION": 0}, "indices": 1,
                                          "material": 0}]},
    {"name": "DotMesh", "primitives": [{"attributes": {"POSITION": 0}, "mode": 0}]}
  ],
  "materials": [{"name": "Glow", "emissiveFactor": [1, 0.5, 0],
                 "pbrMetallicRoughness": {"baseColorFactor": [0.2, 0.4, 0.6, 1.0]}}],
  "buffers": [{"byteLength": 44, "uri": ")" +
           bin_name + R"("}],
  "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36},
                  {"buffer": 0, "byteOffset": 36, "byteLength": 6}],
  "accessors": [
    {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
     "min": [0, 0, 0], "max": [1, 1, 0]},
    {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"}
  ]
})";
}

std::string synthetic_gltf_bin() {
    const float positions[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    const std::uint16_t indices[4] = {0, 1, 2, 0};
    std::string bin(sizeof positions + sizeof indices, '\0');
    std::memcpy(bin.data(), positions, sizeof positions);
    std::memcpy(bin.data() + sizeof positions, indices, sizeof indices);
    return bin;
}

/// A Collada quad (0,0,0) (100,0,0) (100,200,0) (0,200,300) in node "Thing" moved by (10,0,0),
/// material "Paint", a camera 5 m behind the origin looking along +Y (Z-up numbers) and a lamp.
std::string synthetic_dae(const std::string& unit_tag, const std::string& up) {
    return R"(<?xml version="1.0" encoding="utf-8"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
  <asset>)" +
           unit_tag + "<up_axis>" + up + R"(</up_axis></asset>
  <library_cameras><camera id="c" name="View"><optics><technique_common><perspective>
    <yfov>40</yfov><aspect_ratio>1.5</aspect_ratio><znear>0.1</znear><zfar>100</zfar>
  </perspective></technique_common></optics></camera></library_cameras>
  <library_lights><light id="l" name="Lamp"><technique_common><point><color>1 1 1</color>
  </point></technique_common></light></library_lights>
  <library_effects><effect id="e"><profile_COMMON><technique sid="t"><lambert>
    <emission><color>0 0 0 1</color></emission>
    <diffuse><color>0.2 0.4 0.6 1</color></diffuse></lambert></technique></profile_COMMON>
  </effect></library_effects>
  <library_materials><material id="m" name="Paint"><instance_effect url="#e"/></material>
  </library_materials>
  <library_geometries><geometry id="g" name="Quad"><mesh>
    <source id="p"><float_array id="pa" count="12">0 0 0 100 0 0 100 200 0 0 200 300</float_array>
      <technique_common><accessor source="#pa" count="4" stride="3"><param name="X" type="float"/>
      <param name="Y" type="float"/><param name="Z" type="float"/></accessor></technique_common>
    </source>
    <vertices id="v"><input semantic="POSITION" source="#p"/></vertices>
    <polylist count="1" material="mat"><input semantic="VERTEX" source="#v" offset="0"/>
      <vcount>4</vcount><p>0 1 2 3</p></polylist>
  </mesh></geometry></library_geometries>
  <library_visual_scenes><visual_scene id="s" name="Scene">
    <node id="n" name="Thing"><translate>10 0 0</translate>
      <instance_geometry url="#g"><bind_material><technique_common>
        <instance_material symbol="mat" target="#m"/></technique_common></bind_material>
      </instance_geometry></node>
    <node id="cn" name="CamNode"><translate>0 -500 100</translate><rotate>1 0 0 90</rotate>
      <instance_camera url="#c"/></node>
    <node id="ln" name="LampNode"><instance_light url="#l"/></node>
  </visual_scene></library_visual_scenes>
  <scene><instance_visual_scene url="#s"/></scene>
</COLLADA>
)";
}

/// An ASCII FBX quad (0,0,0) (1,0,0) (1,2,0) (0,2,3) in model "Quad" moved by (10,0,0).
std::string synthetic_fbx(int up_axis, double unit_scale_factor) {
    return R"(; FBX 7.4.0 project file
FBXHeaderExtension:  {
	FBXHeaderVersion: 1003
	FBXVersion: 7400
	Creator: "abrad test"
}
GlobalSettings:  {
	Version: 1000
	Properties70:  {
		P: "UpAxis", "int", "Integer", "",)" +
           std::to_string(up_axis) + R"(
		P: "UpAxisSign", "int", "Integer", "",1
		P: "FrontAxis", "int", "Integer", "",)" +
           std::to_string(up_axis == 2 ? 1 : 2) + R"(
		P: "FrontAxisSign", "int", "Integer", "",)" +
           (up_axis == 2 ? "-1" : "1") + R"(
		P: "CoordAxis", "int", "Integer", "",0
		P: "CoordAxisSign", "int", "Integer", "",1
		P: "UnitScaleFactor", "double", "Number", "",)" +
           std::to_string(unit_scale_factor) + R"(
	}
}
Objects:  {
	Geometry: 1000, "Geometry::QuadGeo", "Mesh" {
		Vertices: *12 {
			a: 0,0,0,1,0,0,1,2,0,0,2,3
		}
		PolygonVertexIndex: *4 {
			a: 0,1,2,-4
		}
		GeometryVersion: 124
		LayerElementMaterial: 0 {
			Version: 101
			Name: ""
			MappingInformationType: "AllSame"
			ReferenceInformationType: "IndexToDirect"
			Materials: *1 {
				a: 0
			}
		}
		Layer: 0 {
			Version: 100
			LayerElement:  {
				Type: "LayerElementMaterial"
				TypedIndex: 0
			}
		}
	}
	Model: 2000, "Model::Quad", "Mesh" {
		Version: 232
		Properties70:  {
			P: "Lcl Translation", "Lcl Translation", "", "A",10,0,0
		}
	}
	Material: 3000, "Material::Brick", "" {
		Version: 102
		ShadingModel: "lambert"
		Properties70:  {
			P: "DiffuseColor", "Color", "", "A",0.5,0.25,0.125
			P: "EmissiveColor", "Color", "", "A",0,0,0
		}
	}
}
Connections:  {
	C: "OO",2000,0
	C: "OO",1000,2000
	C: "OO",3000,2000
}
)";
}

/// DXF group code / value lines for a 3DFACE on `layer` with corners `pts` (x, y, z each).
std::string dxf_face(const std::string& layer, const std::vector<glm::dvec3>& pts) {
    std::string s = "0\n3DFACE\n8\n" + layer + "\n";
    for (std::size_t i = 0; i < pts.size(); ++i) {
        const std::string k = std::to_string(i);
        std::ostringstream v;
        v << "1" << k << "\n"
          << pts[i].x << "\n2" << k << "\n"
          << pts[i].y << "\n3" << k << "\n"
          << pts[i].z << "\n";
        s += v.str();
    }
    return s;
}

/// Millimetre DXF: a wall on layer Walls, a floor triangle on Floor, block Tile (a 100 mm square
/// on layer 0) inserted at (5000, 6000) scaled 2 and turned 90°, and block Post (base point
/// (10, 10, 0), a face on layer Posts and a nested unscaled Tile at (1000, 0, 0)) inserted at
/// (0, 0, 3000) on layer Misc.
std::string synthetic_dxf() {
    std::string s = "0\nSECTION\n2\nHEADER\n9\n$INSUNITS\n70\n4\n0\nENDSEC\n";
    s += "0\nSECTION\n2\nBLOCKS\n";
    s += "0\nBLOCK\n8\n0\n2\nTile\n70\n0\n10\n0\n20\n0\n30\n0\n3\nTile\n";
    s += dxf_face("0", {{0, 0, 0}, {100, 0, 0}, {100, 100, 0}, {0, 100, 0}});
    s += "0\nENDBLK\n8\n0\n";
    s += "0\nBLOCK\n8\n0\n2\nPost\n70\n0\n10\n10\n20\n10\n30\n0\n3\nPost\n";
    s += dxf_face("Posts", {{10, 10, 0}, {20, 10, 0}, {20, 10, 500}});
    s += "0\nINSERT\n8\n0\n2\nTile\n10\n1000\n20\n0\n30\n0\n";
    s += "0\nENDBLK\n8\n0\n";
    s += "0\nENDSEC\n";
    s += "0\nSECTION\n2\nENTITIES\n";
    s += dxf_face("Walls", {{0, 0, 0}, {1000, 0, 0}, {1000, 0, 2500}, {0, 0, 2500}});
    s += dxf_face("Floor", {{0, 0, 0}, {1000, 0, 0}, {1000, 1000, 0}});
    s += "0\nINSERT\n8\nFloor\n2\nTile\n10\n5000\n20\n6000\n30\n0\n41\n2\n42\n2\n43\n2\n50\n90\n";
    s += "0\nINSERT\n8\nMisc\n2\nPost\n10\n0\n20\n0\n30\n3000\n";
    s += "0\nINSERT\n8\nMisc\n2\nNoSuchBlock\n10\n0\n20\n0\n30\n0\n";
    s += "0\nENDSEC\n0\nEOF\n";
    return s;
}

// ---------------------------------------------------------------------------------------------

TEST(AssimpImport, PlyAsciiAndBinaryCubesAgree) {
    ABRAD_REQUIRE_SHARED_DATA("misc/cube_binary.ply");
    std::vector<std::string> notes;
    const RawModel ascii = read_assimp(kSharedData / "misc/cube.ply", {}, notes);
    const RawModel binary = read_assimp(kSharedData / "misc/cube_binary.ply", {}, notes);
    EXPECT_EQ(ascii.faces.size(), 6U);    // quads
    EXPECT_EQ(binary.faces.size(), 12U);  // triangles
    for (const RawModel* m : {&ascii, &binary}) {
        std::size_t triangles = 0;
        double area = 0.0;
        for (const RawFace& f : m->faces) {
            triangles += f.count - 2;
            area += glm::length(newell(*m, f)) / 2.0;
        }
        EXPECT_EQ(triangles, 12U) << m->file;
        EXPECT_NEAR(area, 6.0, 1e-12) << m->file;
        const Box b = face_box(*m);
        EXPECT_VEC_NEAR(glm::dvec3(0.0), b.lo, 0.0);
        EXPECT_VEC_NEAR(glm::dvec3(1.0), b.hi, 0.0);
        EXPECT_EQ(m->positions.size(), 8U);
        ASSERT_EQ(m->slots.size(), 1U);
        EXPECT_EQ(m->slots[0].material, "default");  // PLY has no materials
        EXPECT_EQ(m->source.format, "ply");
        EXPECT_EQ(m->source.unit, "m");
        EXPECT_EQ(m->source.up_axis, "z");
    }
    // The same eight corners
    std::set<std::tuple<double, double, double>> a;
    std::set<std::tuple<double, double, double>> b;
    for (const glm::dvec3& p : ascii.positions) a.emplace(p.x, p.y, p.z);
    for (const glm::dvec3& p : binary.positions) b.emplace(p.x, p.y, p.z);
    EXPECT_EQ(a, b);
    EXPECT_EQ(binary.slots[0].name, "cube_binary");  // no node or mesh name: the file stem
    EXPECT_EQ(ascii.source.checksum, fnv1a64_hex(read_bytes(kSharedData / "misc/cube.ply")));
    EXPECT_EQ(ascii.source.size_bytes, fs::file_size(kSharedData / "misc/cube.ply"));
}

TEST(AssimpImport, GltfYUpTurnedToZUp) {
    ABRAD_REQUIRE_SHARED_DATA("gltf_bad/BoxTextured-glTF/BoxTextured.gltf");
    // A real file: with up = 'z' nothing turns; by default (glTF is Y up) (x, y, z) -> (x, -z, y)
    const fs::path box = kSharedData / "gltf_bad/BoxTextured-glTF/BoxTextured.gltf";
    std::vector<std::string> notes;
    const RawModel turned = read_assimp(box, {}, notes);
    ImportOptions keep;
    keep.up = 'z';
    const RawModel kept = read_assimp(box, keep, notes);
    EXPECT_EQ(turned.source.up_axis, "y");
    EXPECT_EQ(kept.source.up_axis, "z");
    EXPECT_EQ(turned.source.format, "gltf");
    ASSERT_EQ(turned.positions.size(), 24U);
    ASSERT_EQ(turned.positions.size(), kept.positions.size());
    bool any_moved = false;
    for (std::size_t i = 0; i < kept.positions.size(); ++i) {
        const glm::dvec3& k = kept.positions[i];
        EXPECT_VEC_NEAR(glm::dvec3(k.x, -k.z, k.y), turned.positions[i], 0.0);
        any_moved = any_moved || k != turned.positions[i];
    }
    EXPECT_TRUE(any_moved);
    EXPECT_VEC_NEAR(glm::dvec3(-0.5), face_box(turned).lo, 1e-7);
    EXPECT_VEC_NEAR(glm::dvec3(0.5), face_box(turned).hi, 1e-7);
    EXPECT_EQ(turned.faces.size(), 12U);
    ASSERT_EQ(turned.slots.size(), 1U);
    EXPECT_EQ(turned.slots[0].name, "Mesh");  // unnamed nodes ("nodes[1]"): the mesh name
    EXPECT_EQ(turned.slots[0].material, "Texture");

    // A known coordinate: glTF (0, 1, 0) of node TriA at (10, 0, 0) is (10, 0, 1) Z up
    TempDir dir;
    dir.write("tri.bin", synthetic_gltf_bin());
    const fs::path tri = dir.write("tri.gltf", synthetic_gltf("tri.bin"));
    notes.clear();
    const RawModel m = read_assimp(tri, {}, notes);
    ASSERT_GE(m.faces.size(), 1U);
    EXPECT_EQ(m.slots[m.faces[0].slot].name, "TriA");
    EXPECT_VEC_NEAR(glm::dvec3(10, 0, 0), corner(m, m.faces[0], 0), 0.0);
    EXPECT_VEC_NEAR(glm::dvec3(11, 0, 0), corner(m, m.faces[0], 1), 0.0);
    EXPECT_VEC_NEAR(glm::dvec3(10, 0, 1), corner(m, m.faces[0], 2), 0.0);
    const RawModel z = read_assimp(tri, keep, notes);
    EXPECT_VEC_NEAR(glm::dvec3(10, 1, 0), corner(z, z.faces[0], 2), 0.0);
}

TEST(AssimpImport, GltfInstancesMaterialsCameraLightsPoints) {
    TempDir dir;
    dir.write("tri.bin", synthetic_gltf_bin());
    const fs::path tri = dir.write("tri.gltf", synthetic_gltf("tri.bin"));
    std::vector<std::string> notes;
    const RawModel m = read_assimp(tri, {}, notes);

    // Three instances of one triangle, each where its node puts it
    ASSERT_EQ(m.faces.size(), 3U) << joined(notes);
    EXPECT_EQ(m.positions.size(), 9U);
    std::map<std::string, const RawFace*> by_object;
    for (const RawFace& f : m.faces) by_object[m.slots[f.slot].name] = &f;
    ASSERT_EQ(by_object.size(), 3U);
    ASSERT_TRUE(by_object.count("TriA") && by_object.count("TriB") && by_object.count("Mirror"));
    const RawFace& b = *by_object["TriB"];  // glTF translation (0, 0, -3): y + 3 when Z up
    EXPECT_VEC_NEAR(glm::dvec3(0, 3, 0), corner(m, b, 0), 0.0);
    EXPECT_VEC_NEAR(glm::dvec3(0, 3, 1), corner(m, b, 2), 0.0);
    // Every front faces -y (glTF +z), the mirrored instance too: its corners were reversed
    for (const RawFace& f : m.faces) {
        const glm::dvec3 n = glm::normalize(newell(m, f));
        SCOPED_TRACE(m.slots[f.slot].name);
        EXPECT_VEC_NEAR(glm::dvec3(0, -1, 0), n, 1e-12);
    }
    const Box mirror = face_box(m, [](const RawSlot& s) { return s.name == "Mirror"; });
    EXPECT_VEC_NEAR(glm::dvec3(-6, 0, 0), mirror.lo, 0.0);
    EXPECT_VEC_NEAR(glm::dvec3(-5, 0, 1), mirror.hi, 0.0);

    // Material: PBR base colour and emissive factor
    const visdb::Material* glow = material(m, "Glow");
    ASSERT_NE(glow, nullptr);
    EXPECT_VEC_NEAR(glm::dvec3(0.2, 0.4, 0.6), glow->reflectance, 1e-7);
    EXPECT_VEC_NEAR(glm::dvec3(1.0, 0.5, 0.0), glow->emittance, 1e-7);
    EXPECT_DOUBLE_EQ(glow->opacity, 1.0);
    EXPECT_TRUE(any_note(notes, "'Glow': emissive colour (1, 0.5, 0) taken as emittance in W/m"))
        << joined(notes);

    // Camera at its node (glTF (0, 2, 5)), looking down glTF -Z, yfov 0.8 rad
    ASSERT_EQ(m.cameras.size(), 1U);
    const visdb::Camera& cam = m.cameras[0];
    EXPECT_EQ(cam.name, "Cam");
    EXPECT_VEC_NEAR(glm::dvec3(0, -5, 2), cam.position, 1e-6);
    EXPECT_VEC_NEAR(glm::dvec3(0, -4, 2), cam.look_at, 1e-6);
    EXPECT_VEC_NEAR(glm::dvec3(0, 0, 1), cam.up, 1e-6);
    EXPECT_NEAR(cam.fov_y_deg, 0.8 * 180.0 / 3.14159265358979323846, 1e-4);

    // Points and lights are noted, not imported
    EXPECT_TRUE(any_note(notes, "3 point and 0 line primitive(s) skipped")) << joined(notes);
    EXPECT_TRUE(any_note(notes, "1 light(s) in the file ignored: 'Lamp'")) << joined(notes);
    EXPECT_TRUE(any_note(notes, "declare emitters in the scene file"));

    // Places name the mesh and face
    EXPECT_EQ(m.where(m.faces[1].place), tri.string() + ": mesh 'TriMesh' face 0");
    EXPECT_EQ(m.where(0), tri.string());
    EXPECT_EQ(m.source.checksum, fnv1a64_hex(read_bytes(tri)));
}

TEST(AssimpImport, GltfWithOnlyPointsHasNoFaces) {
    TempDir dir;
    dir.write("tri.bin", synthetic_gltf_bin());
    std::string json = synthetic_gltf("tri.bin");
    json.replace(json.find("[0, 1, 2, 3, 4, 5]"), 18, "[3]");
    const fs::path dots = dir.write("dots.gltf", json);
    expect_import_error(dots, "no faces to import");
}

TEST(AssimpImport, ColladaUnitAndUpAxis) {
    TempDir dir;
    const std::string cm = R"(<unit name="centimeter" meter="0.01"/>)";
    const fs::path z_up = dir.write("z.dae", synthetic_dae(cm, "Z_UP"));
    const fs::path y_up = dir.write("y.dae", synthetic_dae(cm, "Y_UP"));
    std::vector<std::string> notes;

    // Z up, centimetres: Assimp's float 0.01 is corrected to exact metres
    const RawModel z = read_assimp(z_up, {}, notes);
    ASSERT_EQ(z.faces.size(), 1U);
    ASSERT_EQ(z.faces[0].count, 4U);
    EXPECT_VEC_NEAR(glm::dvec3(0.1, 0, 0), corner(z, z.faces[0], 0), 1e-12);
    EXPECT_VEC_NEAR(glm::dvec3(1.1, 0, 0), corner(z, z.faces[0], 1), 1e-12);
    EXPECT_VEC_NEAR(glm::dvec3(1.1, 2, 0), corner(z, z.faces[0], 2), 1e-12);
    EXPECT_VEC_NEAR(glm::dvec3(0.1, 2, 3), corner(z, z.faces[0], 3), 1e-12);
    EXPECT_EQ(z.source.unit, "cm");
    EXPECT_EQ(z.source.up_axis, "z");
    EXPECT_EQ(z.source.format, "dae");
    EXPECT_EQ(z.slots[0].name, "Thing");  // the node's name, not its id
    EXPECT_EQ(z.slots[0].material, "Paint");
    const visdb::Material* paint = material(z, "Paint");
    ASSERT_NE(paint, nullptr);
    EXPECT_VEC_NEAR(glm::dvec3(0.2, 0.4, 0.6), paint->reflectance, 1e-7);

    // Camera: 5 m behind, 1 m up, looking along +y; yfov 40 degrees
    ASSERT_EQ(z.cameras.size(), 1U);
    EXPECT_VEC_NEAR(glm::dvec3(0, -5, 1), z.cameras[0].position, 1e-6);
    EXPECT_VEC_NEAR(glm::dvec3(0, -4, 1), z.cameras[0].look_at, 1e-6);
    EXPECT_VEC_NEAR(glm::dvec3(0, 0, 1), z.cameras[0].up, 1e-6);
    EXPECT_NEAR(z.cameras[0].fov_y_deg, 40.0, 1e-3);
    EXPECT_TRUE(any_note(notes, "1 light(s) in the file ignored")) << joined(notes);

    // Y up: (x, y, z) -> (x, -z, y)
    const RawModel y = read_assimp(y_up, {}, notes);
    EXPECT_VEC_NEAR(glm::dvec3(0.1, -3, 2), corner(y, y.faces[0], 3), 1e-12);
    EXPECT_EQ(y.source.up_axis, "y");

    // A unit given in the options wins over the file's, with a note
    notes.clear();
    ImportOptions mm;
    mm.unit = "mm";
    const RawModel m = read_assimp(z_up, mm, notes);
    EXPECT_VEC_NEAR(glm::dvec3(0.01, 0.2, 0.3), corner(m, m.faces[0], 3), 1e-12);
    EXPECT_EQ(m.source.unit, "mm");
    EXPECT_TRUE(any_note(notes, "declares its unit as cm")) << joined(notes);

    // No <unit>: metres
    const fs::path plain = dir.write("plain.dae", synthetic_dae("", "Z_UP"));
    const RawModel p = read_assimp(plain, {}, notes);
    EXPECT_VEC_NEAR(glm::dvec3(10, 200, 300), corner(p, p.faces[0], 3), 1e-9);
    EXPECT_EQ(p.source.unit, "m");
}

TEST(AssimpImport, FbxUnitScaleFactorAndUpAxis) {
    TempDir dir;
    std::vector<std::string> notes;
    // Z up, UnitScaleFactor 100 (centimetres per unit): metres
    const RawModel z = read_assimp(dir.write("z.fbx", synthetic_fbx(2, 100.0)), {}, notes);
    ASSERT_EQ(z.faces.size(), 1U) << joined(notes);
    EXPECT_VEC_NEAR(glm::dvec3(10, 0, 0), corner(z, z.faces[0], 0), 1e-12);
    EXPECT_VEC_NEAR(glm::dvec3(10, 2, 3), corner(z, z.faces[0], 3), 1e-12);
    EXPECT_EQ(z.source.unit, "m");
    EXPECT_EQ(z.source.up_axis, "z");
    EXPECT_EQ(z.slots[0].name, "Quad");
    EXPECT_EQ(z.slots[0].material, "Brick");
    const visdb::Material* brick = material(z, "Brick");
    ASSERT_NE(brick, nullptr);
    EXPECT_VEC_NEAR(glm::dvec3(0.5, 0.25, 0.125), brick->reflectance, 1e-7);

    // Y up, UnitScaleFactor 1: centimetres, turned to Z up
    const RawModel y = read_assimp(dir.write("y.fbx", synthetic_fbx(1, 1.0)), {}, notes);
    ASSERT_EQ(y.faces.size(), 1U);
    EXPECT_VEC_NEAR(glm::dvec3(0.10, -0.03, 0.02), corner(y, y.faces[0], 3), 1e-12);
    EXPECT_EQ(y.source.unit, "cm");
    EXPECT_EQ(y.source.up_axis, "y");
}

TEST(AssimpImport, StlAndOff) {
    TempDir dir;
    const fs::path stl = dir.write("t.stl",
                                   "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\n"
                                   "vertex 2 0 0\nvertex 0 3 0\nendloop\nendfacet\nendsolid t\n");
    const fs::path off = dir.write("q.off", "OFF\n4 1 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n");
    std::vector<std::string> notes;
    const RawModel s = read_assimp(stl, {}, notes);
    ASSERT_EQ(s.faces.size(), 1U);
    EXPECT_NEAR(glm::length(newell(s, s.faces[0])) / 2.0, 3.0, 1e-12);
    EXPECT_EQ(s.source.format, "stl");
    const RawModel o = read_assimp(off, {}, notes);
    ASSERT_EQ(o.faces.size(), 1U);
    EXPECT_EQ(o.faces[0].count, 4U);  // the quad is not triangulated
    ImportOptions ft;
    ft.unit = "ft";
    const RawModel of = read_assimp(off, ft, notes);
    EXPECT_VEC_NEAR(glm::dvec3(0.3048, 0.3048, 0), face_box(of).hi, 1e-15);
    EXPECT_EQ(of.source.unit, "ft");
}

TEST(AssimpImport, DxfSharedFiles) {
    ABRAD_REQUIRE_SHARED_DATA("dxf");
    std::vector<std::string> notes;
    // 3dface.dxf: $INSUNITS 4 (millimetres), 44 3DFACEs in ENTITIES (two more in an unused
    // block), flat at z = 0
    const RawModel faces = read_assimp(kSharedData / "dxf/3dface.dxf", {}, notes);
    EXPECT_EQ(faces.faces.size(), 44U);
    EXPECT_EQ(faces.source.unit, "mm");
    EXPECT_EQ(faces.source.up_axis, "z");
    const Box fb = face_box(faces);
    EXPECT_VEC_NEAR(glm::dvec3(0.689843, 0.243863, 0), fb.lo, 1e-6);
    EXPECT_VEC_NEAR(glm::dvec3(4.91944, 3.85768, 0), fb.hi, 1e-5);
    ASSERT_EQ(faces.slots.size(), 1U);
    EXPECT_EQ(faces.slots[0].layer, "0");
    EXPECT_EQ(faces.slots[0].material, "default");

    // PinkEggFromLW.dxf: no header, 288 quads, Z up, metres
    const RawModel egg = read_assimp(kSharedData / "dxf/PinkEggFromLW.dxf", {}, notes);
    EXPECT_EQ(egg.faces.size(), 288U);
    EXPECT_EQ(egg.source.unit, "m");
    EXPECT_VEC_NEAR(glm::dvec3(-2.15, -2.1, -2.5), face_box(egg).lo, 1e-6);
    EXPECT_VEC_NEAR(glm::dvec3(2.15, 2.1, 2.6), face_box(egg).hi, 1e-6);

    // issue_2229.dxf: inches; four polyface meshes with point and line records
    notes.clear();
    const RawModel polyface = read_assimp(kSharedData / "dxf/issue_2229.dxf", {}, notes);
    EXPECT_EQ(polyface.faces.size(), 1132U);
    EXPECT_EQ(polyface.source.unit, "in");
    EXPECT_NEAR(face_box(polyface).hi.x, 600 * 0.0254, 1e-9);
    EXPECT_TRUE(any_note(notes, "140 point and 17 line primitive(s) skipped")) << joined(notes);

    // wuson.dxf: a polyface mesh in block Mesh (layer Meshes) placed by an INSERT at the origin
    const RawModel wuson = read_assimp(kSharedData / "dxf/wuson.dxf", {}, notes);
    EXPECT_EQ(wuson.faces.size(), 3732U);
    ASSERT_EQ(wuson.slots.size(), 1U);
    EXPECT_EQ(wuson.slots[0].layer, "Meshes");
    EXPECT_EQ(wuson.slots[0].name, "Meshes");
    EXPECT_VEC_NEAR(glm::dvec3(-0.459976, -0.000566, -1.62224), face_box(wuson).lo, 1e-5);
    EXPECT_VEC_NEAR(glm::dvec3(0.459976, 1.51525, 1.62224), face_box(wuson).hi, 1e-5);
}

TEST(AssimpImport, DxfInsertsPlacedScaledTurnedAndNested) {
    TempDir dir;
    const fs::path file = dir.write("blocks.dxf", synthetic_dxf());
    std::vector<std::string> notes;
    const RawModel m = read_assimp(file, {}, notes);
    EXPECT_EQ(m.source.unit, "mm");
    std::map<std::string, std::size_t> faces_per_layer;
    for (const RawFace& f : m.faces) ++faces_per_layer[m.slots[f.slot].layer];
    EXPECT_EQ(faces_per_layer["Walls"], 1U);
    EXPECT_EQ(faces_per_layer["Floor"], 2U);  // the floor triangle and the Tile on layer 0
    EXPECT_EQ(faces_per_layer["Posts"], 1U);
    EXPECT_EQ(faces_per_layer["Misc"], 1U);  // the nested Tile takes the outer INSERT's layer

    const auto layer_box = [&m](const std::string& layer) {
        return face_box(m, [&layer](const RawSlot& s) { return s.layer == layer; });
    };
    EXPECT_VEC_NEAR(glm::dvec3(0, 0, 0), layer_box("Walls").lo, 1e-9);
    EXPECT_VEC_NEAR(glm::dvec3(1, 0, 2.5), layer_box("Walls").hi, 1e-9);
    // Tile: (5000, 6000) + turn 90° of 2 × [0, 100]²: x in [4800, 5000], y in [6000, 6200]
    const Box tile = face_box(m, [](const RawSlot& s) { return s.layer == "Floor"; });
    EXPECT_VEC_NEAR(glm::dvec3(0, 0, 0), tile.lo, 1e-9);  // with the floor triangle
    bool found_tile = false;
    for (const RawFace& f : m.faces) {
        if (m.slots[f.slot].layer != "Floor" || f.count != 4) continue;
        found_tile = true;
        Box b;
        for (std::size_t k = 0; k < 4; ++k) b.add(corner(m, f, k));
        EXPECT_VEC_NEAR(glm::dvec3(4.8, 6.0, 0), b.lo, 1e-6);
        EXPECT_VEC_NEAR(glm::dvec3(5.0, 6.2, 0), b.hi, 1e-6);
        // The turn keeps the corner order: (0,0) -> (5000,6000), (100,0) -> (5000,6200)
        EXPECT_VEC_NEAR(glm::dvec3(5.0, 6.0, 0), corner(m, f, 0), 1e-6);
        EXPECT_VEC_NEAR(glm::dvec3(5.0, 6.2, 0), corner(m, f, 1), 1e-6);
    }
    EXPECT_TRUE(found_tile);
    // Post: base point (10, 10, 0) moved to (0, 0, 3000)
    EXPECT_VEC_NEAR(glm::dvec3(0, 0, 3.0), layer_box("Posts").lo, 1e-6);
    EXPECT_VEC_NEAR(glm::dvec3(0.01, 0, 3.5), layer_box("Posts").hi, 1e-6);
    // Nested Tile: (1000, 0, 0) in Post, minus Post's base point, plus (0, 0, 3000)
    EXPECT_VEC_NEAR(glm::dvec3(0.99, -0.01, 3.0), layer_box("Misc").lo, 1e-6);
    EXPECT_VEC_NEAR(glm::dvec3(1.09, 0.09, 3.0), layer_box("Misc").hi, 1e-6);
    // An INSERT of a block that does not exist is noted with its line
    EXPECT_TRUE(any_note(notes, "INSERT of undefined block 'NoSuchBlock' ignored"))
        << joined(notes);
    EXPECT_TRUE(any_note(notes, file.string() + ":")) << joined(notes);
}

// Issue 19: MINSERT counts whose product overflows 64 bits (2^32 x 2^32 wrapped to 0 and
// passed the copy limit, then the loop ran 2^64 times) are too many copies: noted, ignored
TEST(AssimpImport, DxfMinsertCountOverflowIsIgnored) {
    TempDir dir;
    std::string s = "0\nSECTION\n2\nBLOCKS\n";
    s += "0\nBLOCK\n8\n0\n2\nTile\n70\n0\n10\n0\n20\n0\n30\n0\n";
    s += dxf_face("0", {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}});
    s += "0\nENDBLK\n8\n0\n0\nENDSEC\n";
    s += "0\nSECTION\n2\nENTITIES\n";
    s += dxf_face("Floor", {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}});
    s += "0\nINSERT\n8\nMisc\n2\nTile\n70\n4294967296\n71\n4294967296\n";
    s += "0\nINSERT\n8\nMisc\n2\nTile\n70\n9223372036854775807\n71\n2\n";
    s += "0\nENDSEC\n0\nEOF\n";
    const fs::path file = dir.write("overflow.dxf", s);
    std::vector<std::string> notes;
    const RawModel m = read_assimp(file, {}, notes);
    EXPECT_EQ(m.faces.size(), 1U);
    EXPECT_TRUE(any_note(notes, "too many copies ignored")) << joined(notes);
}

// Issue 19: nested MINSERTs asking for 10^10 faces in a few hundred bytes are refused, naming
// the INSERT's line and handle, before anything is expanded
TEST(AssimpImport, DxfInsertBombIsRefusedBeforeExpanding) {
    TempDir dir;
    const std::string s = abrad::testing::dxf_insert_bomb("2A");
    const fs::path file = dir.write("bomb.dxf", s);
    expect_import_error(file, "(handle 2A) expands the blocks to more than 5000000 entities");
    // The line of the INSERT (its "0" code line)
    expect_import_error(file, file.string() + ":" +
                                  std::to_string(abrad::testing::line_of(s, "0\nINSERT\n5\n2A")) +
                                  ": INSERT of block 'B2'");
}

TEST(AssimpImport, IfcFzkHaus) {
    ABRAD_REQUIRE_SHARED_DATA("ifc/AC14-FZK-Haus.ifc");
    const fs::path file = kSharedData / "ifc/AC14-FZK-Haus.ifc";
    std::vector<std::string> notes;
    const auto t0 = std::chrono::steady_clock::now();
    const RawModel m = read_assimp(file, {}, notes);
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    RecordProperty("read_seconds", std::to_string(seconds));
    EXPECT_GT(m.faces.size(), 10000U);
    EXPECT_EQ(m.source.unit, "m");
    EXPECT_EQ(m.source.up_axis, "z");
    EXPECT_EQ(m.source.format, "ifc");

    // Layers are IFC entity types, objects the products' names
    std::set<std::string> layers;
    std::set<std::string> objects;
    for (const RawSlot& s : m.slots) {
        layers.insert(s.layer);
        objects.insert(s.name);
    }
    for (const char* type : {"IfcWallStandardCase", "IfcSlab", "IfcWindow", "IfcDoor", "IfcBeam",
                             "IfcStair", "IfcSite", "IfcFurnishingElement"}) {
        EXPECT_EQ(layers.count(type), 1U) << type;
    }
    EXPECT_EQ(layers.count("IfcOpeningElement"), 0U);  // openings are holes, not faces
    EXPECT_GE(objects.size(), 50U);
    EXPECT_EQ(objects.count("Wand-Ext-ERDG-1"), 1U);
    EXPECT_EQ(objects.count("EG-Fenster-6"), 1U);
    EXPECT_NE(material(m, "Anstrich"), nullptr);
    EXPECT_NE(material(m, "Glas"), nullptr);

    // The house without its terrain: 13 m × 11 m with the roof overhang, 6.3 m to the ridge,
    // the ground floor slab from -0.2 to 0; the terrain plate 18 m × 16 m, 1 m thick
    const Box house = face_box(m, [](const RawSlot& s) { return s.layer != "IfcSite"; });
    EXPECT_VEC_NEAR(glm::dvec3(-0.5, -0.5, -0.2), house.lo, 1e-6);
    EXPECT_VEC_NEAR(glm::dvec3(12.5, 10.5, 6.31769), house.hi, 1e-4);
    const Box site = face_box(m, [](const RawSlot& s) { return s.layer == "IfcSite"; });
    EXPECT_VEC_NEAR(glm::dvec3(-3, -3, -1), site.lo, 1e-6);
    EXPECT_VEC_NEAR(glm::dvec3(15, 13, 0), site.hi, 1e-6);
    const Box walls =
        face_box(m, [](const RawSlot& s) { return s.layer == "IfcWallStandardCase"; });
    EXPECT_VEC_NEAR(glm::dvec3(0, 0, 0), walls.lo, 1e-6);

    // Walls are vertical: every face of a ground floor ("ERDG") wall is vertical or horizontal
    // to float precision (upper floor gable walls have sloped tops)
    std::size_t vertical = 0;
    std::size_t horizontal = 0;
    std::size_t ground_slab_top = 0;
    for (const RawFace& f : m.faces) {
        const RawSlot& s = m.slots[f.slot];
        const glm::dvec3 n = glm::normalize(newell(m, f));
        if (s.layer == "IfcWallStandardCase" && s.name.find("ERDG") != std::string::npos) {
            if (std::abs(n.z) < 1e-6)
                ++vertical;
            else if (std::abs(std::abs(n.z) - 1.0) < 1e-9)
                ++horizontal;
            else
                ADD_FAILURE() << m.where(f.place) << " is neither vertical nor horizontal";
        }
        if (s.layer == "IfcSlab" && n.z > 1.0 - 1e-9) {
            const double z = corner(m, f, 0).z;
            if (std::abs(z) < 1e-6) ++ground_slab_top;
        }
    }
    EXPECT_GT(vertical, 100U);
    EXPECT_GT(horizontal, 10U);
    EXPECT_GE(ground_slab_top, 1U);
}

TEST(AssimpImport, ThreeDsFiles) {
    ABRAD_REQUIRE_SHARED_DATA("misc/fels.3ds");
    std::vector<std::string> notes;
    const RawModel test1 = read_assimp(kSharedData / "misc/test1.3ds", {}, notes);
    EXPECT_EQ(test1.faces.size(), 108U);
    std::set<std::string> objects;
    for (const RawSlot& s : test1.slots) objects.insert(s.name);
    EXPECT_EQ(objects, (std::set<std::string>{"Box01", "Box02", "Box04", "Box05", "Box06", "Box07",
                                              "Box08", "Box09", "Box10"}));
    const visdb::Material* mat = material(test1, "1 - Default");
    ASSERT_NE(mat, nullptr);
    EXPECT_NEAR(mat->reflectance.x, 150.0 / 255.0, 1e-6);
    EXPECT_EQ(test1.source.up_axis, "z");
    EXPECT_VEC_NEAR(glm::dvec3(-10.3432, -0.194163, -10.1551), face_box(test1).lo, 1e-4);
    EXPECT_VEC_NEAR(glm::dvec3(9.85085, 10.2303, 10.2476), face_box(test1).hi, 1e-4);

    const RawModel fels = read_assimp(kSharedData / "misc/fels.3ds", {}, notes);
    EXPECT_EQ(fels.faces.size(), 768U);
    ASSERT_EQ(fels.slots.size(), 1U);
    EXPECT_EQ(fels.slots[0].name, "fels");  // no object name in the file: the stem
    EXPECT_EQ(fels.slots[0].material, "Default");
    // Assimp's Z-up -> Y-up root rotation is undone: the file's own numbers come back
    ImportOptions y;
    y.up = 'y';
    const RawModel fels_y = read_assimp(kSharedData / "misc/fels.3ds", y, notes);
    ASSERT_EQ(fels.positions.size(), fels_y.positions.size());
    for (std::size_t i = 0; i < fels.positions.size(); ++i) {
        const glm::dvec3& p = fels.positions[i];
        EXPECT_VEC_NEAR(glm::dvec3(p.x, -p.z, p.y), fels_y.positions[i], 1e-12);
    }
}

TEST(AssimpImport, BadGltfFilesThrowOrImport) {
    ABRAD_REQUIRE_SHARED_DATA("gltf_bad");
    const fs::path dir = kSharedData / "gltf_bad";
    std::vector<std::string> notes;
    // Bad normals: normals are not read, so the box imports as it is
    const RawModel normals =
        read_assimp(dir / "BoxBadNormals-glTF-Binary/BoxBadNormals.glb", {}, notes);
    EXPECT_EQ(normals.faces.size(), 12U);
    EXPECT_EQ(normals.source.format, "glb");
    expect_import_error(dir / "BoxWithInfinites-glTF-Binary/BoxWithInfinites.glb",
                        "mesh 'Mesh' vertex 0: coordinates are not finite");
    expect_import_error(dir / "IndexOutOfRange/IndexOutOfRange.gltf", "out of range");
    expect_import_error(dir / "IndexOutOfRange/AllIndicesOutOfRange.gltf", "cannot read");
}

TEST(AssimpImport, MissingEmptyDirectoryAndNonModelFiles) {
    TempDir dir;
    expect_import_error(dir.path() / "nothing.glb", "no such file");
    fs::create_directories(dir.path() / "folder.dxf");
    expect_import_error(dir.path() / "folder.dxf", "is a directory");
    expect_import_error(dir.write("empty.ifc", ""), "empty file");
    const std::string text = "This is a shopping list, not a model.\nmilk\nbread\n";
    expect_import_error(dir.write("list.dxf", text), "");
    expect_import_error(dir.write("list.glb", text), "");
    expect_import_error(dir.write("list.ifc", text), "");
    expect_import_error(dir.write("list.xyz", text), "cannot read");
    // Truncated binary glTF (the rest of the test runs without the shared data)
    ABRAD_REQUIRE_SHARED_DATA("gltf_bad/BoxBadNormals-glTF-Binary/BoxBadNormals.glb");
    const std::string glb =
        read_bytes(kSharedData / "gltf_bad/BoxBadNormals-glTF-Binary/BoxBadNormals.glb");
    expect_import_error(dir.write("cut.glb", glb.substr(0, glb.size() / 2)), "");
}

TEST(AssimpImport, DamagedFilesNameTheirPlace) {
    TempDir dir;
    const std::string header =
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
        "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
    const std::string points = "0 0 0\n1 0 0\n0 1 0\n";
    std::vector<std::string> notes;
    const RawModel ok = read_assimp(dir.write("ok.ply", header + points + "3 0 1 2\n"), {}, notes);
    EXPECT_EQ(ok.faces.size(), 1U);
    const fs::path index = dir.write("index.ply", header + points + "3 0 1 9\n");
    expect_import_error(index, "index.ply:13: PLY: vertex index '9' out of range (3 vertices)");
    expect_import_error(dir.write("short.ply", header + points), "file ends in element 'face'");
    expect_import_error(dir.write("word.ply", header + "0 0 zero\n"),
                        "word.ply:10: PLY: missing or malformed number");
    // Binary: a list count running past the end
    std::string binary =
        "ply\nformat binary_little_endian 1.0\nelement vertex 3\n"
        "property float x\nproperty float y\nproperty float z\n"
        "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
    binary += std::string(36, '\0');
    binary += static_cast<char>(200);
    binary += std::string(12, '\0');
    expect_import_error(dir.write("count.ply", binary), "list count 200 in element 'face' 0");

    // DXF: a broken group code names its line; a missing EOF is noted
    const std::string dxf = synthetic_dxf();
    std::string bad = dxf;
    bad.replace(bad.find("\n10\n0\n20\n0\n30\n0\n3\nTile"), 4, "\nxy\n");
    expect_import_error(dir.write("code.dxf", bad), "DXF group code 'xy' is not a group code");
    notes.clear();
    const std::string no_eof = dxf.substr(0, dxf.rfind("0\nEOF"));
    const RawModel partial = read_assimp(dir.write("cut.dxf", no_eof), {}, notes);
    EXPECT_FALSE(partial.faces.empty());
    EXPECT_TRUE(any_note(notes, "no EOF at the end of the file")) << joined(notes);

    // IFC: a file cut short
    expect_import_error(dir.write("cut.ifc", "ISO-10303-21;\nHEADER;\n"), "truncated file");
}

/// A 3DS chunk: its id, its length (the 6-byte header counted) and its body, little endian.
std::string chunk_3ds(std::uint16_t id, const std::string& body) {
    std::string s;
    const auto put = [&](std::uint64_t v, int bytes) {
        for (int b = 0; b < bytes; ++b) s += static_cast<char>((v >> (8 * b)) & 0xFF);
    };
    put(id, 2);
    put(6 + body.size(), 4);
    return s + body;
}

/// One triangle (0,0,0) (1,0,0) (0,1,0) in object "Tri": main > version, editor > object >
/// mesh > vertices (at byte 38), faces.
std::string synthetic_3ds() {
    std::string vertices = std::string("\x03\x00", 2);
    for (const float x : {0.0F, 0.0F, 0.0F, 1.0F, 0.0F, 0.0F, 0.0F, 1.0F, 0.0F}) {
        char b[4];
        std::memcpy(b, &x, 4);
        vertices.append(b, 4);
    }
    const std::string faces = std::string("\x01\x00\x00\x00\x01\x00\x02\x00\x00\x00", 10);
    const std::string mesh = chunk_3ds(0x4110, vertices) + chunk_3ds(0x4120, faces);
    const std::string object = chunk_3ds(0x4000, std::string("Tri\0", 4) + chunk_3ds(0x4100, mesh));
    return chunk_3ds(
        0x4D4D, chunk_3ds(0x0002, std::string("\x03\x00\x00\x00", 4)) + chunk_3ds(0x3D3D, object));
}

/// Line (1-based) of the first occurrence of `part` in `text`.
std::size_t line_of(const std::string& text, const std::string& part) {
    const std::size_t at = text.find(part);
    return static_cast<std::size_t>(std::count(text.begin(), text.begin() + at, '\n')) + 1;
}

// Issue 19: Assimp's messages name no place ("Unable to read file, malformed XML", "Chunk is
// too large", "Cannot parse string "abc" as a real number"). Broken files of each format
// are refused at their line (Collada, DXF, PLY) or byte (3DS), and every refusal names the
// file and the format.
TEST(AssimpImport, BrokenFilesOfEachFormatNameTheirPlaceAndFormat) {
    TempDir dir;
    const std::string dae = synthetic_dae("", "Z_UP");
    // Collada: cut in the middle of an element, a mismatched tag, an index past the vertices
    const std::string cut = dae.substr(0, dae.find("<library_geometries>") + 30);
    const std::size_t cut_lines = line_of(cut + "\x01", "\x01");
    expect_import_error(dir.write("cut.dae", cut),
                        "cut.dae:" + std::to_string(cut_lines) + ": column ");
    expect_import_error(dir.write("cut2.dae", cut), "not well-formed Collada XML (");
    std::string tag = dae;
    tag.replace(tag.find("</vcount>"), 9, "</count>");
    expect_import_error(dir.write("tag.dae", tag),
                        "tag.dae:" + std::to_string(line_of(dae, "</vcount>")) +
                            ": column 18: not well-formed Collada XML (mismatched tag)");
    std::string index = dae;
    index.replace(index.find("<p>0 1 2 3</p>"), 14, "<p>0 1 2 7</p>");
    expect_import_error(dir.write("index.dae", index), "cannot read as Collada: ");

    // 3DS: the file cut short (the main chunk claims more), a damaged inner length
    const std::string tds = synthetic_3ds();
    std::vector<std::string> notes;
    EXPECT_EQ(read_assimp(dir.write("ok.3ds", tds), {}, notes).faces.size(), 1U);
    expect_import_error(dir.write("cut.3ds", tds.substr(0, tds.size() - 10)),
                        "cut.3ds: 3DS: byte 0: chunk 0x4D4D claims 98 bytes, the file has 88");
    std::string inner = tds;
    inner[40] = '\x40';  // the vertex chunk's length 0x2C becomes 0x010040
    inner[42] = '\x01';
    expect_import_error(
        dir.write("inner.3ds", inner),
        "inner.3ds: 3DS: byte 38: chunk 0x4110 claims 65600 bytes, the file has 60");

    // DXF: a coordinate that is not a number, at its line
    std::string dxf = synthetic_dxf();
    const std::string wall = "3DFACE\n8\nWalls\n10\n0\n";
    const std::size_t value = dxf.find(wall) + wall.size() - 2;
    dxf.replace(value, 1, "abc");
    expect_import_error(dir.write("word.dxf", dxf),
                        "word.dxf:" + std::to_string(line_of(dxf, "\nabc\n") + 1) +
                            ": cannot read as DXF: Cannot parse string \"abc\" as a real number");

    // PLY: an ASCII file cut in its faces, a binary one cut in its vertices
    const std::string header =
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
        "property float z\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n";
    expect_import_error(dir.write("cut.ply", header + "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"),
                        "cut.ply: PLY: file ends in element 'face' 1 of 2");
    std::string binary = header;
    binary.replace(binary.find("ascii"), 5, "binary_little_endian");
    expect_import_error(dir.write("cut_binary.ply", binary + std::string(20, '\0')),
                        "cut_binary.ply: PLY: file ends in element 'vertex' 1 of 3");
}

TEST(AssimpImport, InvalidOptions) {
    ABRAD_REQUIRE_SHARED_DATA("misc/cube.ply");
    std::vector<std::string> notes;
    ImportOptions unit;
    unit.unit = "furlong";
    EXPECT_THROW((void)read_assimp(kSharedData / "misc/cube.ply", unit, notes),
                 std::invalid_argument);
    ImportOptions up;
    up.up = 'x';
    EXPECT_THROW((void)read_assimp(kSharedData / "misc/cube.ply", up, notes),
                 std::invalid_argument);
}

/// Every file of the shared data (and truncated copies of the model files) either gives
/// polygons or an ImportError naming it; nothing else escapes, nothing crashes.
TEST(AssimpImport, EverySharedFileGivesPolygonsOrImportError) {
    ABRAD_REQUIRE_SHARED_DATA("");
    TempDir dir;
    std::size_t files = 0;
    std::size_t imported = 0;
    const auto check = [&](const fs::path& p) {
        std::vector<std::string> notes;
        try {
            const RawModel m = read_assimp(p, {}, notes);
            EXPECT_FALSE(m.faces.empty()) << p;
            for (const glm::dvec3& q : m.positions) {
                ASSERT_TRUE(std::isfinite(q.x) && std::isfinite(q.y) && std::isfinite(q.z)) << p;
            }
            for (const std::uint32_t c : m.corners) ASSERT_LT(c, m.positions.size()) << p;
            for (const RawFace& f : m.faces) {
                ASSERT_GE(f.count, 3U) << p;
                ASSERT_LE(f.first + f.count, m.corners.size()) << p;
                ASSERT_LT(f.slot, m.slots.size()) << p;
            }
            ++imported;
        } catch (const ImportError& e) {
            EXPECT_NE(std::string(e.what()).find(p.string()), std::string::npos) << e.what();
        } catch (const std::exception& e) {
            ADD_FAILURE() << p << ": unexpected exception " << e.what();
        }
    };
    std::vector<fs::path> paths;
    for (const auto& entry : fs::recursive_directory_iterator(kSharedData)) {
        if (entry.is_regular_file()) paths.push_back(entry.path());
    }
    std::sort(paths.begin(), paths.end());
    for (const fs::path& p : paths) {
        const std::string ext = p.extension().string();
        const std::string name = p.filename().string();
        if (ext == ".mtl" || ext == ".txt" || ext == ".md" || name.starts_with("LICENSE")) continue;
        ++files;
        check(p);
        // Truncated copies of the model files (the 4 MB IFC once, at its half)
        if (ext == ".png" || ext == ".bin") continue;
        const std::string bytes = read_bytes(p);
        if (bytes.size() > 1'000'000) {
            expect_import_error(dir.write("half_" + name, bytes.substr(0, bytes.size() / 2)),
                                "truncated file");
            continue;
        }
        for (std::size_t k = 1; k < 8; ++k) {
            const std::size_t keep = bytes.size() * k / 8;
            check(dir.write("cut_" + std::to_string(keep) + "_" + name, bytes.substr(0, keep)));
        }
    }
    EXPECT_GE(files, 20U);
    EXPECT_GE(imported, 15U);
}

}  // namespace
}  // namespace abrad::convert::detail
