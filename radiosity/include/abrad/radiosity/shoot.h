#pragma once
// One shooting step from a point: rasterize every patch onto the hemicube with an A-buffer
// (Carpenter 1984) or a Z-buffer, propagate delta form factors through the depth-sorted
// fragment lists (Wang et al., "Using A-Buffer in Radiosity", Algorithm 1, PropFF), and merge
// the kept fragment lists into occlusion lists (Algorithm 2, MergeOcclusionList).

#include <cstdint>
#include <glm/geometric.hpp>
#include <glm/vec3.hpp>
#include <limits>
#include <span>
#include <string>
#include <vector>

#include "abrad/radiosity/bvh.h"
#include "abrad/radiosity/geometry.h"
#include "abrad/radiosity/hemicube.h"

namespace abrad::radiosity {

/// Visibility method of the hemicube.
enum class Visibility {
    ZBuffer,  ///< item buffer: one sample at each pixel centre, the nearest patch takes ΔF
    ABuffer,  ///< fragment lists with S×S coverage masks, translucency, undersampling masks
};

/// Where the light a patch takes lands when patches are split among targets (the
/// interreflection's elements: cells of a grid over each plane), so that a hemicube rasterizes
/// whole triangles and its form factors still go to the cells they cover.
class Targets {
  public:
    /// The cells of a square grid in a patch's plane: cell (i, j) holds the points x with
    /// floor((x − origin)·u / size) = i and floor((x − origin)·v / size) = j.
    struct Grid {
        glm::dvec3 origin{0.0}, u{1.0, 0.0, 0.0}, v{0.0, 1.0, 0.0};
        double size = 1.0;
    };
    virtual ~Targets() = default;
    /// The one target of `patch`, or kNoPatch when it spans several.
    virtual std::uint32_t whole(std::uint32_t patch) const = 0;
    /// The grid whose cells hold the targets of `patch` (one spanning several).
    virtual Grid grid(std::uint32_t patch) const = 0;
    /// The target of `patch` in cell (i, j) of its grid.
    virtual std::uint32_t cell(std::uint32_t patch, int i, int j) const = 0;
};

/// Patches a culling hemicube rasterizes before its walk (large_occluders: walls and slabs):
/// those within `near` of the shooter (per axis) nearest first, the others through their BVH,
/// front to back, skipping those hidden behind what is drawn. So a row does not pay for every
/// wall of the building.
struct Occluders {
    std::vector<std::uint32_t> ids;  ///< patch indices, ascending
    Bvh bvh;                         ///< over their boxes: item k is patch ids[k]
    double near = 0.0;               ///< metres
};

/// A shooter's large occluders within this many element sides (the room around it: 5 m at
/// the default 0.5 m elements) are drawn nearest first (Occluders::near).
inline constexpr double kNearOccluders = 10.0;

struct ShootOptions {
    Visibility method = Visibility::ABuffer;
    int subpixels = 8;      ///< A-buffer mask side S: 4, 8 or 16 (fine masks are 2S)
    bool occlusion = true;  ///< also build occlusion lists (Algorithm 2)
    /// Patch index the shooter belongs to (never rasterized), or kNoPatch.
    std::uint32_t exclude = kNoPatch;
    /// When set, only these patch indices are rasterized (the rest get form factor 0): the
    /// patches a light can reach (cull.h). Not owned; must outlive the call.
    const std::vector<std::uint32_t>* only = nullptr;
    /// When set (a BVH over the same patches, and `only` unset), the patches are visited
    /// front to back through it and, without occlusion lists, a whole node whose box lies
    /// behind the shooter's plane or behind closed pixels is skipped: a hemicube costs what it
    /// sees, not the size of the building. Form factors are those of the plain walk. Not
    /// owned; must outlive the call.
    const Bvh* bvh = nullptr;
    /// With `bvh` and `occlusion`: also cull what lies behind closed pixels (whole nodes and
    /// pieces), as without lists, so that a light's shot costs what it sees. The lists then
    /// hold only the pairs found in pixels before they closed (a receiver hidden wholly has
    /// none): for callers that complete them conservatively (the shadow edges' shaft
    /// queries). Form factors are unchanged.
    bool cull_listed = false;
    /// Form factors as `ShootResult::hits` (only the patches that got some) instead of the
    /// dense `form_factor`, so that a shot's cost does not grow with the patch count.
    bool sparse = false;
    /// When set (with `sparse`, without occlusion lists), `hits` are by target: each
    /// fragment's form factor goes to the target holding the point its pixel sees. Not owned.
    const Targets* targets = nullptr;
    /// With `bvh`: patches rasterized before the walk (large_occluders: walls and slabs; the
    /// near ones nearest first, the others through their own BVH, Occluders), so that the
    /// pixels they close hide what lies behind them from the start, not only once the walk
    /// reaches them. Form factors are unchanged. Not owned.
    const Occluders* occluders_first = nullptr;
    /// A piece of a patch that holds none of a pixel's S × S samples gets a 2S × 2S mask of
    /// its own (the paper's rule for undersampled patches). False (with `sparse` or
    /// `targets`): a projected piece under a quarter of a sample's area is one partial sample,
    /// the one holding its centroid, whose coverage is its area over the sample's (partial
    /// samples in one sample add up, as the small faces of a mesh do, to at most the whole
    /// sample); a larger piece is point sampled, the pixels where it holds no sample left out
    /// (docs/algorithms.md#a-buffer). For form factors summed over many pixels (the elements'
    /// rows, the gathers of probes and grids).
    bool fine_masks = true;
};

/// A patch and its form factor from the shooting point.
struct PatchFormFactor {
    std::uint32_t patch;
    double ff;
};

/// One occlusion relation: `occluder` is in front of `receiver` along some hemicube ray.
struct OcclusionPair {
    std::uint32_t receiver;
    std::uint32_t occluder;
    friend bool operator==(const OcclusionPair&, const OcclusionPair&) = default;
};

struct ShootResult {
    /// Form factor from the shooting point to each patch (the fraction of the point's
    /// emitted power the patch absorbs or stops, weighted by its opacity). Same size as the
    /// patch list.
    std::vector<double> form_factor;
    /// With ShootOptions::sparse, instead of `form_factor`: the patches (or, with
    /// ShootOptions::targets, the targets) with F > 0, ascending.
    std::vector<PatchFormFactor> hits;
    /// Occlusion pairs sorted by (receiver, occluder), without duplicates.
    std::vector<OcclusionPair> occlusion;
    std::size_t fragments = 0;            ///< fragments stored over all pixels
    std::size_t undersampled_pixels = 0;  ///< fragments with a finer mask, or partial samples
    std::size_t raw_pairs = 0;            ///< occlusion pairs found before deduplication
    std::size_t hidden_pieces = 0;        ///< patch pieces culled as hidden behind closed pixels
    std::size_t hidden_nodes = 0;         ///< BVH nodes skipped whole (behind or hidden)
    std::size_t visited = 0;              ///< patches clipped and projected
    /// With ShootOptions::cull_listed (its receivers are found from them): the patches clipped
    /// and projected (not culled whole), in the order visited. Empty otherwise, so that the
    /// interreflection's rows and the gathers copy nothing they do not read.
    std::vector<std::uint32_t> rasterized;
    double seconds_occlusion = 0.0;  ///< time spent merging occlusion lists (Algorithm 2)

    /// Occluders of `receiver` (a sub-range of `occlusion`).
    std::span<const OcclusionPair> occluders_of(std::uint32_t receiver) const;
};

/// The hemicube frame of a patch: at its centroid, around its front (counter-clockwise) normal.
inline ShooterFrame frame_of(const Patch& p) {
    return ShooterFrame::at(centroid(p), unit_normal(p));
}

/// The A-buffer mask sides shoot supports (ShootOptions::subpixels): 4, 8 or 16.
constexpr bool supported_subpixels(int s) { return s == 4 || s == 8 || s == 16; }

/// Shoots from `frame` (a point and its normal) to `patches` with a hemicube of the given
/// resolution. Patches behind the shooter's plane get nothing; every patch occludes from
/// both sides. Throws std::invalid_argument for an unsupported `subpixels`.
ShootResult shoot(const ShooterFrame& frame, std::span<const Patch> patches,
                  const Hemicube& hemicube, const ShootOptions& options);

/// The opaque patches of at least `min_area` (squared units of the coordinates), ascending:
/// the occluders a culling hemicube rasterizes first (ShootOptions::occluders_first), those
/// within `near` nearest first.
Occluders large_occluders(std::span<const Patch> patches, double min_area, double near);

std::string to_string(Visibility method);

}  // namespace abrad::radiosity
