// Collada and 3DS checks before Assimp (format_checks.h).

#include "format_checks.h"

#include <expat.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <memory>
#include <new>

#include "abrad/convert/obj_import.h"

namespace abrad::convert::detail {

void check_collada_xml(std::string_view bytes, const std::string& file) {
    const std::unique_ptr<XML_ParserStruct, decltype(&XML_ParserFree)> parser(
        XML_ParserCreate(nullptr), &XML_ParserFree);
    if (!parser) throw std::bad_alloc();
    // No handlers: expat checks well-formedness only; fed in pieces (its length is an int)
    constexpr std::size_t kPiece = std::size_t{1} << 24;
    std::size_t at = 0;
    XML_Status status = XML_STATUS_OK;
    do {
        const std::size_t n = std::min(kPiece, bytes.size() - at);
        const bool last = at + n == bytes.size();
        status = XML_Parse(parser.get(), bytes.data() + at, static_cast<int>(n), last ? 1 : 0);
        at += n;
    } while (status == XML_STATUS_OK && at < bytes.size());
    if (status == XML_STATUS_OK) return;
    const auto line = static_cast<std::size_t>(XML_GetCurrentLineNumber(parser.get()));
    const auto column = static_cast<std::size_t>(XML_GetCurrentColumnNumber(parser.get())) + 1;
    throw ImportError(file, line,
                      "column " + std::to_string(column) + ": not well-formed Collada XML (" +
                          XML_ErrorString(XML_GetErrorCode(parser.get())) + ")");
}

namespace {

constexpr std::size_t kChunkHeader = 6;
constexpr int kMaxChunkDepth = 8;

/// "0x4D4D" for a chunk id.
std::string chunk_id(std::uint16_t id) {
    std::array<char, 8> s{};
    std::snprintf(s.data(), s.size(), "0x%04X", static_cast<unsigned>(id));
    return s.data();
}

/// Chunks whose body is a sequence of chunks (after `skip` bytes of their own: an object's
/// name, 0 for the rest) in Assimp's 3DS reader; -1 for chunks it reads as data.
int container_skip(std::uint16_t id, std::string_view body) {
    switch (id) {
        case 0x4D4D:  // main
        case 0x3D3D:  // editor (objects, materials)
        case 0x4100:  // triangle mesh
        case 0xAFFF:  // material
        case 0xB000:  // keyframer
            return 0;
        case 0x4000: {  // object: a NUL-terminated name, then chunks
            const std::size_t end = body.find('\0');
            return end == std::string_view::npos ? -1
                                                 : static_cast<int>(std::min<std::size_t>(
                                                       end + 1, std::numeric_limits<int>::max()));
        }
        default:
            return -1;
    }
}

/// Walks the chunks in bytes [begin, end) at nesting `depth` (at depth 0 the first chunk only:
/// Assimp reads the main chunk and ignores what follows it).
void walk_chunks(std::string_view bytes, std::size_t begin, std::size_t end, int depth,
                 const std::string& file) {
    std::size_t at = begin;
    while (end - at >= kChunkHeader) {
        const auto byte = [&](std::size_t k) { return static_cast<unsigned char>(bytes[at + k]); };
        const auto id = static_cast<std::uint16_t>(byte(0) | byte(1) << 8);
        const std::uint32_t length =
            static_cast<std::uint32_t>(byte(2)) | static_cast<std::uint32_t>(byte(3)) << 8 |
            static_cast<std::uint32_t>(byte(4)) << 16 | static_cast<std::uint32_t>(byte(5)) << 24;
        // Assimp refuses a chunk shorter than its header or longer than the rest of the file
        if (length < kChunkHeader) {
            throw ImportError(file, 0,
                              "3DS: byte " + std::to_string(at) + ": chunk " + chunk_id(id) +
                                  " claims " + std::to_string(length) +
                                  " bytes, less than its 6-byte header (damaged file)");
        }
        if (length > bytes.size() - at) {
            throw ImportError(file, 0,
                              "3DS: byte " + std::to_string(at) + ": chunk " + chunk_id(id) +
                                  " claims " + std::to_string(length) + " bytes, the file has " +
                                  std::to_string(bytes.size() - at) +
                                  " from there (truncated or damaged file)");
        }
        const std::size_t stop = std::min(end, at + length);
        const int skip =
            container_skip(id, bytes.substr(at + kChunkHeader, stop - at - kChunkHeader));
        if (skip >= 0 && depth < kMaxChunkDepth)
            walk_chunks(bytes, at + kChunkHeader + static_cast<std::size_t>(skip), stop, depth + 1,
                        file);
        if (depth == 0) return;
        at = stop;
    }
}

}  // namespace

void check_3ds_chunks(std::string_view bytes, const std::string& file) {
    walk_chunks(bytes, 0, bytes.size(), 0, file);
}

}  // namespace abrad::convert::detail
