// Exact direct irradiance at arbitrary points (calculation grids, probes).

#include "abrad/radiosity/direct.h"

#include <cmath>
#include <glm/geometric.hpp>

#include "abrad/radiosity/bake.h"
#include "abrad/radiosity/exact.h"

namespace abrad::radiosity {

namespace {

std::vector<Patch> scene_patches(const visdb::Scene& scene, std::vector<visdb::Rgb>& emittance) {
    std::vector<Patch> patches;
    for (const visdb::Surface& s : scene.surfaces) {
        if (s.material >= scene.materials.size())
            throw BakeError("surface '" + s.name + "' has no material " +
                            std::to_string(s.material));
        const visdb::Material& m = scene.materials[s.material];
        for (const glm::u32vec3& t : s.mesh.triangles) {
            const Patch p{
                {s.mesh.positions.at(t.x), s.mesh.positions.at(t.y), s.mesh.positions.at(t.z)},
                m.opacity};
            const double area2 = glm::length(glm::cross(p.p[1] - p.p[0], p.p[2] - p.p[0]));
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
        if (m_emittance[i].x > 0.0 || m_emittance[i].y > 0.0 || m_emittance[i].z > 0.0)
            m_lights.push_back(static_cast<std::uint32_t>(i));
    if (m_lights.empty())
        throw BakeError("the scene has no light sources (no material with emittance > 0)");
}

visdb::Rgb DirectField::irradiance(const glm::dvec3& x, const glm::dvec3& n) const {
    visdb::Rgb h(0.0);
    std::vector<const Patch*> occluders;
    for (const std::uint32_t l : m_lights) {
        occluders.clear();
        for_each_shadow_candidate(m_bvh, m_patches, l, x,
                                  [&](std::uint32_t id) { occluders.push_back(&m_patches[id]); });
        h += m_emittance[l] * visible_form_factor(x, n, m_patches[l], occluders);
    }
    return h;
}

}  // namespace abrad::radiosity
