// Stage 1 of the bake: the scene's triangles as one mesh to shoot onto and shade, and its
// planar regions (stages.h).

#include <cmath>
#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <numeric>
#include <string>
#include <utility>
#include <vector>

#include "stages.h"

namespace abrad::radiosity {

namespace {

// Triangles around each vertex, as compressed rows.
void build_incidence(BakeGeometry& g) {
    const std::size_t nv = g.mesh.positions.size();
    g.incident_start.assign(nv + 1, 0);
    for (const auto& t : g.mesh.triangles)
        for (int k = 0; k < 3; ++k) ++g.incident_start[t[k] + 1];
    for (std::size_t i = 0; i < nv; ++i) g.incident_start[i + 1] += g.incident_start[i];
    g.incident.resize(g.incident_start[nv]);
    std::vector<std::uint32_t> fill(g.incident_start.begin(), g.incident_start.end() - 1);
    for (std::size_t t = 0; t < g.mesh.triangles.size(); ++t)
        for (int k = 0; k < 3; ++k)
            g.incident[fill[g.mesh.triangles[t][k]]++] = static_cast<std::uint32_t>(t);
}

void find_lights(BakeGeometry& g) {
    g.lights.clear();
    for (std::size_t t = 0; t < g.emittance.size(); ++t)
        if (visdb::any_positive(g.emittance[t])) g.lights.push_back(static_cast<std::uint32_t>(t));
}

// Appends one surface's triangles to `g`, a vertex per (source vertex, face normal).
void add_surface(const visdb::Surface& surface, std::uint32_t index,
                 const visdb::Material& material, BakeGeometry& g, std::uint64_t& degenerate) {
    // Faces share a vertex when their exact (double) unit normals agree to cos >= 1 - 1e-9
    constexpr double kSameNormal = 1.0 - 1e-9;
    // For each source vertex: the bake vertices made from it, with their exact normals
    std::vector<std::vector<std::pair<std::uint32_t, glm::dvec3>>> made(
        surface.mesh.positions.size());
    for (const glm::u32vec3& t : surface.mesh.triangles) {
        const Patch p{{surface.mesh.positions.at(t.x), surface.mesh.positions.at(t.y),
                       surface.mesh.positions.at(t.z)},
                      material.opacity};
        const glm::dvec3 cr = cross_normal(p);
        const double len = glm::length(cr);
        if (!(len > 0.0) || !std::isfinite(len)) {
            ++degenerate;
            continue;
        }
        const glm::dvec3 normal = cr / len;
        glm::u32vec3 tri;
        for (int k = 0; k < 3; ++k) {
            const std::uint32_t src = t[k];
            std::uint32_t found = kNoPatch;
            for (const auto& [cand, cand_normal] : made[src])
                if (glm::dot(cand_normal, normal) >= kSameNormal) {
                    found = cand;
                    break;
                }
            if (found == kNoPatch) {
                found = static_cast<std::uint32_t>(g.mesh.positions.size());
                g.mesh.positions.push_back(surface.mesh.positions[src]);
                g.mesh.normals.push_back(glm::vec3(normal));
                made[src].emplace_back(found, normal);
            }
            tri[k] = found;
        }
        g.mesh.triangles.push_back(tri);
        g.mesh.triangle_surface.push_back(index);
        g.patches.push_back(p);
        g.area.push_back(0.5 * len);
        g.emittance.push_back(material.emittance);
        g.reflectance.push_back(material.reflectance);
    }
}

/// The diagonal of the bounding box of `positions` (0 when empty).
double bounding_diagonal(const std::vector<glm::dvec3>& positions) {
    if (positions.empty()) return 0.0;
    glm::dvec3 lo = positions[0], hi = positions[0];
    for (const glm::dvec3& p : positions) {
        lo = glm::min(lo, p);
        hi = glm::max(hi, p);
    }
    return glm::length(hi - lo);
}

/// The diagonal of the bounding box of every surface's vertices.
double scene_diagonal(const visdb::Scene& scene) {
    std::vector<glm::dvec3> corners;
    for (const visdb::Surface& surface : scene.surfaces) {
        if (surface.mesh.positions.empty()) continue;
        glm::dvec3 lo = surface.mesh.positions[0], hi = lo;
        for (const glm::dvec3& p : surface.mesh.positions) {
            lo = glm::min(lo, p);
            hi = glm::max(hi, p);
        }
        corners.push_back(lo);
        corners.push_back(hi);
    }
    return bounding_diagonal(corners);
}

}  // namespace

BakeGeometry build_bake_mesh(const visdb::Scene& scene, visdb::BakeStats* stats) {
    BakeGeometry g;
    g.luminaires = scene.luminaires;
    std::uint64_t degenerate = 0;
    for (const visdb::Surface& surface : scene.surfaces)
        if (surface.material >= scene.materials.size())
            throw InputError("surface '" + surface.name + "' has no material " +
                             std::to_string(surface.material));
    ContactCut contacts = hide_contacts(scene, scene_diagonal(scene));
    for (std::size_t s = 0; s < scene.surfaces.size(); ++s) {
        const visdb::Surface& surface = scene.surfaces[s];
        const visdb::Material& material = scene.materials[surface.material];
        if (contacts.meshes[s]) {
            visdb::Surface cut{surface.name, surface.layer, surface.material, surface.source,
                               std::move(*contacts.meshes[s])};
            add_surface(cut, static_cast<std::uint32_t>(s), material, g, degenerate);
        } else {
            add_surface(surface, static_cast<std::uint32_t>(s), material, g, degenerate);
        }
    }
    build_incidence(g);
    find_lights(g);
    g.size = bounding_diagonal(g.mesh.positions);
    if (stats) {
        stats->degenerate_skipped = degenerate;
        stats->contact_hidden_m2 = contacts.hidden_m2;
        stats->contact_faces_cut = contacts.faces_cut;
    }
    if (g.mesh.triangles.empty()) throw InputError("the scene has no triangles to bake");
    if (g.lights.empty() && g.luminaires.empty()) {
        throw InputError(
            "the scene has no light sources (no material with emittance > 0, no luminaire)");
    }
    return g;
}

BakeGeometry describe_mesh(const visdb::Scene& scene, visdb::BakeMesh mesh) {
    BakeGeometry g;
    g.luminaires = scene.luminaires;
    g.mesh = std::move(mesh);
    for (std::size_t t = 0; t < g.mesh.triangles.size(); ++t) {
        const glm::u32vec3 tri = g.mesh.triangles[t];
        const visdb::Material& m =
            scene.materials[scene.surfaces[g.mesh.triangle_surface[t]].material];
        const Patch p{{g.mesh.positions[tri.x], g.mesh.positions[tri.y], g.mesh.positions[tri.z]},
                      m.opacity};
        g.patches.push_back(p);
        g.area.push_back(area(p));
        g.emittance.push_back(m.emittance);
        g.reflectance.push_back(m.reflectance);
    }
    build_incidence(g);
    find_lights(g);
    g.size = bounding_diagonal(g.mesh.positions);
    return g;
}

Regions make_regions(const BakeGeometry& g) {
    const std::size_t nv = g.mesh.positions.size(), nt = g.mesh.triangles.size();
    // Union-find over vertices: a triangle joins its three corners
    std::vector<std::uint32_t> parent(nv);
    std::iota(parent.begin(), parent.end(), 0u);
    auto find = [&](std::uint32_t a) {
        while (parent[a] != a) a = parent[a] = parent[parent[a]];
        return a;
    };
    for (const auto& t : g.mesh.triangles) {
        const std::uint32_t a = find(t.x), b = find(t.y), c = find(t.z);
        parent[b] = a;
        parent[find(c)] = a;
    }
    // One region per component, with its own vertex numbering
    Regions r;
    r.of_triangle.resize(nt);
    std::vector<std::uint32_t> region_of_root(nv, kNoPatch), local(nv, kNoPatch);
    std::vector<glm::dvec3> normal_sum;
    for (std::size_t t = 0; t < nt; ++t) {
        const glm::u32vec3 tri = g.mesh.triangles[t];
        const std::uint32_t root = find(tri.x);
        if (region_of_root[root] == kNoPatch) {
            region_of_root[root] = static_cast<std::uint32_t>(r.planar.size());
            r.planar.emplace_back();
            r.surface.push_back(g.mesh.triangle_surface[t]);
            r.emitter.push_back(visdb::any_positive(g.emittance[t]));
            normal_sum.emplace_back(0.0);
        }
        const std::uint32_t id = region_of_root[root];
        r.of_triangle[t] = id;
        PlanarRegion& region = r.planar[id];
        glm::u32vec3 lt;
        for (int k = 0; k < 3; ++k) {
            if (local[tri[k]] == kNoPatch) {
                local[tri[k]] = static_cast<std::uint32_t>(region.positions.size());
                region.positions.push_back(g.mesh.positions[tri[k]]);
            }
            lt[k] = local[tri[k]];
        }
        region.triangles.push_back(lt);
        normal_sum[id] += cross_normal(g.patches[t]);
    }
    for (std::size_t i = 0; i < r.planar.size(); ++i)
        r.planar[i].normal = glm::normalize(normal_sum[i]);
    return r;
}

std::vector<glm::dvec3> region_normals(const Regions& regions) {
    std::vector<glm::dvec3> n;
    n.reserve(regions.planar.size());
    for (const PlanarRegion& r : regions.planar) n.push_back(r.normal);
    return n;
}

}  // namespace abrad::radiosity
