#pragma once
// Shadow edges (Wang et al., "Using A-Buffer in Radiosity", Algorithm 3, ProjectShadowEdge;
// docs/algorithms.md#shadow-edges): occluder edges projected from points of a light onto a
// receiver triangle's plane, clipped to the receiver, with the parts hidden by other opaque
// occluders removed (translucent occluders let them pass).

#include <array>
#include <cstdint>
#include <glm/vec3.hpp>
#include <limits>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "abrad/radiosity/shoot.h"

namespace abrad::radiosity {

/// How a light-source triangle is modelled when casting shadow edges.
enum class LightModel {
    Centroid,  ///< one point light at the centroid: hard shadow edges
    Vertices,  ///< a point light at each vertex: umbra and penumbra boundaries (EV events)
    Area,      ///< Vertices plus the wedges through each light edge and occluder vertex (VE events)
};

std::string to_string(LightModel model);
std::optional<LightModel> parse_light_model(std::string_view text);

/// One shadow edge on a receiver: a segment in the receiver's plane, inside the receiver.
struct ShadowSegment {
    glm::dvec3 a, b;
};

struct ShadowStats {
    std::size_t edges_projected = 0;  ///< occluder edge × light point projections made
    std::size_t shared_edges_skipped =
        0;                           ///< shared edges that are no silhouette from the light point
    std::size_t segments_split = 0;  ///< segments cut by an opaque occluder in front of them
    std::size_t segments = 0;        ///< segments returned
    ShadowStats& operator+=(const ShadowStats& o);
};

/// Which edges of a light triangle lie inside its emitter: edge e (from p[e] to p[e+1]) is
/// interior when another triangle of the same uniform, planar emitter shares it (the two
/// triangles of a rectangular panel share their diagonal). The emitter's light is continuous
/// across such an edge, so it casts no shadow edge: no VE wedge along it, and no EV event from
/// a corner whose two edges in this triangle are both interior (that corner is inside the
/// emitter, or another triangle of the emitter, with a boundary edge there, casts the same
/// events).
struct EmitterEdges {
    std::array<bool, 3> interior{false, false, false};
    bool corner_inside(int k) const {
        return interior[static_cast<std::size_t>((k + 2) % 3)] &&
               interior[static_cast<std::size_t>(k)];
    }
};

/// The shadow edges that `occluders` cast on `receiver` from `light` (front faces
/// counter-clockwise; the light emits from its front). Only the part of the receiver in
/// front of the light and facing it is considered. An occluder edge shared by two occluders
/// is projected once, and not at all when it is no silhouette from the light point (its two
/// faces, of the same opacity, lie on opposite sides of the plane through the light point and
/// the edge). Segments shorter than `min_length` metres are dropped.
std::vector<ShadowSegment> shadow_edges(const Patch& light, LightModel model, const Patch& receiver,
                                        std::span<const Patch* const> occluders,
                                        double min_length = 1e-9, ShadowStats* stats = nullptr,
                                        const EmitterEdges& emitter = {});

/// The shadow edges that `occluders` cast on `receiver` from a point source at `source` (a
/// luminaire): the central projection from the point of the occluders' silhouette edges (the
/// VE wedge through the point and each edge), clipped to the receiver, with the parts hidden
/// by other opaque occluders removed; and the contact edges, where an occluder face standing
/// on the receiver's plane meets it (a box on a floor: the light stops there whatever the
/// point's place). Shared edges and `min_length` as shadow_edges; the caller checks that the
/// receiver faces the point.
/// How much an emitter's visible light departs from linear across a shadow segment on
/// `receiver`, at the length `delta` (metres, the finest the mesh will resolve). F(x) is the
/// form factor from the receiver's plane at x to the parts of the emitter's triangles `lights`
/// seen past `occluders`, summed (the triangles of a panel cast the same lines from their
/// shared corners). On the lines across the segment (m: its unit normal in the receiver's
/// plane) through its middle and its ends x: the largest departure of F(x + tδm) at t = 0,
/// ±1/2 from the straight line between F(x − δm) and F(x + δm) (the refinement's test on an
/// edge of 2δ across the segment; a step of J across it shows as J/4, a shadow narrower than δ
/// as its depth), and the largest F there. A hard edge departs by a good part of the
/// emitter's value; a weak, distant or tiny occluder's edge (a wide, shallow penumbra) by a
/// small part of it, and a smooth fall-off not at all. Stops at the first point where the
/// departure reaches `enough` (the caller's decision is then made).
struct ShadowContrast {
    double change = 0.0;  ///< largest departure of F from linear across the segment
    double level = 0.0;   ///< largest F there
};
ShadowContrast shadow_contrast(std::span<const Patch* const> lights, const Patch& receiver,
                               std::span<const Patch* const> occluders,
                               const ShadowSegment& segment, double delta,
                               double enough = std::numeric_limits<double>::infinity());

std::vector<ShadowSegment> point_shadow_edges(const glm::dvec3& source, const Patch& receiver,
                                              std::span<const Patch* const> occluders,
                                              double min_length = 1e-9,
                                              ShadowStats* stats = nullptr);

}  // namespace abrad::radiosity
