// Faces pressed against another solid are cut away before the bake (stages.h hide_contacts):
// a partition's top under the slab, its ends against the outer walls, the floor under it.
// Two rooms under one slab, the light in one: left in the mesh, the slab's underside was one
// region over both rooms, its elements straddled the partition, and the dark room received
// light the closed partition cannot pass.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>
#include <string>
#include <vector>

#include "abrad/radiosity/bake.h"
#include "cie171.h"
#include "scenes.h"

namespace abrad::radiosity {
namespace {

using cie171::add_material;
using cie171::facing;
using glm::dvec3;

// A closed box, fronts outside, as one surface (a wall or a slab of an IFC model).
visdb::Surface box(const std::string& name, std::uint32_t material, dvec3 lo, dvec3 hi, int n) {
    visdb::Surface out;
    out.name = name;
    out.material = material;
    const dvec3 centre = 0.5 * (lo + hi);
    for (int axis = 0; axis < 3; ++axis)
        for (const double side : {lo[axis], hi[axis]}) {
            const int i = (axis + 1) % 3, j = (axis + 2) % 3;
            dvec3 o = lo, u(0.0), v(0.0);
            o[axis] = side;
            u[i] = hi[i] - lo[i];
            v[j] = hi[j] - lo[j];
            dvec3 outside = centre;
            outside[axis] = side + (side == lo[axis] ? -1.0 : 1.0);
            const visdb::Surface f = facing(name, material, o, u, v, n, outside);
            const auto base = static_cast<std::uint32_t>(out.mesh.positions.size());
            out.mesh.positions.insert(out.mesh.positions.end(), f.mesh.positions.begin(),
                                      f.mesh.positions.end());
            for (const glm::u32vec3& t : f.mesh.triangles)
                out.mesh.triangles.push_back(t + glm::u32vec3(base));
        }
    return out;
}

// Two rooms of 3 × 3 × 2.5 m side by side (x in [0, 6]): a floor and four outer walls (sheets,
// fronts inside), a 0.2 m partition box from the floor to `partition_top` (the slab's
// underside, or through the slab) at x in [2.9, 3.1], a 0.2 m slab box on top, and a 1 × 1 m
// light under the slab in the first room.
visdb::Scene two_rooms(double partition_top = 2.5) {
    visdb::Scene s;
    const std::uint32_t wall = add_material(s, "wall", 0.7);
    const std::uint32_t light = add_material(s, "light", 0.0, 1000.0);
    const dvec3 in(3.0, 1.5, 1.25);
    s.surfaces.push_back(facing("floor", wall, {0, 0, 0}, {6, 0, 0}, {0, 3, 0}, 12, in));
    s.surfaces.push_back(facing("wall_s", wall, {0, 0, 0}, {6, 0, 0}, {0, 0, 2.5}, 6, in));
    s.surfaces.push_back(facing("wall_n", wall, {0, 3, 0}, {6, 0, 0}, {0, 0, 2.5}, 6, in));
    s.surfaces.push_back(facing("wall_w", wall, {0, 0, 0}, {0, 3, 0}, {0, 0, 2.5}, 3, in));
    s.surfaces.push_back(facing("wall_e", wall, {6, 0, 0}, {0, 3, 0}, {0, 0, 2.5}, 3, in));
    s.surfaces.push_back(box("partition", wall, {2.9, 0, 0}, {3.1, 3, partition_top}, 2));
    s.surfaces.push_back(box("slab", wall, {0, 0, 2.5}, {6, 3, 2.7}, 4));
    s.surfaces.push_back(
        facing("light", light, {1, 1, 2.45}, {1, 0, 0}, {0, 1, 0}, 1, {1.5, 1.5, 0}));
    return s;
}

double triangle_area(const visdb::BakeMesh& m, std::size_t t) {
    const glm::u32vec3 tri = m.triangles[t];
    return visdb::triangle_area(m.positions[tri.x], m.positions[tri.y], m.positions[tri.z]);
}

// The bake of two_rooms(partition_top): the light stays in the first room, and no slab or
// floor triangle is left over the partition. Returns the area cut away.
double bake_two_rooms(double partition_top) {
    const visdb::Scene scene = two_rooms(partition_top);
    // Converged without the ambient term (which spreads what is left everywhere, the dark room
    // too)
    BakeOptions o;
    o.ambient = false;
    o.converge = 1e-4;
    const visdb::Bake b = bake(scene, o);
    // No triangle of the slab's underside or the floor lies over the partition's footprint
    double underside = 0.0;
    for (std::size_t t = 0; t < b.mesh.triangles.size(); ++t) {
        const glm::u32vec3 tri = b.mesh.triangles[t];
        const dvec3 c =
            (b.mesh.positions[tri.x] + b.mesh.positions[tri.y] + b.mesh.positions[tri.z]) / 3.0;
        const std::string& name = scene.surfaces[b.mesh.triangle_surface[t]].name;
        if (name == "slab" && std::abs(c.z - 2.5) < 1e-9) underside += triangle_area(b.mesh, t);
        if (name == "slab" || name == "floor") {
            EXPECT_FALSE(c.x > 2.9 && c.x < 3.1 && (c.z < 1e-9 || std::abs(c.z - 2.5) < 1e-9))
                << name << " triangle " << t << " over the partition";
        }
    }
    EXPECT_NEAR(underside, 18.0 - 0.6, 1e-6);
    // The second room gets no light: nothing passes the partition, and no element of the
    // slab or the floor carries the first room's light over it
    double lit = 0.0, dark = 0.0;
    std::size_t n_lit = 0;
    for (std::size_t v = 0; v < b.mesh.positions.size(); ++v) {
        const dvec3& x = b.mesh.positions[v];
        const double e = visdb::luminance(b.mesh.irradiance[v]);
        if (x.x < 2.9 - 1e-6) {
            lit += e;
            ++n_lit;
        } else if (x.x > 3.1 + 1e-6) {
            dark = std::max(dark, e);
        }
    }
    EXPECT_GT(n_lit, 0u);
    lit /= double(std::max<std::size_t>(n_lit, 1));
    EXPECT_LT(dark, 1e-6 * lit) << "the dark room's brightest vertex, against the lit room's "
                                   "mean vertex irradiance "
                                << lit;
    return b.statistics.contact_hidden_m2;
}

TEST(Contacts, APartitionUnderTheSlabKeepsTheNextRoomDark) {
    // Cut away: the slab's underside over the partition and the partition's top (0.6 m²
    // each), the floor under it (0.6 m²; the partition's foot stays, the floor sheet has no
    // solid behind it), the outer walls behind its ends (0.5 m² each)
    EXPECT_NEAR(bake_two_rooms(2.5), 2.8, 1e-6);
}

TEST(Contacts, APartitionThroughTheSlabKeepsTheNextRoomDark) {
    // The partition runs on through the slab to 2.9 m (as the FZK-Haus's outer walls pass
    // the slab's edge): the slab's underside and top over it lie inside it (0.6 m² each), and
    // so do its sides within the slab (0.2 × 3 m each); the floor under it and the outer walls
    // behind its ends as before (0.6 + 2 × 0.5 m²). Left in, the underside over the partition
    // kept the two rooms' ceilings one region, and its elements straddled the partition
    EXPECT_NEAR(bake_two_rooms(2.9), 0.6 + 0.6 + 2 * 0.6 + 0.6 + 2 * 0.5, 1e-6);
}

TEST(Contacts, SheetsBackToBackAndGlassAreNotContacts) {
    // Two sheets back to back (a two-sided panel as two surfaces: no solid behind either) and
    // a glass box on the floor (light passes it): nothing is cut
    visdb::Scene s;
    const std::uint32_t wall = add_material(s, "wall", 0.5);
    const std::uint32_t light = add_material(s, "light", 0.0, 100.0);
    const std::uint32_t glass = add_material(s, "glass", 0.1);
    s.materials[glass].opacity = 0.3;
    s.surfaces.push_back(facing("floor", wall, {-2, -2, 0}, {4, 0, 0}, {0, 4, 0}, 4, {0, 0, 1}));
    s.surfaces.push_back(facing("up", wall, {-1, -1, 1}, {1, 0, 0}, {0, 1, 0}, 1, {0, 0, 2}));
    s.surfaces.push_back(facing("down", wall, {-1, -1, 1}, {1, 0, 0}, {0, 1, 0}, 1, {0, 0, 0}));
    s.surfaces.push_back(box("glass", glass, {0.5, 0.5, 0}, {1, 1, 0.5}, 1));
    s.surfaces.push_back(
        facing("light", light, {-0.5, -0.5, 3}, {1, 0, 0}, {0, 1, 0}, 1, {0, 0, 0}));
    BakeOptions o;
    o.bounces = 0;
    o.dm = false;
    const visdb::Bake b = bake(s, o);
    EXPECT_EQ(b.statistics.contact_hidden_m2, 0.0);
    EXPECT_EQ(b.statistics.contact_faces_cut, 0u);
    double area = 0.0;
    for (std::size_t t = 0; t < b.mesh.triangles.size(); ++t) area += triangle_area(b.mesh, t);
    // floor 16, the sheets 1 each, the glass box 1.5, the light 1
    EXPECT_NEAR(area, 20.5, 1e-9);
}

}  // namespace
}  // namespace abrad::radiosity
