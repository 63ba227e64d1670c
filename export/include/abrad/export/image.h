#pragma once
// Image output and comparison through OpenImageIO (loaded at the first call, not at start-up:
// export/src/oiio_module.h): linear RGB buffers written as PNG (sRGB)
// or EXR (linear), a perceptual false-colour scale with a legend, and the image comparison
// behind `abrad compare`.
//
// Pixel buffers are row-major, top row first, RGB interleaved (3 floats per pixel).

#include <filesystem>
#include <glm/vec3.hpp>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace abrad::exporter {

/// A linear RGB image held in memory (3 floats per pixel, row-major, top row first).
struct Image {
    int width = 0;
    int height = 0;
    std::vector<float> rgb;  ///< width * height * 3 linear values

    /// The value of channel `c` of pixel (x, y); no bounds check beyond the vector's.
    float at(int x, int y, int c) const {
        return rgb[(static_cast<std::size_t>(y) * static_cast<std::size_t>(width) +
                    static_cast<std::size_t>(x)) *
                       3 +
                   static_cast<std::size_t>(c)];
    }
};

/// The sRGB transfer function (IEC 61966-2-1) of a linear value; clamps to [0, 1].
double srgb_encode(double linear);
/// The inverse sRGB transfer function of an encoded value in [0, 1].
double srgb_decode(double encoded);

/// Writes a linear RGB buffer. The format follows the extension: `.exr` (half float, linear,
/// values kept as they are), `.hdr` (Radiance, linear), `.png`/`.jpg`/`.tif` (8-bit sRGB: each
/// value clamped to [0, 1] and sRGB-encoded, so pass display values, e.g. tone-mapped ones).
/// Throws ExportError "PATH: ..." when `rgb_linear` is not width*height*3 long, the size is
/// not positive, or OpenImageIO cannot write the file.
void write_image(const std::filesystem::path& path, int width, int height,
                 std::span<const float> rgb_linear);

/// Reads any image OpenImageIO reads as linear RGB: 8/16-bit files tagged sRGB (PNG, JPEG)
/// are decoded from sRGB, EXR/HDR are taken as they are; grey is copied to RGB and channels
/// past the third (alpha) are dropped. Throws ExportError "PATH: ..." when unreadable.
Image read_image(const std::filesystem::path& path);

/// Loads the image library now (it is otherwise loaded at the first image call), so that a
/// missing module is reported as such and not as an unreadable input. Throws ExportError.
void require_image_support();

/// What an image file's header claims (no pixel read).
struct ImageHeader {
    int width = 0;
    int height = 0;
    int depth = 1;
    int channels = 0;
    std::size_t bytes_per_channel = 0;
};

/// Opens an image file and reads only its header, so that a claimed size can be checked
/// before any pixel is allocated; nullopt when no reader opens it (read_image then says why).
std::optional<ImageHeader> read_image_header(const std::filesystem::path& path);

/// The legend's default font (Debian fonts-dejavu-core).
inline const std::filesystem::path kLegendFont = "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf";

/// A perceptual false-colour scale (viridis: dark blue → green → yellow, lightness rising
/// monotonically) as *linear* RGB, ready for write_image. `t` is clamped to [0, 1]; NaN gives
/// the colour of 0.
glm::vec3 false_colour(double t);

/// Writes `values` (width × height, row-major, top row first; NaN = no data, drawn dark grey)
/// as a false-colour image through false_colour((v - vmin) / (vmax - vmin)), with a legend bar
/// to the right: the colour scale from vmin (bottom) to vmax (top), five tick labels and the
/// unit (e.g. "W/m²" or "lux") above it. The file is `width + legend width` pixels wide (the
/// legend is about 90 pixels, more for long labels). Images less than 160 pixels high (a
/// calculation grid's values, one per point) are first enlarged by the smallest whole factor
/// that makes them 160 high, each value a square block of pixels. Labels use the TrueType `font`
/// (DejaVu Sans from fonts-dejavu-core by default) through OpenImageIO's render_text when that file
/// exists and renders, else a built-in 5×7 bitmap font (digits, '.', '-', '+', 'e', and the
/// letters of "W/m²", "lux"). Throws ExportError on a size mismatch, vmax <= vmin, non-finite
/// bounds or a write failure.
void write_false_colour_image(const std::filesystem::path& path, int width, int height,
                              std::span<const double> values, double vmin, double vmax,
                              std::string_view unit,
                              const std::filesystem::path& font = kLegendFont);

/// How two images differ, in linear light over every pixel and RGB channel.
struct ImageDifference {
    double rmse = 0.0;         ///< root mean square of the channel differences
    double psnr_db = 0.0;      ///< 20 log10(1 / rmse) (peak 1 = white after exposure); inf if equal
    double max_error = 0.0;    ///< largest absolute channel difference
    int max_x = 0, max_y = 0;  ///< the pixel of max_error
    double mean_a = 0.0, mean_b = 0.0;  ///< mean channel value of each image
    std::string to_string() const;
};

/// Compares two linear images of the same size with OpenImageIO's ImageBufAlgo::compare.
/// Throws ExportError when the sizes differ (naming both).
ImageDifference compare_images(const Image& a, const Image& b);

/// The per-pixel absolute difference |a - b| times `gain` (linear), for a person to look at.
Image difference_image(const Image& a, const Image& b, double gain = 1.0);

}  // namespace abrad::exporter
