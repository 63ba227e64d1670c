// Fuzz target: the scene file (TOML through toml++ in a child process, then abrad's tables).

#include "abrad/convert/obj_import.h"
#include "abrad/convert/scene_file.h"
#include "fuzz_target.h"

ABRAD_FUZZ_TARGET(scene) {
    try {
        (void)abrad::convert::read_scene_file(
            abrad::fuzz::write_input("scene.toml", abrad::fuzz::as_text(data, size)));
    } catch (const abrad::convert::ImportError&) {
    }
    return 0;
}
