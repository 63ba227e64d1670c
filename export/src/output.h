#pragma once
// Private helpers of the writers: mesh validation, number formatting, and their output file
// (abrad/atomic_file.h with ExportError).

#include <charconv>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <string>
#include <string_view>

#include "abrad/atomic_file.h"
#include "abrad/export/writers.h"

namespace abrad::exporter::detail {

/// `PATH: MESSAGE` as an ExportError.
[[noreturn]] inline void fail(const std::filesystem::path& path, std::string_view message) {
    throw ExportError(path.string() + ": " + std::string(message));
}

/// Checks what both writers need of a BakeMesh: every per-vertex array as long as
/// `positions`, one surface id per triangle, every index below the vertex count, and counts
/// and ids that fit the `int` of the PLY contract. Throws ExportError naming `path`.
inline void validate_bake_mesh(const std::filesystem::path& path, const visdb::BakeMesh& mesh) {
    const std::size_t n = mesh.positions.size();
    const auto check_length = [&](std::size_t size, const char* what) {
        if (size != n) {
            fail(path, std::string("invalid mesh: ") + what + " has " + std::to_string(size) +
                           " entries, positions has " + std::to_string(n));
        }
    };
    check_length(mesh.normals.size(), "normals");
    check_length(mesh.irradiance.size(), "irradiance");
    check_length(mesh.radiosity.size(), "radiosity");
    if (mesh.triangle_surface.size() != mesh.triangles.size()) {
        fail(path, "invalid mesh: triangle_surface has " +
                       std::to_string(mesh.triangle_surface.size()) + " entries for " +
                       std::to_string(mesh.triangles.size()) + " triangles");
    }
    constexpr auto kIntMax = static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max());
    if (n > kIntMax) fail(path, "invalid mesh: too many vertices (" + std::to_string(n) + ")");
    if (mesh.triangles.size() > kIntMax) {
        fail(path,
             "invalid mesh: too many triangles (" + std::to_string(mesh.triangles.size()) + ")");
    }
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
        const auto& tri = mesh.triangles[t];
        for (int k = 0; k < 3; ++k) {
            if (tri[k] >= n) {
                fail(path, "invalid mesh: triangle " + std::to_string(t) + " index " +
                               std::to_string(tri[k]) + " out of range (" + std::to_string(n) +
                               " vertices)");
            }
        }
        if (mesh.triangle_surface[t] > kIntMax) {
            fail(path, "invalid mesh: triangle " + std::to_string(t) + " surface id " +
                           std::to_string(mesh.triangle_surface[t]) + " does not fit an int");
        }
    }
}

/// Appends the shortest text that reads back as exactly `value` (double or float).
template <typename T>
void append_exact(std::string& out, T value) {
    char buf[64];
    const auto res = std::to_chars(buf, buf + sizeof buf, value);
    out.append(buf, res.ptr);
}

/// Appends `value` with `decimals` fixed decimals.
inline void append_fixed(std::string& out, double value, int decimals) {
    char buf[400];  // fixed notation of the largest double needs ~310 characters
    const auto res =
        std::to_chars(buf, buf + sizeof buf, value, std::chars_format::fixed, decimals);
    out.append(buf, res.ptr);
}

/// Replaces whitespace and control characters with `_` so a name is one OBJ/MTL token.
inline std::string sanitise_name(std::string_view name) {
    std::string out(name);
    for (char& c : out) {
        const auto u = static_cast<unsigned char>(c);
        if (u <= 0x20 || u == 0x7f) c = '_';
    }
    return out;
}

/// `v` in the frame of a file with `up` up (UpAxis::Y: (x, y, z) -> (x, z, -y), a rotation;
/// 0 - y rather than -y so that a zero stays +0 and is not written as "-0").
inline glm::dvec3 to_up(const glm::dvec3& v, UpAxis up) {
    return up == UpAxis::Y ? glm::dvec3{v.x, v.z, 0.0 - v.y} : v;
}

/// The writers' output file (abrad/atomic_file.h): a temporary beside `PATH`, renamed to
/// `PATH` by commit() once every byte reached the disk; errors are ExportError
/// "PATH: cannot write: <strerror>", and a failure leaves an existing file as it was.
using AtomicFile = BasicAtomicFile<ExportError>;

}  // namespace abrad::exporter::detail
