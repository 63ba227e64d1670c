// Images made from other images: see compose.h.

#include "abrad/export/compose.h"

#include <algorithm>

#include "abrad/export/writers.h"

namespace abrad::exporter {

void clip_image(Image& image, float limit) {
    for (float& v : image.rgb) v = std::clamp(v, 0.0f, limit);
}

Image side_by_side(const Image& a, const Image& b, double gain) {
    const Image diff = difference_image(a, b, gain);  // throws on a size mismatch
    const int w = a.width, h = a.height;
    Image out{
        3 * w, h,
        std::vector<float>(static_cast<std::size_t>(3 * w) * static_cast<std::size_t>(h) * 3)};
    const Image* parts[3] = {&a, &b, &diff};
    for (int p = 0; p < 3; ++p)
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x)
                for (int k = 0; k < 3; ++k)
                    out.rgb[(static_cast<std::size_t>(y) * static_cast<std::size_t>(3 * w) +
                             static_cast<std::size_t>(p * w + x)) *
                                3 +
                            static_cast<std::size_t>(k)] =
                        static_cast<float>(tone_value(static_cast<double>(parts[p]->at(x, y, k)),
                                                      ToneMap{.exposure = 1.0}));
    return out;
}

}  // namespace abrad::exporter
