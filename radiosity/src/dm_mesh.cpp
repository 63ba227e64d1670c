// PLACEHOLDER: being written.
#include "abrad/radiosity/dm_mesh.h"
#include <stdexcept>
namespace abrad::radiosity {
std::vector<MeshedRegion> mesh_regions(std::span<const PlanarRegion>, const DmOptions&, DmStats*) {
    throw std::logic_error("mesh_regions: not written yet");
}
}  // namespace abrad::radiosity
