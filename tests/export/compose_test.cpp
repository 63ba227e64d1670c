// Image composition for `abrad compare` (export/compose.h).

#include "abrad/export/compose.h"

#include <gtest/gtest.h>

#include <cmath>

#include "abrad/export/writers.h"

namespace abrad::exporter {
namespace {

// A w x h image whose every channel is `v`.
Image flat(int w, int h, float v) {
    return Image{w, h, std::vector<float>(static_cast<std::size_t>(w * h * 3), v)};
}

TEST(Compose, ClipClampsToZeroAndTheLimit) {
    Image img{2, 1, {-1.0f, 0.5f, 2.0f, 7.0f, 4.0f, 3.9f}};
    clip_image(img, 4.0f);
    EXPECT_EQ(img.rgb, (std::vector<float>{0.0f, 0.5f, 2.0f, 4.0f, 4.0f, 3.9f}));
}

TEST(Compose, SideBySideIsAThenBThenTheGainedDifferenceToneMapped) {
    Image a = flat(2, 2, 0.5f);
    const Image b = flat(2, 2, 0.25f);
    a.rgb[3 * 3 + 1] = 1.5f;  // pixel (1, 1), green
    const Image s = side_by_side(a, b, 4.0);
    ASSERT_EQ(s.width, 6);
    ASSERT_EQ(s.height, 2);
    ASSERT_EQ(s.rgb.size(), 36u);
    auto tone = [](double v) { return 1.0 - std::exp(-v); };
    EXPECT_NEAR(s.at(0, 0, 0), tone(0.5), 1e-6);
    EXPECT_NEAR(s.at(1, 1, 1), tone(1.5), 1e-6);
    EXPECT_NEAR(s.at(2, 0, 2), tone(0.25), 1e-6);
    EXPECT_NEAR(s.at(3, 1, 1), tone(0.25), 1e-6);
    EXPECT_NEAR(s.at(4, 0, 0), tone(4.0 * 0.25), 1e-6);
    EXPECT_NEAR(s.at(5, 1, 1), tone(4.0 * 1.25), 1e-6);
    EXPECT_NEAR(s.at(5, 1, 0), tone(4.0 * 0.25), 1e-6);
}

TEST(Compose, SideBySideRefusesImagesOfDifferentSizes) {
    EXPECT_THROW(side_by_side(flat(2, 2, 0.0f), flat(3, 2, 0.0f), 1.0), ExportError);
}

}  // namespace
}  // namespace abrad::exporter
