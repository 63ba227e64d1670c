// glTF export read back with tinygltf: Y up, metres, COLOR_0 = the tone-mapped bake, unlit
// materials, the irradiance/radiosity attributes.

#include <gtest/gtest.h>
#include <tiny_gltf.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "abrad/export/text.h"
#include "abrad/export/writers.h"
#include "export_scenes.h"
#include "temp_dir.h"

namespace fs = std::filesystem;
using namespace abrad;
using namespace abrad::exporter;

namespace {

using abrad::testing::survey_mesh;
using abrad::testing::two_surfaces;

std::vector<float> read_vec3(const tinygltf::Model& model, int accessor) {
    const auto& a = model.accessors[static_cast<std::size_t>(accessor)];
    EXPECT_EQ(a.componentType, TINYGLTF_COMPONENT_TYPE_FLOAT);
    EXPECT_EQ(a.type, TINYGLTF_TYPE_VEC3);
    const auto& view = model.bufferViews[static_cast<std::size_t>(a.bufferView)];
    const auto& buf = model.buffers[static_cast<std::size_t>(view.buffer)];
    std::vector<float> out(a.count * 3);
    std::memcpy(out.data(), buf.data.data() + view.byteOffset + a.byteOffset,
                out.size() * sizeof(float));
    return out;
}

std::vector<std::uint32_t> read_indices(const tinygltf::Model& model, int accessor) {
    const auto& a = model.accessors[static_cast<std::size_t>(accessor)];
    const auto& view = model.bufferViews[static_cast<std::size_t>(a.bufferView)];
    const unsigned char* data = model.buffers[static_cast<std::size_t>(view.buffer)].data.data() +
                                view.byteOffset + a.byteOffset;
    std::vector<std::uint32_t> out(a.count);
    for (std::size_t i = 0; i < a.count; ++i) {
        if (a.componentType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT) {
            std::uint16_t v = 0;
            std::memcpy(&v, data + 2 * i, 2);
            out[i] = v;
        } else {
            EXPECT_EQ(a.componentType, TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT);
            std::memcpy(&out[i], data + 4 * i, 4);
        }
    }
    return out;
}

tinygltf::Model load(const fs::path& path) {
    tinygltf::TinyGLTF loader;
    tinygltf::Model model;
    std::string err, warn;
    const bool ok = path.extension() == ".glb"
                        ? loader.LoadBinaryFromFile(&model, &err, &warn, path.string())
                        : loader.LoadASCIIFromFile(&model, &err, &warn, path.string());
    EXPECT_TRUE(ok) << err;
    return model;
}

void check_round_trip(const fs::path& path) {
    const visdb::BakeMesh m = survey_mesh(false);
    const ToneMap tone{.exposure = 0.05};
    write_gltf(path, two_surfaces(), m, tone);

    const tinygltf::Model model = load(path);
    ASSERT_EQ(model.meshes.size(), 2u);
    EXPECT_EQ(model.meshes[1].name, "wall");
    ASSERT_EQ(model.extensionsUsed.size(), 1u);
    EXPECT_EQ(model.extensionsUsed[0], "KHR_materials_unlit");
    ASSERT_EQ(model.materials.size(), 2u);
    EXPECT_TRUE(model.materials[0].extensions.count("KHR_materials_unlit"));
    EXPECT_FALSE(model.materials[0].doubleSided);

    // The root node carries the origin (Y up); children the surfaces
    const tinygltf::Node& root = model.nodes[static_cast<std::size_t>(model.scenes[0].nodes[0])];
    ASSERT_EQ(root.translation.size(), 3u);
    ASSERT_EQ(root.children.size(), 2u);
    const glm::dvec3 t(root.translation[0], root.translation[1], root.translation[2]);

    // Every surface's triangles, corner by corner, against the bake's vertices
    for (std::uint32_t s = 0; s < 2; ++s) {
        std::vector<std::uint32_t> corners;  // the bake's vertex of each corner of surface s
        for (std::size_t k = 0; k < m.triangles.size(); ++k)
            if (m.triangle_surface[k] == s)
                for (int c = 0; c < 3; ++c) corners.push_back(m.triangles[k][c]);
        const tinygltf::Primitive& prim = model.meshes[s].primitives[0];
        const auto idx = read_indices(model, prim.indices);
        const auto pos = read_vec3(model, prim.attributes.at("POSITION"));
        const auto col = read_vec3(model, prim.attributes.at("COLOR_0"));
        const auto irr = read_vec3(model, prim.attributes.at("_IRRADIANCE"));
        const auto nor = read_vec3(model, prim.attributes.at("NORMAL"));
        ASSERT_EQ(idx.size(), corners.size());
        EXPECT_EQ(pos.size(), 9u);  // its own three vertices, not the bake's six
        for (std::size_t k = 0; k < idx.size(); ++k) {
            const std::size_t j = idx[k];
            const std::size_t i = corners[k];
            ASSERT_LT(3 * j, pos.size());
            // glTF (x, y, z) = abrad (x, z, -y): back to abrad's frame, to the millimetre
            const glm::dvec3 g = t + glm::dvec3(pos[3 * j], pos[3 * j + 1], pos[3 * j + 2]);
            EXPECT_NEAR(g.x, m.positions[i].x, 1e-5);
            EXPECT_NEAR(-g.z, m.positions[i].y, 1e-5);
            EXPECT_NEAR(g.y, m.positions[i].z, 1e-5);
            EXPECT_FLOAT_EQ(nor[3 * j + 1], m.normals[i].z);
            for (int c = 0; c < 3; ++c) {
                const std::size_t o = 3 * j + static_cast<std::size_t>(c);
                EXPECT_NEAR(col[o], tone_value(m.radiosity[i][c], tone), 1e-6);
                EXPECT_FLOAT_EQ(irr[o], m.irradiance[i][c]);
            }
        }
    }
}

// A strip of `surfaces` surfaces, each `quads` unit quads along x (two triangles, four
// vertices of its own per quad), in one bake mesh.
visdb::BakeMesh strips(std::uint32_t surfaces, std::uint32_t quads) {
    visdb::BakeMesh m;
    for (std::uint32_t s = 0; s < surfaces; ++s)
        for (std::uint32_t q = 0; q < quads; ++q) {
            const auto v = static_cast<std::uint32_t>(m.positions.size());
            const glm::dvec3 o(q, s, 0);
            for (const glm::dvec3 d : {glm::dvec3(0, 0, 0), glm::dvec3(1, 0, 0),
                                       glm::dvec3(1, 1, 0), glm::dvec3(0, 1, 0)}) {
                m.positions.push_back(o + d);
                m.normals.emplace_back(0, 0, 1);
                m.radiosity.emplace_back(static_cast<float>(s), 1.0f, static_cast<float>(q));
                m.irradiance.push_back(m.radiosity.back());
            }
            m.triangles.push_back({v, v + 1, v + 2});
            m.triangles.push_back({v, v + 2, v + 3});
            m.triangle_surface.insert(m.triangle_surface.end(), 2, s);
        }
    return m;
}

}  // namespace

TEST(GltfExport, RoundTripGltf) {
    const abrad::testing::TempDir dir("gltf");
    check_round_trip(dir / "round_trip.gltf");
}

TEST(GltfExport, RoundTripGlb) {
    const abrad::testing::TempDir dir("gltf");
    check_round_trip(dir / "round_trip.glb");
}

TEST(GltfExport, RefusesOtherExtensionsAndBadMeshes) {
    const abrad::testing::TempDir dir("gltf");
    const fs::path p = dir / "bad.obj";
    EXPECT_THROW(write_gltf(p, two_surfaces(), survey_mesh(false), {}), ExportError);
    EXPECT_FALSE(fs::exists(p));
    visdb::BakeMesh bad = survey_mesh(false);
    bad.radiosity.pop_back();
    EXPECT_THROW(write_gltf(dir / "bad.gltf", two_surfaces(), bad, {}), ExportError);
    EXPECT_FALSE(fs::exists(dir / "bad.gltf"));
}

// Names are valid UTF-8 whatever the CAD file wrote: UTF-8 kept, anything else read as
// Windows-1252 (Latin-1 plus the typographic 0x80-0x9F), undefined bytes U+FFFD.
TEST(Utf8Text, ValidUtf8KeptOtherBytesReadAsWindows1252) {
    EXPECT_EQ(to_utf8("Terraind\xc3\xa6k").text, "Terraind\xc3\xa6k");  // UTF-8 æ
    EXPECT_FALSE(to_utf8("Terraind\xc3\xa6k").transcoded);
    EXPECT_FALSE(to_utf8("plain ascii").transcoded);
    EXPECT_EQ(to_utf8("\xf0\x9f\x92\xa1").text, "\xf0\x9f\x92\xa1");  // 4-byte form kept
    const auto latin1 = to_utf8("Terraind\xe6k");                     // Latin-1 æ
    EXPECT_TRUE(latin1.transcoded);
    EXPECT_EQ(latin1.text, "Terraind\xc3\xa6k");
    EXPECT_EQ(to_utf8("\x80 5").text, "\xe2\x82\xac 5");  // CP1252 euro sign
    EXPECT_EQ(to_utf8("a\x81z").text, "a\xef\xbf\xbdz");  // undefined in CP1252: U+FFFD
    // Not UTF-8: overlong, a surrogate, truncated, a stray continuation byte
    for (const char* bad : {"\xc0\xaf", "\xed\xa0\x80", "ab\xe2\x82", "\xa0x"})
        EXPECT_TRUE(to_utf8(bad).transcoded) << bad;
}

TEST(GltfExport, NamesThatAreNotUtf8AreTranscoded) {
    const abrad::testing::TempDir dir("gltf");
    visdb::Scene scene = two_surfaces();
    scene.materials[0].name = "Terraind\xe6k";    // Latin-1, as an OBJ from a Danish CAD tool
    scene.surfaces[1].name = "V\xe6g \x96 nord";  // Latin-1 æ, CP1252 en dash
    const fs::path path = dir / "names.gltf";
    EXPECT_EQ(write_gltf(path, scene, survey_mesh(false), {.exposure = 0.05}), 2u);
    const tinygltf::Model model = load(path);
    ASSERT_EQ(model.materials.size(), 2u);
    EXPECT_EQ(model.materials[0].name, "Terraind\xc3\xa6k");
    ASSERT_EQ(model.meshes.size(), 2u);
    EXPECT_EQ(model.meshes[1].name, "V\xc3\xa6g \xe2\x80\x93 nord");
    EXPECT_EQ(model.meshes[0].name, "floor");  // UTF-8 (ASCII) names untouched
}

// Each primitive's accessors cover its own vertices only: every vertex of its POSITION is one
// of its triangles' corners, the counts add up to the bake's vertices (the FZK-Haus exported
// 136 times its vertices when each mesh referenced the whole shared buffer), and a surface of
// 65,535 vertices or more gets 32-bit indices.
TEST(GltfExport, EachMeshCoversOnlyItsOwnVertices) {
    const abrad::testing::TempDir dir("gltf");
    visdb::Scene scene;
    scene.materials = {{.name = "m"}};
    const std::uint32_t kSurfaces = 5, kQuads = 3;
    visdb::BakeMesh m = strips(kSurfaces, kQuads);
    // One more surface of 16,400 quads: 65,600 vertices
    const visdb::BakeMesh big = strips(1, 16400);
    const auto base = static_cast<std::uint32_t>(m.positions.size());
    m.positions.insert(m.positions.end(), big.positions.begin(), big.positions.end());
    m.normals.insert(m.normals.end(), big.normals.begin(), big.normals.end());
    m.radiosity.insert(m.radiosity.end(), big.radiosity.begin(), big.radiosity.end());
    m.irradiance.insert(m.irradiance.end(), big.irradiance.begin(), big.irradiance.end());
    for (const auto& tri : big.triangles)
        m.triangles.push_back({tri[0] + base, tri[1] + base, tri[2] + base});
    m.triangle_surface.insert(m.triangle_surface.end(), big.triangles.size(), kSurfaces);
    scene.surfaces.resize(kSurfaces + 1);

    const fs::path path = dir / "strips.glb";
    write_gltf(path, scene, m, {.exposure = 1.0});
    const tinygltf::Model model = load(path);
    ASSERT_EQ(model.meshes.size(), kSurfaces + 1);
    std::size_t total = 0;
    for (std::size_t s = 0; s <= kSurfaces; ++s) {
        const tinygltf::Primitive& prim = model.meshes[s].primitives[0];
        const auto idx = read_indices(model, prim.indices);
        const std::size_t expected = s < kSurfaces ? 4 * kQuads : 4 * 16400;
        EXPECT_EQ(model.accessors[static_cast<std::size_t>(prim.indices)].componentType,
                  s < kSurfaces ? TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT
                                : TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT);
        std::vector<bool> used(expected, false);
        for (const auto i : idx) {
            ASSERT_LT(i, expected);
            used[i] = true;
        }
        EXPECT_EQ(std::count(used.begin(), used.end(), false), 0) << "surface " << s;
        for (const auto& [name, accessor] : prim.attributes)
            EXPECT_EQ(model.accessors[static_cast<std::size_t>(accessor)].count, expected)
                << name << " of surface " << s;
        // The radiosity of the surface's vertices carries its surface id in red
        const auto rad = read_vec3(model, prim.attributes.at("_RADIOSITY"));
        for (std::size_t k = 0; k < rad.size(); k += 3)
            ASSERT_EQ(rad[k], static_cast<float>(s < kSurfaces ? s : 0));
        total += expected;
    }
    EXPECT_EQ(total, m.positions.size());
}
