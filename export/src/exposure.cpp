// Automatic exposure from the camera's view, and clipped-pixel counts
// (export/include/abrad/export/exposure.h).

#include "abrad/export/exposure.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "abrad/export/image.h"

namespace abrad::exporter {

namespace {

/// Step 1: the percentile of the lit receivers' irradiance and the tone value it maps to.
constexpr double kLookPercentile = 0.95;
constexpr double kLookTarget = 0.8;
/// The largest image the exposure is measured on; larger views are scaled down to it.
constexpr double kMaxPixels = 640.0 * 480.0;
/// How far under the clipping exposure step 2 stays (float rounding of the tone curve).
constexpr double kClipMargin = 0.999;

// The value of exposure × B at which a channel's 8-bit display code reaches 255: the tone
// value 1 - exp(-x) whose sRGB encoding rounds to 255 (encoded ≥ 254.5 / 255).
double clip_threshold() { return -std::log(1.0 - srgb_decode(254.5 / 255.0)); }

// The value at rank `k` (0-based, ascending) of `v`, which it reorders.
double rank_value(std::vector<double>& v, std::size_t k) {
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
    return v[k];
}

double finite_or_zero(float v) { return std::isfinite(v) ? static_cast<double>(v) : 0.0; }

}  // namespace

double PixelCounts::receivers_clipped_percent() const {
    return receivers
               ? 100.0 * static_cast<double>(receivers_clipped) / static_cast<double>(receivers)
               : 0.0;
}

bool on_emitter(const visdb::Scene& scene, const visdb::BakeMesh& mesh, std::uint32_t triangle) {
    if (triangle >= mesh.triangle_surface.size()) return false;
    const std::uint32_t surface = mesh.triangle_surface[triangle];
    if (surface >= scene.surfaces.size()) return false;
    const std::uint32_t material = scene.surfaces[surface].material;
    return material < scene.materials.size() && scene.materials[material].is_emitter();
}

PixelCounts count_pixels(const visdb::Scene& scene, const visdb::BakeMesh& mesh,
                         const Raster& radiosity, const ToneMap& tone) {
    PixelCounts n;
    n.pixels = radiosity.value.size();
    for (std::size_t i = 0; i < n.pixels; ++i) {
        if (radiosity.covered[i] != 1) continue;
        if (on_emitter(scene, mesh, radiosity.triangle[i])) {
            ++n.emitters;
            continue;
        }
        ++n.receivers;
        const auto code = display_colour(radiosity.value[i], tone);
        if (std::max({code[0], code[1], code[2]}) == 255) ++n.receivers_clipped;
    }
    return n;
}

ToneMap camera_tone_map(const visdb::BakeMesh& mesh, const visdb::Scene& scene,
                        const visdb::Camera& camera, int width, int height) {
    // Render the view, scaled down to at most kMaxPixels of the same aspect
    RenderOptions o{.width = width, .height = height};
    const double pixels = static_cast<double>(width) * static_cast<double>(height);
    if (pixels > kMaxPixels) {
        const double scale = std::sqrt(kMaxPixels / pixels);
        o.width = std::max(1, static_cast<int>(std::lround(width * scale)));
        o.height = std::max(1, static_cast<int>(std::lround(height * scale)));
    }
    o.quantity = RenderQuantity::Radiosity;
    const Raster b = render_bake(mesh, camera, o);
    o.quantity = RenderQuantity::Irradiance;
    const Raster h = render_bake(mesh, camera, o);

    // The receivers' pixels: _peak_ radiosity channel of each, irradiance luminance _lit_ of
    // the lit ones
    std::vector<double> peak, lit;
    for (std::size_t i = 0; i < b.value.size(); ++i) {
        if (b.covered[i] != 1 || on_emitter(scene, mesh, b.triangle[i])) continue;
        const glm::vec3& v = b.value[i];
        peak.push_back(
            std::max({finite_or_zero(v.r), finite_or_zero(v.g), finite_or_zero(v.b), 0.0}));
        const double y = visdb::luminance(h.value[i]);
        if (std::isfinite(y) && y > 0.0) lit.push_back(y);
    }
    if (lit.empty()) return auto_tone_map(mesh);

    // Step 1: a white surface at the 95th percentile of irradiance shows 0.8
    const double h95 = rank_value(lit, static_cast<std::size_t>(std::floor(
                                           kLookPercentile * static_cast<double>(lit.size() - 1))));
    double exposure = -std::log(1.0 - kLookTarget) / h95;

    // Step 2: at most kClippedShare of the receivers' pixels clip
    const auto allowed =
        static_cast<std::size_t>(std::floor(kClippedShare * static_cast<double>(peak.size())));
    const double m = rank_value(peak, peak.size() - 1 - allowed);
    if (m > 0.0) exposure = std::min(exposure, kClipMargin * clip_threshold() / m);
    return ToneMap{.exposure = exposure};
}

}  // namespace abrad::exporter
