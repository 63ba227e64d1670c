#pragma once
// A bounding-volume hierarchy of axis-aligned boxes, for conservative "which items can lie in
// this region" queries (median split on the longest axis of the box centres): the one BVH of
// abrad, over the bake's patches (shadow candidates, culling) and over the mesher's edges,
// triangles and points (dm_mesh.cpp).

#include <array>
#include <cstdint>
#include <glm/vec3.hpp>
#include <span>
#include <vector>

#include "abrad/radiosity/geometry.h"

namespace abrad::radiosity {

/// An axis-aligned box, metres.
struct Box {
    glm::dvec3 lo{1e300}, hi{-1e300};
    void grow(const glm::dvec3& p);
    void grow(const Box& b);
    /// Pushes every face out by `r` metres.
    void inflate(double r) {
        lo -= glm::dvec3(r);
        hi += glm::dvec3(r);
    }
    bool overlaps(const Box& b) const {
        return lo.x <= b.hi.x && b.lo.x <= hi.x && lo.y <= b.hi.y && b.lo.y <= hi.y &&
               lo.z <= b.hi.z && b.lo.z <= hi.z;
    }
};

/// The convex hull of a few points (a light triangle and a receiver point or triangle) as a
/// box and the hull's face planes, for shaft culling (Haines & Wallace 1994): a box outside
/// one plane cannot meet the hull. Conservative: planes are pushed out by a relative 1e-9.
class Hull {
  public:
    /// Up to 8 points; with fewer than 4 affinely independent ones only the box (and, for a
    /// flat set, its plane's two sides) bound the region.
    explicit Hull(std::span<const glm::dvec3> points);

    const Box& box() const { return m_box; }
    /// False when `b` lies entirely outside the hull (outside one of its face planes).
    bool may_overlap(const Box& b) const {
        for (int i = 0; i < m_count; ++i) {
            const Plane& p = m_planes[i];
            // The box corner furthest against the outward normal
            const double x = p.n.x >= 0.0 ? b.lo.x : b.hi.x, y = p.n.y >= 0.0 ? b.lo.y : b.hi.y,
                         z = p.n.z >= 0.0 ? b.lo.z : b.hi.z;
            if (p.n.x * x + p.n.y * y + p.n.z * z > p.d) return false;
        }
        return true;
    }

  private:
    Box m_box;
    struct Plane {
        glm::dvec3 n;
        double d;  // inside: dot(n, p) <= d
    };
    std::array<Plane, 24> m_planes{};
    int m_count = 0;
};

/// A static BVH over boxes; leaves hold up to kLeafMax items (or items whose box centres
/// coincide).
class Bvh {
  public:
    /// Items in a leaf at most. Small leaves cull finely but cost a node visit (a box
    /// test and a stack push) for every few items; 32 measured fastest on the FZK-Haus default
    /// bake (8.5 % less CPU than 4, 3 % less than 16; 64 was 3 % slower again): testing a few
    /// dozen items costs less than walking the subtree that would sort them.
    static constexpr std::uint32_t kLeafMax = 32;

    /// Over the patches' bounding boxes: items are patch indices.
    explicit Bvh(std::span<const Patch> patches);
    /// Over `boxes`: items are indices into it.
    explicit Bvh(std::vector<Box> boxes);

    /// Item `id`'s box.
    const Box& box(std::uint32_t id) const { return m_boxes[id]; }

    /// Calls `visit(patch_index)` for every patch whose box overlaps `query`.
    template <typename Visit>
    void query(const Box& query, Visit&& visit) const {
        traverse([&](const Box& b) { return b.overlaps(query); }, visit);
    }

    /// Calls `visit(patch_index)` for every patch whose box meets `hull` (conservative).
    template <typename Visit>
    void query(const Hull& hull, Visit&& visit) const {
        traverse([&](const Box& b) { return b.overlaps(hull.box()) && hull.may_overlap(b); },
                 visit);
    }

    /// Walks the tree nearest child first as seen from `eye` (an ordered depth-first walk,
    /// front to back up to the overlap of sibling boxes): `enter(box)` says whether a node is
    /// entered (false skips its whole subtree), and `visit(item)` gets every item of an
    /// entered leaf. For occlusion culling (shoot.h), where a node behind closed pixels is
    /// skipped.
    template <typename Enter, typename Visit>
    void front_to_back(const glm::dvec3& eye, Enter&& enter, Visit&& visit) const {
        walk(enter, visit, [&](const Node& n) {
            return distance2(m_nodes[n.first].box, eye) <= distance2(m_nodes[n.first + 1].box, eye);
        });
    }

    /// Squared distance from `p` to the box (0 inside).
    static double distance2(const Box& b, const glm::dvec3& p) {
        double d2 = 0.0;
        for (int k = 0; k < 3; ++k) {
            const double d =
                p[k] < b.lo[k] ? b.lo[k] - p[k] : (p[k] > b.hi[k] ? p[k] - b.hi[k] : 0.0);
            d2 += d * d;
        }
        return d2;
    }

  private:
    struct Node {
        Box box;
        std::uint32_t first = 0;  // first child (inner) or first index into m_order (leaf)
        std::uint32_t count = 0;  // patches in a leaf, 0 for inner nodes
    };
    void build(std::uint32_t self, std::uint32_t begin, std::uint32_t end, int depth);

    // Depth-first walk: nodes and patches whose box passes `meets` are entered or visited.
    template <typename Meets, typename Visit>
    void traverse(Meets&& meets, Visit&& visit) const {
        walk(
            meets,
            [&](std::uint32_t id) {
                if (meets(m_boxes[id])) visit(id);
            },
            [](const Node&) { return false; });
    }

    // The one stack walk: nodes passing `enter` are entered, every item of an entered leaf
    // goes to `visit`, and an inner node's left child is walked first when `left_first(node)`
    // (the right one otherwise). Depth is bounded by build (48), the stack by 64.
    template <typename Enter, typename Visit, typename LeftFirst>
    void walk(Enter&& enter, Visit&& visit, LeftFirst&& left_first) const {
        if (m_nodes.empty()) return;
        std::uint32_t stack[64];
        int top = 0;
        stack[top++] = 0;
        while (top > 0) {
            const Node& n = m_nodes[stack[--top]];
            if (!enter(n.box)) continue;
            if (n.count > 0) {
                for (std::uint32_t i = 0; i < n.count; ++i) visit(m_order[n.first + i]);
                continue;
            }
            // The child walked first goes on top of the stack
            const bool left = left_first(n);
            stack[top++] = left ? n.first + 1 : n.first;
            stack[top++] = left ? n.first : n.first + 1;
        }
    }

    std::vector<Box> m_boxes;
    std::vector<glm::dvec3> m_centres;
    std::vector<std::uint32_t> m_order;
    std::vector<Node> m_nodes;
};

}  // namespace abrad::radiosity
