#pragma once
// Small convex polygons with a fixed capacity and their clipping (Sutherland–Hodgman 1974).
//
// Numeric assumptions: clipping uses double arithmetic with the plane test evaluated once per
// vertex, so two clips against the same plane with opposite signs partition a polygon
// consistently (a vertex is on exactly one side: `dist >= 0` keeps it, `dist < 0` does not).
// Intersection points are constructed (not exact).

#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <cstddef>
#include <glm/geometric.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <string>
#include <utility>

namespace abrad::radiosity {

/// A polygon of at most N vertices stored inline (no heap allocation).
template <typename V, std::size_t N>
class FixedPolygon {
  public:
    static constexpr std::size_t kCapacity = N;

    // Only the vertices in use are copied, and storage is not cleared: the clippers make
    // and copy these in the hemicube's innermost loop
    FixedPolygon() = default;
    FixedPolygon(const FixedPolygon& o) : m_size(o.m_size) {
        std::copy_n(o.m_vertices.data(), m_size, m_vertices.data());
    }
    FixedPolygon& operator=(const FixedPolygon& o) {
        m_size = o.m_size;
        std::copy_n(o.m_vertices.data(), m_size, m_vertices.data());
        return *this;
    }
    ~FixedPolygon() = default;

    std::size_t size() const { return m_size; }
    bool empty() const { return m_size == 0; }
    void clear() { m_size = 0; }
    void push_back(const V& v) {
        assert(m_size < N);
        if (m_size < N) m_vertices[m_size++] = v;
    }
    const V& operator[](std::size_t i) const { return m_vertices[i]; }
    V& operator[](std::size_t i) { return m_vertices[i]; }
    const V* begin() const { return m_vertices.data(); }
    const V* end() const { return m_vertices.data() + m_size; }

  private:
    // NOLINTNEXTLINE(cppcoreguidelines-pro-type-member-init): only [0, m_size) is read
    std::array<V, N> m_vertices;
    std::size_t m_size = 0;
};

/// Capacity enough for a triangle clipped by up to 9 planes.
using Polygon3 = FixedPolygon<glm::dvec3, 12>;
using Polygon2 = FixedPolygon<glm::dvec2, 16>;

/// Keeps the part of `in` where `dist(v) >= 0`; `dist` is evaluated once per vertex.
/// The result may be empty or degenerate (zero area).
template <typename Poly, typename Dist>
Poly clip_polygon(const Poly& in, Dist&& dist) {
    Poly out;
    const std::size_t n = in.size();
    if (n == 0) return out;
    // Only [0, n) is written and read: not cleared (this is the hemicube's innermost loop)
    // NOLINTNEXTLINE(cppcoreguidelines-pro-type-member-init)
    std::array<double, Poly::kCapacity> d;
    bool all_in = true, all_out = true;
    for (std::size_t i = 0; i < n; ++i) {
        d[i] = dist(in[i]);
        all_in = all_in && d[i] >= 0.0;
        all_out = all_out && d[i] < 0.0;
    }
    if (all_in) return in;
    if (all_out) return out;
    for (std::size_t i = 0; i < n; ++i) {
        const std::size_t j = (i + 1) % n;
        const bool in_i = d[i] >= 0.0, in_j = d[j] >= 0.0;
        if (in_i) out.push_back(in[i]);
        if (in_i != in_j) {
            // Edge crosses the plane: construct the crossing from the inside end, so a shared
            // edge clipped in two polygons (in either direction) gives bit-identical points
            const std::size_t a = in_i ? i : j, b = in_i ? j : i;
            const double t = d[a] / (d[a] - d[b]);
            out.push_back(in[a] + (in[b] - in[a]) * t);
        }
    }
    return out;
}

/// clip_polygon(p, dist) into `p` itself, which is left as it is (not copied) when wholly
/// inside: the hemicube clips each triangle against five planes, most of which miss it.
template <typename Poly, typename Dist>
void clip_in_place(Poly& p, Dist&& dist) {
    const std::size_t n = p.size();
    bool all_in = true;
    for (std::size_t i = 0; i < n && all_in; ++i) all_in = dist(p[i]) >= 0.0;
    if (!all_in) p = clip_polygon(p, dist);
}

/// Twice the signed area of a 2D polygon (positive when counter-clockwise).
template <typename Poly>
double signed_area2(const Poly& p) {
    double a = 0.0;
    for (std::size_t i = 0, n = p.size(); i < n; ++i) {
        const auto& u = p[i];
        const auto& v = p[(i + 1) % n];
        a += u.x * v.y - v.x * u.y;
    }
    return a;
}

/// Area (in squared units of the coordinates) and area-weighted centroid of a simple 2D
/// polygon; a polygon of no area gives 0 and its first vertex.
template <typename Poly>
std::pair<double, glm::dvec2> area_centroid(const Poly& p) {
    double a2 = 0.0;
    glm::dvec2 c(0.0);
    for (std::size_t k = 0, n = p.size(); k < n; ++k) {
        const glm::dvec2& x = p[k];
        const glm::dvec2& y = p[(k + 1) % n];
        const double w = x.x * y.y - y.x * x.y;
        a2 += w;
        c += w * (x + y);
    }
    if (a2 == 0.0) return {0.0, p.size() == 0 ? glm::dvec2(0.0) : glm::dvec2(p[0])};
    return {0.5 * std::abs(a2), c / (3.0 * a2)};
}

/// Area vector (normal times area) of a planar 3D polygon (Newell's method).
template <typename Poly>
glm::dvec3 area_vector(const Poly& p) {
    glm::dvec3 a(0.0);
    for (std::size_t i = 0, n = p.size(); i < n; ++i) a += glm::cross(p[i], p[(i + 1) % n]);
    return 0.5 * a;
}

}  // namespace abrad::radiosity
