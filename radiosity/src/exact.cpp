// Exact visible form factor of a light polygon from a point, past convex occluders.

#include "abrad/radiosity/exact.h"

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>
#include <limits>
#include <vector>

#include "abrad/radiosity/form_factor.h"
#include "abrad/radiosity/polygon.h"

namespace abrad::radiosity {

namespace {

using Poly2 = FixedPolygon<glm::dvec2, 32>;

// A convex piece of the light still seen from x, with the transmittance it is seen through.
struct Piece {
    Poly2 poly;
    double weight;
    glm::dvec2 lo, hi;  // bounding box
};

void bound(Piece& p) {
    p.lo = p.hi = p.poly[0];
    for (const auto& v : p.poly) {
        p.lo = glm::min(p.lo, v);
        p.hi = glm::max(p.hi, v);
    }
}

// Signed distance-like value of v from the directed line a->b (positive on the left).
inline double left_of(const glm::dvec2& a, const glm::dvec2& b, const glm::dvec2& v) {
    return (b.x - a.x) * (v.y - a.y) - (b.y - a.y) * (v.x - a.x);
}

// The light's plane (point l0, unit front normal nl, 2D frame e1, e2 counter-clockwise seen
// from the front) and the receiving point x at height sx above it.
struct LightPlane {
    glm::dvec3 l0, nl, e1, e2, x, n;
    double sx, scale;

    glm::dvec2 to2(const glm::dvec3& q) const {
        const glm::dvec3 d = q - l0;
        return glm::dvec2(glm::dot(d, e1), glm::dot(d, e2));
    }
    glm::dvec3 to3(const glm::dvec2& q) const { return l0 + q.x * e1 + q.y * e2; }
};

// The shadow of `occ` seen from x on the light plane, counter-clockwise; false when the
// occluder cannot block any of the light from x, or when its shadow misses the box [lo, hi]
// of what is left of the light.
bool occluder_shadow(const LightPlane& lp, const Patch& occ, const glm::dvec2& lo,
                     const glm::dvec2& hi, double coplanar, Poly2& shadow) {
    const glm::dvec3 x = lp.x, n = lp.n, l0 = lp.l0, nl = lp.nl;
    const double sx = lp.sx;
    // Quick rejection: a blocking point lies strictly above x's tangent plane and strictly
    // between x and the light's plane (0 < r < 1, r = s(p)/s(x))
    constexpr double kEps = 1e-9;
    bool above = false, below_light = false, beyond_x = false, inside = true;
    double sp[3];
    for (int k = 0; k < 3; ++k) {
        const glm::dvec3& p = occ.p[k];
        sp[k] = glm::dot(p - l0, nl);
        const double r = sp[k] / sx;
        above = above || glm::dot(p - x, n) > 0.0;
        below_light = below_light || r < 1.0 - kEps;
        beyond_x = beyond_x || r > kEps;
        inside = inside && r - kEps >= 0.0 && (1.0 - kEps) - r >= 0.0;
    }
    if (!above || !below_light || !beyond_x) return false;
    // Central projection from x onto the light plane. The whole triangle lies between the
    // planes (the usual case): project its corners and drop it at once when their box misses
    // what is left of the light, before any clipping
    const auto project = [&](const glm::dvec3& p, double s) {
        return lp.to2(x + (p - x) * (sx / (sx - s)));
    };
    shadow.clear();
    if (inside) {
        glm::dvec2 slo(std::numeric_limits<double>::infinity()), shi(-slo);
        for (int k = 0; k < 3; ++k) {
            const glm::dvec2 q = project(occ.p[k], sp[k]);
            slo = glm::min(slo, q);
            shi = glm::max(shi, q);
            shadow.push_back(q);
        }
        if (shi.x <= lo.x || slo.x >= hi.x || shi.y <= lo.y || slo.y >= hi.y) return false;
    }
    // An occluder whose plane contains x blocks nothing: the rays from x that meet it lie in
    // its plane, a set of measure zero of the light. (Projected from x, such an occluder
    // collapses to a segment with a zero-length edge, which the subtraction below would read
    // as covering nothing on both sides of it: the light piece was counted twice, 1.3-3x the
    // exact irradiance at the corners of every room.)
    const glm::dvec3 on = glm::cross(occ.p[1] - occ.p[0], occ.p[2] - occ.p[0]);
    const double on_len = glm::length(on);
    if (!(on_len > 0.0)) return false;  // degenerate: no area to block with
    const double size = std::sqrt(on_len);
    if (std::abs(glm::dot(x - occ.p[0], on / on_len)) <= std::max(1e-9 * size, coplanar))
        return false;
    if (!inside) {
        // Keep the part of the occluder strictly between the light plane and x:
        // r in (eps, 1 - eps)
        Polygon3 part;
        for (const auto& p : occ.p) part.push_back(p);
        part = clip_polygon(part,
                            [&](const glm::dvec3& p) { return glm::dot(p - l0, nl) / sx - kEps; });
        part = clip_polygon(
            part, [&](const glm::dvec3& p) { return (1.0 - kEps) - glm::dot(p - l0, nl) / sx; });
        if (part.size() < 3) return false;
        for (const auto& p : part) shadow.push_back(project(p, glm::dot(p - l0, nl)));
    }
    const double a2 = signed_area2(shadow);
    if (std::abs(a2) <= 1e-18 * lp.scale * lp.scale) return false;
    if (a2 < 0.0) {  // make it counter-clockwise
        Poly2 rev;
        for (std::size_t i = shadow.size(); i-- > 0;) rev.push_back(shadow[i]);
        shadow = rev;
    }
    return true;
}

// Subtracts the convex shadow (its polygon and box; letting `transmit` of the light through)
// from every piece it overlaps: those pieces are replaced by their parts outside it (and, when it
// lets light through, the part under it); the others stay where they are. `cut` is scratch. True
// when the shadow covered some piece.
bool subtract_shadow(std::vector<Piece>& pieces, const Piece& shadow_piece, double transmit,
                     std::vector<Piece>& cut) {
    const Poly2& shadow = shadow_piece.poly;
    const glm::dvec2 slo = shadow_piece.lo, shi = shadow_piece.hi;
    cut.clear();
    bool touched = false;
    std::size_t kept = 0;
    for (std::size_t i = 0; i < pieces.size(); ++i) {
        Piece& piece = pieces[i];
        if (piece.hi.x <= slo.x || piece.lo.x >= shi.x || piece.hi.y <= slo.y ||
            piece.lo.y >= shi.y) {
            if (kept != i) pieces[kept] = piece;
            ++kept;
            continue;
        }
        // A piece wholly outside one of the shadow's edges stays as it is: most pieces whose
        // box meets the shadow's do (an evaluation of a bake meets some twenty such shadows
        // and is hidden by six), and clipping them edge by edge only to put them back whole
        // was most of the exact shading's time
        bool apart = false;
        for (std::size_t k = 0; k < shadow.size() && !apart; ++k) {
            const glm::dvec2 a = shadow[k], b = shadow[(k + 1) % shadow.size()];
            if (a == b) continue;  // (an edge seen end on: no line)
            apart = std::all_of(piece.poly.begin(), piece.poly.end(),
                                [&](const glm::dvec2& v) { return left_of(a, b, v) <= 0.0; });
        }
        if (apart) {
            if (kept != i) pieces[kept] = piece;
            ++kept;
            continue;
        }
        Poly2 rest = piece.poly;
        for (std::size_t k = 0; k < shadow.size() && rest.size() >= 3; ++k) {
            const glm::dvec2 a = shadow[k], b = shadow[(k + 1) % shadow.size()];
            if (a == b) continue;
            // The part of _rest_ outside this edge is visible past the occluder
            Poly2 outside =
                clip_polygon(rest, [&](const glm::dvec2& v) { return -left_of(a, b, v); });
            if (outside.size() >= 3 && std::abs(signed_area2(outside)) > 0.0) {
                Piece p{outside, piece.weight, {}, {}};
                bound(p);
                cut.push_back(p);
            }
            rest = clip_polygon(rest, [&](const glm::dvec2& v) { return left_of(a, b, v); });
        }
        if (rest.size() >= 3 && std::abs(signed_area2(rest)) > 0.0) {
            touched = true;
            if (transmit > 0.0) {
                Piece p{rest, piece.weight * transmit, {}, {}};
                bound(p);
                cut.push_back(p);
            }
        }
    }
    pieces.resize(kept);
    pieces.insert(pieces.end(), cut.begin(), cut.end());
    return touched;
}

// The box of all pieces.
void bound_all(const std::vector<Piece>& pieces, glm::dvec2& lo, glm::dvec2& hi) {
    lo = glm::dvec2(std::numeric_limits<double>::infinity());
    hi = -lo;
    for (const Piece& p : pieces) {
        lo = glm::min(lo, p.lo);
        hi = glm::max(hi, p.hi);
    }
}

}  // namespace

double visible_form_factor(const glm::dvec3& x, const glm::dvec3& n, const Patch& light,
                           std::span<const Patch* const> occluders, VisibleStats* stats,
                           double coplanar) {
    return visible_form_factor(x, n, std::span<const glm::dvec3>(light.p), occluders, stats,
                               coplanar);
}

double visible_form_factor(const glm::dvec3& x, const glm::dvec3& n,
                           std::span<const glm::dvec3> light,
                           std::span<const Patch* const> occluders, VisibleStats* stats,
                           double coplanar) {
    // Light plane: unit normal _nl_ (front, from its first three corners), signed height _sx_
    // of x above it
    if (light.size() < 3 || light.size() > 8) return 0.0;
    const glm::dvec3 l0 = light[0];
    const glm::dvec3 area = glm::cross(light[1] - l0, light[2] - l0);
    const double area_len = glm::length(area);
    if (area_len <= 0.0) return 0.0;
    const glm::dvec3 nl = area / area_len;
    const double sx = glm::dot(x - l0, nl);
    const double scale = std::sqrt(area_len);
    if (sx <= 1e-12 * scale) return 0.0;

    // Clip the light to the point's hemisphere (strictly above its tangent plane)
    Polygon3 lit;
    for (const auto& p : light) lit.push_back(p);
    lit = clip_polygon(lit, [&](const glm::dvec3& q) { return glm::dot(q - x, n); });
    if (lit.size() < 3) return 0.0;

    // 2D frame (e1, e2) in the light plane, counter-clockwise seen from the front
    const glm::dvec3 e1 = glm::normalize(light[1] - l0);
    const LightPlane lp{l0, nl, e1, glm::cross(nl, e1), x, n, sx, scale};

    // Scratch kept by the thread: this runs hundreds of thousands of times in a bake
    thread_local std::vector<Piece> pieces, cut;
    pieces.resize(1);
    pieces[0].poly.clear();
    for (const auto& q : lit) pieces[0].poly.push_back(lp.to2(q));
    pieces[0].weight = 1.0;
    bound(pieces[0]);

    // The occluders' shadows first, then subtracted largest first: a large blocker (a table
    // top over a point under it) removes the light in one cut, and the small ones after it
    // mostly miss what is left, instead of each cutting the light into more pieces. The
    // visible part is the same whatever the order (to rounding).
    // The order is sorted as small keys (area, place in `shadows`), not as the shadows
    // themselves: a bake's evaluations meet some sixty shadows each.
    struct Order {
        double area2;
        std::uint32_t at;  // in `shadows`, made in the occluders' order
    };
    thread_local std::vector<Piece> shadows;        // the polygons and their boxes (weights unused)
    thread_local std::vector<std::uint32_t> index;  // each shadow's occluder
    thread_local std::vector<Order> order;
    shadows.clear();
    index.clear();
    order.clear();
    {
        Piece s{};
        for (std::size_t oi = 0; oi < occluders.size(); ++oi) {
            if (stats) ++stats->occluders_tested;
            if (!occluder_shadow(lp, *occluders[oi], pieces[0].lo, pieces[0].hi, coplanar, s.poly))
                continue;
            bound(s);
            order.push_back({signed_area2(s.poly), static_cast<std::uint32_t>(shadows.size())});
            index.push_back(static_cast<std::uint32_t>(oi));
            shadows.push_back(s);
        }
    }
    // (the places follow the occluders' order, so ties go in that order)
    std::sort(order.begin(), order.end(), [](const Order& a, const Order& b) {
        return a.area2 > b.area2 || (a.area2 == b.area2 && a.at < b.at);
    });

    glm::dvec2 lo = pieces[0].lo, hi = pieces[0].hi;  // box of what is left of the light
    for (const Order& o : order) {
        const Piece& shadow = shadows[o.at];
        const glm::dvec2 slo = shadow.lo, shi = shadow.hi;
        if (shi.x <= lo.x || slo.x >= hi.x || shi.y <= lo.y || slo.y >= hi.y) continue;
        const Patch* occ = occluders[index[o.at]];
        const double transmit = 1.0 - std::clamp(occ->opacity, 0.0, 1.0);
        const bool touched = subtract_shadow(pieces, shadow, transmit, cut);
        if (touched || !cut.empty()) bound_all(pieces, lo, hi);
        if (touched && stats) {
            ++stats->occluders_projected;
            if (stats->touched) stats->touched->push_back(index[o.at]);
        }
        if (pieces.empty()) break;
    }
    if (stats) stats->max_pieces = std::max(stats->max_pieces, pieces.size());

    // Sum the form factors of the visible pieces
    double ff = 0.0;
    glm::dvec3 corners[32];
    for (const Piece& piece : pieces) {
        for (std::size_t i = 0; i < piece.poly.size(); ++i) corners[i] = lp.to3(piece.poly[i]);
        ff += piece.weight * point_polygon_form_factor(x, n, {corners, piece.poly.size()});
    }
    return ff;
}

}  // namespace abrad::radiosity
