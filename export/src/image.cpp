// Image output and comparison through OpenImageIO (export/include/abrad/export/image.h); the
// library's calls are in a module loaded at first use (oiio_module.h).

#include "abrad/export/image.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <limits>
#include <sstream>

#include "abrad/atomic_file.h"
#include "abrad/export/writers.h"
#include "oiio_module.h"

namespace abrad::exporter {

namespace {

namespace fs = std::filesystem;

[[noreturn]] void fail(const fs::path& path, const std::string& message) {
    throw ExportError(path.string() + ": " + message);
}

std::string lower_extension(const fs::path& path) {
    std::string ext = path.extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    return ext;
}

bool is_linear_format(const std::string& ext) { return ext == ".exr" || ext == ".hdr"; }

// Viridis (matplotlib, CC0) at 11 evenly spaced points, sRGB-encoded.
constexpr std::array<std::array<double, 3>, 11> kViridis{{
    {0.267004, 0.004874, 0.329415},
    {0.282623, 0.140926, 0.457517},
    {0.253935, 0.265254, 0.529983},
    {0.206756, 0.371758, 0.553117},
    {0.163625, 0.471133, 0.558148},
    {0.127568, 0.566949, 0.550556},
    {0.134692, 0.658636, 0.517649},
    {0.266941, 0.748751, 0.440573},
    {0.477504, 0.821444, 0.318195},
    {0.741388, 0.873449, 0.149561},
    {0.993248, 0.906157, 0.143936},
}};

// A 5×7 bitmap font for the legend when no TrueType font is installed: each glyph is seven
// rows of five bits, most significant bit on the left. '^' stands for the superscript two.
struct Glyph {
    char c;
    std::array<std::uint8_t, 7> rows;
};
constexpr std::array<Glyph, 24> kFont{{
    {'0', {0x0E, 0x11, 0x13, 0x15, 0x19, 0x11, 0x0E}},
    {'1', {0x04, 0x0C, 0x04, 0x04, 0x04, 0x04, 0x0E}},
    {'2', {0x0E, 0x11, 0x01, 0x02, 0x04, 0x08, 0x1F}},
    {'3', {0x1F, 0x02, 0x04, 0x02, 0x01, 0x11, 0x0E}},
    {'4', {0x02, 0x06, 0x0A, 0x12, 0x1F, 0x02, 0x02}},
    {'5', {0x1F, 0x10, 0x1E, 0x01, 0x01, 0x11, 0x0E}},
    {'6', {0x06, 0x08, 0x10, 0x1E, 0x11, 0x11, 0x0E}},
    {'7', {0x1F, 0x01, 0x02, 0x04, 0x08, 0x08, 0x08}},
    {'8', {0x0E, 0x11, 0x11, 0x0E, 0x11, 0x11, 0x0E}},
    {'9', {0x0E, 0x11, 0x11, 0x0F, 0x01, 0x02, 0x0C}},
    {'.', {0x00, 0x00, 0x00, 0x00, 0x00, 0x0C, 0x0C}},
    {'-', {0x00, 0x00, 0x00, 0x1F, 0x00, 0x00, 0x00}},
    {'+', {0x00, 0x04, 0x04, 0x1F, 0x04, 0x04, 0x00}},
    {'e', {0x00, 0x00, 0x0E, 0x11, 0x1F, 0x10, 0x0E}},
    {'W', {0x11, 0x11, 0x11, 0x15, 0x15, 0x15, 0x0A}},
    {'/', {0x00, 0x01, 0x02, 0x04, 0x08, 0x10, 0x00}},
    {'m', {0x00, 0x00, 0x1A, 0x15, 0x15, 0x11, 0x11}},
    {'^', {0x0C, 0x12, 0x04, 0x08, 0x1E, 0x00, 0x00}},
    {'l', {0x0C, 0x04, 0x04, 0x04, 0x04, 0x04, 0x0E}},
    {'u', {0x00, 0x00, 0x11, 0x11, 0x11, 0x13, 0x0D}},
    {'x', {0x00, 0x00, 0x11, 0x0A, 0x04, 0x0A, 0x11}},
    {'k', {0x10, 0x10, 0x12, 0x14, 0x18, 0x14, 0x12}},
    {' ', {0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00}},
    {'?', {0x1F, 0x11, 0x11, 0x11, 0x11, 0x11, 0x1F}},  // any other character: a box
}};

const Glyph& glyph_of(char c) {
    for (const Glyph& g : kFont)
        if (g.c == c) return g;
    return kFont.back();
}

// Replaces the UTF-8 superscript two (U+00B2) by the bitmap font's '^'.
std::string bitmap_text(std::string_view text) {
    std::string out;
    for (std::size_t i = 0; i < text.size(); ++i) {
        if (static_cast<unsigned char>(text[i]) == 0xC2 && i + 1 < text.size() &&
            static_cast<unsigned char>(text[i + 1]) == 0xB2) {
            out += '^';
            ++i;
        } else {
            out += text[i];
        }
    }
    return out;
}

// Draws `text` with the bitmap font, top-left corner at (x, y), each font pixel scale×scale.
void draw_bitmap_text(Image& img, int x, int y, std::string_view text, int scale) {
    int cx = x;
    for (char c : bitmap_text(text)) {
        const Glyph& g = glyph_of(c);
        for (int row = 0; row < 7; ++row)
            for (int col = 0; col < 5; ++col) {
                if (!(g.rows[static_cast<std::size_t>(row)] & (0x10 >> col))) continue;
                for (int sy = 0; sy < scale; ++sy)
                    for (int sx = 0; sx < scale; ++sx) {
                        const int px = cx + col * scale + sx, py = y + row * scale + sy;
                        if (px < 0 || py < 0 || px >= img.width || py >= img.height) continue;
                        for (int k = 0; k < 3; ++k)
                            img.rgb[(static_cast<std::size_t>(py) *
                                         static_cast<std::size_t>(img.width) +
                                     static_cast<std::size_t>(px)) *
                                        3 +
                                    static_cast<std::size_t>(k)] = 1.0f;
                    }
            }
        cx += 6 * scale;
    }
}

// Short text of a tick value: whole numbers from 1000 up (lux values), else three significant
// digits without trailing zeros.
std::string tick_label(double v) {
    if (std::abs(v) < 1e-12) v = 0.0;
    char buf[400];
    const auto res = std::abs(v) >= 1000.0 && std::abs(v) < 1e15
                         ? std::to_chars(buf, buf + sizeof buf, v, std::chars_format::fixed, 0)
                         : std::to_chars(buf, buf + sizeof buf, v, std::chars_format::general, 3);
    return std::string(buf, res.ptr);
}

}  // namespace

double srgb_encode(double v) {
    v = std::clamp(v, 0.0, 1.0);
    return v < 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1.0 / 2.4) - 0.055;
}

double srgb_decode(double v) {
    return v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4);
}

void write_image(const fs::path& path, int width, int height, std::span<const float> rgb) {
    if (width <= 0 || height <= 0)
        fail(path, "cannot write an image of " + std::to_string(width) + "x" +
                       std::to_string(height) + " pixels");
    const std::size_t n = static_cast<std::size_t>(width) * static_cast<std::size_t>(height) * 3;
    if (rgb.size() != n)
        fail(path, "image buffer has " + std::to_string(rgb.size()) + " values, " +
                       std::to_string(width) + "x" + std::to_string(height) + " RGB needs " +
                       std::to_string(n));
    const std::string ext = lower_extension(path);
    std::vector<unsigned char> data;
    std::string error;
    if (is_linear_format(ext)) {
        // Linear formats keep the values; EXR as half float
        error = oiio::api().encode(path.string(), width, height,
                                   ext == ".exr" ? oiio::Storage::Half : oiio::Storage::Float,
                                   rgb.data(), data);
    } else {
        // Display formats: clamp, sRGB-encode, 8 bits
        std::vector<std::uint8_t> bytes(n);
        for (std::size_t i = 0; i < n; ++i) {
            const double v = std::isfinite(rgb[i]) ? static_cast<double>(rgb[i]) : 0.0;
            bytes[i] = static_cast<std::uint8_t>(std::lround(srgb_encode(v) * 255.0));
        }
        error = oiio::api().encode(path.string(), width, height, oiio::Storage::Srgb8, bytes.data(),
                                   data);
    }
    if (!error.empty()) fail(path, "cannot write: " + error);
    if (data.empty()) fail(path, "cannot write: the image encoded to nothing");
    BasicAtomicFile<ExportError> file(path);
    file.write({reinterpret_cast<const char*>(data.data()), data.size()});
    file.commit();
}

Image read_image(const fs::path& path) {
    if (!fs::exists(path)) fail(path, "cannot read image: no such file");
    oiio::Pixels all;
    if (const std::string error = oiio::api().read(path.string(), all); !error.empty())
        fail(path, "cannot read image: " + error);
    Image img{all.width, all.height, {}};
    img.rgb.resize(static_cast<std::size_t>(all.width) * static_cast<std::size_t>(all.height) * 3);
    const auto nc = static_cast<std::size_t>(all.channels);
    for (std::size_t p = 0, i = 0; p < all.data.size(); p += nc)
        for (std::size_t c = 0; c < 3; ++c) {
            const float v = all.data[p + std::min(c, nc - 1)];
            img.rgb[i++] = all.srgb ? static_cast<float>(srgb_decode(static_cast<double>(v))) : v;
        }
    return img;
}

void require_image_support() { oiio::api(); }

std::optional<ImageHeader> read_image_header(const fs::path& path) {
    ImageHeader h;
    if (!oiio::api().header(path.string(), h)) return std::nullopt;
    return h;
}

glm::vec3 false_colour(double t) {
    if (!(t > 0.0)) t = 0.0;  // NaN too
    t = std::min(t, 1.0);
    const double pos = t * static_cast<double>(kViridis.size() - 1);
    const auto i = std::min(static_cast<std::size_t>(pos), kViridis.size() - 2);
    const double f = pos - static_cast<double>(i);
    glm::vec3 out;
    for (int c = 0; c < 3; ++c) {
        const auto k = static_cast<std::size_t>(c);
        const double encoded = kViridis[i][k] + f * (kViridis[i + 1][k] - kViridis[i][k]);
        out[c] = static_cast<float>(srgb_decode(encoded));
    }
    return out;
}

void write_false_colour_image(const fs::path& path, int width, int height,
                              std::span<const double> values, double vmin, double vmax,
                              std::string_view unit, const fs::path& font) {
    if (width <= 0 || height <= 0)
        fail(path, "cannot write an image of " + std::to_string(width) + "x" +
                       std::to_string(height) + " pixels");
    if (values.size() != static_cast<std::size_t>(width) * static_cast<std::size_t>(height))
        fail(path, "false-colour image has " + std::to_string(values.size()) + " values for " +
                       std::to_string(width) + "x" + std::to_string(height) + " pixels");
    if (!std::isfinite(vmin) || !std::isfinite(vmax) || !(vmax > vmin))
        fail(path,
             "false-colour range [" + tick_label(vmin) + ", " + tick_label(vmax) + "] is empty");

    // Tick labels decide the legend's width
    constexpr int kTicks = 5;
    std::array<std::string, kTicks> labels;
    std::size_t longest = std::string(unit).size();
    for (int k = 0; k < kTicks; ++k) {
        labels[static_cast<std::size_t>(k)] = tick_label(vmin + (vmax - vmin) * k / (kTicks - 1));
        longest = std::max(longest, labels[static_cast<std::size_t>(k)].size());
    }
    // Small images (calculation grids) are enlarged by a whole factor, each value a block of
    // pixels, so that the legend fits
    constexpr int kMinHeight = 160;
    const int block = height < kMinHeight ? (kMinHeight + height - 1) / height : 1;
    const int out_w = width * block, out_h = height * block;
    const int scale = out_h >= 360 ? 2 : 1;
    const int bar_x = out_w + 8 * scale, bar_w = 16 * scale;
    const int legend_w =
        8 * scale + bar_w + 6 * scale + static_cast<int>(longest) * 6 * scale + 8 * scale;
    const int total_w = out_w + std::max(legend_w, 90);
    const int bar_top = 20 * scale, bar_bottom = out_h - 8 * scale;

    Image img{total_w, out_h,
              std::vector<float>(
                  static_cast<std::size_t>(total_w) * static_cast<std::size_t>(out_h) * 3, 0.0f)};
    auto set = [&](int x, int y, const glm::vec3& c) {
        const std::size_t o = (static_cast<std::size_t>(y) * static_cast<std::size_t>(total_w) +
                               static_cast<std::size_t>(x)) *
                              3;
        img.rgb[o] = c.r, img.rgb[o + 1] = c.g, img.rgb[o + 2] = c.b;
    };
    // Map the values; no data is dark grey
    const glm::vec3 no_data(0.02f);
    for (int y = 0; y < out_h; ++y)
        for (int x = 0; x < out_w; ++x) {
            const double v =
                values[static_cast<std::size_t>(y / block) * static_cast<std::size_t>(width) +
                       static_cast<std::size_t>(x / block)];
            set(x, y, std::isnan(v) ? no_data : false_colour((v - vmin) / (vmax - vmin)));
        }
    // Draw the legend bar, vmax at the top
    if (bar_bottom > bar_top) {
        for (int y = bar_top; y <= bar_bottom; ++y) {
            const double t =
                static_cast<double>(bar_bottom - y) / static_cast<double>(bar_bottom - bar_top);
            for (int x = bar_x; x < bar_x + bar_w; ++x) set(x, y, false_colour(t));
        }
    }
    // Tick marks at the label positions
    std::array<int, kTicks> tick_y{};
    for (int k = 0; k < kTicks; ++k) {
        tick_y[static_cast<std::size_t>(k)] =
            bar_bottom - (bar_bottom - bar_top) * k / (kTicks - 1);
        for (int x = bar_x + bar_w; x < bar_x + bar_w + 4 * scale && x < total_w; ++x)
            if (tick_y[static_cast<std::size_t>(k)] >= 0 &&
                tick_y[static_cast<std::size_t>(k)] < out_h)
                set(x, tick_y[static_cast<std::size_t>(k)], glm::vec3(1.0f));
    }
    const int text_x = bar_x + bar_w + 6 * scale;

    // Labels: DejaVu Sans through OpenImageIO, else the bitmap font
    bool drawn = false;
    if (!font.empty() && fs::exists(font)) {
        const std::string font_name = font.string();
        const int size = 11 * scale;
        std::vector<float> text = img.rgb;  // kept only when every label renders
        bool ok = oiio::api().render_text(text.data(), total_w, out_h, bar_x, 14 * scale,
                                          std::string(unit), size, font_name);
        for (int k = 0; ok && k < kTicks; ++k)
            ok = oiio::api().render_text(text.data(), total_w, out_h, text_x,
                                         tick_y[static_cast<std::size_t>(k)] + 4 * scale,
                                         labels[static_cast<std::size_t>(k)], size, font_name);
        if (ok) {
            img.rgb = std::move(text);
            drawn = true;
        }
    }
    if (!drawn) {
        draw_bitmap_text(img, bar_x, 4 * scale, unit, scale);
        for (int k = 0; k < kTicks; ++k)
            draw_bitmap_text(img, text_x, tick_y[static_cast<std::size_t>(k)] - 3 * scale,
                             labels[static_cast<std::size_t>(k)], scale);
    }
    write_image(path, total_w, out_h, img.rgb);
}

std::string ImageDifference::to_string() const {
    std::ostringstream s;
    s << "rmse " << rmse << ", psnr " << psnr_db << " dB, max error " << max_error << " at ("
      << max_x << ", " << max_y << "), mean " << mean_a << " vs " << mean_b;
    return s.str();
}

ImageDifference compare_images(const Image& a, const Image& b) {
    if (a.width != b.width || a.height != b.height)
        throw ExportError("images differ in size: " + std::to_string(a.width) + "x" +
                          std::to_string(a.height) + " vs " + std::to_string(b.width) + "x" +
                          std::to_string(b.height));
    oiio::Comparison r;
    if (const std::string error =
            oiio::api().compare(a.rgb.data(), b.rgb.data(), a.width, a.height, r);
        !error.empty())
        throw ExportError("image comparison failed: " + error);
    ImageDifference d;
    d.rmse = r.rms_error;
    d.psnr_db = r.rms_error > 0.0 ? 20.0 * std::log10(1.0 / r.rms_error)
                                  : std::numeric_limits<double>::infinity();
    d.max_error = r.max_error;
    d.max_x = r.max_x;
    d.max_y = r.max_y;
    double sa = 0.0, sb = 0.0;
    for (float v : a.rgb) sa += static_cast<double>(v);
    for (float v : b.rgb) sb += static_cast<double>(v);
    const double n = static_cast<double>(std::max<std::size_t>(a.rgb.size(), 1));
    d.mean_a = sa / n;
    d.mean_b = sb / n;
    return d;
}

Image difference_image(const Image& a, const Image& b, double gain) {
    if (a.width != b.width || a.height != b.height)
        throw ExportError("images differ in size: " + std::to_string(a.width) + "x" +
                          std::to_string(a.height) + " vs " + std::to_string(b.width) + "x" +
                          std::to_string(b.height));
    Image d{a.width, a.height, std::vector<float>(a.rgb.size())};
    for (std::size_t i = 0; i < a.rgb.size(); ++i)
        d.rgb[i] = static_cast<float>(
            gain * std::abs(static_cast<double>(a.rgb[i]) - static_cast<double>(b.rgb[i])));
    return d;
}

}  // namespace abrad::exporter
