#pragma once
// Images made from other images for a person to look at (`abrad compare`): a clipped copy and
// the side-by-side strip A | B | difference. The difference image itself is
// difference_image in image.h.

#include "abrad/export/image.h"

namespace abrad::exporter {

/// Clamps every linear value of `image` to [0, limit] in place (emitters are tens of times
/// brighter than what they light: clipped, their edge pixels stop swamping the metrics).
void clip_image(Image& image, float limit);

/// The strip A | B | gain × |A − B| (3 × width by height), every value through the tone curve
/// 1 − exp(−v) (exposure 1), ready for write_image as display values. Throws ExportError when
/// the sizes differ.
Image side_by_side(const Image& a, const Image& b, double gain);

}  // namespace abrad::exporter
