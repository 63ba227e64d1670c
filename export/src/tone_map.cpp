// Tone mapping of linear radiosity to 8-bit sRGB display colours.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

#include "abrad/export/image.h"
#include "abrad/export/writers.h"

namespace abrad::exporter {

namespace {

/// The value v' of 1 - exp(-exposure v) that the 95th percentile luminance maps to.
constexpr double kPercentileTarget = 0.8;
constexpr double kPercentile = 0.95;

using visdb::luminance;

/// 8-bit code of one channel: clamp the tone-mapped value, encode, round.
std::uint8_t channel_byte(float radiosity, double exposure) {
    const double mapped = tone_value(static_cast<double>(radiosity), ToneMap{.exposure = exposure});
    const double encoded = srgb_encode(std::clamp(mapped, 0.0, 1.0));
    return static_cast<std::uint8_t>(std::lround(std::clamp(encoded, 0.0, 1.0) * 255.0));
}

}  // namespace

double tone_value(double radiosity, const ToneMap& tone) {
    // NaN and negative radiosity show as black
    const double v = radiosity > 0.0 ? radiosity : 0.0;
    return 1.0 - std::exp(-tone.exposure * v);
}

ToneMap auto_tone_map(const visdb::BakeMesh& mesh) {
    // Collect the finite vertex luminances _ys_
    std::vector<double> ys;
    ys.reserve(mesh.radiosity.size());
    for (const auto& b : mesh.radiosity) {
        const double y = luminance(b);
        if (std::isfinite(y)) ys.push_back(y);
    }
    if (ys.empty()) return ToneMap{.exposure = 1.0};

    // Find the 95th percentile _y95_, interpolating linearly between the closest ranks
    const double pos = kPercentile * static_cast<double>(ys.size() - 1);
    const auto lo = static_cast<std::size_t>(std::floor(pos));
    const std::size_t hi = std::min(lo + 1, ys.size() - 1);
    std::nth_element(ys.begin(), ys.begin() + static_cast<std::ptrdiff_t>(lo), ys.end());
    const double y_lo = ys[lo];
    double y_hi = y_lo;
    if (hi != lo) {
        // After nth_element the smallest of the upper part is the next rank
        y_hi = *std::min_element(ys.begin() + static_cast<std::ptrdiff_t>(hi), ys.end());
    }
    const double y95 = y_lo + (pos - static_cast<double>(lo)) * (y_hi - y_lo);

    // Solve 1 - exp(-exposure y95) = 0.8 for _exposure_; an all-dark mesh keeps exposure 1
    if (!(y95 > 0.0)) return ToneMap{.exposure = 1.0};
    return ToneMap{.exposure = -std::log(1.0 - kPercentileTarget) / y95};
}

std::array<std::uint8_t, 3> display_colour(const glm::vec3& radiosity, const ToneMap& tone) {
    return {channel_byte(radiosity.r, tone.exposure), channel_byte(radiosity.g, tone.exposure),
            channel_byte(radiosity.b, tone.exposure)};
}

}  // namespace abrad::exporter
