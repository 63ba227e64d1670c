// abrad compare: two images compared in linear light (RMSE, PSNR, max error), a difference
// image and a side-by-side strip (export/compose.h), exit 1 past a threshold.

#include <CLI/CLI.hpp>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <optional>
#include <sstream>

#include "abrad/export/compose.h"
#include "abrad/export/image.h"
#include "abrad/export/writers.h"
#include "cli_common.h"

namespace abrad::tools::cli {
namespace {

struct CompareArgs {
    std::string a, b;
    std::string diff;
    std::string side_by_side;
    double diff_gain = 4.0;
    std::optional<double> max_rmse, min_psnr, max_error;
    std::optional<double> clip;
};

CompareArgs& state() {
    static CompareArgs s;
    return s;
}

std::string text(double v) {
    std::ostringstream s;
    s << v;
    return s.str();
}

// The thresholds `d` misses, as "rmse 0.2 > 0.1" phrases.
std::vector<std::string> missed(const CompareArgs& c, const exporter::ImageDifference& d) {
    std::vector<std::string> failed;
    if (c.max_rmse && !(d.rmse <= *c.max_rmse))
        failed.push_back("rmse " + text(d.rmse) + " > " + text(*c.max_rmse));
    if (c.min_psnr && !(d.psnr_db >= *c.min_psnr))
        failed.push_back("psnr " + text(d.psnr_db) + " dB < " + text(*c.min_psnr) + " dB");
    if (c.max_error && !(d.max_error <= *c.max_error))
        failed.push_back("max error " + text(d.max_error) + " > " + text(*c.max_error));
    return failed;
}

// Decoded bytes an image file may claim per byte it holds: deflate (PNG, EXR's ZIP and DWA)
// stops at 1,032 to 1, EXR's RLE at 64 to 1, PIZ and B44 lower.
constexpr double kMaxExpansion = 1100.0;
// Images up to this many decoded bytes are read whatever their file size.
constexpr double kAlwaysReadBytes = 64.0 * 1024 * 1024;

// An image header can claim any size: refuses one whose pixels no file of its size can hold,
// before a pixel is allocated (an EXR header claiming 10^6 x 48 pixels in 400 bytes).
void check_claimed_size(const std::string& path) {
    std::error_code ec;
    if (!std::filesystem::is_regular_file(path, ec)) return;  // read_image says why
    const auto file_bytes = std::filesystem::file_size(path, ec);
    if (ec) return;
    const auto spec = exporter::read_image_header(path);
    if (!spec) return;  // read_image reports the reader's message
    const double pixels = static_cast<double>(spec->width) * static_cast<double>(spec->height) *
                          static_cast<double>(std::max(1, spec->depth));
    const double decoded =
        pixels * std::max(1, spec->channels) * static_cast<double>(spec->bytes_per_channel);
    if (decoded > kAlwaysReadBytes && decoded > kMaxExpansion * static_cast<double>(file_bytes)) {
        bad_input(path + ": the image header claims " + std::to_string(spec->width) + "x" +
                  std::to_string(spec->height) + " pixels of " + std::to_string(spec->channels) +
                  " channels (" + text(decoded) + " bytes), more than a file of " +
                  std::to_string(file_bytes) + " bytes can hold");
    }
}

}  // namespace

void add_compare(CLI::App& app) {
    CompareArgs& c = state();
    app.add_option("A", c.a, "First image (PNG is decoded from sRGB, EXR is linear)")->required();
    app.add_option("B", c.b, "Second image, same size")->required();
    app.add_option("--diff", c.diff, "Write |A - B| x gain here (PNG or EXR)");
    app.add_option("--side-by-side", c.side_by_side,
                   "Write A | B | gain x |A - B| here, tone-mapped for a person (PNG)");
    app.add_option("--diff-gain", c.diff_gain, "Gain of the difference images")
        ->capture_default_str()
        ->check(CLI::PositiveNumber);
    app.add_option("--clip", c.clip,
                   "Clamp both images' linear values to [0, "
                   "CLIP] first (e.g. 4: emitters stop dominating)")
        ->check(CLI::PositiveNumber);
    app.add_option("--max-rmse", c.max_rmse, "Fail (exit 1) when the RMSE is larger");
    app.add_option("--min-psnr", c.min_psnr, "Fail (exit 1) when the PSNR (dB, peak 1) is lower");
    app.add_option("--max-error", c.max_error, "Fail (exit 1) when a channel differs by more");
}

int run_compare(const Invocation&) {
    const CompareArgs& c = state();
    exporter::Image a, b;
    exporter::require_image_support();  // exit 1 when missing, not "bad input"
    check_claimed_size(c.a);
    check_claimed_size(c.b);
    try {
        a = exporter::read_image(c.a);
        b = exporter::read_image(c.b);
    } catch (const exporter::ExportError& e) {
        bad_input(e.what());
    }
    if (a.width != b.width || a.height != b.height)
        bad_input(c.b + ": image is " + std::to_string(b.width) + "x" + std::to_string(b.height) +
                  ", " + c.a + " is " + std::to_string(a.width) + "x" + std::to_string(a.height));
    if (c.clip) {
        exporter::clip_image(a, static_cast<float>(*c.clip));
        exporter::clip_image(b, static_cast<float>(*c.clip));
    }
    const exporter::ImageDifference d = exporter::compare_images(a, b);
    std::printf(
        "a: %s\nb: %s\nsize: %dx%d\nrmse: %.6g\npsnr_db: %.4g\nmax_error: %.6g\n"
        "max_error_pixel: %d,%d\nmean_a: %.6g\nmean_b: %.6g\n",
        c.a.c_str(), c.b.c_str(), a.width, a.height, d.rmse, d.psnr_db, d.max_error, d.max_x,
        d.max_y, d.mean_a, d.mean_b);
    if (!c.diff.empty()) {
        const exporter::Image diff = exporter::difference_image(a, b, c.diff_gain);
        exporter::write_image(c.diff, diff.width, diff.height, diff.rgb);
        std::printf("diff: %s (|a - b| x %g)\n", c.diff.c_str(), c.diff_gain);
    }
    if (!c.side_by_side.empty()) {
        const exporter::Image strip = exporter::side_by_side(a, b, c.diff_gain);
        exporter::write_image(c.side_by_side, strip.width, strip.height, strip.rgb);
        std::printf("side_by_side: %s (a | b | |a - b| x %g, display 1 - exp(-v))\n",
                    c.side_by_side.c_str(), c.diff_gain);
    }
    const std::vector<std::string> failed = missed(c, d);
    if (failed.empty()) {
        std::printf("result: pass\n");
        return kExitOk;
    }
    std::string msg;
    for (const auto& f : failed) msg += (msg.empty() ? "" : "; ") + f;
    std::printf("result: fail\n");
    std::fflush(stdout);
    std::cerr << "abrad compare: " << c.a << " vs " << c.b << ": " << msg << "\n";
    return kExitFailure;
}

}  // namespace abrad::tools::cli
