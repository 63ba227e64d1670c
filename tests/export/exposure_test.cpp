// Automatic exposure from the camera's view (camera_tone_map) and clipped-pixel counts,
// against exposures worked out by hand for floors of known irradiance seen from above.

#include "abrad/export/exposure.h"

#include <gtest/gtest.h>

#include <cmath>

#include "abrad/export/image.h"
#include "export_scenes.h"

using namespace abrad;
using namespace abrad::exporter;
using abrad::testing::add_quad;
using abrad::testing::make_camera;

namespace {

// Surfaces 0 "floor" and 1 "platform" (receivers), 2 "light" (an emitter).
visdb::Scene floor_scene() {
    visdb::Scene s;
    s.materials = {{.name = "floor"},
                   {.name = "light", .reflectance = {0, 0, 0}, .emittance = {1000, 1000, 1000}}};
    s.surfaces.resize(3);
    s.surfaces[0].name = "floor";
    s.surfaces[1].name = "platform";
    s.surfaces[2].name = "light";
    s.surfaces[2].material = 1;
    return s;
}

// The floor z = 0 over [-10, 10]², irradiance 10 and radiosity 5 everywhere.
visdb::BakeMesh lit_floor() {
    visdb::BakeMesh m;
    add_quad(m, 0, {-10, -10, 0}, {10, -10, 0}, {10, 10, 0}, {-10, 10, 0}, {5.0f, 5.0f, 5.0f},
             {10.0f, 10.0f, 10.0f});
    return m;
}

// Looking straight down at the floor from 5 m: it fills the whole view.
visdb::Camera from_above() { return make_camera("above", {0, 0, 5}, {0, 0, 0}, {0, 1, 0}, 60.0); }

// exposure × B at which the 8-bit display code reaches 255, from the sRGB formulas.
double clip_value() {
    const double lin = std::pow((254.5 / 255.0 + 0.055) / 1.055, 2.4);
    return -std::log(1.0 - lin);
}

constexpr int kW = 160, kH = 120;

}  // namespace

TEST(Exposure, FollowsTheReceiversIrradianceNotTheEmittersOrTheBackground) {
    // A bright emitter in the middle of the view and a floor of irradiance 10: a white
    // surface at irradiance 10 shows 0.8, whatever the emitter's radiosity
    const visdb::Scene scene = floor_scene();
    visdb::BakeMesh m = lit_floor();
    add_quad(m, 2, {-1, -1, 1}, {1, -1, 1}, {1, 1, 1}, {-1, 1, 1}, {1000.0f, 1000.0f, 1000.0f},
             {0.0f, 0.0f, 0.0f});
    const ToneMap tone = camera_tone_map(m, scene, from_above(), kW, kH);
    EXPECT_NEAR(tone.exposure, -std::log(0.2) / 10.0, 1e-6);

    // The vertex percentile (the exposure without a camera) is pulled by the emitter's
    // vertices: half of the vertices are the light's
    EXPECT_GT(std::abs(auto_tone_map(m).exposure - tone.exposure), 0.1);

    // Background: looking at the floor's edge from the side, half the view is empty
    visdb::Camera edge = from_above();
    edge.position = {0, -12, 5};
    edge.look_at = {0, 10, 0};
    edge.up = {0, 0, 1};
    EXPECT_NEAR(camera_tone_map(m, scene, edge, kW, kH).exposure, -std::log(0.2) / 10.0, 1e-6);

    // The pixels by what covers them
    const Raster r = render_bake(m, from_above(), {.width = kW, .height = kH});
    const PixelCounts n = count_pixels(scene, m, r, tone);
    EXPECT_EQ(n.pixels, static_cast<std::size_t>(kW * kH));
    EXPECT_EQ(n.receivers + n.emitters, n.pixels);
    EXPECT_GT(n.emitters, 0u);
    EXPECT_EQ(n.receivers_clipped, 0u);  // 5 x 0.16 = 0.8 is far from clipping
}

TEST(Exposure, LowersItselfUntilAtMostOnePercentOfTheReceiversClip) {
    // A platform of radiosity 100 over about 3 % of the view: at the exposure of the floor's
    // irradiance (0.16) it would clip; the exposure drops to 0.999 T / 100 and nothing clips
    const visdb::Scene scene = floor_scene();
    visdb::BakeMesh m = lit_floor();
    add_quad(m, 1, {1, 1, 0.01}, {2.15, 1, 0.01}, {2.15, 2.15, 0.01}, {1, 2.15, 0.01},
             {100.0f, 100.0f, 100.0f}, {200.0f, 200.0f, 200.0f});
    const ToneMap tone = camera_tone_map(m, scene, from_above(), kW, kH);
    EXPECT_NEAR(tone.exposure, 0.999 * clip_value() / 100.0, 1e-6);

    const Raster r = render_bake(m, from_above(), {.width = kW, .height = kH});
    const PixelCounts n = count_pixels(scene, m, r, tone);
    EXPECT_EQ(n.receivers_clipped, 0u);
    // Just past the bound the whole platform clips: more than 1 % of the pixels
    const PixelCounts over = count_pixels(scene, m, r, ToneMap{.exposure = clip_value() / 99.0});
    EXPECT_GT(over.receivers_clipped_percent(), 1.0);
    EXPECT_LT(over.receivers_clipped_percent(), 5.0);
    EXPECT_EQ(
        count_pixels(scene, m, r, ToneMap{.exposure = -std::log(0.2) / 10.0}).receivers_clipped,
        over.receivers_clipped);
}

TEST(Exposure, AnUnlitViewFallsBackToTheVertices) {
    // Nothing lit in view: the camera looks away from the floor, at nothing
    const visdb::Scene scene = floor_scene();
    const visdb::BakeMesh m = lit_floor();
    visdb::Camera up = from_above();
    up.look_at = {0, 0, 10};
    EXPECT_EQ(camera_tone_map(m, scene, up, kW, kH).exposure, auto_tone_map(m).exposure);
}

TEST(Exposure, LargeViewsAreMeasuredScaledDown) {
    // 4000 x 3000 is measured on 640 x 480: the same answer as at that size
    const visdb::Scene scene = floor_scene();
    visdb::BakeMesh m = lit_floor();
    add_quad(m, 1, {1, 1, 0.01}, {2.15, 1, 0.01}, {2.15, 2.15, 0.01}, {1, 2.15, 0.01},
             {100.0f, 100.0f, 100.0f}, {200.0f, 200.0f, 200.0f});
    EXPECT_EQ(camera_tone_map(m, scene, from_above(), 4000, 3000).exposure,
              camera_tone_map(m, scene, from_above(), 640, 480).exposure);
}
