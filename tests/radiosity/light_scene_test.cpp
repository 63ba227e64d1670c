// Light scenes without re-baking (visdb/light_scene.h, bake.h): a bake of a scene that names
// light groups stores its shades per group; a mix of 0 for a group equals a bake without that
// group's lights, the bake's own mix gives the bake bit for bit, and the groups add up to it.

#include "abrad/visdb/light_scene.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "abrad/radiosity/bake.h"
#include "scenes.h"

namespace abrad::radiosity {
namespace {

/// A type C web of `cd` candela in every direction.
visdb::Luminaire uniform_luminaire(const std::string& name, double cd, const glm::dvec3& position,
                                   const std::string& group) {
    visdb::Luminaire l;
    l.name = name;
    l.file = "lights/" + name + ".ies";
    l.web.horizontal = {0.0};
    l.web.vertical = {0.0, 90.0, 180.0};
    l.web.candela = {cd, cd, cd};
    l.position = position;
    l.group = group;
    return l;
}

/// The floor-and-light scene (testing::floor_and_light: an emitting panel over a floor with an
/// occluder, here photometric) with a wall beside it and two point sources: the panel in
/// group "panel", one luminaire in "office" and one in "corridor" (or none of them named).
visdb::Scene grouped_scene(bool corridor = true) {
    visdb::Scene scene = testing::floor_and_light(6, true);
    scene.emittance_unit = "lm/m2";
    scene.materials[1].group = "panel";
    scene.surfaces.push_back(
        testing::quad_grid("wall", 0, {1.0, -1.0, 0.0}, {0.0, 0.0, 1.5}, {0.0, 2.0, 0.0}, 3));
    scene.luminaires.push_back(uniform_luminaire("desk", 40.0, {0.6, 0.5, 1.2}, "office"));
    if (corridor)
        scene.luminaires.push_back(uniform_luminaire("hall", 25.0, {-0.7, -0.6, 1.0}, "corridor"));
    return scene;
}

BakeOptions options(int bounces, bool dm) {
    BakeOptions o;
    o.bounces = bounces;
    o.dm = dm;
    o.resolution = 24;
    o.element_size = 0.5;
    o.threads = 2;
    return o;
}

/// Every vertex's irradiance and radiosity within `tolerance` × the largest value of `expected`.
void expect_same_shades(const visdb::BakeMesh& expected, const visdb::BakeMesh& actual,
                        double tolerance) {
    ASSERT_EQ(expected.positions.size(), actual.positions.size());
    ASSERT_EQ(expected.positions, actual.positions);
    double top = 0.0;
    for (std::size_t v = 0; v < expected.positions.size(); ++v)
        for (int c = 0; c < 3; ++c)
            top = std::max({top, std::abs(double(expected.irradiance[v][c])),
                            std::abs(double(expected.radiosity[v][c]))});
    ASSERT_GT(top, 0.0);
    for (std::size_t v = 0; v < expected.positions.size(); ++v)
        for (int c = 0; c < 3; ++c) {
            EXPECT_NEAR(actual.irradiance[v][c], expected.irradiance[v][c], tolerance * top)
                << "vertex " << v << " channel " << c;
            EXPECT_NEAR(actual.radiosity[v][c], expected.radiosity[v][c], tolerance * top)
                << "vertex " << v << " channel " << c;
        }
}

/// `bake` mixed by `mix` (its scene's lights dimmed too).
visdb::Bake mixed(visdb::Bake bake, visdb::Scene scene, const std::string& mix) {
    visdb::apply_scene_mix(visdb::parse_scene_mix(mix), scene, bake);
    return bake;
}

TEST(LightScenes, SceneMixParsesAndRefusesWhatItCannotRead) {
    const visdb::SceneMix mix = visdb::parse_scene_mix(" office = 1, corridor=0.3 ,x=0");
    ASSERT_EQ(mix.factors.size(), 3u);
    EXPECT_EQ(mix.factor("office"), 1.0);
    EXPECT_EQ(mix.factor("corridor"), 0.3);
    EXPECT_EQ(mix.factor("x"), 0.0);
    EXPECT_EQ(mix.factor("not named"), 1.0);
    EXPECT_FALSE(mix.is_identity());
    EXPECT_TRUE(visdb::parse_scene_mix("a=1,b=1.0").is_identity());
    for (const char* bad :
         {"", "office", "=1", "a=", "a=-1", "a=nan", "a=inf", "a=1x", "a=1,a=2", "a=1,"})
        EXPECT_THROW(visdb::parse_scene_mix(bad), std::invalid_argument) << bad;
}

TEST(LightScenes, DefaultGroupsAreTheFileStemAndEmitters) {
    visdb::Scene scene = grouped_scene();
    scene.materials[1].group.clear();
    scene.luminaires[1].group.clear();
    EXPECT_TRUE(visdb::names_light_groups(scene));  // "desk" names office
    EXPECT_EQ(visdb::light_groups(scene), (std::vector<std::string>{"emitters", "office", "hall"}));
    scene.luminaires[0].group.clear();
    EXPECT_FALSE(visdb::names_light_groups(scene));
}

TEST(LightScenes, SceneWithoutGroupsStoresNone) {
    visdb::Scene scene = grouped_scene();
    scene.materials[1].group.clear();
    for (visdb::Luminaire& l : scene.luminaires) l.group.clear();
    const visdb::Bake b = bake(scene, options(0, false));
    EXPECT_TRUE(b.light_groups.empty());
    EXPECT_EQ(b.statistics.seconds_light_groups, 0.0);
    for (const auto& [key, value] : b.parameters) EXPECT_NE(key, "light_groups");
    // No group to mix: any mix but the identity is refused, naming the group
    visdb::Scene s = scene;
    visdb::Bake copy = b;
    EXPECT_THROW(visdb::apply_scene_mix(visdb::parse_scene_mix("office=0.5"), s, copy),
                 std::invalid_argument);
}

TEST(LightScenes, ZeroForAGroupEqualsABakeWithoutItsLightsDirectOnly) {
    const visdb::Scene scene = grouped_scene();
    const visdb::Bake all = bake(scene, options(0, false));
    ASSERT_EQ(all.light_groups.size(), 3u);
    EXPECT_EQ(all.light_groups[0].name, "panel");
    EXPECT_EQ(all.light_groups[1].name, "office");
    EXPECT_EQ(all.light_groups[2].name, "corridor");
    EXPECT_GT(all.statistics.seconds_light_groups, 0.0);

    // Without the corridor's luminaire
    const visdb::Bake no_corridor = bake(grouped_scene(false), options(0, false));
    expect_same_shades(no_corridor.mesh, mixed(all, scene, "corridor=0").mesh, 1e-6);

    // Without the panel (its material emits nothing; the panel stays a surface)
    visdb::Scene dark = scene;
    dark.materials[1].emittance = visdb::Rgb(0.0);
    const visdb::Bake no_panel = bake(dark, options(0, false));
    expect_same_shades(no_panel.mesh, mixed(all, scene, "panel=0").mesh, 1e-6);

    // Dimmed: the office at 0.3 is a bake with its luminaire's flux scaled by 0.3
    visdb::Scene dimmed = scene;
    dimmed.luminaires[0].flux_scale = 0.3;
    const visdb::Bake office_dimmed = bake(dimmed, options(0, false));
    expect_same_shades(office_dimmed.mesh, mixed(all, scene, "office=0.3").mesh, 1e-6);
}

TEST(LightScenes, ZeroForAGroupEqualsABakeWithoutItsLightsWithInterreflection) {
    // Interreflection is solved once per group: a group's share is the solve of its lights
    const visdb::Scene scene = grouped_scene();
    visdb::Scene two = scene;
    two.materials[1].group = "office";  // two groups: office (panel, desk) and corridor
    const visdb::Bake all = bake(two, options(-1, false));
    ASSERT_EQ(all.light_groups.size(), 2u);
    ASSERT_TRUE(all.statistics.indirect.has_value());
    const visdb::Bake no_corridor = bake(grouped_scene(false), options(-1, false));
    expect_same_shades(no_corridor.mesh, mixed(all, two, "corridor=0").mesh, 1e-6);
}

TEST(LightScenes, BakesOwnMixIsBitForBitAndGroupsAddUpToIt) {
    const visdb::Scene scene = grouped_scene();
    for (const bool dm : {false, true}) {
        SCOPED_TRACE(dm ? "dm on" : "dm off");
        const visdb::Bake all = bake(scene, options(0, dm));
        ASSERT_EQ(all.light_groups.size(), 3u);
        const visdb::Bake own = mixed(all, scene, "panel=1,office=1,corridor=1");
        EXPECT_EQ(own.mesh.irradiance, all.mesh.irradiance);
        EXPECT_EQ(own.mesh.radiosity, all.mesh.radiosity);
        // The groups add up to the bake (with DM the groups' exact sums ask every source of
        // the group, the bake's only those its hemicubes saw reach the region)
        visdb::Bake sum = all;
        for (std::size_t v = 0; v < sum.mesh.positions.size(); ++v) {
            glm::dvec3 h(0.0), b(0.0);
            for (const visdb::LightGroupShades& g : all.light_groups) {
                h += glm::dvec3(g.irradiance[v]);
                b += glm::dvec3(g.radiosity[v]);
            }
            sum.mesh.irradiance[v] = glm::vec3(h);
            sum.mesh.radiosity[v] = glm::vec3(b);
        }
        expect_same_shades(all.mesh, sum.mesh, dm ? 1e-4 : 1e-6);
    }
}

TEST(LightScenes, MixNamingAnUnknownGroupIsRefused) {
    const visdb::Scene scene = grouped_scene();
    visdb::Bake b = bake(scene, options(0, false));
    visdb::Scene s = scene;
    try {
        visdb::apply_scene_mix(visdb::parse_scene_mix("office=1,kitchen=0"), s, b);
        FAIL() << "no error";
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("no light group 'kitchen'"), std::string::npos)
            << e.what();
        EXPECT_NE(std::string(e.what()).find("'panel', 'office', 'corridor'"), std::string::npos)
            << e.what();
    }
}

}  // namespace
}  // namespace abrad::radiosity
