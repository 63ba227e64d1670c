#pragma once
// The bake: one shooting iteration per light-source triangle with the A-buffer (or Z-buffer)
// hemicube, then a radiosity value at every vertex (Wang et al., "Using A-Buffer in
// Radiosity", section 3.5).

#include <cstddef>
#include <functional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "abrad/radiosity/indirect.h"
#include "abrad/radiosity/shadow_edges.h"
#include "abrad/radiosity/shoot.h"
#include "abrad/visdb/model.h"

namespace abrad::radiosity {

/// How vertex shades are computed.
enum class Shading {
    Exact,  ///< exact direct irradiance at each vertex, occluders from the fragment lists
    Patch,  ///< area-weighted irradiance of the vertex's patches from the hemicube (the paper)
};

/// Settings of a bake. Defaults are the documented command-line defaults.
struct BakeOptions {
    std::string name;  ///< stored bake name; empty = "bake-<n>" chosen by the caller
    Visibility method = Visibility::ABuffer;
    int resolution = 50;  ///< hemicube resolution R (even)
    int subpixels = 8;    ///< A-buffer mask side
    /// Interreflection: 0 = direct light only (the paper's setting, the default), -1 = shoot
    /// from reflecting elements until the unshot fraction is below `converge`, N = N bounces
    /// (Jacobi sweeps).
    int bounces = 0;
    double converge = 0.005;      ///< unshot power / emitted power at which to stop
    double element_size = 0.5;    ///< metres: element grid of the interreflection solution
    double overrelaxation = 1.0;  ///< Southwell ω in [1, 2) when converging
    bool ambient = true;          ///< spread what is left unshot as the ambient term
    /// When set, receives the convergence curve (unshot fraction against shots and time).
    std::vector<ConvergenceSample>* convergence = nullptr;
    Shading shading = Shading::Exact;
    int threads = 0;  ///< 0 = all cores
    /// Light reach in metres (0 = unlimited): a light shoots, shades and casts shadow edges only
    /// on triangles whose box meets the cube of this half side around it (cull.h states the
    /// error bound). Triangles wholly behind a light's plane are always culled (exact).
    double reach = 0.0;
    /// Discontinuity meshing: receivers re-meshed along the shadow edges (CGAL CDT per
    /// planar region), then refined where the exact irradiance departs from linear.
    bool dm = true;
    LightModel lights = LightModel::Area;  ///< how lights cast shadow edges
    double dm_min_angle = 0.0;  ///< Ruppert/Chew minimum angle, degrees (0 = none, max 20.7)
    int refine_rounds = 4;      ///< illumination-driven refinement rounds (0 = shadow edges only)
    double refine_tolerance = 0.1;  ///< split an edge when its midpoint's exact irradiance departs
                                    ///< from the linear interpolation by more than this, relative
    double refine_min_edge = 0.05;  ///< edges shorter than this (metres) are not split
};

/// Bad bake settings or a scene that cannot be baked (no lights...): the caller exits 2.
class BakeError : public std::runtime_error {
  public:
    using std::runtime_error::runtime_error;
};

/// Progress of a long bake: a stage name and `done` of `total` units.
using ProgressFn = std::function<void(std::string_view stage, std::size_t done, std::size_t total)>;

/// Checks options (resolution even in [2, 4096], subpixels 4/8/16, bounces in [-1, 1000],
/// converge in (0, 1), element_size > 0, overrelaxation in [1, 2), threads >= 0,
/// reach >= 0,
/// dm_min_angle in [0, 20.7], refine_rounds in [0, 20], refine_tolerance > 0,
/// refine_min_edge > 0); throws BakeError naming the option and value.
void validate(const BakeOptions& options);

/// Bakes direct light into `scene`, then (bounces != 0) interreflection: the indirect part,
/// interpolated from the element solution, is added to every vertex's direct value. Without
/// discontinuity meshing the result's mesh is the scene's, with one vertex per (surface,
/// position, face normal); with it, each planar region is re-meshed (conforming: no
/// T-vertices) and every vertex, old and new, is shaded by the shading mode. Parameters and
/// statistics are filled, `name` is options.name.
visdb::Bake bake(const visdb::Scene& scene, const BakeOptions& options,
                 const ProgressFn& progress = {});

std::string to_string(Shading shading);

}  // namespace abrad::radiosity
