// Tests of the healing every importer shares: welding within a tolerance (and not beyond it,
// at survey coordinates too), consistent winding, coplanar overlap (z-fighting) reports and
// triangulation of concave polygons, each against counts and geometry known by construction.

#include <gtest/gtest.h>

#include <cmath>
#include <glm/geometric.hpp>
#include <string>
#include <vector>

#include "raw_model.h"

namespace abrad::convert::detail {
namespace {

/// Builds a RawModel face by face; every face is its own place (1-based).
class Soup {
  public:
    Soup() {
        m_raw.file = "soup";
        m_raw.where = [](std::size_t place) { return "soup:" + std::to_string(place); };
    }

    std::uint32_t slot(const std::string& name, const std::string& material = "m") {
        m_raw.slots.push_back({name, "", material, m_raw.faces.size() + 1});
        return static_cast<std::uint32_t>(m_raw.slots.size() - 1);
    }

    void face(std::uint32_t slot, const std::vector<glm::dvec3>& corners) {
        RawFace f;
        f.place = m_raw.faces.size() + 1;
        f.slot = slot;
        f.first = m_raw.corners.size();
        f.count = static_cast<std::uint32_t>(corners.size());
        for (const glm::dvec3& p : corners) {
            m_raw.corners.push_back(static_cast<std::uint32_t>(m_raw.positions.size()));
            m_raw.positions.push_back(p);
        }
        m_raw.faces.push_back(f);
    }

    /// An axis-aligned quad in the plane z = `z`, counter-clockwise seen from +z (or from -z
    /// when `down`).
    void quad_z(std::uint32_t s, double x0, double y0, double x1, double y1, double z, bool down) {
        if (down)
            face(s, {{x0, y0, z}, {x0, y1, z}, {x1, y1, z}, {x1, y0, z}});
        else
            face(s, {{x0, y0, z}, {x1, y0, z}, {x1, y1, z}, {x0, y1, z}});
    }

    RawModel& raw() { return m_raw; }

  private:
    RawModel m_raw;
};

bool has_note(const ImportReport& r, const std::string& prefix) {
    for (const std::string& n : r.notes)
        if (n.rfind(prefix, 0) == 0) return true;
    return false;
}

glm::dvec3 normal_of(const visdb::TriangleMesh& m, const glm::u32vec3& t) {
    return glm::normalize(
        glm::cross(m.positions[t.y] - m.positions[t.x], m.positions[t.z] - m.positions[t.x]));
}

double area_of(const visdb::Scene& scene) {
    double a = 0.0;
    for (const auto& s : scene.surfaces)
        for (const auto& t : s.mesh.triangles)
            a += 0.5 * glm::length(glm::cross(s.mesh.positions[t.y] - s.mesh.positions[t.x],
                                              s.mesh.positions[t.z] - s.mesh.positions[t.x]));
    return a;
}

TEST(Heal, WeldsWithinToleranceOnly) {
    // Two unit quads side by side; the right one's shared corners are 1e-8 m off (inside a
    // weld distance of 1e-7 × diagonal ≈ 2.2e-7 m), and a third quad 1e-5 m away (outside).
    Soup soup;
    const std::uint32_t s = soup.slot("floor");
    soup.quad_z(s, 0, 0, 1, 1, 0, false);
    soup.face(s, {{1 + 1e-8, 0, 0}, {2, 0, 0}, {2, 1, 0}, {1 - 1e-8, 1, 0}});
    soup.quad_z(s, 0, 1 + 1e-5, 2, 2, 0, false);
    ImportReport report;
    const visdb::Scene scene = heal(soup.raw(), {1e-7}, report);
    EXPECT_NEAR(report.weld_distance, 1e-7 * std::sqrt(8.0), 1e-12);
    EXPECT_EQ(report.vertices_welded_near, 2u);
    EXPECT_EQ(report.vertices_welded, 2u);
    ASSERT_EQ(scene.surfaces.size(), 1u);
    EXPECT_EQ(scene.surfaces[0].mesh.positions.size(), 10u);  // 12 corners, 2 welded
    // The representatives keep their coordinates exactly
    bool found = false;
    for (const glm::dvec3& p : scene.surfaces[0].mesh.positions)
        found = found || (p == glm::dvec3{1, 0, 0});
    EXPECT_TRUE(found);

    // With welding off, nothing within tolerance merges
    ImportReport exact;
    heal(soup.raw(), {0.0}, exact);
    EXPECT_EQ(exact.vertices_welded, 0u);
}

TEST(Heal, SurveyCoordinatesKeepMillimetreDetail) {
    // A 10 m room at a 1e6 m survey offset with a 1 mm reveal: 1 mm apart must stay apart,
    // 1 µm apart must weld, and every coordinate comes through bit for bit.
    const glm::dvec3 o{2'500'000.0, 1'200'000.0, 400.0};
    Soup soup;
    const std::uint32_t s = soup.slot("slab");
    soup.quad_z(s, o.x, o.y, o.x + 10.0, o.y + 10.0, o.z, false);
    soup.quad_z(s, o.x + 10.001, o.y, o.x + 11.0, o.y + 10.0, o.z, false);
    soup.face(s, {{o.x + 11.0 + 1e-6, o.y, o.z},
                  {o.x + 12.0, o.y, o.z},
                  {o.x + 12.0, o.y + 10.0, o.z},
                  {o.x + 11.0, o.y + 10.0 - 1e-6, o.z}});
    ImportReport report;
    const visdb::Scene scene = heal(soup.raw(), {1e-6}, report);
    EXPECT_EQ(report.vertices_welded_near, 2u);  // only the 1 µm pair
    ASSERT_EQ(scene.surfaces.size(), 1u);
    EXPECT_EQ(scene.surfaces[0].mesh.positions.size(), 10u);
    bool reveal_edge = false;
    for (const glm::dvec3& p : scene.surfaces[0].mesh.positions)
        reveal_edge = reveal_edge || (p.x == o.x + 10.001 && p.y == o.y);
    EXPECT_TRUE(reveal_edge);
    EXPECT_NEAR(area_of(scene), 120.0 - 10.0 * 0.001, 1e-6);
}

TEST(Heal, FlipsTheMinorityToConsistentWinding) {
    // A 3×3 grid of unit quads facing +z, two of them drawn the other way round
    Soup soup;
    const std::uint32_t s = soup.slot("floor");
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            soup.quad_z(s, i, j, i + 1, j + 1, 0, (i == 1 && j == 1) || (i == 2 && j == 0));
    ImportReport report;
    const visdb::Scene scene = heal(soup.raw(), {1e-7}, report);
    EXPECT_EQ(report.triangles_flipped, 4u);
    EXPECT_EQ(report.surfaces_flipped, 1u);
    EXPECT_TRUE(has_note(report, "soup:1: surface 'floor': 4 of 18 triangles flipped"))
        << report.to_string();
    for (const auto& t : scene.surfaces[0].mesh.triangles)
        EXPECT_GT(normal_of(scene.surfaces[0].mesh, t).z, 0.999);
}

TEST(Heal, ClosedBoxKeepsItsMajorityOrientation) {
    // A unit cube with outward faces, one face drawn inward; a separate surface drawn all
    // inward (a room seen from inside) is consistent and left alone.
    const auto cube = [](Soup& soup, std::uint32_t s, glm::dvec3 o, bool inward, int bad_face) {
        const std::vector<std::vector<glm::dvec3>> faces = {
            {{0, 0, 0}, {0, 1, 0}, {1, 1, 0}, {1, 0, 0}},  // bottom, -z
            {{0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}},  // top, +z
            {{0, 0, 0}, {1, 0, 0}, {1, 0, 1}, {0, 0, 1}},  // -y
            {{0, 1, 0}, {0, 1, 1}, {1, 1, 1}, {1, 1, 0}},  // +y
            {{0, 0, 0}, {0, 0, 1}, {0, 1, 1}, {0, 1, 0}},  // -x
            {{1, 0, 0}, {1, 1, 0}, {1, 1, 1}, {1, 0, 1}},  // +x
        };
        for (int f = 0; f < 6; ++f) {
            std::vector<glm::dvec3> c = faces[static_cast<std::size_t>(f)];
            for (glm::dvec3& p : c) p += o;
            if (inward != (f == bad_face)) std::reverse(c.begin(), c.end());
            soup.face(s, c);
        }
    };
    Soup soup;
    cube(soup, soup.slot("box"), {0, 0, 0}, false, 3);
    cube(soup, soup.slot("room"), {5, 0, 0}, true, -1);
    ImportReport report;
    const visdb::Scene scene = heal(soup.raw(), {1e-7}, report);
    EXPECT_EQ(report.triangles_flipped, 2u);
    EXPECT_EQ(report.surfaces_flipped, 1u);
    ASSERT_EQ(scene.surfaces.size(), 2u);
    for (std::size_t k = 0; k < 2; ++k) {
        const auto& m = scene.surfaces[k].mesh;
        for (const auto& t : m.triangles) {
            const glm::dvec3 c = (m.positions[t.x] + m.positions[t.y] + m.positions[t.z]) / 3.0;
            const glm::dvec3 centre =
                k == 0 ? glm::dvec3{0.5, 0.5, 0.5} : glm::dvec3{5.5, 0.5, 0.5};
            const double outward = glm::dot(normal_of(m, t), c - centre);
            if (k == 0)
                EXPECT_GT(outward, 0.0);
            else
                EXPECT_LT(outward, 0.0);
        }
    }
}

TEST(Heal, ReportsALightFlushWithTheCeiling) {
    // A 4×4 ceiling facing down at z = 3 and a 1×1 light facing down in the same plane:
    // z-fighting over 1 m² (2 light triangles against the ceiling triangles under them)
    Soup soup;
    const std::uint32_t ceiling = soup.slot("ceiling");
    soup.quad_z(ceiling, 0, 0, 4, 4, 3, true);
    const std::uint32_t light = soup.slot("light", "lamp");
    soup.quad_z(light, 1.5, 1.5, 2.5, 2.5, 3, true);
    ImportReport report;
    heal(soup.raw(), {1e-7}, report);
    EXPECT_GE(report.overlapping_pairs, 2u);
    EXPECT_TRUE(has_note(report, "soup:2: surfaces 'ceiling' and 'light' overlap coplanar"))
        << report.to_string();
    bool area_ok = false;
    for (const std::string& n : report.notes)
        area_ok = area_ok || n.find(", 1 m²") != std::string::npos;
    EXPECT_TRUE(area_ok) << report.to_string();

    // 1 cm under the ceiling, or facing up (back to back), it is no z-fighting
    for (const bool lowered : {true, false}) {
        Soup other;
        const std::uint32_t c2 = other.slot("ceiling");
        other.quad_z(c2, 0, 0, 4, 4, 3, true);
        const std::uint32_t l2 = other.slot("light", "lamp");
        other.quad_z(l2, 1.5, 1.5, 2.5, 2.5, lowered ? 2.99 : 3.0, lowered);
        ImportReport r2;
        heal(other.raw(), {1e-7}, r2);
        EXPECT_EQ(r2.overlapping_pairs, 0u) << r2.to_string();
    }
}

TEST(Heal, AdjacentTrianglesAreNoOverlap) {
    // A 20×20 grid of quads in one plane touches along every edge but overlaps nowhere
    Soup soup;
    const std::uint32_t s = soup.slot("floor");
    for (int i = 0; i < 20; ++i)
        for (int j = 0; j < 20; ++j)
            soup.quad_z(s, i * 0.1, j * 0.1, (i + 1) * 0.1, (j + 1) * 0.1, 0, false);
    ImportReport report;
    const visdb::Scene scene = heal(soup.raw(), {1e-7}, report);
    EXPECT_EQ(report.overlapping_pairs, 0u);
    EXPECT_EQ(scene.triangle_count(), 800u);
    EXPECT_NEAR(area_of(scene), 4.0, 1e-12);
}

TEST(Heal, TriangulatesConcaveAndNonPlanarPolygons) {
    // An L-shaped hexagon (area 3) and a skewed quad whose corner is 10% off its plane
    Soup soup;
    const std::uint32_t s = soup.slot("plan");
    soup.face(s, {{0, 0, 0}, {2, 0, 0}, {2, 1, 0}, {1, 1, 0}, {1, 2, 0}, {0, 2, 0}});
    soup.face(s, {{5, 0, 0}, {6, 0, 0}, {6, 1, 0.1}, {5, 1, 0}});
    ImportReport report;
    const visdb::Scene scene = heal(soup.raw(), {1e-7}, report);
    EXPECT_EQ(report.polygons_triangulated, 2u);
    EXPECT_EQ(report.non_planar_polygons, 1u);
    EXPECT_TRUE(has_note(report, "soup:2: polygon not planar")) << report.to_string();
    EXPECT_EQ(scene.triangle_count(), 6u);
    const auto& m = scene.surfaces[0].mesh;
    double l_area = 0.0;
    for (const auto& t : m.triangles) {
        if (m.positions[t.x].x > 4.0) continue;
        EXPECT_GT(normal_of(m, t).z, 0.999);  // no ear flipped
        l_area += 0.5 * glm::length(glm::cross(m.positions[t.y] - m.positions[t.x],
                                               m.positions[t.z] - m.positions[t.x]));
    }
    EXPECT_NEAR(l_area, 3.0, 1e-12);
}

TEST(Heal, NothingLeftIsAnError) {
    Soup soup;
    const std::uint32_t s = soup.slot("line");
    soup.face(s, {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}});
    ImportReport report;
    try {
        heal(soup.raw(), {1e-7}, report);
        FAIL() << "expected ImportError";
    } catch (const ImportError& e) {
        EXPECT_NE(std::string(e.what()).find("soup: no triangles left after healing"),
                  std::string::npos)
            << e.what();
    }
}

}  // namespace
}  // namespace abrad::convert::detail
