// Fuzz target: the probe points CSV (radiosity::read_probe_points).

#include "abrad/radiosity/grid.h"
#include "fuzz_target.h"

ABRAD_FUZZ_TARGET(probe) {
    try {
        (void)abrad::radiosity::read_probe_points(
            abrad::fuzz::write_input("points.csv", abrad::fuzz::as_text(data, size)));
    } catch (const abrad::radiosity::InputFileError&) {
    }
    return 0;
}
