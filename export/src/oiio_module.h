#pragma once
// The OpenImageIO calls of abrad, behind a table of functions in a module loaded at first use
// (libabrad_oiio.so, built from oiio_module.cpp).
//
// OpenImageIO's Debian build depends on about 230 shared libraries (FFmpeg, OpenCV, GDAL,
// DCMTK, OpenVDB, GStreamer, ...), and resolving their relocations took about 0.25 s of CPU at
// the start of every abrad process and test, whether it wrote an image or not. Loaded here only
// when an image is written, read or compared, the commands that do not (bake, info, probe,
// import) start in a few milliseconds.
//
// The module is the file named by the environment variable ABRAD_OIIO_MODULE when it is set;
// else libabrad_oiio.so beside the running executable, else the build tree's copy (the path
// compiled in). Both sides are built together by the same compiler, so the table
// passes C++ types; its version and size are checked when it is loaded.

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "abrad/export/image.h"

namespace abrad::exporter::oiio {

/// Pixels as OpenImageIO read them: every channel, as float, row-major, top row first.
struct Pixels {
    int width = 0;
    int height = 0;
    int channels = 0;
    bool srgb = false;  ///< 8- or 16-bit data tagged sRGB or untagged (decode); false for float
    std::vector<float> data;
};

/// What an image file's header claims, before any pixel is read.
using Header = ImageHeader;

/// How an image is stored by `encode`.
enum class Storage {
    Half,   ///< linear, half float (EXR)
    Float,  ///< linear, float (HDR)
    Srgb8,  ///< 8-bit values already sRGB-encoded (PNG, JPEG, TIFF)
};

/// What compare() finds (OpenImageIO's ImageBufAlgo::compare).
struct Comparison {
    double rms_error = 0.0;
    double max_error = 0.0;
    int max_x = 0;
    int max_y = 0;
};

inline constexpr int kAbi = 1;

struct Api {
    int abi = kAbi;
    std::size_t size = sizeof(Api);
    /// Encodes a w×h RGB image into `out` in the format `path`'s extension names: `pixels` are
    /// floats for Half/Float, bytes for Srgb8. Returns "" or the reason it cannot.
    std::string (*encode)(const std::string& path, int width, int height, Storage storage,
                          const void* pixels, std::vector<unsigned char>& out) = nullptr;
    /// Reads an image file. Returns "" or the reader's message.
    std::string (*read)(const std::string& path, Pixels& out) = nullptr;
    /// Draws `text` into a w×h RGB float image in place with a TrueType font; false when the
    /// font does not load or render.
    bool (*render_text)(float* rgb, int width, int height, int x, int y, const std::string& text,
                        int size, const std::string& font) = nullptr;
    /// Compares two w×h RGB float images. Returns "" or the reason it failed.
    std::string (*compare)(const float* a, const float* b, int width, int height,
                           Comparison& out) = nullptr;
    /// Opens an image file and reads its header only; false when no reader opens it.
    bool (*header)(const std::string& path, Header& out) = nullptr;
};

/// The module's table, loaded on first use (thread-safe). Throws ExportError naming the
/// places it looked when the module cannot be loaded.
const Api& api();

}  // namespace abrad::exporter::oiio

/// The module's one exported symbol.
extern "C" const abrad::exporter::oiio::Api* abrad_oiio_api();
