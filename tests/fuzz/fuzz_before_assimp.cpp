// Fuzz targets: what abrad checks and rewrites before Assimp sees a file, in this process: the
// DXF pre-pass and INSERT expansion (dxf), the PLY walk (ply), the GLB chunk lengths (glb),
// the Collada XML and index checks (dae: expat) and the 3DS chunk walk (tds).

#include <vector>

#include "abrad/convert/obj_import.h"
#include "fuzz_target.h"
#include "raw_model.h"

namespace {

int check(const std::uint8_t* data, std::size_t size, const std::string& ext) {
    std::vector<std::string> notes;
    try {
        abrad::convert::detail::check_before_assimp(abrad::fuzz::as_text(data, size), ext,
                                                    "input." + ext, notes);
    } catch (const abrad::convert::ImportError&) {
    }
    return 0;
}

}  // namespace

#if !defined(ABRAD_FUZZ_LIBFUZZER) || defined(ABRAD_FUZZ_DXF)
ABRAD_FUZZ_TARGET(dxf) { return check(data, size, "dxf"); }
#endif
#if !defined(ABRAD_FUZZ_LIBFUZZER) || defined(ABRAD_FUZZ_PLY)
ABRAD_FUZZ_TARGET(ply) { return check(data, size, "ply"); }
#endif
#if !defined(ABRAD_FUZZ_LIBFUZZER) || defined(ABRAD_FUZZ_GLB)
ABRAD_FUZZ_TARGET(glb) { return check(data, size, "glb"); }
#endif
#if !defined(ABRAD_FUZZ_LIBFUZZER) || defined(ABRAD_FUZZ_DAE)
ABRAD_FUZZ_TARGET(dae) { return check(data, size, "dae"); }
#endif
#if !defined(ABRAD_FUZZ_LIBFUZZER) || defined(ABRAD_FUZZ_TDS)
ABRAD_FUZZ_TARGET(tds) { return check(data, size, "3ds"); }
#endif
