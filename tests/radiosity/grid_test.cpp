// Calculation grids and probe-point files (radiosity/grid.h) against exact answers.

#include "abrad/radiosity/grid.h"

#include <gtest/gtest.h>

#include <array>
#include <filesystem>
#include <fstream>
#include <string>

#include "abrad/atomic_file.h"
#include "abrad/radiosity/form_factor.h"
#include "file_size_limit.h"
#include "scenes.h"
#include "temp_dir.h"

namespace abrad::radiosity {
namespace {

namespace fs = std::filesystem;

// One square light, 1 x 1 m at z = 3 facing down, emitting E = 10 W/m² (grey); no occluder.
visdb::Scene one_light() {
    visdb::Scene scene;
    visdb::Material light;
    light.name = "light";
    light.emittance = {10.0, 10.0, 10.0};
    scene.materials.push_back(light);
    scene.sources.push_back({});
    scene.surfaces.push_back(abrad::testing::grid("light", 0, -0.5, 0.5, -0.5, 0.5, 3.0, 1, false));
    return scene;
}

// The closed-form irradiance at x (normal +z) under the light: E times the point-to-polygon
// form factor.
double exact_under_light(const glm::dvec3& x) {
    const std::array<glm::dvec3, 4> square = {
        glm::dvec3{-0.5, -0.5, 3.0}, {0.5, -0.5, 3.0}, {0.5, 0.5, 3.0}, {-0.5, 0.5, 3.0}};
    return 10.0 * point_polygon_form_factor(x, {0.0, 0.0, 1.0}, square);
}

TEST(Grid, PointsAtCellCentres) {
    const visdb::CalculationGrid g{
        .name = "g", .min = {0.0, 0.0}, .max = {2.0, 1.0}, .z = 0.8, .spacing = 0.6};
    const GridValues v = grid_points(g);
    ASSERT_EQ(v.nx, 4);  // ceil(2 / 0.6)
    ASSERT_EQ(v.ny, 2);  // ceil(1 / 0.6)
    ASSERT_EQ(v.points.size(), 8u);
    EXPECT_DOUBLE_EQ(v.points[0].x.x, 0.25);
    EXPECT_DOUBLE_EQ(v.points[0].x.y, 0.25);
    EXPECT_DOUBLE_EQ(v.points[0].x.z, 0.8);
    EXPECT_DOUBLE_EQ(v.points[7].x.x, 1.75);
    EXPECT_DOUBLE_EQ(v.points[7].x.y, 0.75);
    // An exact multiple of the spacing gives no extra row
    const GridValues w = grid_points({.name = "w", .max = {1.0, 1.0}, .spacing = 0.5});
    EXPECT_EQ(w.nx, 2);
    EXPECT_EQ(w.ny, 2);
}

TEST(Grid, UnderOneSquareLightMatchesTheClosedForm) {
    const visdb::Scene scene = one_light();
    const PointIrradiance field(scene, nullptr);
    const visdb::CalculationGrid g{
        .name = "floor", .min = {-1.5, -1.0}, .max = {1.5, 1.0}, .z = 0.0, .spacing = 0.5};
    const GridValues v = evaluate_grid(field, g);
    ASSERT_EQ(v.nx, 6);
    ASSERT_EQ(v.ny, 4);
    ASSERT_EQ(v.value.size(), 24u);
    double sum = 0.0, lo = 1e300, hi = 0.0;
    for (std::size_t k = 0; k < v.points.size(); ++k) {
        const double expected = exact_under_light(v.points[k].x);
        EXPECT_NEAR(v.value[k], expected, 1e-9 * expected) << "point " << k;
        EXPECT_NEAR(v.irradiance[k].x, expected, 1e-9 * expected);
        sum += expected;
        lo = std::min(lo, expected);
        hi = std::max(hi, expected);
    }
    EXPECT_NEAR(v.e_avg, sum / 24.0, 1e-9 * sum);
    EXPECT_NEAR(v.e_min, lo, 1e-9 * lo);
    EXPECT_NEAR(v.e_max, hi, 1e-9 * hi);
    EXPECT_DOUBLE_EQ(v.u0(), v.e_min / v.e_avg);
    EXPECT_GT(v.u0(), 0.0);
    EXPECT_LT(v.u0(), 1.0);
    // The corners are the darkest points, the four central ones the brightest
    EXPECT_DOUBLE_EQ(v.e_min, v.value[0]);
    EXPECT_DOUBLE_EQ(v.e_max, v.value[std::size_t(1 * 6 + 2)]);
}

TEST(Grid, UniformityOfKnownValues) {
    GridValues v;
    EXPECT_EQ(v.u0(), 0.0);  // no light: 0, not NaN
    v.e_min = 2.0;
    v.e_avg = 8.0;
    EXPECT_DOUBLE_EQ(v.u0(), 0.25);
}

TEST(Grid, ImageHasTheLargestYOnTop) {
    GridValues v;
    v.nx = 2;
    v.ny = 3;
    v.value = {0, 1, 2, 3, 4, 5};  // row j = 0 (smallest y) first
    EXPECT_EQ(v.image(), (std::vector<double>{4, 5, 2, 3, 0, 1}));
}

TEST(Grid, CsvHasOneLinePerPoint) {
    const visdb::Scene scene = one_light();
    const PointIrradiance field(scene, nullptr);
    const GridValues v = evaluate_grid(field, {.name = "g", .max = {1.0, 0.5}, .spacing = 0.5});
    const abrad::testing::TempDir dir("grid");
    const fs::path csv = dir / "grid.csv";
    write_grid_csv(csv, v);
    std::ifstream in(csv);
    std::string line;
    std::getline(in, line);
    EXPECT_EQ(line, "x,y,z,illuminance,irradiance_r,irradiance_g,irradiance_b");
    int rows = 0;
    while (std::getline(in, line)) ++rows;
    EXPECT_EQ(rows, 2);
    EXPECT_THROW(write_grid_csv("/nonexistent-dir/grid.csv", v), std::runtime_error);

    // On a full disk (a file-size limit): an error naming the file, the old file as it was
    const std::string old = abrad::testing::file_bytes(csv);
    std::string message;
    {
        const abrad::testing::FileSizeLimit full(16);  // bytes
        try {
            write_grid_csv(csv, v);
        } catch (const abrad::OutputError& e) {
            message = e.what();
        }
    }
    EXPECT_EQ(message, csv.string() + ": cannot write: File too large");
    EXPECT_EQ(abrad::testing::file_bytes(csv), old);
    EXPECT_EQ(dir.entry_count(), 1u);
}

// Probe-point files in a scratch folder of the test's own.
class ProbePoints : public ::testing::Test {
  protected:
    // Writes `text` to `name` in the test's folder and returns its path.
    fs::path points_file(const std::string& name, const std::string& text) const {
        return m_dir.write(name, text);
    }
    abrad::testing::TempDir m_dir{"grid"};
};

// The message of the InputFileError that reading `path` throws.
std::string read_error(const fs::path& path) {
    try {
        (void)read_probe_points(path);
    } catch (const InputFileError& e) {
        return e.what();
    }
    return "(no error)";
}

TEST_F(ProbePoints, ReadsHeaderBlankLinesAndNormalises) {
    const fs::path p =
        points_file("abrad_points_ok.csv", "x,y,z,nx,ny,nz\r\n1, 2 ,3,0,0,2\n\n\t\n4,5,6,3,0,4\n");
    const std::vector<ProbePoint> pts = read_probe_points(p);
    ASSERT_EQ(pts.size(), 2u);
    EXPECT_EQ(pts[0].x, glm::dvec3(1, 2, 3));
    EXPECT_EQ(pts[0].n, glm::dvec3(0, 0, 1));
    EXPECT_NEAR(pts[1].n.x, 0.6, 1e-15);
    EXPECT_NEAR(pts[1].n.z, 0.8, 1e-15);
    fs::remove(p);
}

TEST_F(ProbePoints, MalformedLinesAreRefusedNamingFileAndLine) {
    const struct {
        const char* text;
        const char* message;
    } cases[] = {
        {"1,2,3,0,0,1\n1,2,3,0,0\n", ":2: expected six finite numbers"},
        {"1,2,3,0,0,1\n1,2,3,0,0,1,7\n", ":2: expected six finite numbers"},
        {"1,2,3,0,0,1\n\n1;2;3;0;0;1\n", ":3: expected six finite numbers"},
        {"1,2,3,0,0,1\n1,2,nan,0,0,1\n", ":2: expected six finite numbers"},
        {"x1,y,z,nx,ny,nz\n", ":1: expected six finite numbers"},  // a digit: not a header
        {"1,2,3,0,0,0\n", ":1: normal is zero"},
    };
    for (const auto& c : cases) {
        const fs::path p = points_file("abrad_points_bad.csv", c.text);
        const std::string what = read_error(p);
        EXPECT_NE(what.find(p.string() + c.message), std::string::npos) << c.text << " -> " << what;
        fs::remove(p);
    }
    const fs::path empty = points_file("abrad_points_empty.csv", "x,y,z,nx,ny,nz\n\n");
    EXPECT_EQ(read_error(empty), empty.string() + ": no points");
    fs::remove(empty);
    EXPECT_EQ(read_error("/nonexistent-dir/p.csv"),
              "/nonexistent-dir/p.csv: cannot open points file");
}

}  // namespace
}  // namespace abrad::radiosity
