#include "abrad/radiosity/shadow_edges.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <glm/geometric.hpp>
#include <string>
#include <utility>
#include <vector>

namespace abrad::radiosity {
namespace {

using glm::dvec3;

Patch tri(dvec3 a, dvec3 b, dvec3 c, double opacity = 1.0) {
    Patch p;
    p.p[0] = a;
    p.p[1] = b;
    p.p[2] = c;
    p.opacity = opacity;
    return p;
}

// A big floor triangle at z = 0 facing up.
Patch floor_big() { return tri({-20, -20, 0}, {20, -20, 0}, {0, 20, 0}); }

// A small light triangle centred at `c` (its centroid) facing down.
Patch light_down(dvec3 c, double s = 0.1) {
    return tri(c + dvec3(-s, -s, 0), c + dvec3(0, 2 * s, 0), c + dvec3(s, -s, 0));
}

// Central projection of v from L onto the floor z = 0 (similar triangles).
dvec3 proj(dvec3 L, dvec3 v) { return L + (v - L) * (L.z / (L.z - v.z)); }

std::vector<ShadowSegment> cast(const Patch& light, LightModel model, const Patch& receiver,
                                const std::vector<Patch>& occ, ShadowStats* stats = nullptr,
                                const EmitterEdges& emitter = {}) {
    std::vector<const Patch*> ptr;
    for (const auto& o : occ) ptr.push_back(&o);
    return shadow_edges(light, model, receiver, ptr, 1e-9, stats, emitter);
}

bool near(dvec3 a, dvec3 b, double tol) { return glm::length(a - b) <= tol; }

// Number of segments equal to a-b in either direction.
int count_segment(const std::vector<ShadowSegment>& s, dvec3 a, dvec3 b, double tol) {
    int n = 0;
    for (const auto& g : s)
        n += (near(g.a, a, tol) && near(g.b, b, tol)) || (near(g.a, b, tol) && near(g.b, a, tol));
    return n;
}

std::string fmt(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.17g", v);
    return buf;
}

std::string dump(const std::vector<ShadowSegment>& s) {
    std::string out;
    for (const auto& g : s) {
        out += "(" + fmt(g.a.x) + "," + fmt(g.a.y) + "," + fmt(g.a.z) + ")-(" + fmt(g.b.x) + "," +
               fmt(g.b.y) + "," + fmt(g.b.z) + ")\n";
    }
    return out;
}

void expect_finite_in_plane(const std::vector<ShadowSegment>& s) {
    for (const auto& g : s) {
        for (const dvec3& p : {g.a, g.b}) {
            EXPECT_TRUE(std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z));
            EXPECT_NEAR(p.z, 0.0, 1e-12);
        }
        EXPECT_GT(glm::length(g.b - g.a), 1e-9);
    }
}

TEST(ShadowEdges, LightModelNames) {
    for (LightModel m : {LightModel::Centroid, LightModel::Vertices, LightModel::Area})
        EXPECT_EQ(parse_light_model(to_string(m)), m);
    EXPECT_FALSE(parse_light_model("sphere").has_value());
}

TEST(ShadowEdges, ParallelTriangleProjectsCentrally) {
    const dvec3 L(0.3, -0.2, 3.0);
    const dvec3 v[3] = {{0.2, 0.1, 1}, {0.6, 0.1, 1}, {0.3, 0.5, 1}};
    ShadowStats st;
    const auto s =
        cast(light_down(L), LightModel::Centroid, floor_big(), {tri(v[0], v[1], v[2])}, &st);
    ASSERT_EQ(s.size(), 3u) << dump(s);
    // By hand: scale L.z / (L.z - 1) = 1.5 about L
    EXPECT_EQ(count_segment(s, {0.15, 0.25, 0}, {0.75, 0.25, 0}, 1e-6), 1) << dump(s);
    EXPECT_EQ(count_segment(s, {0.75, 0.25, 0}, {0.3, 0.85, 0}, 1e-6), 1) << dump(s);
    EXPECT_EQ(count_segment(s, {0.3, 0.85, 0}, {0.15, 0.25, 0}, 1e-6), 1) << dump(s);
    EXPECT_EQ(st.edges_projected, 3u);
    EXPECT_EQ(st.segments, 3u);
    expect_finite_in_plane(s);
}

TEST(ShadowEdges, ClippedToReceiverBoundary) {
    // Receiver: the right triangle x, y >= 0, x + y <= 2 at z = 0
    const Patch receiver = tri({0, 0, 0}, {2, 0, 0}, {0, 2, 0});
    const dvec3 L(0, 0, 4);
    // Occluder at z = 2 (scale 2): projects to (-1, 0.5), (1.5, 0.5), (0.5, 1.5)... shifted
    const dvec3 a(-0.5, 0.25, 2), b(0.75, 0.25, 2), c(0.25, 0.5, 2);
    const auto s = cast(light_down(L), LightModel::Centroid, receiver, {tri(a, b, c)});
    expect_finite_in_plane(s);
    // Edge a-b projects to y = 0.5, x in [-1, 1.5]: clipped at x = 0
    EXPECT_EQ(count_segment(s, {0, 0.5, 0}, {1.5, 0.5, 0}, 1e-9), 1) << dump(s);
    // Edge c-a projects to (0.5, 1) - (-1, 0.5): crosses x = 0 at y = 0.5 + 1/3 (by hand)
    EXPECT_EQ(count_segment(s, {0, 0.5 + 1.0 / 3.0, 0}, {0.5, 1, 0}, 1e-9), 1) << dump(s);
    // Edge b-c: (1.5, 0.5) - (0.5, 1), inside
    EXPECT_EQ(count_segment(s, {1.5, 0.5, 0}, {0.5, 1, 0}, 1e-9), 1) << dump(s);
    for (const auto& g : s)
        for (const dvec3& p : {g.a, g.b}) {
            EXPECT_GE(p.x, -1e-12);
            EXPECT_GE(p.y, -1e-12);
            EXPECT_LE(p.x + p.y, 2 + 1e-12);
        }
    EXPECT_EQ(s.size(), 3u) << dump(s);

    // Completely outside the receiver: nothing
    const auto none = cast(light_down(L), LightModel::Centroid, receiver,
                           {tri({-2, -2, 2}, {-1.5, -2, 2}, {-1.5, -1.5, 2})});
    EXPECT_TRUE(none.empty()) << dump(none);
}

TEST(ShadowEdges, FlatQuadSharedDiagonalIsNoSilhouette) {
    const dvec3 L(0, 0, 4);
    const dvec3 q0(-0.5, -0.5, 2), q1(0.5, -0.5, 2), q2(0.5, 0.5, 2), q3(-0.5, 0.5, 2);
    ShadowStats st;
    const auto s = cast(light_down(L), LightModel::Centroid, floor_big(),
                        {tri(q0, q1, q2), tri(q0, q2, q3)}, &st);
    ASSERT_EQ(s.size(), 4u) << dump(s);
    EXPECT_EQ(st.shared_edges_skipped, 1u);
    EXPECT_EQ(count_segment(s, {-1, -1, 0}, {1, -1, 0}, 1e-9), 1);
    EXPECT_EQ(count_segment(s, {1, -1, 0}, {1, 1, 0}, 1e-9), 1);
    EXPECT_EQ(count_segment(s, {1, 1, 0}, {-1, 1, 0}, 1e-9), 1);
    EXPECT_EQ(count_segment(s, {-1, 1, 0}, {-1, -1, 0}, 1e-9), 1);

    // The same quad folded along the diagonal (a roof seen from above on one side): the
    // diagonal is a silhouette only when both faces lie on one side of it from L
    ShadowStats folded;
    const auto f = cast(light_down({3, 3, 4}), LightModel::Centroid, floor_big(),
                        {tri(q0, q1, q2), tri(q0, q2, {0.5, -0.5, 0.5})}, &folded);
    EXPECT_EQ(folded.shared_edges_skipped, 0u) << dump(f);
}

// Occluder 1 at z = 2 with an edge along y = 0, x in [-1, 1]: from L = (0, 0, 4) it projects
// to x in [-2, 2]. Occluder 2 at z = 3 covers x in [-0.1, 0.1] on the line y = 0 (its
// hypotenuse x + 0.4 y = 0.1 crosses y = 0 at x = 0.1), so it hides X in [-0.4, 0.4].
std::vector<Patch> two_layers(double alpha2) {
    return {tri({-1, 0, 2}, {1, 0, 2}, {0, 1, 2}),
            tri({-0.1, -0.5, 3}, {0.3, -0.5, 3}, {-0.1, 0.5, 3}, alpha2)};
}

std::vector<ShadowSegment> on_line_y0(const std::vector<ShadowSegment>& s) {
    std::vector<ShadowSegment> out;
    for (const auto& g : s)
        if (std::abs(g.a.y) < 1e-9 && std::abs(g.b.y) < 1e-9) out.push_back(g);
    return out;
}

TEST(ShadowEdges, OpaqueOccluderInFrontCutsEdge) {
    ShadowStats st;
    const auto s =
        cast(light_down({0, 0, 4}), LightModel::Centroid, floor_big(), two_layers(1.0), &st);
    expect_finite_in_plane(s);
    const auto y0 = on_line_y0(s);
    ASSERT_EQ(y0.size(), 2u) << dump(s);
    EXPECT_EQ(count_segment(y0, {-2, 0, 0}, {-0.4, 0, 0}, 1e-9), 1) << dump(s);
    EXPECT_EQ(count_segment(y0, {0.4, 0, 0}, {2, 0, 0}, 1e-9), 1) << dump(s);
    // Occluder 2 (projected: (-0.4, -2), (1.2, -2), (-0.4, 2)) cuts occluder 1's edges on
    // y = 0 and from (-2, 0) to (0, 2); occluder 1 (shadow (-2, 0), (2, 0), (0, 2)) cuts
    // occluder 2's two edges that cross its shadow
    EXPECT_EQ(st.segments_split, 4u);
    // Occluder 2's edge at y = -0.5 projects (scale 4) to y = -2, x in [-0.4, 1.2], uncut
    EXPECT_EQ(count_segment(s, {-0.4, -2, 0}, {1.2, -2, 0}, 1e-9), 1) << dump(s);
}

TEST(ShadowEdges, TranslucentOccluderDoesNotCut) {
    ShadowStats st;
    const auto s =
        cast(light_down({0, 0, 4}), LightModel::Centroid, floor_big(), two_layers(0.5), &st);
    const auto y0 = on_line_y0(s);
    ASSERT_EQ(y0.size(), 1u) << dump(s);
    EXPECT_EQ(count_segment(y0, {-2, 0, 0}, {2, 0, 0}, 1e-9), 1) << dump(s);
    // Only opaque occluder 1 cuts: occluder 2's two edges crossing its shadow
    EXPECT_EQ(st.segments_split, 2u);
}

TEST(ShadowEdges, VerticesAndAreaModels) {
    const Patch light = light_down({0.3, -0.2, 3.0}, 0.2);
    // No occluder edge parallel to a light edge (their events would be collinear)
    const dvec3 v[3] = {{0.2, 0.1, 1}, {0.6, 0.2, 1}, {0.3, 0.5, 1}};
    const std::vector<Patch> occ{tri(v[0], v[1], v[2])};

    const auto s = cast(light, LightModel::Vertices, floor_big(), occ);
    ASSERT_EQ(s.size(), 9u) << dump(s);
    for (const dvec3& L : light.p)
        for (int e = 0; e < 3; ++e)
            EXPECT_EQ(count_segment(s, proj(L, v[e]), proj(L, v[(e + 1) % 3]), 1e-9), 1) << dump(s);
    // One by hand: from (0.1, -0.4, 3) the scale is 1.5: (0.2, 0.1) -> (0.25, 0.35)
    EXPECT_EQ(count_segment(s, {0.25, 0.35, 0}, {0.85, 0.5, 0}, 1e-9), 1) << dump(s);

    // Area: plus one VE segment per light edge and occluder vertex, proj_a(v) to proj_b(v)
    const auto area = cast(light, LightModel::Area, floor_big(), occ);
    ASSERT_EQ(area.size(), 18u) << dump(area);
    for (int e = 0; e < 3; ++e)
        for (const dvec3& w : v)
            EXPECT_EQ(count_segment(area, proj(light.p[e], w), proj(light.p[(e + 1) % 3], w), 1e-9),
                      1)
                << dump(area);
    // By hand: light edge (0.1, -0.4, 3) - (0.3, 0.2, 3), vertex (0.2, 0.1, 1)
    EXPECT_EQ(count_segment(area, {0.25, 0.35, 0}, {0.15, 0.05, 0}, 1e-9), 1) << dump(area);
}

TEST(ShadowEdges, PanelDiagonalCastsNothing) {
    // A 1 x 1 m panel at z = 3 facing down, made of two triangles that share the diagonal
    // a-b; a plate at z = 1. The panel's light is continuous across its diagonal, so no wedge
    // through the diagonal and a plate vertex may give a segment once the diagonal is marked
    // interior; unmarked, those wedges are cast (per triangle, the diagonal is an edge).
    const dvec3 a{-0.5, -0.5, 3}, b{0.5, 0.5, 3};
    const Patch first = tri(a, {-0.5, 0.5, 3}, b);   // edge 2 is b-a
    const Patch second = tri(a, b, {0.5, -0.5, 3});  // edge 0 is a-b
    const dvec3 v[4] = {{0.13, -0.21, 1}, {0.71, -0.17, 1}, {0.67, 0.38, 1}, {0.09, 0.33, 1}};
    const std::vector<Patch> occ{tri(v[0], v[1], v[2]), tri(v[0], v[2], v[3])};
    const auto on_diagonal_wedge = [&](const std::vector<ShadowSegment>& s) {
        int n = 0;
        for (const dvec3& w : v) {
            const dvec3 nw = glm::normalize(glm::cross(b - a, w - a));
            for (const auto& g : s)
                n += std::abs(glm::dot(g.a - a, nw)) < 1e-9 &&
                     std::abs(glm::dot(g.b - a, nw)) < 1e-9;
        }
        return n;
    };
    std::vector<ShadowSegment> plain, marked;
    for (const auto& [light, diagonal] : {std::pair{first, 2}, std::pair{second, 0}}) {
        for (const auto& g : cast(light, LightModel::Area, floor_big(), occ)) plain.push_back(g);
        EmitterEdges emitter;
        emitter.interior[static_cast<std::size_t>(diagonal)] = true;
        for (const auto& g : cast(light, LightModel::Area, floor_big(), occ, nullptr, emitter))
            marked.push_back(g);
    }
    EXPECT_GE(on_diagonal_wedge(plain), 4) << dump(plain);
    EXPECT_EQ(on_diagonal_wedge(marked), 0) << dump(marked);
    // The panel's own corners and boundary edges still cast theirs: every segment kept is one
    // the unmarked triangles cast too
    EXPECT_LT(marked.size(), plain.size());
    for (const auto& g : marked) EXPECT_GE(count_segment(plain, g.a, g.b, 1e-9), 1) << dump(marked);
}

TEST(ShadowEdges, CornerInsideAnEmitterCastsNothing) {
    // A fan around the centre c of a disc-like emitter: the corner c of this triangle has both
    // its edges inside the emitter, so it is no corner of the emitter and casts no EV event
    const dvec3 c{0, 0, 3};
    const Patch light = tri(c, {0.3, -0.5, 3}, {-0.3, -0.5, 3});  // faces down; c is corner 0
    const std::vector<Patch> occ{tri({0.2, 0.1, 1}, {0.6, 0.2, 1}, {0.3, 0.5, 1})};
    EmitterEdges emitter;
    emitter.interior = {true, false, true};  // edges c-p1 and p2-c
    ASSERT_TRUE(emitter.corner_inside(0));
    const auto s = cast(light, LightModel::Vertices, floor_big(), occ, nullptr, emitter);
    ASSERT_EQ(s.size(), 6u) << dump(s);  // three occluder edges from each of p1 and p2
    for (int e = 0; e < 3; ++e)
        EXPECT_EQ(count_segment(s, proj(c, occ[0].p[e]), proj(c, occ[0].p[(e + 1) % 3]), 1e-9), 0)
            << dump(s);
}

TEST(ShadowEdges, VeWedgeCutByOpaqueOccluder) {
    // Light edge a-b along x at z = 4; vertex v = (0, 0, 2) of occluder 1: the VE segment runs
    // from proj_a(v) to proj_b(v), i.e. x in [-1, 1] on y = 0 for a = (1, 0, 4), b = (-1, 0, 4).
    // normal -z; the third vertex off the axes so that no other event lies on y = 0
    const Patch light = tri({1, 0, 4}, {-1, 0, 4}, {0.3, 2.2, 4});
    const std::vector<Patch> occ{
        tri({0, 0, 2}, {0.001, 1, 2}, {-0.001, 1, 2}),
        // A blocker at z = 1 over x in [0.2, 0.6] crossing y = 0: chords from v to (X, 0, 0)
        // pass (X/2, 0, 1), hidden for X in [0.4, 1.2] -> the VE part x in [0.4, 1] is gone.
        tri({0.2, -0.5, 1}, {0.6, -0.5, 1}, {0.6, 0.5, 1}),
        tri({0.2, -0.5, 1}, {0.6, 0.5, 1}, {0.2, 0.5, 1}),
    };
    const auto s = cast(light, LightModel::Area, floor_big(), occ);
    expect_finite_in_plane(s);
    // The VE trace on y = 0 from the light edge (1,0,4)-(-1,0,4) through v
    EXPECT_EQ(count_segment(s, {-1, 0, 0}, {0.4, 0, 0}, 1e-9), 1) << dump(s);
    for (const auto& g : on_line_y0(s))
        EXPECT_FALSE(g.a.x > 0.4 + 1e-9 && g.b.x > 0.4 + 1e-9) << dump(s);
}

TEST(ShadowEdges, ContactShadowStartsAtFoot) {
    // A vertical quad x in [0, 1], z in [0, 1] in the plane y = 0 standing on the floor
    const dvec3 L(0.5, -2, 3);
    const std::vector<Patch> quad{tri({0, 0, 0}, {1, 0, 0}, {1, 0, 1}),
                                  tri({0, 0, 0}, {1, 0, 1}, {0, 0, 1})};
    const auto s = cast(light_down(L), LightModel::Centroid, floor_big(), quad);
    expect_finite_in_plane(s);
    ASSERT_EQ(s.size(), 3u) << dump(s);
    // Top corners (x, 0, 1) project (scale 1.5 about L) to (0.5 + 1.5 (x - 0.5), 1, 0)
    EXPECT_EQ(count_segment(s, {0, 0, 0}, {-0.25, 1, 0}, 1e-9), 1) << dump(s);
    EXPECT_EQ(count_segment(s, {1, 0, 0}, {1.25, 1, 0}, 1e-9), 1) << dump(s);
    EXPECT_EQ(count_segment(s, {-0.25, 1, 0}, {1.25, 1, 0}, 1e-9), 1) << dump(s);
}

// The unit cube [0, 1]³ on the floor, two triangles a face (bottom included).
std::vector<Patch> unit_box() {
    std::vector<Patch> b;
    auto quad = [&](dvec3 p0, dvec3 p1, dvec3 p2, dvec3 p3) {
        b.push_back(tri(p0, p1, p2));
        b.push_back(tri(p0, p2, p3));
    };
    const dvec3 c[8] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0},
                        {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
    quad(c[0], c[3], c[2], c[1]);  // bottom
    quad(c[4], c[5], c[6], c[7]);  // top
    quad(c[0], c[1], c[5], c[4]);  // y = 0
    quad(c[1], c[2], c[6], c[5]);  // x = 1
    quad(c[2], c[3], c[7], c[6]);  // y = 1
    quad(c[3], c[0], c[4], c[7]);  // x = 0
    return b;
}

TEST(ShadowEdges, BoxOnFloorCastsItsSilhouette) {
    // From L = (3, 2, 4) the silhouette is the top edges at x = 0 and y = 0 and the vertical
    // edges (1, 0, z) and (0, 1, z); top corners project with scale 4/3 about L.
    const dvec3 L(3, 2, 4);
    ShadowStats st;
    const auto s = cast(light_down(L), LightModel::Centroid, floor_big(), unit_box(), &st);
    expect_finite_in_plane(s);
    ASSERT_EQ(s.size(), 4u) << dump(s);
    const dvec3 p100(1.0 / 3.0, -2.0 / 3.0, 0), p000(-1, -2.0 / 3.0, 0), p010(-1, 2.0 / 3.0, 0);
    EXPECT_EQ(count_segment(s, {1, 0, 0}, p100, 1e-9), 1) << dump(s);
    EXPECT_EQ(count_segment(s, p100, p000, 1e-9), 1) << dump(s);
    EXPECT_EQ(count_segment(s, p000, p010, 1e-9), 1) << dump(s);
    EXPECT_EQ(count_segment(s, p010, {0, 1, 0}, 1e-9), 1) << dump(s);
    // 5 face diagonals and 4 edges between two lit or two unlit faces are no silhouette
    EXPECT_EQ(st.shared_edges_skipped, 9u);
}

// Segments have no duplicates and stay inside the receiver triangle.
void expect_clean(const std::vector<ShadowSegment>& s, const Patch& receiver) {
    const dvec3 n =
        glm::normalize(glm::cross(receiver.p[1] - receiver.p[0], receiver.p[2] - receiver.p[0]));
    for (std::size_t i = 0; i < s.size(); ++i) {
        for (const dvec3& p : {s[i].a, s[i].b}) {
            ASSERT_TRUE(std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z));
            EXPECT_NEAR(glm::dot(p - receiver.p[0], n), 0.0, 1e-9);
            for (int e = 0; e < 3; ++e) {
                const dvec3 a = receiver.p[e], b = receiver.p[(e + 1) % 3];
                EXPECT_GE(glm::dot(glm::cross(b - a, p - a), n), -1e-9);
            }
        }
        EXPECT_GT(glm::length(s[i].b - s[i].a), 1e-9);
        for (std::size_t j = 0; j < i; ++j)
            EXPECT_EQ(count_segment({s[j]}, s[i].a, s[i].b, 1e-9), 0) << i << " " << j;
    }
}

TEST(ShadowEdges, BoxFootprintGetsNoEdgesFromAreaLight) {
    // Under the box no light point is visible: any edge there would be a missed cut
    const Patch light = light_down({2.5, 1.5, 4}, 0.4);
    for (LightModel m : {LightModel::Centroid, LightModel::Vertices, LightModel::Area}) {
        ShadowStats st;
        const auto s = cast(light, m, floor_big(), unit_box(), &st);
        expect_clean(s, floor_big());
        EXPECT_GT(s.size(), 3u);
        for (const auto& g : s) {
            const dvec3 mid = 0.5 * (g.a + g.b);
            EXPECT_FALSE(mid.x > 1e-6 && mid.x < 1 - 1e-6 && mid.y > 1e-6 && mid.y < 1 - 1e-6)
                << to_string(m) << " " << fmt(g.a.x) << "," << fmt(g.a.y) << " - " << fmt(g.b.x)
                << "," << fmt(g.b.y) << "\n"
                << dump(s);
        }
    }
}

TEST(ShadowEdges, ManyRandomOccludersStayCleanAndFast) {
    // Deterministic pseudo-random triangles between a light and a floor receiver
    std::uint64_t state = 12345;
    auto rnd = [&] {
        state = state * 6364136223846793005ull + 1442695040888963407ull;
        return static_cast<double>(state >> 11) * 0x1.0p-53;
    };
    std::vector<Patch> occ;
    for (int i = 0; i < 150; ++i) {
        const dvec3 c(rnd() * 4 - 2, rnd() * 4 - 2, rnd() * 3.5 - 0.25);
        occ.push_back(tri(c, c + dvec3(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5),
                          c + dvec3(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5),
                          rnd() < 0.7 ? 1.0 : 0.5));
    }
    const Patch receiver = tri({-3, -3, 0}, {3, -3, 0}, {0, 3, 0});
    const Patch light = light_down({0.2, 0.1, 3}, 0.3);
    for (LightModel m : {LightModel::Centroid, LightModel::Vertices, LightModel::Area}) {
        ShadowStats st;
        const auto s = cast(light, m, receiver, occ, &st);
        EXPECT_EQ(st.segments, s.size());
        EXPECT_GT(s.size(), 10u);
        EXPECT_GT(st.segments_split, 0u);
        expect_clean(s, receiver);
    }
}

TEST(ShadowEdges, EdgePointingAtLightProjectsToPoint) {
    // From L = (0, 0, 4), (1, 0, 2) and (0.5, 0, 3) both project to (2, 0, 0); the triangle's
    // plane contains L, so its other two edges both project to (2, 0, 0) - (2, 2, 0).
    const auto s = cast(light_down({0, 0, 4}), LightModel::Centroid, floor_big(),
                        {tri({1, 0, 2}, {0.5, 0, 3}, {1, 1, 2})});
    expect_finite_in_plane(s);
    ASSERT_EQ(s.size(), 1u) << dump(s);
    EXPECT_EQ(count_segment(s, {2, 0, 0}, {2, 2, 0}, 1e-9), 1) << dump(s);
}

TEST(ShadowEdges, EdgeParallelToTiltedLightPlane) {
    // A light tilted about x (normal (0, -s, -c)) and an occluder edge parallel to its plane
    const double c = std::cos(0.5), sn = std::sin(0.5);
    const dvec3 L(0, 1, 4), t(1, 0, 0), u(0, c, -sn);  // u in the light plane, t too
    const Patch light = tri(L - 0.1 * t - 0.1 * u, L + 0.2 * u, L + 0.1 * t - 0.1 * u);
    const dvec3 n = glm::cross(light.p[1] - light.p[0], light.p[2] - light.p[0]);
    ASSERT_LT(n.z, 0.0);
    // Centroid is L; the occluder edge from (-0.5, 0.5, 2) along u
    const dvec3 a(-0.5, 0.5, 2), b = a + 0.5 * u;
    const auto s = cast(light, LightModel::Centroid, floor_big(), {tri(a, b, {0.3, 0.6, 2.1})});
    expect_finite_in_plane(s);
    EXPECT_EQ(count_segment(s, proj(L, a), proj(L, b), 1e-9), 1) << dump(s);
    EXPECT_EQ(s.size(), 3u) << dump(s);
}

TEST(ShadowEdges, NothingWhenOutOfTheSlabOrFacingAway) {
    const Patch light = light_down({0, 0, 4});
    const Patch occ = tri({-0.5, -0.5, 2}, {0.5, -0.5, 2}, {0, 0.5, 2});
    // Occluder below the receiver and above the light
    EXPECT_TRUE(cast(light, LightModel::Area, floor_big(),
                     {tri({-0.5, -0.5, -1}, {0.5, -0.5, -1}, {0, 0.5, -1})})
                    .empty());
    EXPECT_TRUE(cast(light, LightModel::Area, floor_big(),
                     {tri({-0.5, -0.5, 5}, {0.5, -0.5, 5}, {0, 0.5, 5})})
                    .empty());
    // Receiver facing away from the light (clockwise from above)
    const Patch down = tri({-20, -20, 0}, {0, 20, 0}, {20, -20, 0});
    EXPECT_TRUE(cast(light, LightModel::Area, down, {occ}).empty());
    // Light facing away from the receiver (emits upwards)
    const Patch up = tri({-0.1, -0.1, 4}, {0.1, -0.1, 4}, {0, 0.2, 4});
    EXPECT_TRUE(cast(up, LightModel::Area, floor_big(), {occ}).empty());
    // Light behind the receiver's plane (below the floor, facing up): nothing
    const Patch below = tri({-0.1, -0.1, -4}, {0.1, -0.1, -4}, {0, 0.2, -4});
    EXPECT_TRUE(cast(below, LightModel::Area, floor_big(),
                     {tri({-0.5, -0.5, -2}, {0.5, -0.5, -2}, {0, 0.5, -2})})
                    .empty());
    // Occluder lying in the receiver's plane
    EXPECT_TRUE(cast(light, LightModel::Area, floor_big(),
                     {tri({-0.5, -0.5, 0}, {0.5, -0.5, 0}, {0, 0.5, 0})})
                    .empty());
}

TEST(ShadowEdges, IgnoresReceiverLightAndDuplicates) {
    const Patch light = light_down({0, 0, 4});
    const Patch receiver = floor_big();
    const Patch occ = tri({-0.5, -0.4, 2}, {0.5, -0.6, 2}, {0, 0.5, 2});
    const auto once = cast(light, LightModel::Vertices, receiver, {occ});
    ASSERT_EQ(once.size(), 9u) << dump(once);
    // The receiver and the light in the list (in another vertex order), and the occluder twice
    const Patch receiver2 = tri(receiver.p[1], receiver.p[2], receiver.p[0]);
    const Patch light2 = tri(light.p[2], light.p[0], light.p[1]);
    const auto again = cast(light, LightModel::Vertices, receiver, {occ, receiver2, light2, occ});
    EXPECT_EQ(again.size(), 9u) << dump(again);
}

// How far the light departs from linear across a shadow segment (shadow_contrast), against
// the light there: a 0.4 m square half way under a 0.2 m light triangle at 1.5 m has a hard
// umbra edge (within 5 cm of it the light departs from linear by a good part of its value), a
// 2 mm square hides at most 0.05 % of the light: the departure is the light's own smooth
// fall-off over ±5 cm, under 0.3 % of it (a 1 cm square hides 1.3 % of this small light and
// departs by 0.9 %). The bake's criterion (shadow_contrast 0.02 of the refinement's
// tolerance, 0.1 % of the light) is tested on a bake: DmBake.OnlyAStrongOccluderCastsMeshEdges.
TEST(ShadowEdges, ContrastOfAStrongAndATinyOccluder) {
    const Patch light = light_down({0, 0, 1.5});
    const Patch floor = floor_big();
    const Patch* lights[1] = {&light};
    constexpr double kStrong = 0.1, kTiny = 3e-3;
    for (const double half : {0.2, 0.001}) {
        const std::vector<Patch> occ = {
            tri({-half, -half, 0.75}, {half, -half, 0.75}, {half, half, 0.75}),
            tri({-half, -half, 0.75}, {half, half, 0.75}, {-half, half, 0.75})};
        std::vector<const Patch*> ptr;
        ptr.reserve(occ.size());
        for (const Patch& o : occ) ptr.push_back(&o);
        const std::vector<ShadowSegment> segments = cast(light, LightModel::Vertices, floor, occ);
        ASSERT_FALSE(segments.empty()) << half;
        double lowest = 1.0, highest = 0.0;
        for (const ShadowSegment& s : segments) {
            const ShadowContrast c = shadow_contrast(lights, floor, ptr, s, 0.05);
            ASSERT_GT(c.level, 0.0);
            lowest = std::min(lowest, c.change / c.level);
            highest = std::max(highest, c.change / c.level);
        }
        if (half > 0.1) {
            EXPECT_GT(highest, kStrong) << dump(segments);
            EXPECT_GT(lowest, kTiny) << dump(segments);
        } else {
            EXPECT_LT(highest, kTiny) << dump(segments);
        }
    }
}

}  // namespace
}  // namespace abrad::radiosity
