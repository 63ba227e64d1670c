// Tests of the OBJ/MTL importer: geometry and materials, triangulation, healing counts, and
// errors that name the file and line.

#include "abrad/convert/obj_import.h"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <glm/geometric.hpp>
#include <glm/vec2.hpp>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "shared_data.h"
#include "temp_dir.h"

namespace abrad::convert {
namespace {

namespace fs = std::filesystem;

const fs::path kSharedData = abrad::testing::shared_data();

using ::abrad::testing::TempDir;

double triangle_area(const visdb::TriangleMesh& mesh, const glm::u32vec3& t) {
    return 0.5 * glm::length(glm::cross(mesh.positions[t.y] - mesh.positions[t.x],
                                        mesh.positions[t.z] - mesh.positions[t.x]));
}

glm::dvec3 triangle_normal(const visdb::TriangleMesh& mesh, const glm::u32vec3& t) {
    return glm::cross(mesh.positions[t.y] - mesh.positions[t.x],
                      mesh.positions[t.z] - mesh.positions[t.x]);
}

const visdb::Material* find_material(const visdb::Scene& scene, const std::string& name) {
    for (const auto& m : scene.materials) {
        if (m.name == name) return &m;
    }
    return nullptr;
}

bool has_note(const ImportReport& report, const std::string& needle) {
    for (const auto& n : report.notes) {
        if (n.find(needle) != std::string::npos) return true;
    }
    return false;
}

std::string fnv1a64(const std::string& bytes) {
    std::uint64_t h = 0xcbf29ce484222325ULL;
    for (const char c : bytes) {
        h ^= static_cast<unsigned char>(c);
        h *= 0x100000001b3ULL;
    }
    char buf[17];
    std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(h));
    return buf;
}

/// Imports `path` expecting an ImportError at `file`:`line` whose message contains `needle`.
void expect_error(const fs::path& path, const ImportOptions& options, const fs::path& file,
                  std::size_t line, const std::string& needle) {
    try {
        (void)import_obj(path, options);
        ADD_FAILURE() << "no ImportError for " << path;
    } catch (const ImportError& e) {
        const std::string what = e.what();
        EXPECT_EQ(e.file(), file.string());
        EXPECT_EQ(e.line(), line) << what;
        const std::string prefix =
            line > 0 ? file.string() + ":" + std::to_string(line) + ":" : file.string() + ": ";
        EXPECT_EQ(what.rfind(prefix, 0), 0u) << what;
        EXPECT_NE(what.find(needle), std::string::npos) << what;
    }
}

void expect_error(const fs::path& path, std::size_t line, const std::string& needle) {
    expect_error(path, ImportOptions{}, path, line, needle);
}

TEST(ObjImport, QuadWithMtlInMillimetresYUp) {
    TempDir dir;
    dir.write("quad.mtl",
              "# a lamp\n"
              "newmtl lamp\n"
              "  Kd 0.2 0.4 0.6\n"
              "  Ke 10 20 30\n"
              "  Tr 0.5\n"
              "  d 0.75\n"
              "  Ka 0 0 0 # ignored\n"
              "  map_Kd lamp.png\n");
    const std::string obj =
        "mtllib quad.mtl\n"
        "v 0 0 0\n"
        "v 1000 0 0\n"
        "v 1000 0 -1234\n"
        "v 0 0 -1234\n"
        "o lamp_panel\n"
        "usemtl lamp\n"
        "f 1 2 3 4\n";
    const fs::path path = dir.write("quad.obj", obj);
    const ImportResult r = import_obj(path, {.unit = "mm", .up = 'y'});

    EXPECT_EQ(r.report.faces_read, 1u);
    EXPECT_EQ(r.report.triangles, 2u);
    EXPECT_EQ(r.report.polygons_triangulated, 1u);
    EXPECT_EQ(r.report.emitter_triangles, 2u);
    EXPECT_EQ(r.report.vertices_welded, 0u);
    EXPECT_EQ(r.scene.triangle_count(), 2u);
    ASSERT_EQ(r.scene.surfaces.size(), 1u);
    const visdb::Surface& s = r.scene.surfaces[0];
    EXPECT_EQ(s.name, "lamp_panel");
    EXPECT_EQ(s.layer, "");

    ASSERT_EQ(r.scene.materials.size(), 1u);
    const visdb::Material& m = r.scene.materials[s.material];
    EXPECT_EQ(m.name, "lamp");
    EXPECT_EQ(m.reflectance, visdb::Rgb(0.2, 0.4, 0.6));
    EXPECT_EQ(m.emittance, visdb::Rgb(10.0, 20.0, 30.0));
    EXPECT_EQ(m.opacity, 0.75);  // d wins over Tr whatever their order
    EXPECT_TRUE(m.is_emitter());

    // mm -> m exactly, Y up -> Z up: (x, y, z) -> (x, -z, y)
    ASSERT_EQ(s.mesh.positions.size(), 4u);
    std::vector<glm::dvec3> expected = {
        {0.0, 0.0, 0.0}, {1.0, 0.0, 0.0}, {1.0, 1.234, 0.0}, {0.0, 1.234, 0.0}};
    for (const auto& e : expected) {
        EXPECT_NE(std::find(s.mesh.positions.begin(), s.mesh.positions.end(), e),
                  s.mesh.positions.end())
            << e.x << " " << e.y << " " << e.z;
    }
    // The file's counter-clockwise front faces +Y in the file, so +Z here
    double area = 0.0;
    for (const auto& t : s.mesh.triangles) {
        const glm::dvec3 n = glm::normalize(triangle_normal(s.mesh, t));
        EXPECT_NEAR(n.z, 1.0, 1e-12);
        area += triangle_area(s.mesh, t);
    }
    EXPECT_NEAR(area, 1.234, 1e-12);

    ASSERT_EQ(r.scene.sources.size(), 1u);
    const visdb::Source& src = r.scene.sources[0];
    EXPECT_EQ(src.path, path.string());
    EXPECT_EQ(src.format, "obj");
    EXPECT_EQ(src.checksum, fnv1a64(obj));
    EXPECT_EQ(src.checksum.size(), 16u);
    EXPECT_EQ(src.size_bytes, obj.size());
    EXPECT_EQ(src.unit, "mm");
    EXPECT_EQ(src.up_axis, "y");
    EXPECT_EQ(src.imported_at.size(), 20u) << src.imported_at;  // 2024-01-02T03:04:05Z
    EXPECT_EQ(src.imported_at.back(), 'Z');
    EXPECT_EQ(src.report, r.report.to_string());
    EXPECT_NE(src.report.find("emitter triangles: 2"), std::string::npos) << src.report;
}

TEST(ObjImport, UnitsAndOptions) {
    EXPECT_EQ(metres_per_unit("mm"), 0.001);
    EXPECT_EQ(metres_per_unit("cm"), 0.01);
    EXPECT_EQ(metres_per_unit("m"), 1.0);
    EXPECT_EQ(metres_per_unit("in"), 0.0254);
    EXPECT_EQ(metres_per_unit("ft"), 0.3048);
    EXPECT_THROW(metres_per_unit("yd"), std::invalid_argument);

    TempDir dir;
    const fs::path path = dir.write("t.obj", "v 0 0 0\nv 10 0 0\nv 0 10 0\nf 1 2 3\n");
    EXPECT_THROW(import_obj(path, {.unit = "furlong", .up = 'z'}), std::invalid_argument);
    EXPECT_THROW(import_obj(path, {.unit = "m", .up = 'x'}), std::invalid_argument);

    const ImportResult ft = import_obj(path, {.unit = "ft", .up = 'z'});
    ASSERT_EQ(ft.scene.surfaces.size(), 1u);
    const auto& pos = ft.scene.surfaces[0].mesh.positions;
    EXPECT_NE(std::find(pos.begin(), pos.end(), glm::dvec3(10.0 * 0.3048, 0.0, 0.0)), pos.end());
    EXPECT_EQ(ft.scene.surfaces[0].name, "t");  // no o or g: the file stem
    EXPECT_EQ(ft.scene.materials[0].name, "default");
    EXPECT_EQ(ft.scene.materials[0].reflectance, visdb::Rgb(0.5));
    EXPECT_TRUE(has_note(ft.report, "faces without usemtl"));
}

TEST(ObjImport, ConcaveLShapeInTiltedPlane) {
    // L-shape of area 3 in the plane spanned by (1,0,0) and (0,0.6,0.8), listed from corner
    // (2,0), from which a fan would leave the polygon (and flip a triangle)
    const auto corner = [](double x, double y) {
        std::ostringstream s;
        s.precision(17);
        s << "v " << x << " " << 0.6 * y << " " << 0.8 * y << "\n";
        return s.str();
    };
    TempDir dir;
    const fs::path path =
        dir.write("l.obj", corner(0, 0) + corner(2, 0) + corner(2, 1) + corner(1, 1) +
                               corner(1, 2) + corner(0, 2) + "g L\nf 2 3 4 5 6 1\n");
    const ImportResult r = import_obj(path, {});
    EXPECT_EQ(r.report.polygons_triangulated, 1u);
    EXPECT_EQ(r.report.degenerate_dropped, 0u);
    ASSERT_EQ(r.scene.surfaces.size(), 1u);
    const visdb::TriangleMesh& mesh = r.scene.surfaces[0].mesh;
    EXPECT_EQ(r.scene.surfaces[0].name, "L");
    ASSERT_EQ(mesh.triangles.size(), 4u);
    const glm::dvec3 polygon_normal =
        glm::cross(glm::dvec3(1.0, 0.0, 0.0), glm::dvec3(0.0, 0.6, 0.8));
    double area = 0.0;
    for (const auto& t : mesh.triangles) {
        area += triangle_area(mesh, t);
        EXPECT_GT(glm::dot(glm::normalize(triangle_normal(mesh, t)), polygon_normal), 0.999);
    }
    EXPECT_NEAR(area, 3.0, 1e-12);
}

TEST(ObjImport, StarPolygonsKeepTheirArea) {
    // Star-shaped polygons with random radii (concave corners everywhere): the triangles must
    // tile the polygon exactly, all facing the polygon's front
    std::uint64_t state = 12345;
    const auto uniform = [&state] {
        state = state * 6364136223846793005ULL + 1442695040888963407ULL;
        return static_cast<double>(state >> 11) / 9007199254740992.0;
    };
    TempDir dir;
    for (int trial = 0; trial < 20; ++trial) {
        const int n = 5 + trial * 7;
        std::ostringstream obj;
        obj.precision(17);
        std::vector<glm::dvec2> q;
        for (int i = 0; i < n; ++i) {
            const double angle = 2.0 * 3.14159265358979323846 * i / n;
            const double radius = 0.2 + uniform();
            q.emplace_back(radius * std::cos(angle), radius * std::sin(angle));
            obj << "v " << q.back().x << " " << 3.0 << " " << q.back().y << "\n";
        }
        obj << "f";
        for (int i = n; i >= 1; --i)
            obj << " " << i;  // clockwise in (x, z): front is +y (x × z = -y)
        obj << "\n";
        double expected = 0.0;
        for (int i = 0; i < n; ++i) {
            const glm::dvec2 a = q[static_cast<std::size_t>(i)];
            const glm::dvec2 b = q[static_cast<std::size_t>((i + 1) % n)];
            expected += 0.5 * (a.x * b.y - a.y * b.x);
        }
        const ImportResult r = import_obj(dir.write("star.obj", obj.str()), {});
        ASSERT_EQ(r.scene.surfaces.size(), 1u);
        const visdb::TriangleMesh& mesh = r.scene.surfaces[0].mesh;
        EXPECT_EQ(mesh.triangles.size() + r.report.degenerate_dropped,
                  static_cast<std::size_t>(n - 2));
        double area = 0.0;
        for (const auto& t : mesh.triangles) {
            area += triangle_area(mesh, t);
            EXPECT_GT(triangle_normal(mesh, t).y, 0.0) << "trial " << trial;
        }
        EXPECT_NEAR(area, expected, 1e-12 * n) << "trial " << trial << ", " << n << " corners";
    }
}

TEST(ObjImport, SharedConcavePolygon) {
    ABRAD_REQUIRE_SHARED_DATA("misc/concave_polygon.obj");
    const fs::path path = kSharedData / "misc" / "concave_polygon.obj";
    const ImportResult r = import_obj(path, {});

    // Reference: the face's vector area by Newell's formula, read straight from the file
    std::vector<glm::dvec3> v;
    std::vector<std::size_t> face;
    {
        std::ifstream in(path);
        std::string line;
        while (std::getline(in, line)) {
            std::istringstream s(line);
            std::string key;
            s >> key;
            if (key == "v") {
                glm::dvec3 p;
                s >> p.x >> p.y >> p.z;
                v.push_back(p);
            } else if (key == "f") {
                std::string c;
                while (s >> c) face.push_back(std::stoul(c.substr(0, c.find('/'))) - 1);
            }
        }
    }
    ASSERT_EQ(face.size(), 66u);
    glm::dvec3 vector_area{0.0};
    for (std::size_t i = 0; i < face.size(); ++i) {
        vector_area += 0.5 * glm::cross(v[face[i]], v[face[(i + 1) % face.size()]]);
    }

    EXPECT_EQ(r.report.faces_read, 1u);
    EXPECT_EQ(r.report.polygons_triangulated, 1u);
    EXPECT_EQ(r.report.triangles + r.report.degenerate_dropped, 64u);
    EXPECT_EQ(r.report.duplicates_dropped, 0u);
    ASSERT_EQ(r.scene.surfaces.size(), 1u);
    const visdb::Surface& s = r.scene.surfaces[0];
    EXPECT_EQ(s.name, "concave_test.obj");  // o ...
    EXPECT_EQ(s.layer, "default");          // g ...
    EXPECT_EQ(r.scene.materials[s.material].name, "test");
    EXPECT_NEAR(r.scene.materials[s.material].reflectance.z, 0.411765, 1e-15);
    double area = 0.0;
    for (const auto& t : s.mesh.triangles) {
        area += triangle_area(s.mesh, t);
        EXPECT_GT(glm::dot(triangle_normal(s.mesh, t), vector_area), 0.0);
    }
    EXPECT_GT(area, 0.2);  // a ring: the outline minus the hole reached by a bridge edge
    EXPECT_NEAR(area, glm::length(vector_area), 1e-12);
}

TEST(ObjImport, HealingCounts) {
    TempDir dir;
    const fs::path path = dir.write("heal.obj",
                                    "v 0 0 0\n"  // 1
                                    "v 1 0 0\n"  // 2
                                    "v 1 1 0\n"  // 3
                                    "v 0 1 0\n"  // 4
                                    "v 1 0 0\n"  // 5: same place as 2
                                    "v 2 0 0\n"  // 6
                                    "v 5 5 5\n"  // 7: unused
                                    "f 1 2 3\n"  // line 8
                                    "f 1 3 4\n"  // line 9
                                    "f 4 3 1\n"  // line 10: line 9 reversed
                                    "f 5 3 1\n"  // line 11: line 8 rotated, via the weld
                                    "f 1 5 6\n"  // line 12: collinear, zero area
                                    "f 3 4 3\n"  // line 13: repeated vertex
                                    "foo 1\n"    // line 14
                                    "l 1 2\n"    // line 15
                                    "foo 2\n");  // line 16
    const ImportResult r = import_obj(path, {});
    const ImportReport& rep = r.report;
    EXPECT_EQ(rep.vertices_read, 7u);
    EXPECT_EQ(rep.faces_read, 6u);
    EXPECT_EQ(rep.vertices_welded, 1u);
    EXPECT_EQ(rep.duplicates_dropped, 2u);
    EXPECT_EQ(rep.degenerate_dropped, 2u);
    EXPECT_EQ(rep.unused_vertices, 1u);
    EXPECT_EQ(rep.triangles, 2u);
    EXPECT_EQ(rep.polygons_triangulated, 0u);
    EXPECT_EQ(rep.emitter_triangles, 0u);
    ASSERT_EQ(r.scene.surfaces.size(), 1u);
    EXPECT_EQ(r.scene.surfaces[0].mesh.positions.size(), 4u);  // compact: welded, used only

    const std::string f = path.string();
    EXPECT_TRUE(has_note(rep, f + ":10: 1 triangle(s) repeating the face at " + f + ":9 dropped"))
        << rep.to_string();
    EXPECT_TRUE(has_note(rep, f + ":11: 1 triangle(s) repeating the face at " + f + ":8 dropped"))
        << rep.to_string();
    EXPECT_TRUE(has_note(rep, f + ":12: 1 degenerate")) << rep.to_string();
    EXPECT_TRUE(has_note(rep, f + ":13: face has fewer than 3 distinct vertices"))
        << rep.to_string();
    EXPECT_TRUE(has_note(rep, f + ":14: unknown statement 'foo' ignored (2 times"))
        << rep.to_string();
    EXPECT_TRUE(has_note(rep, f + ":15: 'l'")) << rep.to_string();

    const std::string text = rep.to_string();
    for (const char* label :
         {"vertices read: 7", "faces read: 6", "triangles kept: 2", "vertices welded: 1",
          "degenerate triangles dropped: 2", "duplicate triangles dropped: 2", "unused vertices: 1",
          "polygons triangulated: 0", "emitter triangles: 0"}) {
        EXPECT_NE(text.find(label), std::string::npos) << label << "\n" << text;
    }
}

TEST(ObjImport, SyntaxVariantsCrlfContinuationNegativeIndices) {
    TempDir dir;
    dir.write("m.mtl", "newmtl white\r\nKd 1.5 0.5 0.25\r\n");
    const fs::path path = dir.write("syn.obj",
                                    "# comment\r\n"
                                    "\r\n"
                                    "mtllib m.mtl missing.mtl\r\n"
                                    "v 0 0 0 1\r\n"        // with w
                                    "v 1 0 \\\r\n"         // continued...
                                    "  0 0.1 0.2 0.3\r\n"  // ... with a colour
                                    "v +1 1 0\r\n"
                                    "vt 0 0\r\n"
                                    "vn 0 0 1\r\n"
                                    "o box\r\n"
                                    "g side wall\r\n"
                                    "usemtl white\r\n"
                                    "s off\r\n"
                                    "f -3/1/1 -2/1/1 -1/1/1\r\n"
                                    "v 0 1 0\r\n"
                                    "usemtl ghost\r\n"  // line 16
                                    "f 1//1 3//-1 4//1\r\n"
                                    "p 1\r\n");
    const ImportResult r = import_obj(path, {});
    EXPECT_EQ(r.report.vertices_read, 4u);
    EXPECT_EQ(r.report.triangles, 2u);
    ASSERT_EQ(r.scene.surfaces.size(), 2u);
    EXPECT_EQ(r.scene.surfaces[0].name, "box");
    EXPECT_EQ(r.scene.surfaces[0].layer, "side");
    EXPECT_EQ(r.scene.surfaces[1].name, "box");
    const visdb::Material* white = find_material(r.scene, "white");
    ASSERT_NE(white, nullptr);
    EXPECT_EQ(white->reflectance, visdb::Rgb(0.999, 0.5, 0.25));  // clamped
    const visdb::Material* ghost = find_material(r.scene, "ghost");
    ASSERT_NE(ghost, nullptr);
    EXPECT_EQ(ghost->reflectance, visdb::Rgb(0.5));
    EXPECT_EQ(ghost->emittance, visdb::Rgb(0.0));
    EXPECT_EQ(ghost->opacity, 1.0);

    const std::string mtl = (dir.path() / "m.mtl").string();
    const std::string f = path.string();
    EXPECT_TRUE(has_note(r.report, mtl + ":2: reflectance of 'white' clamped to 0.999"))
        << r.report.to_string();
    EXPECT_TRUE(has_note(r.report, f + ":3: material library")) << r.report.to_string();
    EXPECT_TRUE(has_note(r.report, f + ":16: material 'ghost' is not defined"))
        << r.report.to_string();
    EXPECT_TRUE(has_note(r.report, f + ":18: 'p'")) << r.report.to_string();
}

TEST(ObjImport, ErrorsNameFileAndLine) {
    TempDir dir;
    const std::string tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";

    expect_error(dir.path() / "absent.obj", 0, "no such file");
    expect_error(dir.write("malformed.obj", tri + "v 1 2 x\nf 1 2 3\n"), 4, "malformed number 'x'");
    expect_error(dir.write("junk.obj", "v 1 2 3x\n"), 1, "malformed number '3x'");
    expect_error(dir.write("few.obj", tri + "\n\nv 1 2\n"), 6, "too few coordinates");
    expect_error(dir.write("range.obj", tri + "f 1 2 3\nf 1 2 9\nv 1 1 1\n"), 5,
                 "vertex index 9 out of range");
    expect_error(dir.write("relative.obj", tri + "f -1 -2 -4\n"), 4,
                 "vertex index -4 out of range");
    expect_error(dir.write("zero.obj", tri + "f 0 1 2\n"), 4, "index 0");
    expect_error(dir.write("two.obj", tri + "f 1 2\n"), 4, "at least 3");
    expect_error(dir.write("corner.obj", tri + "f 1/ 2 3\n"), 4, "malformed face corner");
    expect_error(dir.write("nan.obj", "v nan 0 0\n"), 1, "non-finite coordinate");
    expect_error(dir.write("inf.obj", tri + "v 1e999 0 0\n"), 4, "non-finite coordinate");
    expect_error(dir.write("continued.obj", "v 0 0 \\\n0\nv 1 2 x\n"), 3, "malformed number");

    const fs::path empty = dir.write("nofaces.obj", tri + "# nothing else\n");
    expect_error(empty, 0, "no faces to import");
    try {
        (void)import_obj(empty, {});
    } catch (const ImportError& e) {
        EXPECT_EQ(std::string(e.what()), empty.string() + ": no faces to import");
    }

    const fs::path mtl =
        dir.write("bad.mtl", "newmtl a\nKd 0.5 0.5 0.5\n\nnewmtl b\nKd 0.5 x 0.5\n");
    expect_error(dir.write("badmtl.obj", "mtllib bad.mtl\n" + tri + "usemtl a\nf 1 2 3\n"),
                 ImportOptions{}, mtl, 5, "malformed number 'x'");
    const fs::path mtl_nan = dir.write("nan.mtl", "newmtl a\nKe 1 nan 1\n");
    expect_error(dir.write("nanmtl.obj", "mtllib nan.mtl\n" + tri + "f 1 2 3\n"), ImportOptions{},
                 mtl_nan, 2, "non-finite");
}

// Issue 19: a device or FIFO as the model or as its mtllib would block or never end; only
// regular files are read (the FIFO has no writer: opening it would wait forever)
TEST(ObjImport, DevicesAndFifosAreRefused) {
    TempDir dir;
    const std::string tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    const fs::path fifo = dir / "fifo.obj";
    ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
    expect_error(fifo, 0, "not a regular file");
    ASSERT_EQ(::mkfifo((dir / "fifo.mtl").c_str(), 0600), 0);
    expect_error(dir.write("fifomtl.obj", "mtllib fifo.mtl\n" + tri), ImportOptions{},
                 dir / "fifo.mtl", 0, "not a regular file");
    ImportOptions outside;
    outside.allow_outside_refs = true;
    expect_error(dir.write("zero.obj", "mtllib /dev/zero\n" + tri), outside, "/dev/zero", 0,
                 "not a regular file");
}

// Issue 19: files a model refers to stay inside its folder tree unless allowed, and nothing of
// a file that is not a material library reaches the report
TEST(ObjImport, MaterialLibrariesOutsideTheModelFolderAreRefused) {
    TempDir dir;
    const std::string tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    fs::create_directories(dir / "model/sub");
    (void)dir.write("model/sub/in.mtl", "newmtl a\nKd 0.2 0.2 0.2\n");
    (void)dir.write("secret.txt", "root:x:0:0:root:/root:/bin/bash\nsecret-token 42\n");
    (void)dir.write("outside.mtl", "newmtl b\nKd 0.3 0.3 0.3\n");

    // Inside (through a subfolder and back) is read
    const ImportResult in = import_obj(
        dir.write("model/in.obj", "mtllib sub/../sub/in.mtl\nusemtl a\n" + tri), ImportOptions{});
    EXPECT_NE(find_material(in.scene, "a"), nullptr);

    // Outside, relative or absolute, is refused at the mtllib line
    const fs::path up = dir.write("model/up.obj", "mtllib ../secret.txt\n" + tri);
    expect_error(up, 1, "outside the model's folder");
    expect_error(
        dir.write("model/abs.obj", "mtllib " + (dir / "outside.mtl").string() + "\n" + tri), 1,
        "--allow-outside-refs");
    // A symbolic link inside the folder to a file outside is outside
    fs::create_symlink(dir / "outside.mtl", dir / "model/link.mtl");
    expect_error(dir.write("model/link.obj", "mtllib link.mtl\n" + tri), 1,
                 "outside the model's folder");

    // Allowed: an outside library is read; a file that is not one fails without its content
    ImportOptions allow;
    allow.allow_outside_refs = true;
    const ImportResult out =
        import_obj(dir.write("model/out.obj", "mtllib ../outside.mtl\nusemtl b\n" + tri), allow);
    EXPECT_NE(find_material(out.scene, "b"), nullptr);
    try {
        (void)import_obj(up, allow);
        ADD_FAILURE() << "no ImportError for " << up;
    } catch (const ImportError& e) {
        const std::string what = e.what();
        EXPECT_NE(what.find("not a material library"), std::string::npos) << what;
        EXPECT_EQ(what.find("/bin/bash"), std::string::npos) << what;
        EXPECT_EQ(what.find("secret-token"), std::string::npos) << what;
    }
}

// A comb as one OBJ face, counter-clockwise in the xy plane: a base y in [-10, 0] under
// `teeth` teeth 1 wide and 10 high, 1 apart (4 x teeth corners, integer coordinates).
// `hole`: a 2 x 6 square hole in the base, reached by a bridge from the corner (0, -10) (the
// face walks the bridge there and back: 6 more corners, two of them repeated vertices).
// `crossing`: the two top corners of tooth 1 swapped, so two edges cross. Area: the comb's
// 10 x (2 teeth - 1) + 10 x teeth, minus 12 for the hole.
struct Comb {
    std::string obj;
    std::size_t corners = 0;
    double area = 0.0;
};

Comb comb(std::size_t teeth, bool hole, bool crossing) {
    std::vector<glm::dvec2> v;
    const auto right = static_cast<double>(2 * teeth - 1);
    v.emplace_back(right, -10.0);
    for (std::size_t k = teeth; k-- > 0;) {
        const auto x = static_cast<double>(2 * k);
        if (k + 1 < teeth) v.emplace_back(x + 2.0, 0.0);  // the gap's bottom right
        if (k + 1 < teeth) v.emplace_back(x + 1.0, 0.0);  // the gap's bottom left
        v.emplace_back(x + 1.0, 10.0);
        v.emplace_back(x, 10.0);
    }
    if (crossing) std::swap(v[v.size() - 6], v[v.size() - 5]);
    v.emplace_back(0.0, -10.0);
    std::vector<std::size_t> face(v.size());
    for (std::size_t i = 0; i < v.size(); ++i) face[i] = i + 1;
    if (hole) {
        const std::size_t bridge = v.size();  // 1-based index of (0, -10)
        for (const glm::dvec2 p :
             {glm::dvec2(1, -8), glm::dvec2(1, -2), glm::dvec2(3, -2), glm::dvec2(3, -8)}) {
            v.push_back(p);
            face.push_back(v.size());
        }
        face.push_back(bridge + 1);  // back to (1, -8)
        face.push_back(bridge);      // and over the bridge to (0, -10)
    }
    Comb c;
    for (const glm::dvec2 p : v) {
        c.obj += "v " + std::to_string(std::lround(p.x)) + " " + std::to_string(std::lround(p.y)) +
                 " 0\n";
    }
    c.obj += "f";
    for (const std::size_t i : face) c.obj += " " + std::to_string(i);
    c.obj += "\n";
    c.corners = face.size();
    c.area = 30.0 * static_cast<double>(teeth) - 10.0 - (hole ? 12.0 : 0.0);
    return c;
}

/// Checks that `r` holds `triangles` triangles, all facing +z (none flipped or folded over),
/// whose areas sum to `area`.
void expect_flat_triangulation(const ImportResult& r, std::size_t triangles, double area) {
    EXPECT_EQ(r.report.triangles, triangles);
    double sum = 0.0;
    std::size_t facing_down = 0;
    for (const visdb::Surface& s : r.scene.surfaces) {
        for (const glm::u32vec3& t : s.mesh.triangles) {
            const double twice = triangle_normal(s.mesh, t).z;
            facing_down += twice > 0.0 ? 0 : 1;
            sum += 0.5 * twice;
        }
    }
    EXPECT_EQ(facing_down, 0U);
    EXPECT_NEAR(sum, area, 1e-9 * area);
}

// Issue 19: a face of 64k corners kept the ear clipper busy for minutes (it is quadratic in
// them). Polygons over 256 corners are triangulated by a constrained Delaunay triangulation,
// in O(n log n): every polygon gets n - 2 triangles covering exactly its area.
TEST(ObjImport, PolygonsOfManyCornersAreTriangulated) {
    TempDir dir;
    const Comb big = comb(16384, false, false);
    ASSERT_EQ(big.corners, 65536U);
    const ImportResult r = import_obj(dir.write("comb.obj", big.obj), ImportOptions{});
    expect_flat_triangulation(r, big.corners - 2, big.area);
    EXPECT_EQ(r.report.degenerate_dropped, 0U);

    // A hole reached by a bridge: the bridge is walked twice and is no boundary
    const Comb holed = comb(100, true, false);
    expect_flat_triangulation(import_obj(dir.write("holed.obj", holed.obj), ImportOptions{}),
                              holed.corners - 2, holed.area);
}

// A polygon whose edges cross is no proper polygon for the constrained triangulation: up to
// 2,048 corners the ear clipper takes it (n - 2 triangles, as before), a larger one is
// refused at its line
TEST(ObjImport, SelfCrossingPolygonsOverTheEarClippingLimitAreRefused) {
    TempDir dir;
    const Comb small = comb(300, false, true);
    const ImportResult r = import_obj(dir.write("small.obj", small.obj), ImportOptions{});
    EXPECT_EQ(r.report.triangles + r.report.degenerate_dropped, small.corners - 2);
    const Comb big = comb(600, false, true);
    ASSERT_EQ(big.corners, 2400U);
    expect_error(dir.write("big.obj", big.obj), 2401,
                 "polygon with 2400 corners whose edges cross");
}

TEST(ObjImport, CornellBoxOriginal) {
    ABRAD_REQUIRE_SHARED_DATA("cornell_box/CornellBox-Original.obj");
    const fs::path path = kSharedData / "cornell_box" / "CornellBox-Original.obj";
    const ImportResult r = import_obj(path, {.unit = "m", .up = 'y'});
    const ImportReport& rep = r.report;
    // 18 quads, 72 vertices. The short and tall box's bottom faces use relative indices that
    // point back at the right and front faces: 2 exact duplicate quads (4 triangles) and the 8
    // bottom vertices unused.
    EXPECT_EQ(rep.vertices_read, 72u);
    EXPECT_EQ(rep.faces_read, 18u);
    EXPECT_EQ(rep.polygons_triangulated, 18u);
    EXPECT_EQ(rep.duplicates_dropped, 4u);
    EXPECT_EQ(rep.unused_vertices, 8u);
    EXPECT_EQ(rep.degenerate_dropped, 0u);
    EXPECT_EQ(rep.triangles, 32u);
    EXPECT_EQ(r.scene.triangle_count(), 32u);
    EXPECT_EQ(rep.emitter_triangles, 2u);
    EXPECT_GT(rep.vertices_welded, 0u);
    const std::string f = path.string();
    EXPECT_TRUE(has_note(rep, f + ":62: polygon not planar")) << rep.to_string();  // left wall
    EXPECT_TRUE(has_note(rep, f + ":107: 2 triangle(s) repeating the face at " + f + ":93"))
        << rep.to_string();  // short box bottom = its right face
    EXPECT_TRUE(has_note(rep, f + ":155: 2 triangle(s) repeating the face at " + f + ":148"))
        << rep.to_string();  // tall box bottom = its front face

    const visdb::Material* light = find_material(r.scene, "light");
    ASSERT_NE(light, nullptr);
    EXPECT_EQ(light->emittance, visdb::Rgb(17.0, 12.0, 4.0));
    EXPECT_EQ(light->reflectance, visdb::Rgb(0.78));
    const visdb::Material* right = find_material(r.scene, "rightWall");
    ASSERT_NE(right, nullptr);
    EXPECT_EQ(right->reflectance, visdb::Rgb(0.14, 0.45, 0.091));  // Kd, not Ka

    // The light hangs at y = 1.98 in the file: z = 1.98 here, facing down
    for (const auto& s : r.scene.surfaces) {
        if (r.scene.materials[s.material].name != "light") continue;
        EXPECT_EQ(s.name, "light");
        for (const auto& p : s.mesh.positions) EXPECT_EQ(p.z, 1.98);
        for (const auto& t : s.mesh.triangles) EXPECT_LT(triangle_normal(s.mesh, t).z, 0.0);
    }
    std::cout << rep.to_string();
}

TEST(ObjImport, CornellBoxSphere) {
    ABRAD_REQUIRE_SHARED_DATA("cornell_box/CornellBox-Sphere.obj");
    const fs::path path = kSharedData / "cornell_box" / "CornellBox-Sphere.obj";
    const ImportResult r = import_obj(path, {.unit = "m", .up = 'y'});
    EXPECT_EQ(r.report.faces_read, 2188u);
    EXPECT_EQ(r.report.vertices_read, 1116u);
    EXPECT_GT(r.scene.triangle_count(), 2000u);
    EXPECT_EQ(r.report.triangles + r.report.degenerate_dropped + r.report.duplicates_dropped,
              2188u);
    const visdb::Material* light = find_material(r.scene, "light");
    ASSERT_NE(light, nullptr);
    EXPECT_EQ(light->emittance, visdb::Rgb(10.0));
    EXPECT_EQ(r.report.emitter_triangles, 2u);
    std::cout << r.report.to_string();
}

}  // namespace
}  // namespace abrad::convert
