// The OpenImageIO module (libabrad_oiio.so): see oiio_module.h. Only this file includes
// OpenImageIO; image.cpp loads it when an image is written, read or compared.

#include "oiio_module.h"

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>
#include <OpenImageIO/imageio.h>
#include <OpenImageIO/strutil.h>

namespace {

namespace oiio = abrad::exporter::oiio;
using OIIO::ImageBuf;
using OIIO::ImageSpec;
using OIIO::TypeDesc;

ImageBuf rgb_buf(const float* rgb, int width, int height) {
    ImageBuf buf(ImageSpec(width, height, 3, TypeDesc::FLOAT));
    buf.set_pixels(OIIO::ROI(0, width, 0, height, 0, 1, 0, 3), TypeDesc::FLOAT, rgb);
    return buf;
}

// Encodes into memory (OpenImageIO's writers do not all report failed writes); the caller
// writes the bytes atomically.
std::string encode(const std::string& path, int width, int height, oiio::Storage storage,
                   const void* pixels, std::vector<unsigned char>& out) {
    auto output = OIIO::ImageOutput::create(path);
    if (!output) {
        const std::string dot =
            path.rfind('.') == std::string::npos ? "" : path.substr(path.rfind('.'));
        return "no image format for '" + dot + "' (" + OIIO::geterror() + ")";
    }
    if (!output->supports("ioproxy")) return "the writer of this format cannot encode into memory";
    OIIO::Filesystem::IOVecOutput encoded;
    if (!output->set_ioproxy(&encoded)) return output->geterror();
    const bool bytes = storage == oiio::Storage::Srgb8;
    ImageSpec spec(width, height, 3,
                   bytes                            ? TypeDesc::UINT8
                   : storage == oiio::Storage::Half ? TypeDesc::HALF
                                                    : TypeDesc::FLOAT);
    spec.attribute("oiio:ColorSpace", bytes ? "sRGB" : "linear");
    if (!output->open(path, spec) ||
        !output->write_image(bytes ? TypeDesc::UINT8 : TypeDesc::FLOAT, pixels) || !output->close())
        return output->geterror();
    out = encoded.buffer();
    return "";
}

std::string read(const std::string& path, oiio::Pixels& out) {
    ImageBuf buf(path);
    if (!buf.read(0, 0, true, TypeDesc::FLOAT)) return buf.geterror();
    const ImageSpec& spec = buf.spec();
    if (spec.width <= 0 || spec.height <= 0 || spec.nchannels <= 0) return "empty";
    // 8- and 16-bit display files carry sRGB; float files are linear
    const std::string space = spec.get_string_attribute("oiio:ColorSpace");
    const TypeDesc native = buf.nativespec().format;
    out.srgb = !(native == TypeDesc::FLOAT || native == TypeDesc::HALF) &&
               (space.empty() || OIIO::Strutil::iequals(space, "sRGB"));
    out.width = spec.width;
    out.height = spec.height;
    out.channels = spec.nchannels;
    out.data.resize(static_cast<std::size_t>(spec.width) * static_cast<std::size_t>(spec.height) *
                    static_cast<std::size_t>(spec.nchannels));
    if (!buf.get_pixels(OIIO::ROI(spec.x, spec.x + spec.width, spec.y, spec.y + spec.height, 0, 1,
                                  0, spec.nchannels),
                        TypeDesc::FLOAT, out.data.data()))
        return buf.geterror();
    return "";
}

bool render_text(float* rgb, int width, int height, int x, int y, const std::string& text, int size,
                 const std::string& font) {
    ImageBuf buf = rgb_buf(rgb, width, height);
    const float white[3] = {1.0f, 1.0f, 1.0f};
    if (!OIIO::ImageBufAlgo::render_text(buf, x, y, text, size, font, white)) return false;
    return buf.get_pixels(OIIO::ROI(0, width, 0, height, 0, 1, 0, 3), TypeDesc::FLOAT, rgb);
}

std::string compare(const float* a, const float* b, int width, int height, oiio::Comparison& out) {
    const ImageBuf ba = rgb_buf(a, width, height), bb = rgb_buf(b, width, height);
    const auto r = OIIO::ImageBufAlgo::compare(ba, bb, 1e30f, 1e30f);
    if (r.error) return OIIO::geterror();
    out = {r.rms_error, r.maxerror, r.maxx, r.maxy};
    return "";
}

bool header(const std::string& path, oiio::Header& out) {
    const auto in = OIIO::ImageInput::open(path);
    if (!in) {
        OIIO::geterror();  // clear the message: the reader reports it when it reads
        return false;
    }
    const ImageSpec& spec = in->spec();
    out = {spec.width, spec.height, spec.depth, spec.nchannels, spec.format.size()};
    return true;
}

const oiio::Api kApi{oiio::kAbi, sizeof(oiio::Api), encode, read, render_text, compare, header};

}  // namespace

extern "C" const abrad::exporter::oiio::Api* abrad_oiio_api() {
    // The images abrad writes and compares are small: neither OpenImageIO's thread pool nor
    // OpenEXR's is started (their threads, left running in a module loaded with dlopen,
    // crashed LeakSanitizer's exit-time scan in the sanitizer build; OpenEXR's pool follows
    // "threads" unless "exr_threads" is -1)
    static const bool single = OIIO::attribute("threads", 1) && OIIO::attribute("exr_threads", -1);
    (void)single;
    return &kApi;
}
