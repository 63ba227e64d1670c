#pragma once
// Automatic exposure from what a camera sees, and the clipped pixels of a tone-mapped image.
//
// A light meter held where the camera is: the exposure follows the irradiance on the
// receivers in view (emitters, the background and the backs of faces are left out), so a
// white wall looks white and a dark floor dark whatever the share of each in the picture,
// then is lowered until no more than 1 % of the receivers' pixels clip.

#include <cstddef>

#include "abrad/export/render.h"
#include "abrad/export/writers.h"
#include "abrad/visdb/model.h"

namespace abrad::exporter {

/// How an image's pixels split, and how many of them clip.
struct PixelCounts {
    std::size_t pixels = 0;             ///< all pixels of the image
    std::size_t receivers = 0;          ///< fronts of non-emitting faces
    std::size_t receivers_clipped = 0;  ///< receivers with a channel at display code 255
    std::size_t emitters = 0;           ///< fronts of emitting faces (they may clip: lights)
    /// receivers_clipped as a percentage of receivers (0 when there are none).
    double receivers_clipped_percent() const;
};

/// Whether `triangle` of `mesh` lies on an emitting surface of `scene` (its surface's
/// material has E > 0). A surface or material id out of range counts as a receiver.
bool on_emitter(const visdb::Scene& scene, const visdb::BakeMesh& mesh, std::uint32_t triangle);

/// Counts the pixels of `radiosity` (a Raster of RenderQuantity::Radiosity) by what covers
/// them, and the receivers' pixels that the tone map `tone` clips: a channel whose 8-bit
/// display code (display_colour) is 255.
PixelCounts count_pixels(const visdb::Scene& scene, const visdb::BakeMesh& mesh,
                         const Raster& radiosity, const ToneMap& tone);

/// The share of the receivers' pixels that camera_tone_map lets clip, at most.
inline constexpr double kClippedShare = 0.01;

/// Automatic exposure of `mesh` seen through `camera` in an image of `width` × `height`
/// pixels (rendered at that size, or scaled down to at most 640 × 480 pixels of the same
/// aspect). Of the receivers' pixels (fronts of non-emitting faces: emitters, background and
/// backs are left out):
///   1. H95 = the 95th percentile of the irradiance luminance of the lit ones (H > 0), and
///      exposure = -ln(0.2) / H95: a white surface (ρ = 1) at H95 shows 0.8 on the tone curve
///      1 - exp(-exposure B); a surface of reflectance ρ shows its own shade of it;
///   2. lowered, when needed, so that at most kClippedShare of all the receivers' pixels
///      reach display code 255: exposure ≤ 0.999 T / M, with T the value of exposure × B at
///      which the code reaches 255 and M the largest radiosity channel of the pixel at rank
///      n - 1 - floor(kClippedShare n) of the n receivers' pixels sorted by it.
/// Percentiles interpolate no ranks (nearest rank below). When the camera sees no lit
/// receiver, auto_tone_map(mesh) (vertex radiosity) is returned. Throws CameraError on a
/// degenerate camera and ExportError on an inconsistent mesh, as render_bake.
ToneMap camera_tone_map(const visdb::BakeMesh& mesh, const visdb::Scene& scene,
                        const visdb::Camera& camera, int width, int height);

}  // namespace abrad::exporter
