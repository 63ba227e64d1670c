// Format dispatch: OBJ through abrad's strict reader, the rest through Assimp; one healing.

#include "abrad/convert/import.h"

#include <algorithm>
#include <cctype>

#include "raw_model.h"

namespace abrad::convert {

namespace {

constexpr const char* kNeedsOpenCascade =
    "STEP and IGES need OpenCASCADE, which this build does not include; "
    "export the model as IFC, glTF or OBJ";

// The format whose extensions include `ext`, or null.
const ModelFormat* format_of(const std::string& ext) {
    for (const ModelFormat& f : model_formats())
        if (std::find(f.extensions.begin(), f.extensions.end(), ext) != f.extensions.end())
            return &f;
    return nullptr;
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

const std::vector<ModelFormat>& model_formats() {
    static const std::vector<ModelFormat> kFormats = {
        {"OBJ", {"obj"}, ModelReader::Obj, ""},
        {"glTF", {"gltf", "glb"}, ModelReader::Assimp, ""},
        {"3DS", {"3ds"}, ModelReader::Assimp, ""},
        {"Collada", {"dae"}, ModelReader::Assimp, ""},
        {"FBX", {"fbx"}, ModelReader::Assimp, ""},
        {"DXF", {"dxf"}, ModelReader::Assimp, ""},
        {"IFC", {"ifc"}, ModelReader::Assimp, ""},
        {"STL", {"stl"}, ModelReader::Assimp, ""},
        {"PLY", {"ply"}, ModelReader::Assimp, ""},
        {"OFF", {"off"}, ModelReader::Assimp, ""},
        {"STEP", {"step", "stp"}, ModelReader::Unavailable, kNeedsOpenCascade},
        {"IGES", {"iges", "igs"}, ModelReader::Unavailable, kNeedsOpenCascade},
    };
    return kFormats;
}

std::vector<std::string> supported_extensions() {
    std::vector<std::string> all;
    for (const ModelFormat& f : model_formats())
        if (f.reader != ModelReader::Unavailable)
            all.insert(all.end(), f.extensions.begin(), f.extensions.end());
    return all;
}

ImportResult import_model(const std::filesystem::path& path, const ImportOptions& options) {
    const std::string ext = lower_extension(path);
    const std::string file = path.string();
    ImportResult result;
    detail::RawModel raw;
    const ModelFormat* format = format_of(ext);
    if (!format) {
        std::string known;
        for (const std::string& e : supported_extensions())
            known += (known.empty() ? "" : ", ") + e;
        throw ImportError(file, 0,
                          "unknown model format '" + (ext.empty() ? std::string("(none)") : ext) +
                              "' (abrad reads " + known + ")");
    }
    switch (format->reader) {
        case ModelReader::Obj:
            raw = detail::read_obj(path, options, result.report.notes);
            break;
        case ModelReader::Assimp:
            raw = detail::read_assimp(path, options, result.report.notes);
            break;
        case ModelReader::Unavailable:
            throw ImportError(file, 0, format->note);
    }
    return finish(std::move(raw), options, std::move(result));
}

}  // namespace abrad::convert
