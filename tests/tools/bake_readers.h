#pragma once
// Reading what the command line gives back: `abrad probe`'s rows and an exported binary PLY.

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <sstream>
#include <string>
#include <vector>

#include "abrad/visdb/model.h"

namespace abrad::testing {

// The G irradiance of every row `abrad probe` prints (x,y,z,nx,ny,nz,r,g,b).
inline std::vector<double> probe_rows(const std::string& output) {
    std::vector<double> g;
    std::istringstream in(output);
    for (std::string l; std::getline(in, l);) {
        double v[9];
        if (std::sscanf(l.c_str(), "%lf,%lf,%lf,%lf,%lf,%lf,%lf,%lf,%lf", &v[0], &v[1], &v[2],
                        &v[3], &v[4], &v[5], &v[6], &v[7], &v[8]) == 9)
            g.push_back(v[7]);
    }
    return g;
}

// An exported binary PLY read back into a mesh (vertices of 3 doubles, 3 floats, 3 bytes,
// 6 floats; faces of a count byte, 3 ints and the surface); empty when malformed.
inline abrad::visdb::BakeMesh read_ply(const std::string& ply) {
    abrad::visdb::BakeMesh mesh;
    const std::string end = "end_header\n";
    const std::size_t body = ply.find(end), vat = ply.find("element vertex"),
                      fat = ply.find("element face");
    std::size_t vertices = 0, faces = 0;
    if (body == std::string::npos || vat == std::string::npos || fat == std::string::npos ||
        std::sscanf(ply.c_str() + vat, "element vertex %zu", &vertices) != 1 ||
        std::sscanf(ply.c_str() + fat, "element face %zu", &faces) != 1)
        return mesh;
    const std::size_t vstride = 3 * 8 + 3 * 4 + 3 + 6 * 4, fstride = 1 + 3 * 4 + 4;
    if (ply.size() != body + end.size() + vertices * vstride + faces * fstride) return mesh;
    const char* data = ply.data() + body + end.size();
    for (std::size_t v = 0; v < vertices; ++v) {
        double p[3];
        float n[3], h[3];
        std::memcpy(p, data + v * vstride, 24);
        std::memcpy(n, data + v * vstride + 24, 12);
        std::memcpy(h, data + v * vstride + 39, 12);
        mesh.positions.emplace_back(p[0], p[1], p[2]);
        mesh.normals.emplace_back(n[0], n[1], n[2]);
        mesh.irradiance.emplace_back(h[0], h[1], h[2]);
    }
    for (std::size_t f = 0; f < faces; ++f) {
        std::int32_t idx[3];
        std::memcpy(idx, data + vertices * vstride + f * fstride + 1, 12);
        mesh.triangles.emplace_back(idx[0], idx[1], idx[2]);
    }
    return mesh;
}

}  // namespace abrad::testing
