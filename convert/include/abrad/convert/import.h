#pragma once
// One entry point for every model format: OBJ through abrad's own strict reader, the CAD and
// mesh formats through Assimp, then the same reported healing for all.

#include <filesystem>
#include <string>
#include <vector>

#include "abrad/convert/obj_import.h"

namespace abrad::convert {

/// Which reader reads a model format.
enum class ModelReader {
    Obj,          ///< abrad's own strict OBJ/MTL reader
    Assimp,       ///< Assimp
    Unavailable,  ///< not in this build: refused with ModelFormat::note
};

/// One model format: import_model's dispatch and its messages come from the table of these.
struct ModelFormat {
    std::string name;                     ///< e.g. "glTF"
    std::vector<std::string> extensions;  ///< lower case, without the dot
    ModelReader reader;
    std::string note;  ///< Unavailable: why and what to do instead
};

/// Every model format import_model knows, readable ones first, in the order messages list them.
const std::vector<ModelFormat>& model_formats();

/// File extensions `import_model` reads (lower case, without the dot), in table order.
std::vector<std::string> supported_extensions();

/// Reads `path` by its extension (case-insensitive): obj through the OBJ reader; gltf, glb,
/// 3ds, dae, fbx, dxf, ifc, stl, ply, off through Assimp. Applies the unit, up axis and
/// origin shift of `options`, heals, and fills the report. Throws ImportError (file and place)
/// on bad input, an unknown format, or a format this build cannot read.
ImportResult import_model(const std::filesystem::path& path, const ImportOptions& options);

}  // namespace abrad::convert
