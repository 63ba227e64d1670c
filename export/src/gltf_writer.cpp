// glTF 2.0 export of a bake through tinygltf (declaration in writers.h): baked colours as
// COLOR_0 under KHR_materials_unlit materials, metres, Y up.

#include <tiny_gltf.h>

#include <algorithm>
#include <cctype>
#include <cstring>
#include <glm/common.hpp>
#include <limits>
#include <map>
#include <sstream>
#include <utility>

#include "abrad/export/text.h"
#include "abrad/export/writers.h"
#include "output.h"

namespace abrad::exporter {

namespace {

/// abrad's Z-up frame to glTF's Y-up frame: (x, y, z) -> (x, z, -y), a rotation.
glm::dvec3 to_y_up(const glm::dvec3& p) { return {p.x, p.z, -p.y}; }

/// Appends `count` bytes to the buffer, padded to 4 bytes; returns the view index.
int add_view(tinygltf::Model& model, const void* data, std::size_t bytes, int target) {
    auto& buf = model.buffers[0].data;
    const std::size_t offset = buf.size();
    buf.resize(offset + bytes);
    std::memcpy(buf.data() + offset, data, bytes);
    buf.resize((buf.size() + 3) / 4 * 4, 0);
    tinygltf::BufferView view;
    view.buffer = 0;
    view.byteOffset = offset;
    view.byteLength = bytes;
    view.target = target;
    model.bufferViews.push_back(view);
    return static_cast<int>(model.bufferViews.size() - 1);
}

int add_vec3_accessor(tinygltf::Model& model, const std::vector<float>& xyz, bool with_bounds) {
    tinygltf::Accessor a;
    a.bufferView =
        add_view(model, xyz.data(), xyz.size() * sizeof(float), TINYGLTF_TARGET_ARRAY_BUFFER);
    a.componentType = TINYGLTF_COMPONENT_TYPE_FLOAT;
    a.type = TINYGLTF_TYPE_VEC3;
    a.count = xyz.size() / 3;
    if (with_bounds) {
        a.minValues.assign(3, std::numeric_limits<double>::infinity());
        a.maxValues.assign(3, -std::numeric_limits<double>::infinity());
        for (std::size_t i = 0; i < xyz.size(); ++i) {
            a.minValues[i % 3] = std::min(a.minValues[i % 3], static_cast<double>(xyz[i]));
            a.maxValues[i % 3] = std::max(a.maxValues[i % 3], static_cast<double>(xyz[i]));
        }
    }
    model.accessors.push_back(a);
    return static_cast<int>(model.accessors.size() - 1);
}

}  // namespace

std::size_t write_gltf(const std::filesystem::path& path, const visdb::Scene& scene,
                       const visdb::BakeMesh& mesh, const ToneMap& tone) {
    detail::validate_bake_mesh(path, mesh);
    std::string ext = path.extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    if (ext != ".gltf" && ext != ".glb")
        detail::fail(path, "glTF output must end in .gltf or .glb");
    const bool binary = ext == ".glb";

    tinygltf::Model model;
    model.asset.version = "2.0";
    model.asset.generator = "abrad";
    model.extensionsUsed.push_back("KHR_materials_unlit");
    model.buffers.emplace_back();

    // The root node carries the local origin (visdb::local_origin), in double; positions are
    // relative to it
    const glm::dvec3 origin = visdb::local_origin(mesh.positions);

    // Vertex attributes, shared by every surface's primitive
    const std::size_t n = mesh.positions.size();
    std::vector<float> pos(3 * n), nor(3 * n), col(3 * n), irr(3 * n), rad(3 * n);
    for (std::size_t i = 0; i < n; ++i) {
        const glm::dvec3 p = to_y_up(mesh.positions[i] - origin);
        const glm::dvec3 q = to_y_up(glm::dvec3(mesh.normals[i]));
        for (int c = 0; c < 3; ++c) {
            const std::size_t o = 3 * i + static_cast<std::size_t>(c);
            pos[o] = static_cast<float>(p[c]);
            nor[o] = static_cast<float>(q[c]);
            col[o] =
                static_cast<float>(tone_value(static_cast<double>(mesh.radiosity[i][c]), tone));
            irr[o] = mesh.irradiance[i][c];
            rad[o] = mesh.radiosity[i][c];
        }
    }
    const int a_pos = add_vec3_accessor(model, pos, true);
    const int a_nor = add_vec3_accessor(model, nor, false);
    const int a_col = add_vec3_accessor(model, col, false);
    const int a_irr = add_vec3_accessor(model, irr, false);
    const int a_rad = add_vec3_accessor(model, rad, false);

    // Triangles grouped by surface
    std::map<std::uint32_t, std::vector<std::uint32_t>> by_surface;
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
        auto& idx = by_surface[mesh.triangle_surface[t]];
        for (int c = 0; c < 3; ++c) idx.push_back(mesh.triangles[t][c]);
    }

    // Names as JSON needs them: valid UTF-8, counting the ones that were not
    std::size_t transcoded = 0;
    auto utf8 = [&](const std::string& name) {
        Utf8Text t = to_utf8(name);
        transcoded += t.transcoded;
        return std::move(t.text);
    };

    tinygltf::Node root;
    root.name = "abrad bake";
    root.translation = {origin.x, origin.z, -origin.y};
    std::map<std::uint32_t, int> material_index;
    for (const auto& [surface, idx] : by_surface) {
        // An unlit material per scene material
        const std::uint32_t m = surface < scene.surfaces.size()
                                    ? scene.surfaces[surface].material
                                    : std::numeric_limits<std::uint32_t>::max();
        auto it = material_index.find(m);
        if (it == material_index.end()) {
            tinygltf::Material mat;
            mat.name = m < scene.materials.size() ? utf8(scene.materials[m].name) : "abrad";
            mat.pbrMetallicRoughness.baseColorFactor = {1.0, 1.0, 1.0, 1.0};
            mat.pbrMetallicRoughness.metallicFactor = 0.0;
            mat.pbrMetallicRoughness.roughnessFactor = 1.0;
            mat.doubleSided = false;  // a bake shades fronts only: viewers cull the backs
            mat.extensions["KHR_materials_unlit"] = tinygltf::Value(tinygltf::Value::Object());
            model.materials.push_back(mat);
            it = material_index.emplace(m, static_cast<int>(model.materials.size() - 1)).first;
        }
        tinygltf::Accessor ia;
        ia.bufferView = add_view(model, idx.data(), idx.size() * sizeof(std::uint32_t),
                                 TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER);
        ia.componentType = TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT;
        ia.type = TINYGLTF_TYPE_SCALAR;
        ia.count = idx.size();
        model.accessors.push_back(ia);

        tinygltf::Primitive prim;
        prim.mode = TINYGLTF_MODE_TRIANGLES;
        prim.indices = static_cast<int>(model.accessors.size() - 1);
        prim.material = it->second;
        prim.attributes = {{"POSITION", a_pos},
                           {"NORMAL", a_nor},
                           {"COLOR_0", a_col},
                           {"_IRRADIANCE", a_irr},
                           {"_RADIOSITY", a_rad}};
        tinygltf::Mesh gm;
        gm.name = surface < scene.surfaces.size() ? utf8(scene.surfaces[surface].name)
                                                  : "surface " + std::to_string(surface);
        gm.primitives.push_back(prim);
        model.meshes.push_back(gm);
        tinygltf::Node node;
        node.name = gm.name;
        node.mesh = static_cast<int>(model.meshes.size() - 1);
        model.nodes.push_back(node);
        root.children.push_back(static_cast<int>(model.nodes.size() - 1));
    }
    model.nodes.push_back(root);
    tinygltf::Scene sc;
    sc.name = "abrad";
    sc.nodes.push_back(static_cast<int>(model.nodes.size() - 1));
    model.scenes.push_back(sc);
    model.defaultScene = 0;

    // Serialise in memory, then write beside and rename, as the other writers do
    std::ostringstream bytes(std::ios::binary);
    tinygltf::TinyGLTF writer;
    if (!writer.WriteGltfSceneToStream(&model, bytes, !binary, binary) || !bytes)
        detail::fail(path, "cannot write glTF");
    detail::AtomicFile file(path);
    file.write(bytes.view());
    file.commit();
    return transcoded;
}

}  // namespace abrad::exporter
