// abrad render: abrad's own image of a bake (Gouraud-rasterized radiosity, or false-colour
// irradiance with a legend).

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <iostream>

#include "abrad/export/exposure.h"
#include "abrad/export/image.h"
#include "abrad/export/render.h"
#include "abrad/export/writers.h"
#include "cli_common.h"

namespace fs = std::filesystem;

namespace abrad::tools::cli {
namespace {

RenderArgs& state() {
    static RenderArgs s;
    return s;
}

// Irradiance luminance in false colour, no data where nothing (or a face's back) was hit.
void write_false_colour(const RenderArgs& a, const visdb::Bake& b, const visdb::Camera& camera,
                        const exporter::Raster& r, double seconds) {
    std::vector<double> values(r.value.size());
    double hi = 0.0;
    for (std::size_t i = 0; i < values.size(); ++i) {
        const glm::vec3& h = r.value[i];
        const double y = visdb::luminance(h);
        values[i] = r.covered[i] == 1 ? y : std::nan("");  // backs of faces: no data
        if (r.covered[i] == 1 && std::isfinite(y)) hi = std::max(hi, y);
    }
    const double lo_v = a.vmin.value_or(0.0), hi_v = a.vmax.value_or(hi > lo_v ? hi : lo_v + 1.0);
    if (!(hi_v > lo_v))
        bad_input("--vmax (" + std::to_string(hi_v) + ") must exceed --vmin (" +
                  std::to_string(lo_v) + ")");
    const std::string unit = b.unit == "lux" ? "lux" : "W/m\u00b2";
    exporter::write_false_colour_image(a.output, r.width, r.height, values, lo_v, hi_v, unit);
    std::cout << "wrote " << a.output << " (false-colour irradiance, " << lo_v << " .. " << hi_v
              << " " << (b.unit == "lux" ? "lux" : "W/m2") << ", camera '" << camera.name << "', "
              << r.width << "x" << r.height << ", " << seconds << " s)\n";
}

}  // namespace

// EXR/HDR: exposure x B, linear; PNG and the others: the tone curve 1 - exp(-exposure B), sRGB.
void render_image(const RenderArgs& a) {
    std::string ext = fs::path(a.output).extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    if (ext != ".png" && ext != ".exr" && ext != ".hdr" && ext != ".jpg" && ext != ".jpeg" &&
        ext != ".tif" && ext != ".tiff")
        bad_input(a.output + ": unknown image type '" + ext + "' (png, exr, hdr, jpg, tif)");
    visdb::Store store = open_db(a.db);
    visdb::Bake b = load_bake_for(store, a.db, a.bake, "render");
    visdb::Scene scene = store.load_scene();
    const visdb::Camera camera = camera_for(scene, a.view);
    // The exposure of the bake's own light scene: a dimmed one looks dimmer (--exposure wins)
    const exporter::ToneMap tone = exposure_for(b, scene, a.view);
    mix_light_scene(a.scene_mix, scene, b);
    const auto t0 = std::chrono::steady_clock::now();
    const exporter::Raster r =
        exporter::render_bake(b.mesh, camera,
                              {.width = a.view.width,
                               .height = a.view.height,
                               .quantity = a.false_colour ? exporter::RenderQuantity::Irradiance
                                                          : exporter::RenderQuantity::Radiosity});
    const double seconds = seconds_since(t0);
    if (a.false_colour) return write_false_colour(a, b, camera, r, seconds);
    const bool linear = ext == ".exr" || ext == ".hdr";
    std::vector<float> rgb(r.value.size() * 3);
    for (std::size_t i = 0; i < r.value.size(); ++i)
        for (int c = 0; c < 3; ++c) {
            const double v = static_cast<double>(r.value[i][c]);
            rgb[3 * i + static_cast<std::size_t>(c)] =
                static_cast<float>(linear ? tone.exposure * v : exporter::tone_value(v, tone));
        }
    exporter::write_image(a.output, r.width, r.height, rgb);
    std::cout << "wrote " << a.output << " (bake '" << b.name << "', camera '" << camera.name
              << "', " << r.width << "x" << r.height << ", exposure " << tone.exposure << " per "
              << b.unit << (linear ? ", linear" : ", tone-mapped sRGB") << ", " << seconds
              << " s)\n";
    if (!linear) {
        // What the tone curve clips: receivers (emitters are lights, and may)
        const exporter::PixelCounts n = exporter::count_pixels(scene, b.mesh, r, tone);
        std::cout << "clipped: " << n.receivers_clipped << " of " << n.receivers
                  << " receiver pixels (" << n.receivers_clipped_percent() << " %); emitters "
                  << n.emitters << " pixels, background and backs of faces "
                  << n.pixels - n.receivers - n.emitters << "\n";
    }
}

void add_render(CLI::App& app) {
    RenderArgs& s = state();
    app.add_option("--db", s.db, "Visual database")->required();
    app.add_option("--bake", s.bake, "Bake name (default: the latest)");
    add_scene_mix_option(app, s.scene_mix);
    app.add_option("--output", s.output,
                   "Image path: .png (sRGB, tone-mapped) or .exr (linear, "
                   "exposure x radiosity)")
        ->required();
    add_view_options(app, s.view);
    app.add_flag("--false-colour", s.false_colour,
                 "Irradiance luminance in false colour with a "
                 "legend (W/m2 or lux) instead of radiosity");
    app.add_option("--vmin", s.vmin, "False colour: value at the bottom of the scale (default 0)");
    app.add_option("--vmax", s.vmax,
                   "False colour: value at the top (default: the image's maximum)");
}

int run_render(const Invocation& call) {
    const RenderArgs& s = state();
    for (const char* name : {"--vmin", "--vmax"})
        if (call.app.count(name) && !s.false_colour)
            bad_input(std::string(name) + " applies to --false-colour only");
    render_image(s);
    return kExitOk;
}

}  // namespace abrad::tools::cli
