// Fuzz target: the OBJ/MTL reader and healing (import_obj). The input is the OBJ file; after a
// line "#mtl" the rest is the material library m.mtl (seeds say `mtllib m.mtl`).

#include "abrad/convert/obj_import.h"
#include "fuzz_target.h"

ABRAD_FUZZ_TARGET(obj) {
    const std::string_view text = abrad::fuzz::as_text(data, size);
    const std::size_t split = text.find("\n#mtl\n");
    const std::string_view obj = text.substr(0, split);
    const std::string_view mtl =
        split == std::string_view::npos ? std::string_view() : text.substr(split + 6);
    (void)abrad::fuzz::write_input("m.mtl", mtl);
    try {
        (void)abrad::convert::import_obj(abrad::fuzz::write_input("model.obj", obj), {});
    } catch (const abrad::convert::ImportError&) {
    }
    return 0;
}
