// Median-split BVH over patch bounding boxes.

#include "abrad/radiosity/bvh.h"

#include <algorithm>
#include <cmath>
#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <numeric>
#include <utility>

namespace abrad::radiosity {

void Box::grow(const glm::dvec3& p) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
}

void Box::grow(const Box& b) {
    lo = glm::min(lo, b.lo);
    hi = glm::max(hi, b.hi);
}

Hull::Hull(std::span<const glm::dvec3> points) {
    for (const glm::dvec3& p : points) m_box.grow(p);
    const std::size_t n = std::min<std::size_t>(points.size(), 8);
    const double size = glm::length(m_box.hi - m_box.lo);
    if (!(size > 0.0)) return;
    const double eps = 1e-9 * size;
    // Every plane through three of the points with all the others on one side is a face
    // plane of the hull (duplicates are harmless); keep up to m_planes.size() of them
    for (std::size_t a = 0; a < n; ++a)
        for (std::size_t b = a + 1; b < n; ++b)
            for (std::size_t c = b + 1; c < n; ++c) {
                const glm::dvec3 cr = glm::cross(points[b] - points[a], points[c] - points[a]);
                const double len = glm::length(cr);
                if (!(len > 1e-12 * size * size)) continue;
                const glm::dvec3 nrm = cr / len;
                const double d0 = glm::dot(nrm, points[a]);
                double lo = 0.0, hi = 0.0;
                for (std::size_t k = 0; k < n; ++k) {
                    const double d = glm::dot(nrm, points[k]) - d0;
                    lo = std::min(lo, d);
                    hi = std::max(hi, d);
                }
                if (lo < -eps && hi > eps) continue;  // points on both sides: no face
                auto add = [&](const glm::dvec3& nn, double dd) {
                    // The same face seen through another triple of its points: keep one
                    for (int i = 0; i < m_count; ++i)
                        if (glm::dot(m_planes[i].n, nn) > 1.0 - 1e-12 &&
                            std::abs(m_planes[i].d - (dd + eps)) <= eps)
                            return;
                    if (m_count < static_cast<int>(m_planes.size()))
                        m_planes[m_count++] = {nn, dd + eps};
                };
                if (hi <= eps) add(nrm, d0);     // all below: outward normal +nrm
                if (lo >= -eps) add(-nrm, -d0);  // all above (or flat: both sides)
            }
}

namespace {

std::vector<Box> boxes_of(std::span<const Patch> patches) {
    std::vector<Box> boxes(patches.size());
    for (std::size_t i = 0; i < patches.size(); ++i)
        for (const auto& p : patches[i].p) boxes[i].grow(p);
    return boxes;
}

}  // namespace

Bvh::Bvh(std::span<const Patch> patches) : Bvh(boxes_of(patches)) {}

Bvh::Bvh(std::vector<Box> boxes) : m_boxes(std::move(boxes)) {
    const std::size_t n = m_boxes.size();
    m_centres.resize(n);
    for (std::size_t i = 0; i < n; ++i) m_centres[i] = 0.5 * (m_boxes[i].lo + m_boxes[i].hi);
    m_order.resize(n);
    std::iota(m_order.begin(), m_order.end(), 0u);
    if (n > 0) {
        m_nodes.reserve(4 * n / kLeafMax + 2);  // leaves hold kLeafMax / 2 or more
        m_nodes.emplace_back();
        build(0, 0, static_cast<std::uint32_t>(n), 0);
    }
}

// Fills node `self` for [begin, end), appending its descendants. Indices only: m_nodes grows.
void Bvh::build(std::uint32_t self, std::uint32_t begin, std::uint32_t end, int depth) {
    Box box, centres;
    for (std::uint32_t i = begin; i < end; ++i) {
        box.grow(m_boxes[m_order[i]]);
        centres.grow(m_centres[m_order[i]]);
    }
    m_nodes[self].box = box;
    // A leaf: few items, or centres that cannot be split (all the same); depth is bounded so
    // the query stack (64) never overflows
    const glm::dvec3 ext = centres.hi - centres.lo;
    if (end - begin <= kLeafMax || std::max({ext.x, ext.y, ext.z}) <= 0.0 || depth >= 48) {
        m_nodes[self].first = begin;
        m_nodes[self].count = end - begin;
        return;
    }
    // Split at the median of the longest axis of the centres; children are adjacent
    const int axis = ext.x >= ext.y && ext.x >= ext.z ? 0 : (ext.y >= ext.z ? 1 : 2);
    const std::uint32_t mid = begin + (end - begin) / 2;
    std::nth_element(
        m_order.begin() + begin, m_order.begin() + mid, m_order.begin() + end,
        [&](std::uint32_t a, std::uint32_t b) { return m_centres[a][axis] < m_centres[b][axis]; });
    const auto left = static_cast<std::uint32_t>(m_nodes.size());
    m_nodes[self].first = left;
    m_nodes[self].count = 0;
    m_nodes.emplace_back();
    m_nodes.emplace_back();
    build(left, begin, mid, depth + 1);
    build(left + 1, mid, end, depth + 1);
}

}  // namespace abrad::radiosity
