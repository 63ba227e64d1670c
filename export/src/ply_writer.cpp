// The PLY writer: the contract in docs/design.md#exported-ply-contract.

#include <array>
#include <bit>
#include <cstdint>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "abrad/export/writers.h"
#include "output.h"

namespace abrad::exporter {

namespace {

/// Appends `value` as little-endian bytes whatever the host's byte order.
template <typename T>
void append_le(std::string& out, T value) {
    using Bits =
        std::conditional_t<sizeof(T) == 8, std::uint64_t,
                           std::conditional_t<sizeof(T) == 4, std::uint32_t, std::uint8_t>>;
    static_assert(sizeof(Bits) == sizeof(T));
    const auto bits = std::bit_cast<Bits>(value);
    for (std::size_t i = 0; i < sizeof(T); ++i) {
        out.push_back(static_cast<char>(static_cast<unsigned char>((bits >> (8 * i)) & 0xffu)));
    }
}

/// Where the vertices go: the file's frame, and the origin float positions are relative to.
struct Frame {
    UpAxis up = UpAxis::Z;
    bool float_positions = false;
    glm::dvec3 origin{0.0};                      ///< in the file's frame; zero for double positions
    std::vector<std::int32_t> vertex_surface{};  ///< surface ids on the vertices, when not empty
};

/// Each vertex's surface (-1 for a vertex no triangle uses). Throws ExportError naming `path`
/// for a vertex that triangles of two surfaces share.
std::vector<std::int32_t> vertex_surfaces(const std::filesystem::path& path,
                                          const visdb::BakeMesh& mesh) {
    std::vector<std::int32_t> out(mesh.positions.size(), -1);
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
        // validate_bake_mesh checked that ids fit an int
        const auto s = static_cast<std::int32_t>(mesh.triangle_surface[t]);
        for (int k = 0; k < 3; ++k) {
            std::int32_t& v = out[mesh.triangles[t][k]];
            if (v >= 0 && v != s)
                detail::fail(path, "vertex " + std::to_string(mesh.triangles[t][k]) +
                                       " is shared by surfaces " + std::to_string(v) + " and " +
                                       std::to_string(s) + ": surface ids cannot go on vertices");
            v = s;
        }
    }
    return out;
}

/// The header of the contract for `n` vertices and `m` faces.
std::string ply_header(std::size_t n, std::size_t m, const PlyOptions& options,
                       const Frame& frame) {
    std::string h = "ply\n";
    h += options.ascii ? "format ascii 1.0\n" : "format binary_little_endian 1.0\n";
    // One `comment` line per line of the comment, so a newline cannot break the header
    std::string_view rest = options.comment;
    while (!rest.empty()) {
        const auto eol = rest.find_first_of("\r\n");
        h += "comment ";
        h += rest.substr(0, eol);
        h += '\n';
        if (eol == std::string_view::npos) break;
        rest.remove_prefix(eol + 1);
    }
    if (frame.float_positions) {
        h += "comment origin";
        for (int k = 0; k < 3; ++k) {
            h += ' ';
            detail::append_exact(h, frame.origin[k]);
        }
        h += '\n';
    }
    h += "element vertex " + std::to_string(n) + "\n";
    h += frame.float_positions ? "property float x\n"
                                 "property float y\n"
                                 "property float z\n"
                               : "property double x\n"
                                 "property double y\n"
                                 "property double z\n";
    h += "property float nx\n"
         "property float ny\n"
         "property float nz\n"
         "property uchar red\n"
         "property uchar green\n"
         "property uchar blue\n"
         "property float irradiance_r\n"
         "property float irradiance_g\n"
         "property float irradiance_b\n"
         "property float radiosity_r\n"
         "property float radiosity_g\n"
         "property float radiosity_b\n";
    if (options.surface_ids == PlySurfaceIds::Vertex) h += "property int surface\n";
    h += "element face " + std::to_string(m) + "\n";
    h += "property list uchar int vertex_indices\n";
    if (options.surface_ids == PlySurfaceIds::Face) h += "property int surface\n";
    h += "end_header\n";
    return h;
}

/// Appends one vertex's record in the binary body.
void append_vertex_binary(std::string& out, const visdb::BakeMesh& mesh, std::size_t i,
                          const std::array<std::uint8_t, 3>& rgb, const Frame& frame) {
    const glm::dvec3 p = detail::to_up(mesh.positions[i], frame.up) - frame.origin;
    const glm::dvec3 n = detail::to_up(glm::dvec3(mesh.normals[i]), frame.up);
    const auto& h = mesh.irradiance[i];
    const auto& b = mesh.radiosity[i];
    for (int k = 0; k < 3; ++k) {
        if (frame.float_positions) {
            append_le(out, static_cast<float>(p[k]));
        } else {
            append_le(out, p[k]);
        }
    }
    for (int k = 0; k < 3; ++k) append_le(out, static_cast<float>(n[k]));
    for (const auto c : rgb) append_le(out, c);
    for (int k = 0; k < 3; ++k) append_le(out, static_cast<float>(h[k]));
    for (int k = 0; k < 3; ++k) append_le(out, static_cast<float>(b[k]));
    if (!frame.vertex_surface.empty()) append_le(out, frame.vertex_surface[i]);
}

/// Appends one vertex's line in the ASCII body, with round-trip precision.
void append_vertex_ascii(std::string& out, const visdb::BakeMesh& mesh, std::size_t i,
                         const std::array<std::uint8_t, 3>& rgb, const Frame& frame) {
    const glm::dvec3 p = detail::to_up(mesh.positions[i], frame.up) - frame.origin;
    const glm::dvec3 n = detail::to_up(glm::dvec3(mesh.normals[i]), frame.up);
    const auto& h = mesh.irradiance[i];
    const auto& b = mesh.radiosity[i];
    bool first = true;
    const auto put = [&](auto value) {
        if (!first) out += ' ';
        first = false;
        if constexpr (std::is_same_v<decltype(value), std::uint8_t>) {
            out += std::to_string(value);
        } else {
            detail::append_exact(out, value);
        }
    };
    for (int k = 0; k < 3; ++k) {
        if (frame.float_positions) {
            put(static_cast<float>(p[k]));
        } else {
            put(p[k]);
        }
    }
    for (int k = 0; k < 3; ++k) put(static_cast<float>(n[k]));
    for (const auto c : rgb) put(c);
    for (int k = 0; k < 3; ++k) put(static_cast<float>(h[k]));
    for (int k = 0; k < 3; ++k) put(static_cast<float>(b[k]));
    if (!frame.vertex_surface.empty()) out += ' ' + std::to_string(frame.vertex_surface[i]);
    out += '\n';
}

}  // namespace

void write_ply(const std::filesystem::path& path, const visdb::BakeMesh& mesh, const ToneMap& tone,
               const PlyOptions& options) {
    // Validate before anything touches the disk
    detail::validate_bake_mesh(path, mesh);

    Frame frame{.up = options.up, .float_positions = options.positions == PlyPositions::Float};
    if (frame.float_positions)
        frame.origin = detail::to_up(visdb::local_origin(mesh.positions), options.up);
    const bool ids_on_faces = options.surface_ids == PlySurfaceIds::Face;
    if (!ids_on_faces) frame.vertex_surface = vertex_surfaces(path, mesh);

    detail::AtomicFile file(path);
    std::string buf = ply_header(mesh.positions.size(), mesh.triangles.size(), options, frame);

    // Write the vertex element
    for (std::size_t i = 0; i < mesh.positions.size(); ++i) {
        const auto rgb = display_colour(mesh.radiosity[i], tone);
        if (options.ascii) {
            append_vertex_ascii(buf, mesh, i, rgb, frame);
        } else {
            append_vertex_binary(buf, mesh, i, rgb, frame);
        }
        file.write_if_full(buf);
    }

    // Write the face element: `3 a b c surface`, or `3 a b c`
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
        const auto& tri = mesh.triangles[t];
        // validate_bake_mesh checked that indices and ids fit an int
        const auto surface = static_cast<std::int32_t>(mesh.triangle_surface[t]);
        if (options.ascii) {
            buf += "3 " + std::to_string(tri[0]) + ' ' + std::to_string(tri[1]) + ' ' +
                   std::to_string(tri[2]);
            if (ids_on_faces) buf += ' ' + std::to_string(surface);
            buf += '\n';
        } else {
            append_le(buf, std::uint8_t{3});
            for (int k = 0; k < 3; ++k) append_le(buf, static_cast<std::int32_t>(tri[k]));
            if (ids_on_faces) append_le(buf, surface);
        }
        file.write_if_full(buf);
    }

    file.write(buf);
    file.commit();
}

}  // namespace abrad::exporter
