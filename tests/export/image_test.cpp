// Image output through OpenImageIO: sRGB/linear round trips, the false-colour scale and its
// legend, and the comparison metrics behind `abrad compare`.

#include "abrad/export/image.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include "abrad/export/writers.h"
#include "temp_dir.h"

namespace fs = std::filesystem;
using namespace abrad::exporter;

namespace {

double luminance(const glm::vec3& c) { return 0.2126 * c.r + 0.7152 * c.g + 0.0722 * c.b; }

}  // namespace

TEST(Image, SrgbEncodeDecodeRoundTrip) {
    for (double v : {0.0, 0.001, 0.0031308, 0.01, 0.18, 0.5, 0.9, 1.0})
        EXPECT_NEAR(srgb_decode(srgb_encode(v)), v, 1e-8) << v;
    EXPECT_NEAR(srgb_encode(0.5), 0.735356983, 1e-8);  // the standard's curve at mid grey
    EXPECT_NEAR(srgb_encode(2.0), 1.0, 1e-12);         // clamps
}

TEST(Image, ExrKeepsLinearValuesAboveOne) {
    const abrad::testing::TempDir dir("image");  // kept if the test fails
    const fs::path p = dir / "linear.exr";
    std::vector<float> rgb = {0.0f, 0.25f, 1.0f, 3.5f, 120.0f, 0.001f};  // 2x1 pixels
    write_image(p, 2, 1, rgb);
    const Image img = read_image(p);
    ASSERT_EQ(img.width, 2);
    ASSERT_EQ(img.height, 1);
    for (std::size_t i = 0; i < rgb.size(); ++i)
        EXPECT_NEAR(img.rgb[i], rgb[i], 1e-3 * std::max(1.0f, rgb[i])) << i;  // half float
}

TEST(Image, PngIsSrgbEncodedAndReadBackLinear) {
    const abrad::testing::TempDir dir("image");  // kept if the test fails
    const fs::path p = dir / "display.png";
    // Top row 0.5 grey, bottom row (0.2, 0.9, 2.0)
    std::vector<float> rgb = {0.5f, 0.5f, 0.5f, 0.2f, 0.9f, 2.0f};
    write_image(p, 1, 2, rgb);
    const Image img = read_image(p);
    ASSERT_EQ(img.width, 1);
    ASSERT_EQ(img.height, 2);
    // 8-bit sRGB code of 0.5 is round(0.7354 * 255) = 188, decoded 0.5029
    EXPECT_NEAR(img.at(0, 0, 0), srgb_decode(188.0 / 255.0), 1e-6);
    EXPECT_NEAR(img.at(0, 1, 1), 0.9, 0.005);
    EXPECT_NEAR(img.at(0, 1, 2), 1.0, 1e-6);  // clamped
}

TEST(Image, WriteRejectsWrongBufferSizeNamingThePath) {
    const abrad::testing::TempDir dir("image");  // kept if the test fails
    const fs::path p = dir / "bad.png";
    std::vector<float> rgb(5, 0.0f);
    try {
        write_image(p, 2, 1, rgb);
        FAIL() << "no error";
    } catch (const ExportError& e) {
        EXPECT_NE(std::string(e.what()).find("bad.png"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("needs 6"), std::string::npos) << e.what();
    }
    EXPECT_FALSE(fs::exists(p));
}

TEST(Image, ReadMissingFileNamesIt) {
    const abrad::testing::TempDir dir("image");  // kept if the test fails
    try {
        (void)read_image(dir / "missing.exr");
        FAIL() << "no error";
    } catch (const ExportError& e) {
        EXPECT_NE(std::string(e.what()).find("missing.exr"), std::string::npos) << e.what();
    }
}

TEST(FalseColour, LightnessRisesMonotonically) {
    double last = -1.0;
    for (int i = 0; i <= 100; ++i) {
        const double y = luminance(false_colour(i / 100.0));
        EXPECT_GT(y, last) << "t = " << i / 100.0;
        last = y;
    }
    // Ends are viridis' dark violet and yellow; out of range and NaN clamp
    EXPECT_NEAR(false_colour(0.0).r, srgb_decode(0.267004), 1e-6);
    EXPECT_NEAR(false_colour(1.0).g, srgb_decode(0.906157), 1e-6);
    EXPECT_EQ(false_colour(-3.0), false_colour(0.0));
    EXPECT_EQ(false_colour(7.0), false_colour(1.0));
    EXPECT_EQ(false_colour(std::nan("")), false_colour(0.0));
}

TEST(FalseColour, ImageHasValuesNoDataAndALabelledLegend) {
    const abrad::testing::TempDir dir("image");  // kept if the test fails
    const int w = 100, h = 160;
    std::vector<double> values(static_cast<std::size_t>(w * h));
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            values[static_cast<std::size_t>(y * w + x)] = 5.0 * x;  // 0..495
    values[0] = std::nan("");
    const fs::path p = dir / "false.png";
    write_false_colour_image(p, w, h, values, 0.0, 500.0, "W/m\u00b2");
    const Image img = read_image(p);
    ASSERT_GE(img.width, w + 90);
    ASSERT_EQ(img.height, h);
    // A data pixel has the scale's colour (8-bit rounding)
    const glm::vec3 c = false_colour(250.0 / 500.0);
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(img.at(50, 60, k), c[k], 0.01);
    // No data is dark grey
    EXPECT_NEAR(img.at(0, 0, 1), 0.02, 0.005);
    // The legend bar: top is the scale's top, bottom its bottom
    const glm::vec3 top = false_colour(1.0), bottom = false_colour(0.0);
    const int bar_x = w + 12;
    EXPECT_NEAR(img.at(bar_x, 20, 1), top.g, 0.01);
    EXPECT_NEAR(img.at(bar_x, h - 8, 1), bottom.g, 0.01);
    // Labels: white-ish text pixels right of the bar
    int bright = 0;
    for (int y = 0; y < h; ++y)
        for (int x = w + 30; x < img.width; ++x)
            if (img.at(x, y, 0) > 0.5 && img.at(x, y, 1) > 0.5 && img.at(x, y, 2) > 0.5) ++bright;
    EXPECT_GT(bright, 30);
}

TEST(FalseColour, WithoutTheFontTheBitmapFontDrawsTheLabels) {
    const abrad::testing::TempDir dir("image");  // kept if the test fails
    const int w = 40, h = 200;
    std::vector<double> values(static_cast<std::size_t>(w * h), 3.0);
    const fs::path p = dir / "bitmap.png";
    write_false_colour_image(p, w, h, values, 0.0, 1000.0, "lux", dir / "no-such-font.ttf");
    const Image img = read_image(p);
    // Labels "0", "250", "500", "750", "1000" and "lux" in white 5x7 glyphs right of the bar
    int white = 0;
    for (int y = 0; y < h; ++y)
        for (int x = w; x < img.width; ++x)
            if (img.at(x, y, 0) == 1.0f && img.at(x, y, 1) == 1.0f && img.at(x, y, 2) == 1.0f)
                ++white;
    EXPECT_GT(white, 100);
    // The "0" at the bottom tick (y = h - 8): its glyph's top row 0x0E lights columns 1..3
    const int text_x = w + 8 + 16 + 6;
    EXPECT_EQ(img.at(text_x, h - 8 - 3, 0), 0.0f);
    EXPECT_EQ(img.at(text_x + 1, h - 8 - 3, 0), 1.0f);
    EXPECT_EQ(img.at(text_x + 3, h - 8 - 3, 0), 1.0f);
    EXPECT_EQ(img.at(text_x + 4, h - 8 - 3, 0), 0.0f);
}

TEST(FalseColour, SmallGridsAreEnlargedInBlocks) {
    const abrad::testing::TempDir dir("image");  // kept if the test fails
    // A 4 x 3 calculation grid: enlarged 54 times to 216 x 162 pixels, each value a block
    const std::vector<double> values = {0,   100, 200, 300, 400,  500,
                                        600, 700, 800, 900, 1000, std::nan("")};
    const fs::path p = dir / "grid.png";
    write_false_colour_image(p, 4, 3, values, 0.0, 1000.0, "lux");
    const Image img = read_image(p);
    EXPECT_EQ(img.height, 162);
    EXPECT_GE(img.width, 216 + 90);
    for (int k = 0; k < 11; ++k) {
        const glm::vec3 c = false_colour(k / 10.0);
        const int x0 = (k % 4) * 54, y0 = (k / 4) * 54;
        for (const auto& [dx, dy] : {std::pair{0, 0}, std::pair{53, 53}, std::pair{27, 10}})
            EXPECT_NEAR(img.at(x0 + dx, y0 + dy, 1), c.g, 0.01) << "value " << k;
    }
    EXPECT_NEAR(img.at(3 * 54 + 30, 2 * 54 + 30, 1), 0.02, 0.005);  // no data
}

TEST(FalseColour, RejectsAnEmptyRangeAndWrongSizes) {
    const abrad::testing::TempDir dir("image");  // kept if the test fails
    std::vector<double> values(4, 1.0);
    EXPECT_THROW(write_false_colour_image(dir / "e.png", 2, 2, values, 1.0, 1.0, "lux"),
                 ExportError);
    EXPECT_THROW(write_false_colour_image(dir / "e.png", 3, 2, values, 0.0, 1.0, "lux"),
                 ExportError);
    EXPECT_THROW(write_false_colour_image(dir / "e.png", 2, 2, values, 0.0,
                                          std::numeric_limits<double>::infinity(), "lux"),
                 ExportError);
}

TEST(Compare, MetricsOfAKnownDifference) {
    Image a{10, 10, std::vector<float>(300, 0.25f)};
    Image b = a;
    const ImageDifference same = compare_images(a, b);
    EXPECT_EQ(same.rmse, 0.0);
    EXPECT_TRUE(std::isinf(same.psnr_db));
    // One channel of pixel (3, 7) off by 0.5
    b.rgb[(7 * 10 + 3) * 3 + 1] += 0.5f;
    const ImageDifference d = compare_images(a, b);
    EXPECT_NEAR(d.rmse, std::sqrt(0.25 / 300.0), 1e-7);
    EXPECT_NEAR(d.psnr_db, 20.0 * std::log10(1.0 / std::sqrt(0.25 / 300.0)), 1e-4);
    EXPECT_NEAR(d.max_error, 0.5, 1e-7);
    EXPECT_EQ(d.max_x, 3);
    EXPECT_EQ(d.max_y, 7);
    EXPECT_NEAR(d.mean_a, 0.25, 1e-7);
    const Image diff = difference_image(a, b, 2.0);
    EXPECT_NEAR(diff.at(3, 7, 1), 1.0, 1e-6);
    EXPECT_EQ(diff.at(3, 7, 0), 0.0f);
}

TEST(Compare, SizesMustMatch) {
    Image a{2, 2, std::vector<float>(12, 0.0f)};
    Image b{2, 3, std::vector<float>(18, 0.0f)};
    EXPECT_THROW((void)compare_images(a, b), ExportError);
}
