// abrad's Gouraud rasterizer against ray-traced closed forms, the camera choice, and (when
// POV-Ray is installed) the POV-Ray exports rendered by POV-Ray against abrad's own render
// and against the exact direct irradiance.

#include "abrad/export/render.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <glm/geometric.hpp>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include "abrad/export/exposure.h"
#include "abrad/export/image.h"
#include "abrad/export/writers.h"
#include "abrad/radiosity/form_factor.h"
#include "export_scenes.h"
#include "temp_dir.h"

namespace fs = std::filesystem;
using namespace abrad;
using namespace abrad::exporter;

namespace {

// Appends a quad a, b, c, d (counter-clockwise seen from the front) whose vertex radiosity is
// `value(position)` and irradiance twice that.
template <typename F>
void add_quad(visdb::BakeMesh& m, std::uint32_t surface, const glm::dvec3& a, const glm::dvec3& b,
              const glm::dvec3& c, const glm::dvec3& d, F value) {
    abrad::testing::add_quad(m, surface, a, b, c, d, value,
                             [&](const glm::dvec3& p) { return 2.0f * value(p); });
}

// A floor z = -1 from y = -5 (behind the camera) to 18.7 (between two pixel rows) whose radiosity
// is (y + 5, x + 10, 1), and a wall at y = 5 over x in [-1, 1], z in [-1, 0.5] of value 100.
visdb::BakeMesh floor_and_wall() {
    visdb::BakeMesh m;
    add_quad(
        m, 0, {-10, -5, -1}, {10, -5, -1}, {10, 18.7, -1}, {-10, 18.7, -1},
        [](const glm::dvec3& p) { return glm::vec3(float(p.y + 5.0), float(p.x + 10.0), 1.0f); });
    add_quad(m, 1, {-1, 5, -1}, {1, 5, -1}, {1, 5, 0.5}, {-1, 5, 0.5},
             [](const glm::dvec3&) { return glm::vec3(100.0f); });
    return m;
}

visdb::Camera looking_along_y() {
    return abrad::testing::make_camera("test", {0, 0, 0}, {0, 1, 0}, {0, 0, 1}, 90.0);
}

// The ray through pixel (i, j), as CameraFrame documents it.
glm::dvec3 pixel_ray(const CameraFrame& f, int i, int j, int w, int h) {
    return f.forward + ((i + 0.5) / w - 0.5) * f.right_extent * f.right +
           (0.5 - (j + 0.5) / h) * f.up_extent * f.up;
}

bool have_povray() {
#ifdef ABRAD_POVRAY
    return true;
#else
    return false;
#endif
}

// Renders `scene.pov` in `dir` with POV-Ray to `out.exr` (w x h, no antialiasing), or to
// `out.png` when `png`.
void povray(const fs::path& dir, int w, int h, bool png = false) {
#ifdef ABRAD_POVRAY
    const std::string cmd = "cd '" + dir.string() + "' && " + ABRAD_POVRAY + " +Iscene.pov " +
                            (png ? "+Oout.png +FN" : "+Oout.exr +FE") + " +W" + std::to_string(w) +
                            " +H" + std::to_string(h) +
                            " -A -D -V +L/usr/share/povray-3.7/include > povray.log 2>&1";
    ASSERT_EQ(std::system(cmd.c_str()), 0) << "see " << (dir / "povray.log");
#else
    (void)dir, (void)w, (void)h, (void)png;
#endif
}

// The shortest text of a float, as the POV-Ray export writes it.
std::string shortest(float v) {
    char buf[64];
    const auto res = std::to_chars(buf, buf + sizeof buf, v);
    return {buf, res.ptr};
}

// The share of pixels of `img` with a channel at full scale (8-bit code 255), in percent.
double clipped_percent(const Image& img) {
    std::size_t n = 0;
    for (std::size_t i = 0; i < img.rgb.size(); i += 3)
        if (std::max({img.rgb[i], img.rgb[i + 1], img.rgb[i + 2]}) >= 1.0f) ++n;
    return 100.0 * static_cast<double>(n) / static_cast<double>(img.rgb.size() / 3);
}

}  // namespace

TEST(Render, InterpolatesPerspectiveCorrectlyAndClipsAtTheNearPlane) {
    const visdb::BakeMesh m = floor_and_wall();
    const int w = 64, h = 48;
    const Raster r = render_bake(m, looking_along_y(), {.width = w, .height = h});
    const CameraFrame f = camera_frame(looking_along_y(), w, h);
    int floor_pixels = 0, wall_pixels = 0;
    for (int j = 0; j < h; ++j)
        for (int i = 0; i < w; ++i) {
            const glm::dvec3 d = pixel_ray(f, i, j, w, h);
            const std::size_t o = static_cast<std::size_t>(j * w + i);
            // Wall first (nearer), then the floor
            const double tw = 5.0 / d.y;
            const glm::dvec3 pw = tw * d;
            if (std::abs(pw.x) < 0.999 && pw.z > -0.999 && pw.z < 0.499) {
                ASSERT_TRUE(r.covered[o]);
                EXPECT_FLOAT_EQ(r.value[o].r, 100.0f);
                ++wall_pixels;
                continue;
            }
            if (d.z >= -1e-9) {
                EXPECT_FALSE(r.covered[o]) << i << "," << j;
                continue;
            }
            const glm::dvec3 p = (-1.0 / d.z) * d;
            if (std::abs(p.x) > 9.99 || p.y > 18.69) continue;  // edges
            ASSERT_TRUE(r.covered[o]) << i << "," << j;
            // Values affine in the position come back exactly at the hit point
            EXPECT_NEAR(r.value[o].r, p.y + 5.0, 1e-4 * (1.0 + p.y)) << i << "," << j;
            EXPECT_NEAR(r.value[o].g, p.x + 10.0, 1e-4 * (1.0 + p.y)) << i << "," << j;
            ++floor_pixels;
        }
    EXPECT_GT(floor_pixels, 500);
    EXPECT_GT(wall_pixels, 50);
    // Irradiance is the other vertex array
    const Raster ri = render_bake(
        m, looking_along_y(), {.width = w, .height = h, .quantity = RenderQuantity::Irradiance});
    EXPECT_FLOAT_EQ(ri.value[static_cast<std::size_t>(h / 2 * w + w / 2)].r, 200.0f);
}

TEST(Render, TrianglesGrazingTheNearPlaneProjectFarOutside) {
    // A huge floor at survey scale through the near plane: projected coordinates beyond any
    // int must clamp (UBSan checks the conversions), and the visible part is still drawn
    visdb::BakeMesh m;
    add_quad(m, 0, {-1e7, -1e7, -1}, {1e7, -1e7, -1}, {1e7, 1e7, -1}, {-1e7, 1e7, -1},
             [](const glm::dvec3&) { return glm::vec3(2.0f); });
    visdb::Camera c = looking_along_y();
    const Raster r = render_bake(m, c, {.width = 32, .height = 24, .near = 1e-9});
    EXPECT_EQ(r.covered[23 * 32 + 16], 1);
    EXPECT_FLOAT_EQ(r.value[23 * 32 + 16].r, 2.0f);
    EXPECT_EQ(r.covered[0], 0);
}

TEST(Render, BacksOfFacesAreBlack) {
    visdb::BakeMesh m;
    // The wall of floor_and_wall() wound the other way: the camera sees its back
    add_quad(m, 0, {-1, 5, -1}, {-1, 5, 0.5}, {1, 5, 0.5}, {1, 5, -1},
             [](const glm::dvec3&) { return glm::vec3(100.0f); });
    const Raster r = render_bake(m, looking_along_y(), {.width = 32, .height = 24});
    const std::size_t centre = 12 * 32 + 16;
    EXPECT_EQ(r.covered[centre], 2);
    EXPECT_EQ(r.value[centre], glm::vec3(0.0f));
    EXPECT_EQ(r.covered[0], 0);
}

TEST(Render, RejectsDegenerateCamerasAndBadMeshes) {
    visdb::Camera c = looking_along_y();
    c.look_at = c.position;
    EXPECT_THROW((void)render_bake(floor_and_wall(), c, {}), CameraError);
    c = looking_along_y();
    c.up = {0, 2, 0};
    EXPECT_THROW((void)render_bake(floor_and_wall(), c, {}), CameraError);
    visdb::BakeMesh bad = floor_and_wall();
    bad.triangles[0].x = 99;
    EXPECT_THROW((void)render_bake(bad, looking_along_y(), {}), ExportError);
}

namespace {

// A closed room 6 x 4 x 3 m (faces inward) with a ceiling light.
visdb::Scene box_room() {
    visdb::Scene s;
    s.materials = {{.name = "wall"},
                   {.name = "light", .reflectance = {0, 0, 0}, .emittance = {50, 50, 50}}};
    auto quad = [&](const std::string& name, std::uint32_t mat, glm::dvec3 a, glm::dvec3 b,
                    glm::dvec3 c, glm::dvec3 d) {
        visdb::Surface surf;
        surf.name = name;
        surf.material = mat;
        surf.mesh.positions = {a, b, c, d};
        surf.mesh.triangles = {{0, 1, 2}, {0, 2, 3}};
        s.surfaces.push_back(surf);
    };
    quad("floor", 0, {0, 0, 0}, {6, 0, 0}, {6, 4, 0}, {0, 4, 0});
    quad("ceiling", 0, {0, 0, 3}, {0, 4, 3}, {6, 4, 3}, {6, 0, 3});
    quad("south", 0, {0, 0, 0}, {0, 0, 3}, {6, 0, 3}, {6, 0, 0});
    quad("north", 0, {0, 4, 0}, {6, 4, 0}, {6, 4, 3}, {0, 4, 3});
    quad("west", 0, {0, 0, 0}, {0, 4, 0}, {0, 4, 3}, {0, 0, 3});
    quad("east", 0, {6, 0, 0}, {6, 0, 3}, {6, 4, 3}, {6, 4, 0});
    quad("light", 1, {2.5, 1.5, 2.99}, {2.5, 2.5, 2.99}, {3.5, 2.5, 2.99}, {3.5, 1.5, 2.99});
    return s;
}

}  // namespace

TEST(Camera, DefaultIsInsideTheLargestRoomLookingAtItsCentre) {
    const visdb::Camera c = default_camera(box_room());
    EXPECT_EQ(c.name, "default");
    // 75 % of the way from the floor's centroid (3, 2) to its corner (0, 0), 1.6 m up; the
    // ceiling probe passes the light (an emitter, not a ceiling) and meets the ceiling
    EXPECT_NEAR(c.position.x, 0.75, 1e-9);
    EXPECT_NEAR(c.position.y, 0.5, 1e-9);
    EXPECT_NEAR(c.position.z, 1.6, 1e-9);
    EXPECT_NEAR(c.look_at.x, 3.0, 1e-9);
    EXPECT_NEAR(c.look_at.y, 2.0, 1e-9);
    EXPECT_NEAR(c.look_at.z, 0.35 * (3.0 - 1e-4), 1e-9);  // probed from 0.1 mm above the floor
}

TEST(Camera, CeilingHeightPassesFurnitureOverTheFloorsCentre) {
    // A table (a closed box, its top's underside at 0.71 m) right over the floor's centroid
    // (3, 2): the ray up passes it and meets the ceiling at 3 m, so the eye is 1.6 m up (a
    // ceiling taken at the table would put it at 0.6 x 0.71 = 0.43 m)
    visdb::Scene s = box_room();
    visdb::Surface table;
    table.name = "table";
    table.material = 0;
    const glm::dvec3 lo(2.2, 1.6, 0.71), hi(3.8, 2.4, 0.75);
    for (int k = 0; k < 8; ++k)
        table.mesh.positions.emplace_back(k & 1 ? hi.x : lo.x, k & 2 ? hi.y : lo.y,
                                          k & 4 ? hi.z : lo.z);
    // Outward faces: bottom (down), top (up), and the four sides
    table.mesh.triangles = {{0, 2, 3}, {0, 3, 1}, {4, 5, 7}, {4, 7, 6}, {0, 1, 5}, {0, 5, 4},
                            {2, 6, 7}, {2, 7, 3}, {0, 4, 6}, {0, 6, 2}, {1, 3, 7}, {1, 7, 5}};
    s.surfaces.push_back(table);
    const visdb::Camera c = default_camera(s);
    EXPECT_NEAR(c.position.z, 1.6, 1e-9);
    EXPECT_NEAR(c.look_at.z, 0.35 * (3.0 - 1e-4), 1e-9);

    // A ceiling over a fifth of the floor is no ceiling of this room: the floor is seen as
    // a room no more, the model from outside
    visdb::Scene low = box_room();
    low.surfaces[1].mesh.positions = {{2, 1, 3}, {2, 3, 3}, {4, 3, 3}, {4, 1, 3}};
    EXPECT_LT(default_camera(low).position.x, 0.0);
}

TEST(Camera, OpenModelsAreSeenFromOutside) {
    visdb::Scene s = box_room();
    s.surfaces.erase(s.surfaces.begin() + 1);  // no ceiling: no room
    s.surfaces.pop_back();                     // nor the light
    const visdb::Camera c = default_camera(s);
    EXPECT_NEAR(c.look_at.x, 3.0, 1e-9);
    EXPECT_NEAR(c.look_at.z, 1.5, 1e-9);
    EXPECT_LT(c.position.x, 0.0);
    EXPECT_LT(c.position.y, 0.0);
    EXPECT_GT(c.position.z, 3.0);
}

TEST(Camera, SelectByNameFirstOrDefault) {
    visdb::Scene s = box_room();
    EXPECT_EQ(select_camera(s, "").name, "default");
    visdb::Camera a = looking_along_y();
    a.name = "entrance";
    visdb::Camera b = looking_along_y();
    b.name = "desk";
    s.cameras = {a, b};
    EXPECT_EQ(select_camera(s, "").name, "entrance");
    EXPECT_EQ(select_camera(s, "desk").name, "desk");
    EXPECT_EQ(select_camera(s, "default").name, "default");
    try {
        (void)select_camera(s, "attic");
        FAIL() << "no error";
    } catch (const CameraError& e) {
        const std::string what = e.what();
        EXPECT_NE(what.find("'attic'"), std::string::npos) << what;
        EXPECT_NE(what.find("'entrance', 'desk'"), std::string::npos) << what;
    }
}

TEST(PovExport, WritesOneMesh2PerSurfaceWithExactVertexColours) {
    const abrad::testing::TempDir tmp("render");  // kept with its files if the test fails
    const fs::path& dir = tmp.path();
    visdb::Scene scene;
    scene.surfaces.resize(2);
    scene.surfaces[0].name = "floor";
    scene.surfaces[1].name = "wall";
    const visdb::BakeMesh m = floor_and_wall();
    write_pov(dir / "scene.pov", scene, m,
              {.camera = looking_along_y(), .width = 64, .height = 48, .exposure = 0.125});
    std::ifstream in(dir / "scene.pov");
    std::stringstream ss;
    ss << in.rdbuf();
    const std::string text = ss.str();
    auto count = [&](const std::string& what) {
        std::size_t n = 0;
        for (std::size_t p = text.find(what); p != std::string::npos; p = text.find(what, p + 1))
            ++n;
        return n;
    };
    EXPECT_EQ(count("mesh2 {"), 2u);
    EXPECT_EQ(count("light_source"), 0u);
    EXPECT_NE(text.find("#declare Abrad_Exposure = 0.125;"), std::string::npos);
    EXPECT_NE(text.find("emission Abrad_Exposure"), std::string::npos);
    EXPECT_NE(text.find("// surface 1 'wall'"), std::string::npos);
    EXPECT_NE(text.find("texture{pigment{rgb<100,100,100>}finish{Abrad_Finish}}"),
              std::string::npos);
    EXPECT_NE(text.find("<0,2,1>,0,2,1"), std::string::npos);  // POV-Ray's front is left-handed
    EXPECT_NE(text.find("interior_texture { Abrad_Back }"), std::string::npos);
    EXPECT_FALSE(fs::exists(dir / "scene.pov.tmp"));
}

TEST(PovExport, PovRayRendersTheSameImageAsAbrad) {
    if (!have_povray()) GTEST_SKIP() << "povray not installed";
    const abrad::testing::TempDir tmp("render");
    const fs::path& dir = tmp.path();
    const int w = 80, h = 60;
    const double exposure = 0.05;
    visdb::Scene scene;
    scene.surfaces.resize(2);
    const visdb::BakeMesh m = floor_and_wall();
    write_pov(dir / "scene.pov", scene, m,
              {.camera = looking_along_y(), .width = w, .height = h, .exposure = exposure});
    povray(dir, w, h);
    const Image pov = read_image(dir / "out.exr");
    const Raster r = render_bake(m, looking_along_y(), {.width = w, .height = h});
    Image own{w, h, std::vector<float>(static_cast<std::size_t>(w * h * 3))};
    for (std::size_t i = 0; i < r.value.size(); ++i)
        for (int c = 0; c < 3; ++c)
            own.rgb[3 * i + static_cast<std::size_t>(c)] =
                static_cast<float>(exposure * r.value[i][c]);
    const ImageDifference d = compare_images(own, pov);
    write_image(dir / "own.exr", w, h, own.rgb);  // left for a person when the test fails
    // Same data, two rasterizers: only half-float rounding and edge pixels differ
    EXPECT_GT(d.psnr_db, 45.0) << d.to_string();
    int close = 0;
    for (std::size_t i = 0; i < own.rgb.size(); ++i)
        if (std::abs(own.rgb[i] - pov.rgb[i]) <= 2e-3f * std::max(1.0f, own.rgb[i])) ++close;
    EXPECT_GT(close, static_cast<int>(0.99 * static_cast<double>(own.rgb.size())))
        << d.to_string() << "; images in " << dir;
}

TEST(PovExport, ToneMappedVariantWritesDisplayValuesForPng) {
    const abrad::testing::TempDir tmp("render");
    const fs::path& dir = tmp.path();
    visdb::Scene scene;
    scene.surfaces.resize(2);
    const visdb::BakeMesh m = floor_and_wall();
    const PovView view{.camera = looking_along_y(), .width = 64, .height = 48, .exposure = 0.125};
    PovView toned = view;
    toned.tone_mapped = true;
    write_pov(dir / "linear.pov", scene, m, view);
    write_pov(dir / "toned.pov", scene, m, toned);
    auto text = [&](const char* name) {
        std::ifstream in(dir / name);
        std::stringstream ss;
        ss << in.rdbuf();
        return ss.str();
    };
    const std::string linear = text("linear.pov"), tone = text("toned.pov");
    // The linear one: exposure x B for OpenEXR
    EXPECT_NE(linear.find("+Olinear.exr +FE"), std::string::npos);
    EXPECT_NE(linear.find("emission Abrad_Exposure"), std::string::npos);
    // The tone-mapped one: 1 - exp(-0.125 B) as the colour, emission 1, a PNG command, and
    // no exposure left to override
    EXPECT_NE(tone.find("+Otoned.png +FN"), std::string::npos);
    EXPECT_EQ(tone.find("Abrad_Exposure"), std::string::npos);
    EXPECT_NE(tone.find("emission 1 }"), std::string::npos);
    const std::string wall = shortest(static_cast<float>(1.0 - std::exp(-0.125 * 100.0)));
    EXPECT_NE(tone.find("texture{pigment{rgb<" + wall + "," + wall + "," + wall + ">}"),
              std::string::npos)
        << wall;
    // Everything but the header and the colours is the same: the geometry, in the same order
    auto after = [](const std::string& s, const char* from) { return s.substr(s.find(from)); };
    auto without_colours = [](std::string s) {
        for (std::size_t p = s.find("rgb<"); p != std::string::npos; p = s.find("rgb<", p + 4))
            s.erase(p + 4, s.find('>', p) - (p + 4));
        return s;
    };
    EXPECT_EQ(without_colours(after(tone, "// surface 0")),
              without_colours(after(linear, "// surface 0")));
}

// The tone-mapped variant rendered by POV-Ray to a PNG shows abrad render's tone curve (applied
// per vertex) and, with the automatic exposure, clips at most 2 % of the pixels; the linear
// variant at the same exposure, written to a PNG, clips more
TEST(PovExport, ToneMappedPngClipsAtMostTwoPercent) {
    if (!have_povray()) GTEST_SKIP() << "povray not installed";
    const abrad::testing::TempDir tmp("render");
    const fs::path& dir = tmp.path();
    const int w = 80, h = 60;
    visdb::Scene scene;
    scene.surfaces.resize(2);
    const visdb::BakeMesh m = floor_and_wall();
    const ToneMap tone = camera_tone_map(m, scene, looking_along_y(), w, h);
    PovView view{.camera = looking_along_y(), .width = w, .height = h, .exposure = tone.exposure};
    view.tone_mapped = true;
    write_pov(dir / "scene.pov", scene, m, view);
    povray(dir, w, h, true);
    const Image png = read_image(dir / "out.png");
    const double toned_clipped = clipped_percent(png);
    EXPECT_LE(toned_clipped, 2.0) << "images in " << dir;

    // The same picture from abrad's rasterizer over the tone-mapped vertex values
    visdb::BakeMesh toned = m;
    for (auto& b : toned.radiosity)
        for (int c = 0; c < 3; ++c) b[c] = static_cast<float>(tone_value(b[c], tone));
    const Raster r = render_bake(toned, looking_along_y(), {.width = w, .height = h});
    int close = 0;
    for (std::size_t i = 0; i < r.value.size(); ++i)
        for (int c = 0; c < 3; ++c)
            if (std::abs(png.rgb[3 * i + static_cast<std::size_t>(c)] - r.value[i][c]) <= 0.01f)
                ++close;
    EXPECT_GT(close, static_cast<int>(0.99 * 3 * w * h)) << "images in " << dir;

    view.tone_mapped = false;
    write_pov(dir / "scene.pov", scene, m, view);
    povray(dir, w, h, true);
    EXPECT_GT(clipped_percent(read_image(dir / "out.png")), toned_clipped + 1.0);
}

TEST(PovReference, PointLightsGiveTheExactDirectIrradianceOfALambertianEmitter) {
    if (!have_povray()) GTEST_SKIP() << "povray not installed";
    const abrad::testing::TempDir tmp("render");
    const fs::path& dir = tmp.path();
    // A floor (rho 0.5) under a 1 x 1 m emitter at z = 2 facing down, E = 100 W/m²
    visdb::Scene s;
    s.materials = {{.name = "floor", .reflectance = {0.5, 0.5, 0.5}},
                   {.name = "light", .reflectance = {0, 0, 0}, .emittance = {100, 100, 100}}};
    visdb::Surface floor;
    floor.name = "floor";
    floor.material = 0;
    floor.mesh.positions = {{-3, -3, 0}, {3, -3, 0}, {3, 3, 0}, {-3, 3, 0}};
    floor.mesh.triangles = {{0, 1, 2}, {0, 2, 3}};
    visdb::Surface light;
    light.name = "light";
    light.material = 1;
    const std::vector<glm::dvec3> lp = {
        {-0.5, -0.5, 2}, {-0.5, 0.5, 2}, {0.5, 0.5, 2}, {0.5, -0.5, 2}};
    light.mesh.positions = lp;
    light.mesh.triangles = {{0, 1, 2}, {0, 2, 3}};
    s.surfaces = {floor, light};
    visdb::Camera cam;
    cam.name = "down";
    cam.position = {0, 0, 1.5};
    cam.look_at = {0, 0, 0};
    cam.up = {0, 1, 0};
    cam.fov_y_deg = 100.0;
    const int w = 64, h = 48;
    const double exposure = 0.2;
    write_pov_reference(dir / "scene.pov", s,
                        {.view = {.camera = cam, .width = w, .height = h, .exposure = exposure},
                         .light_samples = 256});
    povray(dir, w, h);
    const Image img = read_image(dir / "out.exr");
    const CameraFrame f = camera_frame(cam, w, h);
    int checked = 0;
    double worst = 0.0;
    for (int j = 0; j < h; j += 3)
        for (int i = 0; i < w; i += 3) {
            const glm::dvec3 d = pixel_ray(f, i, j, w, h);
            const glm::dvec3 p = cam.position + (-cam.position.z / d.z) * d;
            if (std::abs(p.x) > 2.9 || std::abs(p.y) > 2.9) continue;
            const double H = 100.0 * radiosity::point_polygon_form_factor(p, {0, 0, 1}, lp);
            const double expected = exposure * 0.5 * H;
            const double got = img.at(i, j, 1);
            worst = std::max(worst, std::abs(got - expected) / expected);
            EXPECT_NEAR(got, expected, 0.01 * expected + 1e-3)
                << "floor point " << p.x << "," << p.y;
            ++checked;
        }
    EXPECT_GT(checked, 100);
    RecordProperty("worst_relative_error", std::to_string(worst));
}

TEST(PovReference, RadiosityBouncesAddIndirectLightInAClosedRoom) {
    if (!have_povray()) GTEST_SKIP() << "povray not installed";
    // The closed 6 x 4 x 3 m room (reflectance 0.5) seen from the default camera: POV-Ray's
    // radiosity must brighten it, by less than the geometric series 1 / (1 - rho) = 2 allows
    const visdb::Scene s = box_room();
    const int w = 48, h = 36;
    double mean[2] = {0.0, 0.0};
    const abrad::testing::TempDir images("render");
    for (int bounces = 0; bounces < 2; ++bounces) {
        const fs::path dir = images / ("bounces_" + std::to_string(bounces));
        fs::create_directories(dir);
        write_pov_reference(
            dir / "scene.pov", s,
            {.view = {.camera = default_camera(s), .width = w, .height = h, .exposure = 0.1},
             .light_samples = 16,
             .bounces = bounces * 3,
             .quality = PovQuality::Low});
        povray(dir, w, h);
        const Image img = read_image(dir / "out.exr");
        for (float v : img.rgb)
            mean[bounces] += std::min(static_cast<double>(v), 4.0);  // the light clipped
        mean[bounces] /= static_cast<double>(img.rgb.size());
    }
    EXPECT_GT(mean[1], 1.2 * mean[0]) << "images in " << images.path();
    EXPECT_LT(mean[1], 2.0 * mean[0]) << "images in " << images.path();
}
