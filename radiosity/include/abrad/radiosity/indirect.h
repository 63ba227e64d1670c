#pragma once
// Interreflection by progressive refinement (Cohen, Chen, Wallace & Greenberg 1988) seen as
// Southwell relaxation (Gortler, Cohen & Slusallek 1993): reflecting elements shoot their
// unshot radiosity with the same A-buffer hemicube as the lights, in order of unshot power,
// optionally over-relaxed; what is left unshot at the end is spread as the ambient term.
//
// Elements are cells of the scene's planar regions (coplanar, connected triangles of one
// surface): every region is cut by a square grid of side `element_size` in its plane, and the
// parts of its triangles in one cell (exact triangle ∩ cell polygons) make one element. The
// element's radiosity is constant; values between elements are interpolated bilinearly from the
// cell centres of the region's grid. Elements receive alone but shoot in groups (shooters:
// blocks of cells, and small faces grouped by place and facing), one hemicube per group, the
// shooting side of a hierarchy (Hanrahan, Salzman & Aupperle 1991) one level deep.

#include <cstddef>
#include <cstdint>
#include <functional>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "abrad/radiosity/direct.h"
#include "abrad/radiosity/hemicube.h"
#include "abrad/radiosity/shoot.h"
#include "abrad/radiosity/stage.h"
#include "abrad/visdb/model.h"

namespace abrad::radiosity {

class Cluster;

/// The scene as the interreflection solver sees it. All spans are per triangle (patch)
/// except `region_normal`, which is per region; coordinates in metres.
/// Each planar region as few triangles as its outline allows (dm_mesh.h
/// outline_triangulation), where that is fewer than its own, for what only asks where the
/// surfaces are: the interreflection's hemicubes, the exact shadow queries. The union of a
/// region's outline patches is the union of its patches, and each has its opacity.
struct Outlines {
    std::vector<Patch> patches;
    std::vector<std::uint32_t> region;  ///< per patch
    std::vector<std::uint32_t> source;  ///< per patch: the input patch it is, or kNoPatch
};
Outlines outline_patches(std::span<const Patch> patches, std::span<const std::uint32_t> region,
                         std::span<const glm::dvec3> region_normal);

struct IndirectInput {
    std::span<const Patch> patches;
    std::span<const visdb::Rgb> reflectance;
    std::span<const visdb::Rgb> emittance;      ///< > 0 marks a light-source triangle
    std::span<const std::uint32_t> region;      ///< planar region of each triangle
    std::span<const glm::dvec3> region_normal;  ///< unit front normal of each region
    /// Point sources (point_source.h): each shoots first, like a light triangle, through two
    /// hemicubes weighted by its web, so its flux feeds the interreflection.
    std::span<const visdb::Luminaire> luminaires = {};
    /// outline_patches of these patches and regions when the caller has them (the bake
    /// shares them with its exact shadow queries); made here otherwise. Not owned.
    const Outlines* outlines = nullptr;
};

struct IndirectOptions {
    /// Number of bounces (each one a Jacobi sweep: every element shoots what it received in
    /// the previous bounce), or 0 to converge on the unshot fraction instead.
    int bounces = 0;
    /// Stop when unshot power / emitted power falls below this; without the ambient term, when
    /// the light still to come (unshot power / (1 − mean ρ)) falls below this fraction of the
    /// reflected light (that and what was received)
    double converge = 0.005;
    double element_size = 0.5;  ///< metres: side of the element grid in each region
    /// Elements shoot in groups (shooters): blocks of shooter_cells × shooter_cells cells of a
    /// region, and the small faces within cubes of that side; 1 = every element alone.
    int shooter_cells = 2;
    double overrelaxation = 1.0;        ///< Southwell factor ω in [1, 2): shoot ω × unshot
    bool ambient = true;                ///< spread what is left unshot as the ambient term
    std::size_t max_shots = 2'000'000;  ///< a safety bound on shots when converging
    std::size_t row_cache_bytes = std::size_t{2} << 30;  ///< form-factor rows kept for reuse
    Visibility method = Visibility::ABuffer;
    int resolution = 50;      ///< hemicube of the lights' shots onto the elements
    int row_resolution = 50;  ///< hemicube of the elements' rows
    /// Undersampled pieces in the rows' hemicubes get finer masks (ShootOptions::fine_masks);
    /// false: one translucent sample each, as accurate for a row's sums and a quarter cheaper
    bool row_fine_masks = false;
    int subpixels = 8;  ///< A-buffer mask side of the lights' shots onto the elements
    /// A-buffer mask side of the elements' rows: 4 × 4 samples a pixel. A row's form factors
    /// are sums over many pixels, where the coarser masks cost little accuracy and a sixth of
    /// the interreflection's time (docs/algorithms.md#interreflection)
    int row_subpixels = 4;
    /// When set, the MPI ranks that share the solve (cluster.h): every rank calls
    /// solve_indirect with the same input; each computes its share of the hemicubes (the
    /// lights' and the shooters' rows, split by measured cost) and receives the others', so
    /// that every rank shoots the same rows in the same order and holds the same solution,
    /// whatever the number of ranks.
    Cluster* cluster = nullptr;
};

/// One point of the convergence curve.
struct ConvergenceSample {
    std::size_t shots = 0;
    double seconds = 0.0;
    double unshot_fraction = 0.0;  ///< Σ|unshot power| / emitted power
};

/// Energy bookkeeping of the whole solution (direct shots from the lights included), in W
/// (or lm), mean over RGB; a luminaire emits luminaire_power (its web's flux × scale ×
/// maintenance factor). emitted = absorbed + escaped + unshot, up to rounding.
struct EnergyBalance {
    double emitted = 0.0;
    double absorbed = 0.0;  ///< by fronts ((1 − ρ) of what they receive) and by backs (all)
    double escaped = 0.0;   ///< what no hemicube pixel caught: through openings, to the sky
    double unshot = 0.0;    ///< received and reflected but not yet shot (signed)
    double ambient = 0.0;   ///< the part of `unshot` spread by the ambient term
};

/// The solved interreflection: indirect irradiance per element, and a way to read it at any
/// point of a region.
struct IndirectSolution {
    /// Interpolated indirect irradiance (W/m² or lux, RGB) at `p` in planar region `region`:
    /// bilinear between the centres of the region's grid cells, over the cells that hold an
    /// element (0 in a region without elements).
    visdb::Rgb at(std::uint32_t region, const glm::dvec3& p) const;
    /// Whether `at` interpolates at `p`: all four cells around it hold elements. False within
    /// half a cell of the region's boundary (and on regions smaller than two cells), where
    /// `at` extrapolates the nearest centres' values: gather_indirect is for those points.
    bool interpolates(std::uint32_t region, const glm::dvec3& p) const;
    /// `p` in the coordinates of `region`'s cell centres: the centre of cell (i, j) at (i, j).
    glm::dvec2 centre_coordinates(std::uint32_t region, const glm::dvec3& p) const;

    // What the solution did
    std::size_t pieces = 0;  ///< parts of triangles in elements (triangle ∩ cell)
    /// Triangles the hemicubes rasterize: each planar region's outline triangulation where it
    /// has fewer than the region (dm_mesh.h outline_triangulation), else its own
    std::size_t visibility_triangles = 0;
    std::size_t shooters = 0;            ///< groups of elements that shoot as one
    std::size_t shots = 0;               ///< shooter shots (the lights' not counted)
    std::size_t rows_computed = 0;       ///< hemicubes placed at shooters
    std::size_t rows_cached = 0;         ///< form-factor rows kept for reuse at the end
    int bounces_done = 0;                ///< complete bounces (bounce mode)
    visdb::Rgb ambient_irradiance{0.0};  ///< added to every element by the ambient term
    double seconds = 0.0;
    EnergyBalance energy;
    std::vector<ConvergenceSample> curve;

    /// One element: a cell of its region's grid.
    struct Element {
        std::uint32_t region = 0;
        glm::ivec2 cell{0};
        glm::dvec3 centroid{0.0};
        double area = 0.0;            ///< m²
        visdb::Rgb reflectance{0.0};  ///< area-weighted over its triangles
        visdb::Rgb direct{0.0};       ///< irradiance from the lights' hemicubes
        visdb::Rgb indirect{0.0};     ///< irradiance from other elements (+ ambient)
    };
    std::vector<Element> elements;

    /// Each region's grid: origin and in-plane axes; cell (i, j) covers
    /// origin + [i, i+1)·size·u + [j, j+1)·size·v.
    struct Grid {
        glm::dvec3 origin{0.0}, u{1.0, 0.0, 0.0}, v{0.0, 1.0, 0.0};
    };
    std::vector<Grid> grids;
    std::unordered_map<std::uint64_t, std::uint32_t> cell_element;  ///< cell_key → element
    /// Per visibility triangle (Outlines::patches): the element it lies wholly in, or
    /// kNoElement, and the element its pixels go to off the region's cells (gather_indirect's
    /// hemicubes hand fragments to elements as the rows' do)
    std::vector<std::uint32_t> visibility_whole, visibility_main;

    /// The element of cell (i, j) of `region`, or kNoElement: a dense table per region over
    /// its cells' bounding rectangle (the hash map for regions whose rectangle is mostly
    /// empty). The hemicubes ask this for every fragment of a triangle larger than a cell.
    std::uint32_t element_at(std::uint32_t region, int i, int j) const;
    /// The element of the cell holding point `p` of `region`'s plane, or kNoElement.
    std::uint32_t element_at(std::uint32_t region, const glm::dvec3& p) const;
    static constexpr std::uint32_t kNoElement = 0xFFFFFFFFu;
    /// Builds the dense tables from `elements` (after the elements are made).
    void index_cells();
    double element_size = 0.5;

    static std::uint64_t cell_key(std::uint32_t region, int i, int j);

  private:
    struct CellTable {
        int i0 = 0, j0 = 0, ni = 0, nj = 0;  // ni = 0: not tabled, ask the map
        std::size_t offset = 0;
    };
    std::vector<CellTable> m_tables;  // per region
    std::vector<std::uint32_t> m_cells;
};

/// Checks options (bounces in [0, 1000], converge in (0, 1), element_size > 0,
/// shooter_cells in [1, 16], overrelaxation in [1, 2), row_resolution even in [2, 4096]);
/// throws InputError naming the option.
void validate(const IndirectOptions& options);

/// Solves the interreflection of `input`: shoots once from every light triangle and every
/// luminaire onto the elements, then from the elements until `bounces` bounces are done or the
/// fraction left (IndirectOptions::converge) is below `converge`. Throws InputError when there
/// is no light. Progress labels carry the fraction left: "interreflection: shots (left 1.2%,
/// target 0.5%)".
IndirectSolution solve_indirect(const IndirectInput& input, const IndirectOptions& options,
                                const ProgressFn& progress = {});

}  // namespace abrad::radiosity

namespace abrad::radiosity {

/// Indirect irradiance at any point, gathered from a stored bake: a hemicube at the point
/// sees the bake's triangles, each carrying the reflected part of its radiosity (B − E, the
/// mean of its vertices), so a probe anywhere (on a surface or in the air over a work plane)
/// gets the light the surfaces reflect towards it. Emitted light is the direct part's.
class IndirectField {
  public:
    /// `mesh` is a bake of `scene` (its triangle_surface indexes scene.surfaces).
    IndirectField(const visdb::Scene& scene, const visdb::BakeMesh& mesh, int resolution = 64);

    /// Irradiance (RGB) at `x` on a plane with unit normal `n`, from reflecting surfaces.
    visdb::Rgb irradiance(const glm::dvec3& x, const glm::dvec3& n) const;

  private:
    glm::dvec3 m_origin{0.0};  // local frame of the patches (survey coordinates)
    std::vector<Patch> m_patches;
    std::vector<glm::dvec3> m_centroid, m_normal;
    std::vector<visdb::Rgb> m_reflected;
    std::optional<Bvh> m_bvh;                     // over m_patches: probes cost what they see
    static constexpr double kOccluderArea = 0.1;  // m²: patches rasterized first (shoot.h)
    static constexpr double kOccluderNear = 5.0;  // m: of those, drawn nearest first
    std::optional<Occluders> m_occluders;
    Hemicube m_hemicube;
};

}  // namespace abrad::radiosity

namespace abrad::radiosity {

/// A point with the unit normal of the plane it measures on.
struct ProbePoint {
    glm::dvec3 x{0.0};
    glm::dvec3 n{0.0, 0.0, 1.0};
};

/// The irradiance abrad reports at arbitrary points (probes, calculation grids): exact direct
/// light plus, when the bake has interreflection, the indirect part gathered from it.
class PointIrradiance {
  public:
    /// `bake` may be null (direct light only); a bake with parameter bounces = 0 adds nothing.
    /// Throws InputError when the scene has no light.
    PointIrradiance(const visdb::Scene& scene, const visdb::Bake* bake);

    /// Irradiance at every point (in parallel), RGB, in the bake's unit.
    std::vector<visdb::Rgb> at(std::span<const ProbePoint> points) const;

    bool has_indirect() const { return m_indirect.has_value(); }

  private:
    DirectField m_direct;
    std::optional<IndirectField> m_indirect;
};

}  // namespace abrad::radiosity

namespace abrad::radiosity {

/// A final gather from the element solution at given points: a hemicube at each (the rows'
/// resolution and masks) sees the visibility triangles, each sample going to the part of an
/// element's cell it lies in (8 × 8 parts a cell), from the element's front. The hemicubes are
/// shot once, in parallel (progress as "indirect: gathers"); `values` then weighs what each
/// part reflects, ρ(direct + indirect) at its centre, as often as the caller's fields change.
/// Where the element field's interpolation extrapolates (within half a cell of a region's
/// edge, IndirectSolution::interpolates), the gather follows the bend of the field that a
/// corner's near surfaces put there. `input` and `options` are the solve's, `solution` its
/// result (kept by reference: it must outlive the gather).
using FieldAt =
    std::function<std::optional<visdb::Rgb>(std::uint32_t element, const glm::dvec3& x)>;
class IndirectGather {
  public:
    IndirectGather(const IndirectInput& input, const IndirectSolution& solution,
                   const IndirectOptions& options, std::span<const ProbePoint> points,
                   const ProgressFn& progress = {});

    /// Indirect irradiance at every point. `direct_at(element, x)`, when given, is the direct
    /// irradiance at point x of the element's region (the bake's exact vertex values,
    /// interpolated), or nothing where it has none; else, and where it has none, the
    /// elements' direct part is interpolated over their cells (linear to a region's edge).
    /// `indirect_at` likewise replaces the elements' interpolated indirect part.
    std::vector<visdb::Rgb> values(const FieldAt& direct_at = {},
                                   const FieldAt& indirect_at = {}) const;

  private:
    struct Hit {
        std::uint32_t id;  // a part (element × 64 + part) or, from m_plain on, a whole element
        float ff;
    };
    std::uint32_t element_of(std::uint32_t id) const;
    const IndirectSolution& m_sol;
    std::uint32_t m_plain = 0;
    std::vector<std::size_t> m_start;  // per point, into m_hits
    std::vector<Hit> m_hits;
};

}  // namespace abrad::radiosity
