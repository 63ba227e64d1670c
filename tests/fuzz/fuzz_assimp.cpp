// Fuzz targets: the Assimp path per format (read_assimp: the checks before Assimp, then Assimp
// and the flattening in a child process). A crash inside Assimp is the child's and ends as an
// ImportError; a finding here is one in the parent (the child's result, the messages).

#include <vector>

#include "abrad/convert/obj_import.h"
#include "fuzz_target.h"
#include "raw_model.h"

namespace {

int read(const std::uint8_t* data, std::size_t size, const std::string& ext) {
    std::vector<std::string> notes;
    try {
        (void)abrad::convert::detail::read_assimp(
            abrad::fuzz::write_input("model." + ext, abrad::fuzz::as_text(data, size)), {}, notes);
    } catch (const abrad::convert::ImportError&) {
    }
    return 0;
}

}  // namespace

#define ABRAD_ASSIMP_FORMAT(ext) \
    ABRAD_FUZZ_TARGET(assimp_##ext) { return read(data, size, #ext); }
#define ABRAD_ASSIMP_FORMAT_EXPANDED(ext) ABRAD_ASSIMP_FORMAT(ext)

#if !defined(ABRAD_FUZZ_LIBFUZZER)
ABRAD_ASSIMP_FORMAT(gltf)
ABRAD_ASSIMP_FORMAT(glb)
ABRAD_ASSIMP_FORMAT(dae)
ABRAD_ASSIMP_FORMAT(fbx)
ABRAD_ASSIMP_FORMAT(3ds)
ABRAD_ASSIMP_FORMAT(dxf)
ABRAD_ASSIMP_FORMAT(ifc)
ABRAD_ASSIMP_FORMAT(stl)
ABRAD_ASSIMP_FORMAT(ply)
ABRAD_ASSIMP_FORMAT(off)
#else
ABRAD_ASSIMP_FORMAT_EXPANDED(ABRAD_FUZZ_ASSIMP_EXT)
#endif
