// glTF 2.0 export of a bake through tinygltf (declaration in writers.h): baked colours as
// COLOR_0 under KHR_materials_unlit materials, metres, Y up, each surface a mesh over its own
// vertices.

#include <tiny_gltf.h>

#include <algorithm>
#include <cctype>
#include <cstdint>
#include <cstring>
#include <glm/common.hpp>
#include <limits>
#include <map>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "abrad/export/text.h"
#include "abrad/export/writers.h"
#include "output.h"

namespace abrad::exporter {

namespace {

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

/// One surface's triangles over its own vertices: `vertices` the bake mesh's indices it uses
/// (ascending), `indices` its corners numbered into `vertices`.
struct SurfacePart {
    std::vector<std::uint32_t> vertices;
    std::vector<std::uint32_t> indices;
};

/// The triangles of every surface, each with its own compact vertex range, by surface id.
std::map<std::uint32_t, SurfacePart> surface_parts(const visdb::BakeMesh& mesh) {
    std::map<std::uint32_t, SurfacePart> parts;
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
        auto& idx = parts[mesh.triangle_surface[t]].indices;
        for (int c = 0; c < 3; ++c) idx.push_back(mesh.triangles[t][c]);
    }
    // Renumber each surface's corners into its sorted unique vertices (`local` is reused:
    // each entry is set before it is read within one surface)
    std::vector<std::uint32_t> local(mesh.positions.size());
    for (auto& [surface, part] : parts) {
        part.vertices = part.indices;
        std::sort(part.vertices.begin(), part.vertices.end());
        part.vertices.erase(std::unique(part.vertices.begin(), part.vertices.end()),
                            part.vertices.end());
        for (std::size_t k = 0; k < part.vertices.size(); ++k)
            local[part.vertices[k]] = static_cast<std::uint32_t>(k);
        for (auto& i : part.indices) i = local[i];
    }
    return parts;
}

/// What every vertex attribute is computed from.
struct VertexSource {
    const visdb::BakeMesh& mesh;
    glm::dvec3 origin;  ///< subtracted from positions (the root node's translation)
    const ToneMap& tone;
};

/// POSITION, NORMAL, COLOR_0, _IRRADIANCE and _RADIOSITY accessors of `vertices`.
std::map<std::string, int> add_attributes(tinygltf::Model& model, const VertexSource& src,
                                          const std::vector<std::uint32_t>& vertices) {
    const std::size_t n = vertices.size();
    std::vector<float> pos(3 * n), nor(3 * n), col(3 * n), irr(3 * n), rad(3 * n);
    for (std::size_t k = 0; k < n; ++k) {
        const std::size_t i = vertices[k];
        const glm::dvec3 p = detail::to_up(src.mesh.positions[i] - src.origin, UpAxis::Y);
        const glm::dvec3 q = detail::to_up(glm::dvec3(src.mesh.normals[i]), UpAxis::Y);
        for (int c = 0; c < 3; ++c) {
            const std::size_t o = 3 * k + static_cast<std::size_t>(c);
            pos[o] = static_cast<float>(p[c]);
            nor[o] = static_cast<float>(q[c]);
            col[o] = static_cast<float>(
                tone_value(static_cast<double>(src.mesh.radiosity[i][c]), src.tone));
            irr[o] = src.mesh.irradiance[i][c];
            rad[o] = src.mesh.radiosity[i][c];
        }
    }
    return {{"POSITION", add_vec3_accessor(model, pos, true)},
            {"NORMAL", add_vec3_accessor(model, nor, false)},
            {"COLOR_0", add_vec3_accessor(model, col, false)},
            {"_IRRADIANCE", add_vec3_accessor(model, irr, false)},
            {"_RADIOSITY", add_vec3_accessor(model, rad, false)}};
}

/// The index accessor of one part: unsigned short when every index fits below 65535 (the
/// primitive-restart value glTF forbids), else unsigned int.
int add_indices(tinygltf::Model& model, const SurfacePart& part) {
    tinygltf::Accessor ia;
    ia.type = TINYGLTF_TYPE_SCALAR;
    ia.count = part.indices.size();
    if (part.vertices.size() < 0xFFFFu) {
        const std::vector<std::uint16_t> idx(part.indices.begin(), part.indices.end());
        ia.bufferView = add_view(model, idx.data(), idx.size() * sizeof(std::uint16_t),
                                 TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER);
        ia.componentType = TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT;
    } else {
        ia.bufferView =
            add_view(model, part.indices.data(), part.indices.size() * sizeof(std::uint32_t),
                     TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER);
        ia.componentType = TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT;
    }
    model.accessors.push_back(ia);
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

    // Each surface's triangles over its own vertices, so a viewer uploads each vertex once
    const auto parts = surface_parts(mesh);
    const VertexSource source{.mesh = mesh, .origin = origin, .tone = tone};

    // Names as JSON needs them: valid UTF-8, counting the ones that were not
    std::size_t transcoded = 0;
    auto utf8 = [&](const std::string& name) {
        Utf8Text t = to_utf8(name);
        transcoded += t.transcoded;
        return std::move(t.text);
    };

    tinygltf::Node root;
    root.name = "abrad bake";
    const glm::dvec3 t = detail::to_up(origin, UpAxis::Y);  // glTF is Y up
    root.translation = {t.x, t.y, t.z};
    std::map<std::uint32_t, int> material_index;
    for (const auto& [surface, part] : parts) {
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
        tinygltf::Primitive prim;
        prim.mode = TINYGLTF_MODE_TRIANGLES;
        prim.indices = add_indices(model, part);
        prim.material = it->second;
        prim.attributes = add_attributes(model, source, part.vertices);
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
