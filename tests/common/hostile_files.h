#pragma once
// Hostile model files shared by the reader tests and the command-line tests (issue 19).

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

namespace abrad::testing {

/// A DXF whose nested MINSERTs ask for 10^10 faces in a few hundred bytes: block B2 holds
/// 1,000 × 100 copies of B1, which holds 1,000 × 100 copies of B0's one 3DFACE; the
/// entities insert B2 once, with entity handle `handle`.
inline std::string dxf_insert_bomb(const std::string& handle) {
    std::string s = "0\nSECTION\n2\nBLOCKS\n";
    s += "0\nBLOCK\n8\n0\n2\nB0\n10\n0\n20\n0\n30\n0\n";
    s += "0\n3DFACE\n8\n0\n10\n0\n20\n0\n30\n0\n11\n1\n21\n0\n31\n0\n12\n1\n22\n1\n32\n0\n";
    s += "0\nENDBLK\n";
    s += "0\nBLOCK\n8\n0\n2\nB1\n10\n0\n20\n0\n30\n0\n";
    s += "0\nINSERT\n8\n0\n2\nB0\n70\n1000\n71\n100\n44\n1\n45\n1\n0\nENDBLK\n";
    s += "0\nBLOCK\n8\n0\n2\nB2\n10\n0\n20\n0\n30\n0\n";
    s += "0\nINSERT\n8\n0\n2\nB1\n70\n1000\n71\n100\n44\n1\n45\n1\n0\nENDBLK\n";
    s += "0\nENDSEC\n0\nSECTION\n2\nENTITIES\n";
    s += "0\nINSERT\n5\n" + handle + "\n8\nMisc\n2\nB2\n";
    s += "0\nENDSEC\n0\nEOF\n";
    return s;
}

/// A glTF file whose JSON nests `depth` arrays (Assimp's JSON parser recurses once per level:
/// 200,000 levels, 400 kB, overflowed its stack).
inline std::string deep_gltf(std::size_t depth = 200000) {
    return "{\"asset\":{\"version\":\"2.0\"},\"extras\":" + std::string(depth, '[') +
           std::string(depth, ']') + "}";
}

/// An ASCII FBX file whose nodes nest `depth` levels (Assimp's FBX parser recurses once per
/// level).
inline std::string deep_fbx(std::size_t depth = 200000) {
    std::string s = "; FBX 7.4.0 project file\n";
    s.reserve(s.size() + depth * 8);
    for (std::size_t i = 0; i < depth; ++i) s += "N: {\n";
    for (std::size_t i = 0; i < depth; ++i) s += "}\n";
    return s;
}

/// A GLB whose JSON chunk claims `chunk_length` bytes (2 GiB by default) in a file of a few
/// dozen: Assimp allocated the claimed size before reading.
inline std::string glb_with_chunk_length(std::uint32_t chunk_length = 0x80000000U) {
    const std::string json = R"({"asset":{"version":"2.0"}})";
    std::string s;
    const auto put = [&s](std::uint32_t v) {
        for (int i = 0; i < 4; ++i) s += static_cast<char>((v >> (8 * i)) & 0xffU);
    };
    s += "glTF";
    put(2);
    put(static_cast<std::uint32_t>(12 + 8 + json.size()));
    put(chunk_length);
    s += "JSON";
    s += json;
    return s;
}

/// A Collada file with one triangle whose <p> indices are fractional ("0.5 1.5 2.5").
inline std::string collada_fractional_indices() {
    return R"(<?xml version="1.0" encoding="utf-8"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
  <asset><unit name="meter" meter="1"/><up_axis>Z_UP</up_axis></asset>
  <library_geometries>
    <geometry id="g" name="g"><mesh>
      <source id="p"><float_array id="pa" count="9">0 0 0 1 0 0 0 1 0</float_array>
        <technique_common><accessor source="#pa" count="3" stride="3">
          <param name="X" type="float"/><param name="Y" type="float"/><param name="Z" type="float"/>
        </accessor></technique_common></source>
      <vertices id="v"><input semantic="POSITION" source="#p"/></vertices>
      <triangles count="1"><input semantic="VERTEX" source="#v" offset="0"/>
        <p>0.5 1.5 2.5</p></triangles>
    </mesh></geometry>
  </library_geometries>
  <library_visual_scenes><visual_scene id="s"><node id="n" name="n">
    <instance_geometry url="#g"/></node></visual_scene></library_visual_scenes>
  <scene><instance_visual_scene url="#s"/></scene>
</COLLADA>
)";
}

/// `ifc` (an IFC file's text) without its first line that defines an IFCCARTESIANPOINT, so
/// that the entities using it point at nothing (Assimp's IFC reader crashed on that).
inline std::string ifc_without_a_point(const std::string& ifc) {
    const std::size_t at = ifc.find("IFCCARTESIANPOINT((");
    if (at == std::string::npos) return ifc;
    const std::size_t begin = ifc.rfind('\n', at) + 1;  // npos + 1 == 0 on the first line
    const std::size_t end = ifc.find('\n', at);
    return ifc.substr(0, begin) + (end == std::string::npos ? "" : ifc.substr(end + 1));
}

/// The 1-based line of `text` on which `needle` starts (needle must occur).
inline std::size_t line_of(const std::string& text, std::string_view needle) {
    const auto at = static_cast<std::ptrdiff_t>(text.find(needle));
    return static_cast<std::size_t>(std::count(text.begin(), text.begin() + at, '\n')) + 1;
}

}  // namespace abrad::testing
