// Format dispatch: OBJ through abrad's strict reader, the rest through Assimp; one healing.

#include "abrad/convert/import.h"

#include <algorithm>
#include <cctype>

#include "raw_model.h"

namespace abrad::convert {

namespace {

const std::vector<std::string>& assimp_extensions() {
    static const std::vector<std::string> kExtensions = {"gltf", "glb", "3ds", "dae", "fbx",
                                                         "dxf",  "ifc", "stl", "ply", "off"};
    return kExtensions;
}

std::string lower_extension(const std::filesystem::path& path) {
    std::string ext = path.extension().string();
    if (!ext.empty() && ext.front() == '.') ext.erase(0, 1);
    std::transform(ext.begin(), ext.end(), ext.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    return ext;
}

/// Shifts the origin, heals and records the source.
ImportResult finish(detail::RawModel raw, const ImportOptions& options, ImportResult result) {
    for (glm::dvec3& p : raw.positions) p -= options.origin_shift;
    for (visdb::Camera& c : raw.cameras) {
        c.position -= options.origin_shift;
        c.look_at -= options.origin_shift;
    }
    result.scene = detail::heal(raw, {options.weld_tolerance}, result.report);
    raw.source.imported_at = detail::utc_now_iso8601();
    raw.source.report = result.report.to_string();
    result.scene.sources.push_back(std::move(raw.source));
    return result;
}

}  // namespace

ImportResult import_obj(const std::filesystem::path& path, const ImportOptions& options) {
    ImportResult result;
    detail::RawModel raw = detail::read_obj(path, options, result.report.notes);
    return finish(std::move(raw), options, std::move(result));
}

std::vector<std::string> supported_extensions() {
    std::vector<std::string> all{"obj"};
    for (const std::string& e : assimp_extensions()) all.push_back(e);
    return all;
}

ImportResult import_model(const std::filesystem::path& path, const ImportOptions& options) {
    const std::string ext = lower_extension(path);
    const std::string file = path.string();
    ImportResult result;
    detail::RawModel raw;
    if (ext == "obj") {
        raw = detail::read_obj(path, options, result.report.notes);
    } else if (std::find(assimp_extensions().begin(), assimp_extensions().end(), ext) !=
               assimp_extensions().end()) {
        raw = detail::read_assimp(path, options, result.report.notes);
    } else if (ext == "step" || ext == "stp" || ext == "iges" || ext == "igs") {
        throw ImportError(file, 0,
                          "STEP and IGES need OpenCASCADE, which this build does not include; "
                          "export the model as IFC, glTF or OBJ");
    } else {
        std::string known;
        for (const std::string& e : supported_extensions())
            known += (known.empty() ? "" : ", ") + e;
        throw ImportError(file, 0,
                          "unknown model format '" + (ext.empty() ? std::string("(none)") : ext) +
                              "' (abrad reads " + known + ")");
    }
    return finish(std::move(raw), options, std::move(result));
}

}  // namespace abrad::convert
