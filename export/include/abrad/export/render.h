#pragma once
// abrad's own Gouraud rasterizer for baked meshes, and the cameras it (and the POV-Ray
// export) look through. The rasterizer samples each pixel at its centre and interpolates
// vertex values perspective-correctly, as a ray tracer hitting the triangle would: rendered
// with the same camera, the POV-Ray `pov` export and render_bake() agree to rounding.

#include <cstdint>
#include <glm/vec3.hpp>
#include <stdexcept>
#include <string_view>
#include <vector>

#include "abrad/visdb/model.h"

namespace abrad::exporter {

/// A camera name that the scene does not hold (bad input); what() lists the cameras it has.
class CameraError : public std::invalid_argument {
  public:
    using std::invalid_argument::invalid_argument;
};

/// The camera called `name` among `scene.cameras`; an empty name picks the scene's first
/// camera, or default_camera() when it has none. Throws CameraError for an unknown name.
visdb::Camera select_camera(const visdb::Scene& scene, std::string_view name);

/// A camera inside the largest room looking at its centre: the largest upward-facing
/// non-emitting surface with a ceiling above it (the floor of a room) gets the eye 75 % of the
/// way from its area centroid toward its bounding-box corner (min x, min y), min(1.6 m, 0.6 h)
/// above the floor, looking at the centroid 0.35 h above the floor, fov 70°. The ceiling height
/// h is measured by a ray up from the centroid to the first non-emitting face whose front faces
/// down on a surface whose downward faces span at least half of the floor's bounding box (xy):
/// furniture over the floor's centre (a table top's underside) is passed, not taken for the
/// ceiling. A scene without such a floor is seen from outside: from the (-x, -y, +z) side of its
/// bounding box, far enough to hold it. Named "default". Precondition: the scene has at least
/// one triangle (else a camera at the origin looking along +y is returned).
visdb::Camera default_camera(const visdb::Scene& scene);

/// A camera's orthonormal frame in metres for an image of `width` × `height` pixels: pixel
/// (i, j) looks along forward + ((i + 0.5) / width - 0.5) * right_extent * right
/// + (0.5 - (j + 0.5) / height) * up_extent * up (j = 0 is the top row), where
/// up_extent = 2 tan(fov_y / 2) and right_extent = up_extent * width / height.
struct CameraFrame {
    glm::dvec3 eye{0.0};
    glm::dvec3 forward{0.0, 1.0, 0.0};
    glm::dvec3 right{1.0, 0.0, 0.0};
    glm::dvec3 up{0.0, 0.0, 1.0};
    double up_extent = 1.0;
    double right_extent = 1.0;
};

/// The frame of `camera`. Throws CameraError when position and look_at coincide, up is
/// parallel to the view direction, or the fov is not in (0, 180) degrees.
CameraFrame camera_frame(const visdb::Camera& camera, int width, int height);

/// Which vertex value a render interpolates.
enum class RenderQuantity {
    Radiosity,   ///< B per RGB channel (W/m² or lm/m²): what the eye sees, up to 1/π
    Irradiance,  ///< H per RGB channel (W/m² or lux)
};

struct RenderOptions {
    int width = 640;
    int height = 480;
    RenderQuantity quantity = RenderQuantity::Radiosity;
    double near = 1e-3;  ///< near clipping distance, metres
};

/// The `Raster::triangle` of a pixel that no triangle covers.
inline constexpr std::uint32_t kNoTriangle = 0xffffffffu;

/// A rendered buffer: per pixel the interpolated linear value (not exposed or tone mapped)
/// and what covers it: 0 nothing, 1 the front of a face, 2 the back of a face (a bake shades
/// fronts only, so backs hold 0, as uncovered pixels do), and which triangle.
struct Raster {
    int width = 0;
    int height = 0;
    std::vector<glm::vec3> value;         ///< row-major, top row first
    std::vector<std::uint8_t> covered;    ///< 0 nothing, 1 front face, 2 back face
    std::vector<std::uint32_t> triangle;  ///< index into the mesh's triangles, or kNoTriangle
};

/// Rasterizes `mesh` through `camera`: both faces of every triangle are drawn (backs black),
/// the nearest wins (Z-buffer on view depth), values are interpolated perspective-correctly between
/// the triangle's vertices, pixels sampled at their centres (no antialiasing). Triangles are
/// clipped at `options.near`. Throws ExportError on an inconsistent mesh, CameraError on a
/// degenerate camera, std::invalid_argument on a non-positive size.
Raster render_bake(const visdb::BakeMesh& mesh, const visdb::Camera& camera,
                   const RenderOptions& options);

}  // namespace abrad::exporter
