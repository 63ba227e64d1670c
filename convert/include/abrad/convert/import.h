#pragma once
// One entry point for every model format: OBJ through abrad's own strict reader, the CAD and
// mesh formats through Assimp, then the same reported healing for all.

#include <filesystem>
#include <string>
#include <vector>

#include "abrad/convert/obj_import.h"

namespace abrad::convert {

/// File extensions `import_model` reads (lower case, without the dot).
std::vector<std::string> supported_extensions();

/// Reads `path` by its extension (case-insensitive): obj through the OBJ reader; gltf, glb,
/// 3ds, dae, fbx, dxf, ifc, stl, ply, off through Assimp. Applies the unit, up axis and
/// origin shift of `options`, heals, and fills the report. Throws ImportError (file and place)
/// on bad input, an unknown format, or a format this build cannot read.
ImportResult import_model(const std::filesystem::path& path, const ImportOptions& options);

}  // namespace abrad::convert
