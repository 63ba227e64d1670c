// Per-light culling: the light's front half-space and its reach (bounding-volume query).

#include "abrad/radiosity/cull.h"

#include <algorithm>
#include <glm/geometric.hpp>

namespace abrad::radiosity {

std::vector<std::uint32_t> light_candidates(const Bvh& bvh, std::span<const Patch> patches,
                                            std::uint32_t light, double reach) {
    const Patch& l = patches[light];
    const glm::dvec3 cr = glm::cross(l.p[1] - l.p[0], l.p[2] - l.p[0]);
    const double len = glm::length(cr);
    std::vector<std::uint32_t> out;
    if (!(len > 0.0)) return out;
    const glm::dvec3 n = cr / len;
    auto in_front = [&](std::uint32_t id) {
        const Patch& p = patches[id];
        return glm::dot(p.p[0] - l.p[0], n) > 0.0 || glm::dot(p.p[1] - l.p[0], n) > 0.0 ||
               glm::dot(p.p[2] - l.p[0], n) > 0.0;
    };
    if (reach > 0.0) {
        const glm::dvec3 c = (l.p[0] + l.p[1] + l.p[2]) / 3.0;
        Box box;
        box.grow(c - glm::dvec3(reach));
        box.grow(c + glm::dvec3(reach));
        bvh.query(box, [&](std::uint32_t id) {
            if (id != light && in_front(id)) out.push_back(id);
        });
        std::sort(out.begin(), out.end());
    } else {
        for (std::uint32_t id = 0; id < patches.size(); ++id)
            if (id != light && in_front(id)) out.push_back(id);
    }
    return out;
}

std::vector<std::uint32_t> vertices_of(std::span<const std::uint32_t> triangles,
                                       std::span<const glm::u32vec3> mesh_triangles) {
    std::vector<std::uint32_t> out;
    out.reserve(triangles.size() * 3);
    for (std::uint32_t t : triangles)
        for (int k = 0; k < 3; ++k) out.push_back(mesh_triangles[t][k]);
    std::sort(out.begin(), out.end());
    out.erase(std::unique(out.begin(), out.end()), out.end());
    return out;
}

}  // namespace abrad::radiosity
