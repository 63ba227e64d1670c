#pragma once
// Checks on baked meshes shared by the radiosity and command-line tests.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <glm/geometric.hpp>
#include <map>
#include <optional>
#include <utility>
#include <vector>

#include "abrad/visdb/model.h"

namespace abrad::testing {

/// T-vertices of `m`: a vertex on the boundary of its region (an edge used by one triangle)
/// lying strictly inside (within `eps` metres) a boundary edge of another triangle, i.e. where
/// neighbouring regions (a floor and a wall, two faces at a crease) do not share their
/// vertices and Gouraud shading cracks. Vertices of objects merely standing on a surface's
/// interior (a table leg on a floor) are contacts, not T-vertices.
inline std::size_t count_t_vertices(const visdb::BakeMesh& m, double eps = 1e-9) {
    std::map<std::pair<std::uint32_t, std::uint32_t>, int> uses;
    for (const auto& t : m.triangles)
        for (int k = 0; k < 3; ++k) ++uses[std::minmax(t[k], t[(k + 1) % 3])];
    std::vector<char> on_boundary(m.positions.size(), 0);
    std::vector<std::pair<std::uint32_t, std::uint32_t>> boundary;
    for (const auto& [e, n] : uses)
        if (n == 1) {
            boundary.push_back(e);
            on_boundary[e.first] = on_boundary[e.second] = 1;
        }
    std::vector<std::uint32_t> by_x;
    for (std::uint32_t i = 0; i < m.positions.size(); ++i)
        if (on_boundary[i]) by_x.push_back(i);
    std::sort(by_x.begin(), by_x.end(),
              [&](auto a, auto b) { return m.positions[a].x < m.positions[b].x; });
    std::size_t found = 0;
    for (const auto& [ia, ib] : boundary) {
        const glm::dvec3 a = m.positions[ia], b = m.positions[ib];
        const double lo = std::min(a.x, b.x) - eps, hi = std::max(a.x, b.x) + eps;
        auto it = std::lower_bound(by_x.begin(), by_x.end(), lo,
                                   [&](std::uint32_t v, double x) { return m.positions[v].x < x; });
        const glm::dvec3 d = b - a;
        const double len2 = glm::dot(d, d);
        for (; it != by_x.end() && m.positions[*it].x <= hi; ++it) {
            const glm::dvec3 p = m.positions[*it];
            const double s = glm::dot(p - a, d) / len2;
            if (s < 0 || s > 1 || s * s * len2 <= eps * eps ||
                (1 - s) * (1 - s) * len2 <= eps * eps)
                continue;
            if (glm::length(a + s * d - p) < eps) ++found;
        }
    }
    return found;
}

/// Area of triangle `t` of `m`, m².
inline double triangle_area(const visdb::BakeMesh& m, std::size_t t) {
    const auto& tri = m.triangles[t];
    return 0.5 * glm::length(glm::cross(m.positions[tri.y] - m.positions[tri.x],
                                        m.positions[tri.z] - m.positions[tri.x]));
}

/// The vertex's irradiance, mean over RGB.
inline double irradiance_at(const visdb::BakeMesh& m, std::uint32_t v) {
    const glm::vec3 x = m.irradiance[v];
    return (double(x.x) + x.y + x.z) / 3.0;
}

/// The exported field at `p`: the Gouraud (barycentric) interpolation of the vertex
/// irradiance (mean over RGB) of the triangle of `m` holding p (within 1e-7 m of its plane)
/// whose front normal is `n`; nullopt when no triangle holds it.
inline std::optional<double> gouraud_at(const visdb::BakeMesh& m, const glm::dvec3& p,
                                        const glm::dvec3& n) {
    for (const auto& t : m.triangles) {
        const glm::dvec3 a = m.positions[t.x], e1 = m.positions[t.y] - a, e2 = m.positions[t.z] - a;
        const glm::dvec3 tn = glm::cross(e1, e2);
        const double len = glm::length(tn);
        if (len == 0.0 || glm::dot(glm::dvec3(m.normals[t.x]), n) < 0.999) continue;
        if (std::abs(glm::dot(tn / len, p - a)) > 1e-7) continue;
        // Barycentric coordinates of p in the triangle's plane
        const glm::dvec3 d = p - a;
        const double d11 = glm::dot(e1, e1), d12 = glm::dot(e1, e2), d22 = glm::dot(e2, e2);
        const double d1 = glm::dot(d, e1), d2 = glm::dot(d, e2);
        const double den = d11 * d22 - d12 * d12;
        const double v = (d22 * d1 - d12 * d2) / den, w = (d11 * d2 - d12 * d1) / den;
        if (v < -1e-9 || w < -1e-9 || v + w > 1.0 + 1e-9) continue;
        return (1.0 - v - w) * irradiance_at(m, t.x) + v * irradiance_at(m, t.y) +
               w * irradiance_at(m, t.z);
    }
    return std::nullopt;
}

/// Area-weighted mean over the triangles `keep(t)` accepts of the Gouraud-interpolated field
/// of the vertex values `value(v)`; their total area goes to `area_out` when given.
template <class Value, class Keep>
double area_mean(const visdb::BakeMesh& m, Value value, Keep keep, double* area_out = nullptr) {
    double sum = 0.0, area = 0.0;
    for (std::size_t t = 0; t < m.triangles.size(); ++t) {
        if (!keep(t)) continue;
        const double a = triangle_area(m, t);
        const auto& tri = m.triangles[t];
        sum += a * (value(tri.x) + value(tri.y) + value(tri.z)) / 3.0;
        area += a;
    }
    if (area_out) *area_out = area;
    return sum / area;
}

// Area-weighted mean irradiance (mean over RGB) of the mesh's Gouraud-interpolated field;
// the total area goes to `area_out` when given.
inline double mean_irradiance(const visdb::Bake& b, double* area_out = nullptr) {
    return area_mean(
        b.mesh, [&](std::uint32_t v) { return irradiance_at(b.mesh, v); },
        [](std::size_t) { return true; }, area_out);
}

}  // namespace abrad::testing
