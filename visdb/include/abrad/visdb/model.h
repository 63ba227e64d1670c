#pragma once
// The scene model of the visual database: plain C++ types, free of SQLite, Assimp and CGAL.
//
// Units: lengths in metres, emittance (radiant exitance) in W/m², irradiance in W/m²,
// reflectance and opacity dimensionless. Frame: right-handed, Z up. A triangle's front is
// counter-clockwise (right-hand normal).

#include <cmath>
#include <cstdint>
#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <glm/trigonometric.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "abrad/visdb/bake_stats.h"
#include "abrad/visdb/photometry.h"

namespace abrad::visdb {

/// Linear radiometric RGB triple.
using Rgb = glm::dvec3;

/// Luminance Y of linear Rec. 709 RGB: 0.2126 R + 0.7152 G + 0.0722 B (the one set of
/// weights: photometric scenes, tone mapping, grids and false colour use it).
template <class Vec3>
constexpr double luminance(const Vec3& c) {
    return 0.2126 * static_cast<double>(c.x) + 0.7152 * static_cast<double>(c.y) +
           0.0722 * static_cast<double>(c.z);
}

/// Mean of the three channels (powers and energies summed over RGB report this).
inline double channel_mean(const Rgb& c) { return (c.x + c.y + c.z) / 3.0; }

/// True iff some channel is positive (an emittance that makes a light source).
inline bool any_positive(const Rgb& c) { return c.x > 0.0 || c.y > 0.0 || c.z > 0.0; }

/// The origin of the local frame that single-precision and tolerance-sensitive work uses
/// (the bake's hemicubes and mesher, glTF and POV-Ray vertices): the centre of the points'
/// bounding box rounded to whole metres when that lies 1 km or more from the origin, else
/// zero. Subtracting it from survey coordinates (1e6 m) is exact (Sterbenz) and leaves
/// coordinates of the building's own size; near the origin the scene's frame is already local
/// (and bakes stay bit-identical to those of a scene given there). The one policy, here for a
/// bounding box [lo, hi] (lo.x > hi.x: empty, zero).
inline glm::dvec3 local_origin(const glm::dvec3& lo, const glm::dvec3& hi) {
    if (!(lo.x <= hi.x)) return glm::dvec3{0.0};  // no points
    const glm::dvec3 origin = glm::round(0.5 * (lo + hi));
    return glm::length(origin) < 1e3 ? glm::dvec3{0.0} : origin;
}

/// Grows the box [lo, hi] to hold `points`.
template <class Points>
void grow_box(const Points& points, glm::dvec3& lo, glm::dvec3& hi) {
    for (const glm::dvec3& p : points) {
        lo = glm::min(lo, p);
        hi = glm::max(hi, p);
    }
}

/// local_origin of the bounding box of `points`.
template <class Points>
glm::dvec3 local_origin(const Points& points) {
    glm::dvec3 lo{std::numeric_limits<double>::max()};
    glm::dvec3 hi{std::numeric_limits<double>::lowest()};
    grow_box(points, lo, hi);
    return local_origin(lo, hi);
}

/// Two unit vectors u, v with (u, v, n) a right-handed orthonormal frame around the unit
/// vector `n`: u is the world axis least aligned with n (x before y before z on ties) crossed
/// with n, normalised; v = n × u. The one rule for frames of a plane (the mesher, polygon
/// triangulation, shadow-edge fans). Two frames keep rules of their own, for a reason: the
/// hemicube's (hemicube.cpp: its rotation about the normal is part of every stored bake) and
/// the DXF object coordinate system (the arbitrary axis algorithm of the DXF reference).
inline std::pair<glm::dvec3, glm::dvec3> orthonormal_basis(const glm::dvec3& n) {
    const glm::dvec3 a = glm::abs(n);
    const glm::dvec3 axis = a.x <= a.y && a.x <= a.z ? glm::dvec3(1, 0, 0)
                            : a.y <= a.z             ? glm::dvec3(0, 1, 0)
                                                     : glm::dvec3(0, 0, 1);
    const glm::dvec3 u = glm::normalize(glm::cross(axis, n));
    return {u, glm::cross(n, u)};
}

/// Area of the triangle (a, b, c), m²: half the length of (b − a) × (c − a).
inline double triangle_area(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c) {
    return 0.5 * glm::length(glm::cross(b - a, c - a));
}

/// A diffuse material. `reflectance` ρ in [0,1) per channel, `emittance` E in W/m² (radiant
/// exitance from the front), `opacity` α in [0,1] (1 = opaque; 1 − α of the light passes).
struct Material {
    std::string name;
    Rgb reflectance{0.5, 0.5, 0.5};
    Rgb emittance{0.0, 0.0, 0.0};
    double opacity = 1.0;
    /// The light group of an emitting material (scene file `group`; empty: the default,
    /// kEmitterGroup). Light scenes mix the bake's groups with dimming factors.
    std::string group{};  // (braced: aggregate initialisers may leave it out)

    /// A material emits iff some channel of E is positive.
    bool is_emitter() const { return any_positive(emittance); }
};

/// The light group of emitting materials whose scene file named none.
inline constexpr const char* kEmitterGroup = "emitters";

/// An indexed triangle mesh in double precision, metres. Triangles index `positions`.
struct TriangleMesh {
    std::vector<glm::dvec3> positions;
    std::vector<glm::u32vec3> triangles;
};

/// A named piece of the model: one object/group of the source file with one material.
struct Surface {
    std::string name;            ///< object or group name from the source file
    std::string layer;           ///< CAD layer, empty when the format has none
    std::uint32_t material = 0;  ///< index into Scene::materials
    std::uint32_t source = 0;    ///< index into Scene::sources
    TriangleMesh mesh;
};

/// A pinhole camera. `fov_y_deg` is the full vertical field of view in degrees.
struct Camera {
    std::string name;
    glm::dvec3 position{0.0};
    glm::dvec3 look_at{0.0, 1.0, 0.0};
    glm::dvec3 up{0.0, 0.0, 1.0};
    double fov_y_deg = 60.0;
};

/// A calculation grid: points on a horizontal work plane at height `z`, `spacing` apart,
/// covering the rectangle [min, max] (x, y, already inset by the margin), facing `normal`.
/// Evaluated after each bake (illuminance E_avg, E_min, E_max, uniformity).
struct CalculationGrid {
    std::string name;
    glm::dvec2 min{0.0};
    glm::dvec2 max{0.0};
    double z = 0.0;
    double spacing = 0.5;
    glm::dvec3 normal{0.0, 0.0, 1.0};
};

/// A luminaire placed in the scene: a photometric web (candela, in the luminaire's
/// photometric frame, see photometry.h) at a position with an orientation. A point source at
/// `position` unless its opening is large against the distance to what it lights.
struct Luminaire {
    std::string name;      ///< unique among the scene's luminaires
    std::string file;      ///< the photometric file as the scene file resolved it
    std::string checksum;  ///< FNV-1a 64 of the photometric file's bytes, 16 hex digits
    PhotometricWeb web;    ///< as the file gives it (its multipliers applied)
    LuminousOpening opening;
    glm::dvec3 position{0.0};  ///< the photometric centre, metres
    /// The luminaire's photometric axes in the world: an orthonormal right-handed frame (x the
    /// length axis, C0; z up, away from the light of a downlight).
    glm::dvec3 axis_x{1.0, 0.0, 0.0};
    glm::dvec3 axis_y{0.0, 1.0, 0.0};
    glm::dvec3 axis_z{0.0, 0.0, 1.0};
    double flux_scale = 1.0;          ///< > 0: multiplies every candela
    double maintenance_factor = 1.0;  ///< in (0, 1]: multiplies every candela
    /// > 0: the lamp-tilt multiplier of the file's TILT=INCLUDE table at the luminaire's tilt
    /// (the angle of its nadir from straight down), 1 without a table; multiplies every candela
    double tilt_factor = 1.0;
    Rgb color{1.0, 1.0, 1.0};  ///< relative colour of luminance 1
    /// The light group (scene file `group`; empty: the default, the photometric file's stem).
    std::string group{};

    /// A world direction in the photometric frame.
    glm::dvec3 to_local(const glm::dvec3& d) const {
        return {glm::dot(d, axis_x), glm::dot(d, axis_y), glm::dot(d, axis_z)};
    }
    /// The web's factor: flux_scale · maintenance_factor · tilt_factor.
    double scale() const { return flux_scale * maintenance_factor * tilt_factor; }
    /// The luminaire's tilt, degrees in [0, 180]: the angle between its nadir (−axis_z) and
    /// straight down (−Z); 0 for a downlight as measured.
    double tilt_degrees() const { return glm::degrees(std::acos(glm::clamp(axis_z.z, -1.0, 1.0))); }
    /// Intensity toward the unit world direction `d`, candela per channel.
    Rgb intensity(const glm::dvec3& d) const {
        return web.intensity(to_local(d)) * scale() * color;
    }
    /// Total luminous flux, lm (the web's, scaled).
    double flux() const { return web.flux() * scale(); }
};

/// One imported file: where it came from and what the import did to it.
struct Source {
    std::string path;      ///< the path as given on the command line
    std::string format;    ///< "obj", ...
    std::string checksum;  ///< FNV-1a 64 of the file's bytes, 16 hex digits
    std::uint64_t size_bytes = 0;
    std::string unit;         ///< unit of the file before conversion to metres
    std::string up_axis;      ///< up axis of the file before conversion to Z up
    std::string imported_at;  ///< ISO 8601 UTC
    std::string report;       ///< the healing report, one line per item
};

/// The imported scene: everything a bake reads.
struct Scene {
    std::vector<Source> sources;
    std::vector<Material> materials;
    std::vector<Surface> surfaces;
    std::vector<Camera> cameras;
    std::vector<CalculationGrid> grids;
    std::vector<Luminaire> luminaires;  ///< from scene files' [[luminaire]] tables
    /// Unit of every material's emittance: "W/m2" (radiometric, irradiance in W/m²) or
    /// "lm/m2" (photometric, illuminance in lux).
    std::string emittance_unit = "W/m2";

    std::size_t triangle_count() const {
        std::size_t n = 0;
        for (const auto& s : surfaces) n += s.mesh.triangles.size();
        return n;
    }
};

/// local_origin of every position of every surface of a scene.
inline glm::dvec3 local_origin(const Scene& scene) {
    glm::dvec3 lo{std::numeric_limits<double>::max()};
    glm::dvec3 hi{std::numeric_limits<double>::lowest()};
    for (const auto& s : scene.surfaces) grow_box(s.mesh.positions, lo, hi);
    return local_origin(lo, hi);
}

/// The mesh a bake produced with its per-vertex shades. Vertices are not shared across
/// surfaces or across faces of different normals. All arrays indexed by vertex have the
/// same length; `triangle_surface` has one entry per triangle (index into Scene::surfaces).
struct BakeMesh {
    std::vector<glm::dvec3> positions;  ///< metres
    std::vector<glm::vec3> normals;     ///< unit, the front side
    std::vector<glm::u32vec3> triangles;
    std::vector<std::uint32_t> triangle_surface;
    std::vector<glm::vec3> irradiance;  ///< H, W/m² (or lux), per vertex
    std::vector<glm::vec3> radiosity;   ///< B = E + ρH, W/m² (or lm/m²), per vertex
};

/// One light group's share of a bake (docs/design.md, "Light scenes"): what the bake's lights
/// of that group alone give every vertex of BakeMesh. Light is linear in the sources, so the
/// groups add up to the bake's own shades (to rounding).
struct LightGroupShades {
    std::string name;
    std::vector<glm::vec3> irradiance;  ///< per vertex of the bake's mesh
    std::vector<glm::vec3> radiosity;   ///< per vertex; the group's emitters' E included
};

/// A stored bake: its settings, what it measured, and its shaded mesh.
struct Bake {
    std::int64_t id = 0;  ///< assigned by the store
    std::string name;
    std::string created_at;                                       ///< ISO 8601 UTC
    std::string unit = "W/m2";                                    ///< unit of irradiance/radiosity
    std::vector<std::pair<std::string, std::string>> parameters;  ///< e.g. {"method","abuffer"}
    BakeStats statistics;                                         ///< what the bake measured
    BakeMesh mesh;
    /// Per light group, when the scene named groups and had lights of two or more; empty
    /// otherwise (the whole bake is one group).
    std::vector<LightGroupShades> light_groups{};
};

}  // namespace abrad::visdb
