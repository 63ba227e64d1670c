// Exact direct irradiance at arbitrary points (calculation grids, probes).

#include "abrad/radiosity/direct.h"

#include <cmath>
#include <glm/common.hpp>
#include <glm/geometric.hpp>

#include "abrad/radiosity/exact.h"
#include "abrad/radiosity/stage.h"

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
    : m_patches(scene_patches(scene, m_emittance)), m_bvh(m_patches) {
    for (std::size_t i = 0; i < m_patches.size(); ++i)
        if (visdb::any_positive(m_emittance[i])) m_lights.push_back(static_cast<std::uint32_t>(i));
    if (m_lights.empty())
        throw InputError("the scene has no light sources (no material with emittance > 0)");
}

visdb::Rgb exact_irradiance(std::span<const Patch> patches, std::span<const visdb::Rgb> emittance,
                            std::span<const std::uint32_t> lights, const Bvh& bvh,
                            const glm::dvec3& x, const glm::dvec3& n,
                            std::vector<const Patch*>& occ, double reach) {
    visdb::Rgb h(0.0);
    for (const std::uint32_t l : lights) {
        const Patch& lp = patches[l];
        // Behind the light's plane (it gives nothing), or beyond its reach (cull.h)
        if (glm::dot(x - lp.p[0], cross_normal(lp)) <= 0.0) continue;
        if (reach > 0.0) {
            const glm::dvec3 d = glm::abs(x - centroid(lp));
            if (d.x > reach || d.y > reach || d.z > reach) continue;
        }
        occ.clear();
        for_each_shadow_candidate(bvh, patches, l, x,
                                  [&](std::uint32_t id) { occ.push_back(&patches[id]); });
        h += emittance[l] * visible_form_factor(x, n, lp, occ);
    }
    return h;
}

visdb::Rgb DirectField::irradiance(const glm::dvec3& x, const glm::dvec3& n) const {
    std::vector<const Patch*> occluders;
    return exact_irradiance(m_patches, m_emittance, m_lights, m_bvh, x, n, occluders);
}

}  // namespace abrad::radiosity
