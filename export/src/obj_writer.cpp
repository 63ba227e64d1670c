// The OBJ writer: baked geometry with per-vertex display colours, and its MTL.

#include <algorithm>
#include <cstdint>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "abrad/export/writers.h"
#include "output.h"

namespace abrad::exporter {

namespace {

/// Appends `x y z` of a vector with round-trip precision.
template <typename Vec>
void append_triple(std::string& out, const Vec& v) {
    for (int k = 0; k < 3; ++k) {
        out += ' ';
        detail::append_exact(out, v[k]);
    }
}

/// Unique MTL names for the materials in `used`: the sanitised name, `material_I` when the
/// name is empty, and `_I` appended when two used materials would share a name.
std::map<std::uint32_t, std::string> material_names(const visdb::Scene& scene,
                                                    const std::set<std::uint32_t>& used) {
    std::map<std::uint32_t, std::string> names;
    std::set<std::string> taken;
    for (const auto m : used) {
        std::string name = detail::sanitise_name(scene.materials[m].name);
        // append() rather than "literal" + to_string(): GCC 12 -O3 warns falsely (-Wrestrict)
        if (name.empty()) name = std::string("material_").append(std::to_string(m));
        if (taken.count(name) != 0) name.append("_").append(std::to_string(m));
        taken.insert(name);
        names.emplace(m, std::move(name));
    }
    return names;
}

}  // namespace

void write_obj(const std::filesystem::path& path, const visdb::Scene& scene,
               const visdb::BakeMesh& mesh, const ToneMap& tone, const ObjOptions& options) {
    // Validate the mesh and its references into the scene before touching the disk
    detail::validate_bake_mesh(path, mesh);
    std::set<std::uint32_t> used_materials;
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
        const auto s = mesh.triangle_surface[t];
        if (s >= scene.surfaces.size()) {
            detail::fail(path, "invalid mesh: triangle " + std::to_string(t) + " surface id " +
                                   std::to_string(s) + " out of range (" +
                                   std::to_string(scene.surfaces.size()) + " surfaces)");
        }
        const auto m = scene.surfaces[s].material;
        if (m >= scene.materials.size()) {
            detail::fail(path, "invalid scene: surface " + std::to_string(s) + " material " +
                                   std::to_string(m) + " out of range (" +
                                   std::to_string(scene.materials.size()) + " materials)");
        }
        used_materials.insert(m);
    }
    const auto mtl_names = material_names(scene, used_materials);

    // Order the triangles by surface id, keeping their order within a surface
    std::vector<std::size_t> order(mesh.triangles.size());
    for (std::size_t t = 0; t < order.size(); ++t) order[t] = t;
    std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
        return mesh.triangle_surface[a] < mesh.triangle_surface[b];
    });

    const std::string mtl_file = path.stem().string() + ".mtl";
    const std::filesystem::path mtl_path = path.parent_path() / mtl_file;
    detail::AtomicFile obj(path);
    detail::AtomicFile mtl(mtl_path);

    // Write the OBJ header and vertices `v x y z r g b`, then normals `vn`
    std::string buf;
    buf += "# abrad baked mesh: " + std::to_string(mesh.positions.size()) + " vertices, " +
           std::to_string(mesh.triangles.size()) + " triangles\n";
    buf += options.up == UpAxis::Y ? "# Y up: abrad's (x, y, z) written as (x, z, -y)\n"
                                   : "# Z up (abrad's frame)\n";
    buf +=
        "# v x y z r g b: position in metres, display colour (tone-mapped radiosity, sRGB, "
        "exposure ";
    detail::append_exact(buf, tone.exposure);
    buf += ")\n";
    buf += "mtllib " + mtl_file + "\n";
    for (std::size_t i = 0; i < mesh.positions.size(); ++i) {
        buf += 'v';
        append_triple(buf, detail::to_up(mesh.positions[i], options.up));
        for (const auto c : display_colour(mesh.radiosity[i], tone)) {
            buf += ' ';
            detail::append_fixed(buf, static_cast<double>(c) / 255.0, 4);
        }
        buf += '\n';
        obj.write_if_full(buf);
    }
    for (const auto& n : mesh.normals) {
        buf += "vn";
        append_triple(buf, glm::vec3(detail::to_up(glm::dvec3(n), options.up)));
        buf += '\n';
        obj.write_if_full(buf);
    }

    // Write the faces surface by surface: `o`, `usemtl`, `f a//a b//b c//c` (1-based)
    std::size_t current = scene.surfaces.size();
    for (const auto t : order) {
        const auto s = mesh.triangle_surface[t];
        if (s != current) {
            current = s;
            const auto& surface = scene.surfaces[s];
            std::string name = detail::sanitise_name(surface.name);
            if (name.empty()) name = "surface_" + std::to_string(s);
            buf += "o " + name + "\n";
            buf += "usemtl " + mtl_names.at(surface.material) + "\n";
        }
        buf += 'f';
        for (int k = 0; k < 3; ++k) {
            const std::string index = std::to_string(std::uint64_t{mesh.triangles[t][k]} + 1);
            buf += ' ';
            buf += index;
            buf += "//";
            buf += index;
        }
        buf += '\n';
        obj.write_if_full(buf);
    }
    obj.write(buf);

    // Write the MTL: one `newmtl` per used material that shows the bake (white, unlit, so the
    // vertex colours show as they are), the material's own ρ, E and α in a comment
    buf = "# abrad materials for " + path.filename().string() +
          ": the bake is in the vertex colours (v x y z r g b); each material is white and\n"
          "# unlit (illum 0) so that viewers show them unchanged. The scene's own reflectance,\n"
          "# emittance and opacity are in each material's '# abrad material:' line.\n";
    for (const auto& [m, name] : mtl_names) {
        const auto& material = scene.materials[m];
        buf += "\nnewmtl " + name + "\n";
        buf += "# abrad material: Kd";
        append_triple(buf, material.reflectance);
        buf += " Ke";
        append_triple(buf, material.emittance);
        buf += " d ";
        detail::append_exact(buf, material.opacity);
        buf += "\nKa 0 0 0\nKd 1 1 1\nKs 0 0 0\nd ";
        detail::append_exact(buf, material.opacity);
        buf += "\nillum 0\n";
    }
    mtl.write(buf);

    // Publish the MTL first so the OBJ never names a missing material library
    obj.close();
    mtl.commit();
    obj.commit();
}

}  // namespace abrad::exporter
