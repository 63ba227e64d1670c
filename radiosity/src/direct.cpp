// Exact direct irradiance at arbitrary points (calculation grids, probes): from light triangles
// (exact.h) and from luminaires as point sources, or, for a receiver closer than five times a
// flat luminous opening's size, integrated over the opening.

#include "abrad/radiosity/direct.h"

#include <algorithm>
#include <cmath>
#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <map>
#include <numbers>
#include <utility>

#include "abrad/radiosity/exact.h"
#include "abrad/radiosity/stage.h"
#include "stages.h"

namespace abrad::radiosity {

namespace {

std::vector<Patch> scene_patches(const visdb::Scene& scene, std::vector<visdb::Rgb>& emittance) {
    std::vector<Patch> patches;
    for (const visdb::Surface& s : scene.surfaces) {
        if (s.material >= scene.materials.size())
            throw InputError("surface '" + s.name + "' has no material " +
                             std::to_string(s.material));
        const visdb::Material& m = scene.materials[s.material];
        for (const glm::u32vec3& t : s.mesh.triangles) {
            const Patch p{
                {s.mesh.positions.at(t.x), s.mesh.positions.at(t.y), s.mesh.positions.at(t.z)},
                m.opacity};
            const double area2 = glm::length(cross_normal(p));
            if (!(area2 > 0.0) || !std::isfinite(area2))
                continue;  // degenerate: sees and hides nothing
            patches.push_back(p);
            emittance.push_back(m.emittance);
        }
    }
    return patches;
}

}  // namespace

DirectField::DirectField(const visdb::Scene& scene)
    : m_patches(scene_patches(scene, m_emittance)),
      m_luminaires(scene.luminaires),
      m_bvh(m_patches) {
    for (std::size_t i = 0; i < m_patches.size(); ++i)
        if (visdb::any_positive(m_emittance[i])) m_lights.push_back(static_cast<std::uint32_t>(i));
    if (m_lights.empty() && m_luminaires.empty()) {
        throw InputError(
            "the scene has no light sources (no material with emittance > 0, no luminaire)");
    }
    m_quads = LightQuads(m_patches, m_emittance, m_lights);
    Box bounds;
    for (const Patch& p : m_patches)
        for (const glm::dvec3& q : p.p) bounds.grow(q);
    if (!m_patches.empty()) m_coplanar = kLengthTolerance * glm::length(bounds.hi - bounds.lo);
}

double segment_crossing(const Patch& p, const glm::dvec3& a, const glm::dvec3& b) {
    constexpr double kEnd = 1e-9;
    const glm::dvec3 d = b - a;
    const glm::dvec3 e1 = p.p[1] - p.p[0];
    const glm::dvec3 e2 = p.p[2] - p.p[0];
    const glm::dvec3 h = glm::cross(d, e2);
    const double det = glm::dot(e1, h);
    if (det == 0.0 || !std::isfinite(det)) return -1.0;  // in the triangle's plane: grazes
    const double inv = 1.0 / det;
    // Barycentric coordinates of the crossing, then its place t along the segment
    const glm::dvec3 s = a - p.p[0];
    const double u = glm::dot(s, h) * inv;
    if (u < 0.0 || u > 1.0) return -1.0;
    const glm::dvec3 q = glm::cross(s, e1);
    const double v = glm::dot(d, q) * inv;
    if (v < 0.0 || u + v > 1.0) return -1.0;
    const double t = glm::dot(e2, q) * inv;
    return t > kEnd && t < 1.0 - kEnd ? t : -1.0;
}

double transmittance(std::span<const Patch> patches, const Bvh& bvh, const glm::dvec3& x,
                     const glm::dvec3& source) {
    // Every crossing along the segment, then 1 − α of each, coplanar ones at one place once
    struct Crossing {
        double t;
        std::uint32_t patch;
    };
    std::vector<Crossing> crossings;
    const glm::dvec3 ends[2] = {x, source};
    bool opaque = false;
    bvh.query(Hull(ends), [&](std::uint32_t id) {
        if (opaque) return;
        const double t = segment_crossing(patches[id], x, source);
        if (t < 0.0) return;
        opaque = patches[id].opacity >= 1.0;
        crossings.push_back({t, id});
    });
    if (opaque) return 0.0;
    std::sort(crossings.begin(), crossings.end(),
              [](const Crossing& a, const Crossing& b) { return a.t < b.t; });
    double through = 1.0;
    for (std::size_t i = 0; i < crossings.size(); ++i) {
        const Patch& p = patches[crossings[i].patch];
        if (i > 0 && crossings[i].t - crossings[i - 1].t <= 1e-9) {
            const Patch& q = patches[crossings[i - 1].patch];
            const glm::dvec3 np = unit_normal(p);
            if (glm::length(glm::cross(np, unit_normal(q))) <= 1e-9 &&
                std::abs(glm::dot(np, q.p[0] - p.p[0])) <= 1e-9 * glm::length(source - x)) {
                continue;  // the same surface, through an edge its triangles share
            }
        }
        through *= 1.0 - p.opacity;
    }
    return through;
}

std::vector<OpeningSample> opening_samples(const visdb::Luminaire& luminaire, double distance) {
    using Shape = visdb::LuminousOpening::Shape;
    const visdb::LuminousOpening& o = luminaire.opening;
    std::vector<OpeningSample> out;
    if (o.shape != Shape::Rectangle && o.shape != Shape::Disc) return out;
    if (!(o.length > 0.0 && o.width > 0.0)) return out;
    if (!(distance < kFiveTimes * o.size())) return out;
    // Cells no larger than a fifth of the distance, two Gauss-Legendre points each way in each
    const int n = std::clamp(static_cast<int>(std::ceil(kFiveTimes * o.size() / distance)), 1,
                             kMaxOpeningCells);
    const double g = 0.5 / std::sqrt(3.0);  // the Gauss points at 0.5 ± g of a unit cell
    const double ax = 0.5 * o.length, ay = 0.5 * o.width;
    const auto place = [&](double u, double v) {
        return luminaire.position + u * luminaire.axis_x + v * luminaire.axis_y;
    };
    if (o.shape == Shape::Rectangle) {
        // [-ax, ax] x [-ay, ay] in n x n cells; every point weighs the same
        const double w = 1.0 / (4.0 * n * n);
        for (int i = 0; i < n; ++i)
            for (int j = 0; j < n; ++j)
                for (const double si : {0.5 - g, 0.5 + g})
                    for (const double sj : {0.5 - g, 0.5 + g})
                        out.push_back({place(ax * (2.0 * (i + si) / n - 1.0),
                                             ay * (2.0 * (j + sj) / n - 1.0)),
                                       w});
        return out;
    }
    // The disc (an ellipse of semi-axes ax, ay) in polar cells: n rings, 4n sectors; the
    // weight of (ρ, φ) is ρ dρ dφ / π
    const int sectors = 4 * n;
    const double dr = 1.0 / n, dphi = 2.0 * std::numbers::pi / sectors;
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < sectors; ++j)
            for (const double si : {0.5 - g, 0.5 + g})
                for (const double sj : {0.5 - g, 0.5 + g}) {
                    const double r = (i + si) * dr, phi = (j + sj) * dphi;
                    out.push_back({place(ax * r * std::cos(phi), ay * r * std::sin(phi)),
                                   r * dr * dphi / (4.0 * std::numbers::pi)});
                }
    return out;
}

visdb::Rgb point_source_irradiance(const visdb::Luminaire& luminaire,
                                   std::span<const Patch> patches, const Bvh& bvh,
                                   const glm::dvec3& x, const glm::dvec3& n) {
    // Direction and distance to the source; nothing from behind the surface
    const glm::dvec3 to_source = luminaire.position - x;
    const double d2 = glm::dot(to_source, to_source);
    if (!(d2 > 0.0)) return visdb::Rgb(0.0);
    // A flat opening large against the distance (the five-times rule): the web's intensity
    // shared evenly by the opening's points, each a point source seen past the occluders
    const std::vector<OpeningSample> samples = opening_samples(luminaire, std::sqrt(d2));
    if (!samples.empty()) {
        visdb::Rgb h(0.0);
        for (const OpeningSample& s : samples) {
            const glm::dvec3 to_point = s.point - x;
            const double r2 = glm::dot(to_point, to_point);
            if (!(r2 > 0.0)) continue;
            const glm::dvec3 w = to_point / std::sqrt(r2);
            const double cos_theta = glm::dot(n, w);
            if (cos_theta <= 0.0) continue;
            const visdb::Rgb intensity = luminaire.intensity(-w);
            if (!visdb::any_positive(intensity)) continue;
            h += intensity * (s.weight * cos_theta / r2 * transmittance(patches, bvh, x, s.point));
        }
        return h;
    }
    const glm::dvec3 w = to_source / std::sqrt(d2);
    const double cos_theta = glm::dot(n, w);
    if (cos_theta <= 0.0) return visdb::Rgb(0.0);
    const visdb::Rgb intensity = luminaire.intensity(-w);
    if (!visdb::any_positive(intensity)) return visdb::Rgb(0.0);
    return intensity * (cos_theta / d2 * transmittance(patches, bvh, x, luminaire.position));
}

visdb::Rgb luminaires_irradiance(std::span<const visdb::Luminaire> luminaires,
                                 std::span<const Patch> patches, const Bvh& bvh,
                                 const glm::dvec3& x, const glm::dvec3& n, double reach) {
    visdb::Rgb h(0.0);
    for (const visdb::Luminaire& l : luminaires) {
        if (reach > 0.0) {
            const glm::dvec3 d = glm::abs(x - l.position);
            if (d.x > reach || d.y > reach || d.z > reach) continue;
        }
        h += point_source_irradiance(l, patches, bvh, x, n);
    }
    return h;
}

visdb::Rgb exact_irradiance(std::span<const Patch> patches, std::span<const visdb::Rgb> emittance,
                            std::span<const std::uint32_t> lights, const Bvh& bvh,
                            const glm::dvec3& x, const glm::dvec3& n,
                            std::vector<const Patch*>& occ, double reach, const LightQuads* quads,
                            double coplanar) {
    return exact_irradiance_with(
        patches, emittance, lights, x, n, occ, reach,
        [&](std::size_t k, std::vector<const Patch*>& out) {
            for_each_shadow_candidate(bvh, patches, lights[k], x,
                                      [&](std::uint32_t id) { out.push_back(&patches[id]); });
        },
        quads, coplanar);
}

LightQuads::LightQuads(std::span<const Patch> patches, std::span<const visdb::Rgb> emittance,
                       std::span<const std::uint32_t> lights) {
    if (lights.empty()) return;
    m_quad_of.assign(static_cast<std::size_t>(*std::max_element(lights.begin(), lights.end())) + 1,
                     kNoPatch);
    // The lights by directed edge: the corners' bits
    using Corner = std::array<double, 3>;
    const auto bits = [](const glm::dvec3& p) { return Corner{p.x, p.y, p.z}; };
    std::map<std::pair<Corner, Corner>, std::uint32_t> by_edge;
    for (const std::uint32_t l : lights)
        for (int e = 0; e < 3; ++e)
            by_edge.emplace(std::pair{bits(patches[l].p[e]), bits(patches[l].p[(e + 1) % 3])}, l);
    const auto unit_normal = [&](std::uint32_t l) {
        return glm::normalize(cross_normal(patches[l]));
    };
    for (const std::uint32_t l : lights) {
        if (m_quad_of[l] != kNoPatch) continue;
        const Patch& a = patches[l];
        if (!(glm::length(cross_normal(a)) > 0.0)) continue;
        for (int e = 0; e < 3; ++e) {
            // The neighbour across edge (p[e], p[e+1]) runs it the other way
            const auto it = by_edge.find({bits(a.p[(e + 1) % 3]), bits(a.p[e])});
            if (it == by_edge.end() || it->second == l || m_quad_of[it->second] != kNoPatch)
                continue;
            const std::uint32_t o = it->second;
            const Patch& b = patches[o];
            if (emittance[o] != emittance[l] || !(glm::length(cross_normal(b)) > 0.0) ||
                glm::length(unit_normal(o) - unit_normal(l)) > 1e-9)
                continue;
            // b's corner d off the shared edge: the edge a.p[e] -> a.p[e+1] becomes the two
            // a.p[e] -> d -> a.p[e+1], so the quadrilateral goes round as a does
            glm::dvec3 d(0.0);
            for (const glm::dvec3& q : b.p)
                if (bits(q) != bits(a.p[e]) && bits(q) != bits(a.p[(e + 1) % 3])) d = q;
            const std::array<glm::dvec3, 4> c = {a.p[e], d, a.p[(e + 1) % 3], a.p[(e + 2) % 3]};
            // Convex: every corner turns the same way as the triangles face
            const glm::dvec3 nl = cross_normal(a);
            bool convex = true;
            for (int k = 0; k < 4; ++k)
                convex = convex && glm::dot(glm::cross(c[(k + 1) % 4] - c[k],
                                                       c[(k + 2) % 4] - c[(k + 1) % 4]),
                                            nl) > 0.0;
            if (!convex) continue;
            m_quad_of[l] = m_quad_of[o] = static_cast<std::uint32_t>(m_quads.size());
            m_quads.push_back({std::min(l, o), std::max(l, o), c});
            break;
        }
    }
}

visdb::Rgb DirectField::irradiance(const glm::dvec3& x, const glm::dvec3& n) const {
    std::vector<const Patch*> occluders;
    visdb::Rgb h = exact_irradiance(m_patches, m_emittance, m_lights, m_bvh, x, n, occluders, 0.0,
                                    &m_quads, m_coplanar);
    return h + luminaires_irradiance(m_luminaires, m_patches, m_bvh, x, n);
}

}  // namespace abrad::radiosity
