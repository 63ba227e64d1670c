// Interreflection: progressive refinement as (over-relaxed) Southwell relaxation on clustered
// elements (Cohen et al. 1988; Gortler, Cohen & Slusallek 1993), with the ambient term.

#include "abrad/radiosity/indirect.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <limits>
#include <map>
#include <memory>
#include <numeric>
#include <optional>
#include <string>

#include "abrad/check.h"
#include "abrad/radiosity/cluster.h"
#include "abrad/radiosity/direct.h"
#include "abrad/radiosity/dm_mesh.h"
#include "abrad/radiosity/form_factor.h"
#include "abrad/radiosity/hemicube.h"
#include "abrad/radiosity/point_source.h"
#include "abrad/radiosity/polygon.h"

namespace abrad::radiosity {

namespace {

using Clock = std::chrono::steady_clock;

using visdb::channel_mean;

// Outline vertices this close to a straight run of the outline (a fraction of the region's
// size) are dropped (outline_patches)
constexpr double kOutlineTolerance = 1e-7;

// One entry of a form-factor row: the element, and the fraction of the shooter's power it
// stops on its front (or, with kBack set, on its back, where it is absorbed).
struct Entry {
    std::uint32_t element;
    float ff;
};
constexpr std::uint32_t kBack = 0x80000000u;

struct Row {
    std::vector<Entry> entries;
    double front = 0.0;  // Σ F over fronts
    double total = 0.0;  // Σ F over fronts and backs: 1 − total escapes
    bool known = false;
};

// A row as bytes in the ranks' exchange (Cluster::all_gather): the header, then its entries.
// `item` is the row's place in the batch, `seconds` what making it took (the cost model's
// measurement, which every rank must see alike so that all split the next batch alike).
struct RowHeader {
    std::uint32_t item = 0;
    std::uint32_t entries = 0;
    double front = 0.0, total = 0.0, seconds = 0.0;
};
static_assert(sizeof(RowHeader) == 32 && sizeof(Entry) == 8, "rows travel as packed bytes");

void pack_row(std::uint32_t item, const Row& row, double seconds, std::vector<std::byte>& out) {
    const RowHeader h{item, static_cast<std::uint32_t>(row.entries.size()), row.front, row.total,
                      seconds};
    const auto header = std::as_bytes(std::span(&h, 1));
    const auto entries = std::as_bytes(std::span(row.entries));
    out.insert(out.end(), header.begin(), header.end());
    out.insert(out.end(), entries.begin(), entries.end());
}

// Reads the row at `at` of `bytes` (pack_row's) into `row`; returns its header and moves `at`
// past it.
RowHeader unpack_row(std::span<const std::byte> bytes, std::size_t& at, Row& row) {
    RowHeader h;
    ABRAD_CHECK(at + sizeof h <= bytes.size(), "a row's header runs past the exchange");
    std::memcpy(&h, bytes.data() + at, sizeof h);
    at += sizeof h;
    const std::size_t n = std::size_t{h.entries} * sizeof(Entry);
    ABRAD_CHECK(at + n <= bytes.size(), "a row's entries run past the exchange");
    row.entries.resize(h.entries);
    if (n > 0) std::memcpy(row.entries.data(), bytes.data() + at, n);
    at += n;
    row.front = h.front;
    row.total = h.total;
    row.known = true;
    return h;
}

// Elements smaller than this fraction of a cell are needles or slivers: whole small triangles,
// or the sliver pieces gathered in their triangle's main element (make_elements).
constexpr double kSmallElement = 1e-3;

// Receivers within this many shooter sides (a cell, or a block's side) of the shooter's
// point get the form factor of the shooter's area instead of its point's (near_ratios), the
// ratio bounded to [1/kNearRatioBound, kNearRatioBound]: the ratio is unoccluded, and a
// receiver the point sees at a grazing angle must not take more than the area can send it
constexpr double kNearShooter = 2.0;
constexpr double kNearRatioBound = 2.0;

// A row with more than this fraction of its form factor on elements' backs stands at a point
// inside something, and is made again from other points of its shooter's pieces, at most
// kEnclosedTries of them (make_row). Half: a point inside a box sees backs nearly everywhere
// (453 FZK-Haus rows over 90 %), while a floor cell beside a single-sided partition sees its
// back legitimately (CIE 171 case 5.7: a quarter moved its wall points by up to 0.24 %)
constexpr double kEnclosedBack = 0.5;
constexpr std::size_t kEnclosedTries = 4;

// The needle and sliver elements and the triangles they are made of.
struct SmallElements {
    std::span<const Patch> patches;
    std::vector<std::vector<std::uint32_t>> triangles;  // per element; empty: not small
};

// Form factors from one shooting point onto the elements (the hemicube's, one per element,
// ascending), each on the element's front or, with kBack, its back. A hemicube gives an element
// smaller than its sample (a needle) a whole fine sample, and dividing that share by the
// element's tiny area made it hundreds of times too bright: with `small` (not for a luminaire,
// whose pixels carry its web), a form factor more than kUndersampledFactor times the closed
// form of the element's triangles' unoccluded view from the shooting point is replaced by the
// closed form (as shade.cpp's patches); with the shooter's area (0: a point), the element's
// form factor to the shooter, f × area / element area, is at most 1.
// What the bounds take off goes to the other elements of the row in proportion to their form
// factors (each still within its bound): a bound corrects where the point's samples put the
// light, not how much of it the shooter's hemisphere sends to surfaces. One point standing
// for a group of elements (a shooter's block, or small faces grouped in a cube) sees its
// nearest neighbours under form factors far above the group's mean, and counting what the
// bound removed as escaped lost 1.4 % of the FZK-Haus's light (918 lm escaped, 698 lm now).
// `near_ratio` (empty, or one per hit) scales the hits a shooter's area sees otherwise than its
// point (near_ratios); the difference, too, goes to or comes from the row's other elements.
void fold_row(std::span<const PatchFormFactor> element_ff,
              const std::vector<IndirectSolution::Element>& elements, const ShooterFrame& from,
              double shooter_area, const SmallElements* small,
              const std::vector<glm::dvec3>& region_normal, Row& row,
              std::span<const double> near_ratio = {}) {
    row.entries.clear();
    row.front = row.total = 0.0;
    std::vector<double> ff(element_ff.size());
    std::vector<char> bounded(element_ff.size(), 0);
    double removed = 0.0, free_sum = 0.0;
    const auto cap = [&](std::uint32_t e) {
        return shooter_area > 0.0 ? elements[e].area / shooter_area
                                  : std::numeric_limits<double>::infinity();
    };
    for (std::size_t k = 0; k < element_ff.size(); ++k) {
        const auto [e, f_hemicube] = element_ff[k];
        double f = f_hemicube;
        const bool near = !near_ratio.empty() && near_ratio[k] != 1.0;
        if (near) f *= near_ratio[k];
        if (small && !small->triangles[e].empty()) {
            double f_max = 0.0;
            for (const std::uint32_t t : small->triangles[e])
                f_max += unoccluded_triangle_form_factor(from.origin, from.n, small->patches[t].p);
            if (f > kUndersampledFactor * f_max) f = f_max;
        }
        f = std::min(f, cap(e));
        ff[k] = f;
        bounded[k] = near || f < f_hemicube;
        removed += f_hemicube - f;
        if (!bounded[k]) free_sum += f;
    }
    if (removed != 0.0 && free_sum > 0.0) {
        const double scale = std::max(0.0, (free_sum + removed) / free_sum);
        for (std::size_t k = 0; k < ff.size(); ++k)
            if (!bounded[k]) ff[k] = std::min(ff[k] * scale, cap(element_ff[k].patch));
    }
    for (std::size_t k = 0; k < element_ff.size(); ++k) {
        const std::uint32_t e = element_ff[k].patch;
        const double f = ff[k];
        // The shooter lights the element's front when it lies in front of the element's plane
        const bool front =
            glm::dot(from.origin - elements[e].centroid, region_normal[elements[e].region]) > 0.0;
        row.entries.push_back({front ? e : e | kBack, static_cast<float>(f)});
        row.front += front ? f : 0.0;
        row.total += f;
    }
    row.known = true;
}

}  // namespace

std::uint64_t IndirectSolution::cell_key(std::uint32_t region, int i, int j) {
    // 24 bits of region, 20 bits per cell coordinate (cells of a region span ±2^19)
    return (std::uint64_t{region} << 40) ^ (std::uint64_t(std::uint32_t(i) & 0xFFFFFu) << 20) ^
           std::uint64_t(std::uint32_t(j) & 0xFFFFFu);
}

std::uint32_t IndirectSolution::element_at(std::uint32_t region, int i, int j) const {
    if (region < m_tables.size()) {
        const CellTable& t = m_tables[region];
        if (t.ni > 0) {
            const int di = i - t.i0, dj = j - t.j0;
            if (di < 0 || dj < 0 || di >= t.ni || dj >= t.nj) return kNoElement;
            return m_cells[t.offset + std::size_t(dj) * std::size_t(t.ni) + std::size_t(di)];
        }
    }
    const auto it = cell_element.find(cell_key(region, i, j));
    return it != cell_element.end() ? it->second : kNoElement;
}

std::uint32_t IndirectSolution::element_at(std::uint32_t region, const glm::dvec3& p) const {
    const Grid& g = grids[region];
    const int i = static_cast<int>(std::floor(glm::dot(p - g.origin, g.u) / element_size));
    const int j = static_cast<int>(std::floor(glm::dot(p - g.origin, g.v) / element_size));
    return element_at(region, i, j);
}

void IndirectSolution::index_cells() {
    m_tables.assign(grids.size(), {});
    std::vector<glm::ivec2> lo(grids.size(), glm::ivec2(std::numeric_limits<int>::max()));
    std::vector<glm::ivec2> hi(grids.size(), glm::ivec2(std::numeric_limits<int>::min()));
    std::vector<std::size_t> count(grids.size(), 0);
    for (const Element& e : elements) {
        lo[e.region] = glm::min(lo[e.region], e.cell);
        hi[e.region] = glm::max(hi[e.region], e.cell);
        ++count[e.region];
    }
    std::size_t total = 0;
    for (std::size_t r = 0; r < grids.size(); ++r) {
        if (count[r] == 0) continue;
        const glm::ivec2 n = hi[r] - lo[r] + 1;
        const auto cells = std::size_t(n.x) * std::size_t(n.y);
        if (cells > 16 * count[r] + 64) continue;  // mostly empty: the map answers
        m_tables[r] = {lo[r].x, lo[r].y, n.x, n.y, total};
        total += cells;
    }
    m_cells.assign(total, kNoElement);
    for (std::size_t k = 0; k < elements.size(); ++k) {
        const CellTable& t = m_tables[elements[k].region];
        if (t.ni == 0) continue;
        const glm::ivec2 d = elements[k].cell - glm::ivec2(t.i0, t.j0);
        m_cells[t.offset + std::size_t(d.y) * std::size_t(t.ni) + std::size_t(d.x)] =
            static_cast<std::uint32_t>(k);
    }
}

glm::dvec2 IndirectSolution::centre_coordinates(std::uint32_t region, const glm::dvec3& p) const {
    const Grid& g = grids[region];
    return {glm::dot(p - g.origin, g.u) / element_size - 0.5,
            glm::dot(p - g.origin, g.v) / element_size - 0.5};
}

visdb::Rgb IndirectSolution::at(std::uint32_t region, const glm::dvec3& p) const {
    if (region >= grids.size()) return visdb::Rgb(0.0);
    const glm::dvec2 c = centre_coordinates(region, p);
    const double s = c.x, t = c.y;
    const double fs = std::floor(s), ft = std::floor(t);
    const int i0 = static_cast<int>(fs), j0 = static_cast<int>(ft);
    const double a = s - fs, b = t - ft;
    visdb::Rgb sum(0.0);
    double weight = 0.0;
    for (int dj = 0; dj < 2; ++dj)
        for (int di = 0; di < 2; ++di) {
            const std::uint32_t e = element_at(region, i0 + di, j0 + dj);
            if (e == kNoElement) continue;
            const double w = (di ? a : 1.0 - a) * (dj ? b : 1.0 - b);
            sum += w * elements[e].indirect;
            weight += w;
        }
    if (weight > 1e-9) return sum / weight;
    // Near the corner of a cell whose neighbours are empty: the nearest element of the 3×3 block
    double best = std::numeric_limits<double>::max();
    visdb::Rgb value(0.0);
    for (int dj = -1; dj <= 2; ++dj)
        for (int di = -1; di <= 2; ++di) {
            const std::uint32_t e = element_at(region, i0 + di, j0 + dj);
            if (e == kNoElement) continue;
            const double d = glm::length(elements[e].centroid - p);
            if (d < best) {
                best = d;
                value = elements[e].indirect;
            }
        }
    return value;
}

bool IndirectSolution::interpolates(std::uint32_t region, const glm::dvec3& p) const {
    if (region >= grids.size()) return false;
    const glm::dvec2 c = centre_coordinates(region, p);
    const int i0 = static_cast<int>(std::floor(c.x)), j0 = static_cast<int>(std::floor(c.y));
    for (int dj = 0; dj < 2; ++dj)
        for (int di = 0; di < 2; ++di)
            if (element_at(region, i0 + di, j0 + dj) == kNoElement) return false;
    return true;
}

void validate(const IndirectOptions& o) {
    if (o.bounces < 0 || o.bounces > 1000)
        throw InputError("--bounces must be in [0, 1000], got " + std::to_string(o.bounces));
    if (!(o.converge > 0.0 && o.converge < 1.0))
        throw InputError("--converge must be in (0, 1), got " + std::to_string(o.converge));
    if (!(o.element_size > 0.0 && std::isfinite(o.element_size)))
        throw InputError("--element-size must be > 0 metres, got " +
                         std::to_string(o.element_size));
    if (o.row_resolution < 2 || o.row_resolution > 4096 || o.row_resolution % 2 != 0)
        throw InputError("--element-resolution must be an even number in [2, 4096], got " +
                         std::to_string(o.row_resolution));
    if (o.method == Visibility::ABuffer && !supported_subpixels(o.row_subpixels))
        throw InputError("--element-subpixels must be 4, 8 or 16, got " +
                         std::to_string(o.row_subpixels));
    if (o.shooter_cells < 1 || o.shooter_cells > 16)
        throw InputError("--shooter-cells must be in [1, 16], got " +
                         std::to_string(o.shooter_cells));
    if (!(o.overrelaxation >= 1.0 && o.overrelaxation < 2.0))
        throw InputError("--overrelax must be in [1, 2), got " + std::to_string(o.overrelaxation));
}

namespace {

// The elements as the hemicube's targets: a triangle within one cell gives its whole form
// factor to that cell's element; a larger one gives each fragment's to the elements of the
// cells its visible samples see (or, off the grid's elements, to the element holding most of
// the triangle).
class ElementTargets final : public Targets {
  public:
    // `region` per visibility triangle; the triangles' own targets are the solution's
    // visibility_whole and visibility_main
    ElementTargets(const IndirectSolution& sol, std::span<const std::uint32_t> region)
        : m_sol(sol), m_region(region) {}

    std::uint32_t whole(std::uint32_t t) const override { return m_sol.visibility_whole[t]; }

    Grid grid(std::uint32_t t) const override {
        const IndirectSolution::Grid& g = m_sol.grids[m_region[t]];
        return {g.origin, g.u, g.v, m_sol.element_size};
    }

    std::uint32_t cell(std::uint32_t t, int i, int j) const override {
        const std::uint32_t e = m_sol.element_at(m_region[t], i, j);
        return e != IndirectSolution::kNoElement ? e : m_sol.visibility_main[t];
    }

  private:
    const IndirectSolution& m_sol;
    std::span<const std::uint32_t> m_region;
};

// The solver's state: elements and their pieces, the rows computed so far, and the Southwell
// unknowns (H received, B shot, r unshot = ρH − B). One method per step of solve_indirect.
class Solver {
  public:
    Solver(const IndirectInput& in, const IndirectOptions& options, const ProgressFn& progress)
        : m_in(in),
          m_options(options),
          m_progress(progress),
          m_hemicube(options.resolution),
          m_row_hemicube(options.row_resolution),
          m_shoot{.method = options.method,
                  .subpixels = options.subpixels,
                  .occlusion = false,
                  .sparse = true},
          m_region_normal(in.region_normal.begin(), in.region_normal.end()) {}

    IndirectSolution run() {
        m_sol.element_size = m_options.element_size;
        make_grids();
        make_elements();
        // Each hemicube walks the triangles front to back, skips what closed pixels hide, and
        // hands what it sees to the elements
        m_bvh = std::make_unique<Bvh>(m_vis);
        make_shooters();
        m_shoot.bvh = m_bvh.get();
        // Walls and slabs (a cell and larger) are rasterized first by every row's hemicube
        m_occluders.emplace(large_occluders(m_vis, m_options.element_size * m_options.element_size,
                                            kNearOccluders * m_options.element_size));
        m_shoot.occluders_first = &*m_occluders;
        m_shoot.targets = m_targets.get();
        shoot_lights();
        // The lights' shots onto the elements keep the finer masks; a row's form factors are
        // sums over many pixels, where one translucent sample per undersampled piece does
        m_shoot.fine_masks = m_options.row_fine_masks;
        m_shoot.subpixels = m_options.row_subpixels;
        m_r.resize(m_ne);
        m_B.assign(m_ne, visdb::Rgb(0.0));
        for (std::size_t e = 0; e < m_ne; ++e) m_r[e] = m_sol.elements[e].reflectance * m_H[e];
        m_rows.resize(m_shooters.size());
        m_region_row_seconds.assign(m_in.region_normal.size(), 0.0);
        m_region_rows.assign(m_in.region_normal.size(), 0);
        for (std::size_t e = 0; e < m_ne; ++e)
            m_rho_mean += channel_mean(m_sol.elements[e].reflectance) * m_sol.elements[e].area;
        if (m_total_area > 0.0) m_rho_mean /= m_total_area;
        double unshot = unshot_power();
        record(unshot);
        if (m_options.bounces > 0)
            run_bounces(unshot);
        else
            run_southwell(unshot);
        account_energy();
        if (m_options.bounces == 0 && m_options.ambient && m_total_area > 0.0) add_ambient();
        for (std::size_t e = 0; e < m_ne; ++e)
            m_sol.elements[e].indirect = m_H[e] - m_sol.elements[e].direct;
        for (const Row& row : m_rows) m_sol.rows_cached += row.known;
        m_sol.seconds = seconds();
        return std::move(m_sol);
    }

  private:
    double seconds() const { return std::chrono::duration<double>(Clock::now() - m_start).count(); }

    // Progress labels carry the unshot fraction (and the target)
    void progress(std::string_view stage, std::size_t done, std::size_t total, double unshot) {
        if (!m_progress) return;
        char text[128];
        std::snprintf(text, sizeof text, "%.*s (left %.3g%%, target %.3g%%)", int(stage.size()),
                      stage.data(), 100.0 * unshot, 100.0 * m_options.converge);
        m_label = text;
        m_progress(m_label, done, total);
    }

    // Region grids: origin at a vertex of the region's first triangle, axes in its plane
    void make_grids() {
        const std::size_t nr = m_in.region_normal.size();
        m_sol.grids.resize(nr);
        std::vector<char> grid_set(nr, 0);
        for (std::size_t t = 0; t < m_in.patches.size(); ++t) {
            const std::uint32_t r = m_in.region[t];
            if (grid_set[r]) continue;
            grid_set[r] = 1;
            const ShooterFrame f = ShooterFrame::at(m_in.patches[t].p[0], m_in.region_normal[r]);
            m_sol.grids[r] = {f.origin, f.u, f.v};
        }
    }

    // The element of cell (i, j) of region r (made when new)
    std::uint32_t element_of(std::uint32_t r, int i, int j) {
        const auto [it, inserted] = m_sol.cell_element.try_emplace(
            IndirectSolution::cell_key(r, i, j), static_cast<std::uint32_t>(m_sol.elements.size()));
        if (inserted) {
            m_sol.elements.push_back({.region = r, .cell = {i, j}});
            m_rho_area.emplace_back(0.0);
        }
        return it->second;
    }

    void add_to(std::uint32_t e, std::size_t t, double piece_area, const glm::dvec3& centroid) {
        auto& el = m_sol.elements[e];
        el.area += piece_area;
        el.centroid += piece_area * centroid;
        m_rho_area[e] += piece_area * m_in.reflectance[t];
    }

    // Elements: each triangle cut by its region's grid into exact pieces (triangle ∩ cell),
    // each piece added to its cell's element; a sliver under 1/1000 of a cell goes to the
    // triangle's largest piece instead of making an element of its own
    void make_elements() {
        const double size = m_options.element_size;
        const std::size_t nt = m_in.patches.size();
        std::vector<std::uint32_t> whole(nt, kNoPatch), main(nt, kNoPatch);
        struct Piece {
            int i, j;
            double area;  // m²
            glm::dvec3 centroid;
        };
        std::vector<Piece> pieces;
        for (std::size_t t = 0; t < nt; ++t) {
            const Patch& p = m_in.patches[t];
            const std::uint32_t r = m_in.region[t];
            const IndirectSolution::Grid& g = m_sol.grids[r];
            // The triangle in cell units of the region's grid
            Polygon2 tri;
            glm::dvec2 lo(std::numeric_limits<double>::infinity()), hi(-lo);
            for (const glm::dvec3& x : p.p) {
                const glm::dvec2 q{glm::dot(x - g.origin, g.u) / size,
                                   glm::dot(x - g.origin, g.v) / size};
                tri.push_back(q);
                lo = glm::min(lo, q);
                hi = glm::max(hi, q);
            }
            const int i0 = static_cast<int>(std::floor(lo.x)),
                      i1 = static_cast<int>(std::floor(hi.x));
            const int j0 = static_cast<int>(std::floor(lo.y)),
                      j1 = static_cast<int>(std::floor(hi.y));
            const double tri_area = area(p);
            if (i0 == i1 && j0 == j1) {
                whole[t] = main[t] = element_of(r, i0, j0);
                add_to(whole[t], t, tri_area, centroid(p));
                ++m_sol.pieces;
                continue;
            }
            pieces.clear();
            for (int j = j0; j <= j1; ++j)
                for (int i = i0; i <= i1; ++i) {
                    Polygon2 c = clip_polygon(tri, [&](const glm::dvec2& q) { return q.x - i; });
                    c = clip_polygon(c, [&](const glm::dvec2& q) { return (i + 1.0) - q.x; });
                    c = clip_polygon(c, [&](const glm::dvec2& q) { return q.y - j; });
                    c = clip_polygon(c, [&](const glm::dvec2& q) { return (j + 1.0) - q.y; });
                    if (c.size() < 3) continue;
                    const auto [a, q] = area_centroid(c);
                    if (!(a > 0.0)) continue;
                    pieces.push_back(
                        {i, j, a * size * size, g.origin + size * (q.x * g.u + q.y * g.v)});
                }
            // Scale the pieces to the triangle's area (the clipping's rounding, and the
            // region's mean plane, are not the triangle's own)
            double sum = 0.0;
            for (const Piece& q : pieces) sum += q.area;
            if (!(sum > 0.0)) {
                // A needle the clipping left no area of: whole, in the cell of its centroid
                // (a region of needles alone must still have elements to hand its pixels to)
                const glm::dvec2 c = (tri[0] + tri[1] + tri[2]) / 3.0;
                whole[t] = main[t] = element_of(r, static_cast<int>(std::floor(c.x)),
                                                static_cast<int>(std::floor(c.y)));
                add_to(whole[t], t, tri_area, centroid(p));
                continue;
            }
            const auto largest =
                std::max_element(pieces.begin(), pieces.end(),
                                 [](const Piece& a, const Piece& b) { return a.area < b.area; });
            main[t] = element_of(r, largest->i, largest->j);
            for (const Piece& q : pieces) {
                const double a = q.area * tri_area / sum;
                const bool sliver = q.area < kSmallElement * size * size;
                add_to(sliver ? main[t] : element_of(r, q.i, q.j), t, a, q.centroid);
                m_sol.pieces += !sliver;
            }
        }
        // Needles and slivers hold only whole triangles and sliver pieces (a piece of a cell's
        // kSmallElement or more makes an element at least that large)
        m_small.patches = m_in.patches;
        m_small.triangles.assign(m_sol.elements.size(), {});
        for (std::size_t t = 0; t < nt; ++t) {
            const std::uint32_t e = whole[t] != kNoPatch ? whole[t] : main[t];
            if (e != kNoPatch && m_sol.elements[e].area < kSmallElement * size * size)
                m_small.triangles[e].push_back(static_cast<std::uint32_t>(t));
        }
        m_ne = m_sol.elements.size();
        m_sol.index_cells();
        make_visibility(whole, main);
        for (std::size_t e = 0; e < m_ne; ++e) {
            auto& el = m_sol.elements[e];
            if (el.area > 0.0) {
                el.centroid /= el.area;
                el.reflectance = m_rho_area[e] / el.area;
            }
            m_total_area += el.area;
        }
    }

    // The hemicubes' patches: each planar region triangulated from its outline alone
    // (outline_triangulation) where that takes fewer triangles, so that a finely meshed wall
    // costs a row what its outline costs. A pixel of such a triangle goes to the elements of the
    // cells its visible samples see (ElementTargets::cell), as one of a large triangle always
    // did. Other regions keep their triangles, and their targets (`whole`, `main`: per
    // triangle).
    void make_visibility(const std::vector<std::uint32_t>& whole,
                         const std::vector<std::uint32_t>& main) {
        if (!m_in.outlines)
            m_own_outlines = outline_patches(m_in.patches, m_in.region, m_region_normal);
        const Outlines& o = m_in.outlines ? *m_in.outlines : m_own_outlines;
        const double size = m_options.element_size;
        std::vector<std::uint32_t> vis_whole(o.patches.size()), vis_main(o.patches.size());
        // Off the elements (rounding at an outline): the element of a triangle of the region
        std::vector<std::uint32_t> fallback(m_region_normal.size(), kNoPatch);
        for (std::size_t t = 0; t < m_in.patches.size(); ++t)
            if (fallback[m_in.region[t]] == kNoPatch)
                fallback[m_in.region[t]] = whole[t] != kNoPatch ? whole[t] : main[t];
        // Each outline triangle's cells (its box in the region's grid): the elements' outline
        // triangles, which element_polygons clips to the cells, and its own target
        m_element_triangle.clear();
        for (std::size_t k = 0; k < o.patches.size(); ++k) {
            const std::uint32_t r = o.region[k];
            const IndirectSolution::Grid& g = m_sol.grids[r];
            glm::ivec2 lo(std::numeric_limits<int>::max()), hi(std::numeric_limits<int>::min());
            for (const glm::dvec3& x : o.patches[k].p) {
                const glm::ivec2 c(
                    static_cast<int>(std::floor(glm::dot(x - g.origin, g.u) / size)),
                    static_cast<int>(std::floor(glm::dot(x - g.origin, g.v) / size)));
                lo = glm::min(lo, c);
                hi = glm::max(hi, c);
            }
            for (int j = lo.y; j <= hi.y; ++j)
                for (int i = lo.x; i <= hi.x; ++i)
                    if (const std::uint32_t e = m_sol.element_at(r, i, j);
                        e != IndirectSolution::kNoElement)
                        m_element_triangle.push_back({e, static_cast<std::uint32_t>(k)});
            if (const std::uint32_t t = o.source[k]; t != kNoPatch) {
                vis_whole[k] = whole[t];
                vis_main[k] = main[t];
                continue;
            }
            const std::uint32_t at = m_sol.element_at(r, centroid(o.patches[k]));
            vis_whole[k] = lo == hi ? m_sol.element_at(r, lo.x, lo.y) : kNoPatch;
            vis_main[k] = at != IndirectSolution::kNoElement ? at : fallback[r];
        }
        std::sort(m_element_triangle.begin(), m_element_triangle.end());
        m_vis = o.patches;
        m_sol.visibility_triangles = m_vis.size();
        m_sol.visibility_whole = std::move(vis_whole);
        m_sol.visibility_main = std::move(vis_main);
        m_targets = std::make_unique<ElementTargets>(m_sol, o.region);
    }

    // Shooters: the elements that shoot as one, from one point, with one row. A region's
    // elements are grouped in blocks of shooter_cells × shooter_cells cells; the elements of
    // regions smaller than a cell (the small faces of frames, fittings and furniture) are grouped
    // in cubes of that side, by the axis their normal lies within 30° of. The elements keep
    // their own unknowns: only the row is shared.
    void make_shooters() {
        const int n = m_options.shooter_cells;
        const double side = n * m_options.element_size;
        std::vector<double> region_area(m_in.region_normal.size(), 0.0);
        for (const auto& el : m_sol.elements) region_area[el.region] += el.area;
        // Key: (kind, a, b, c, d); kind 0 = block of a region, 1 = cube by axis, 2 = alone
        std::map<std::array<std::int64_t, 5>, std::uint32_t> key_shooter;
        m_shooter_of.resize(m_ne);
        const auto block = [&](int i) {
            return static_cast<std::int64_t>(std::floor(double(i) / n));
        };
        for (std::size_t e = 0; e < m_ne; ++e) {
            const auto& el = m_sol.elements[e];
            const glm::dvec3 normal = m_region_normal[el.region];
            std::array<std::int64_t, 5> key{2, std::int64_t(e), 0, 0, 0};
            if (n > 1 &&
                region_area[el.region] >= m_options.element_size * m_options.element_size) {
                key = {0, el.region, block(el.cell.x), block(el.cell.y), 0};
            } else if (n > 1) {
                int axis = 0;
                for (int k = 1; k < 3; ++k)
                    if (std::abs(normal[k]) > std::abs(normal[axis])) axis = k;
                if (std::abs(normal[axis]) >= 0.8660254037844386 /* cos 30° */) {
                    const glm::dvec3 cube = glm::floor(el.centroid / side);
                    key = {1, 2 * axis + (normal[axis] < 0.0), std::int64_t(cube.x),
                           std::int64_t(cube.y), std::int64_t(cube.z)};
                }
            }
            const auto [it, inserted] =
                key_shooter.try_emplace(key, static_cast<std::uint32_t>(key_shooter.size()));
            m_shooter_of[e] = it->second;
        }
        const std::size_t ns = split_unseen_members(key_shooter, split_near_blocks(key_shooter));
        // Members of each shooter (CSR), ascending
        m_member_start.assign(ns + 1, 0);
        for (const std::uint32_t s : m_shooter_of) ++m_member_start[s + 1];
        std::partial_sum(m_member_start.begin(), m_member_start.end(), m_member_start.begin());
        m_members.resize(m_ne);
        std::vector<std::uint32_t> fill(m_member_start.begin(), m_member_start.end() - 1);
        for (std::size_t e = 0; e < m_ne; ++e)
            m_members[fill[m_shooter_of[e]]++] = static_cast<std::uint32_t>(e);
        m_shooters.resize(ns);
        for (std::size_t s = 0; s < ns; ++s)
            m_shooters[s] =
                point_of(members_of(static_cast<std::uint32_t>(s)), static_cast<std::uint32_t>(s));
        m_sol.shooters = ns;
    }

    // Shooter s's point: its members' area centroid when that lies on one of its elements of
    // a block (the cell holding it is a member), else the member centroid nearest to it; the
    // normal is that member's region's
    ShooterFrame point_of(std::span<const std::uint32_t> members, std::uint32_t s) const {
        const std::uint32_t nearest =
            m_point[s] != kNoPatch ? m_point[s] : nearest_to_centroid(members);
        const std::uint32_t r = m_sol.elements[nearest].region;
        glm::dvec3 point = m_sol.elements[nearest].centroid;
        const bool planar = std::all_of(members.begin(), members.end(), [&](std::uint32_t e) {
            return m_sol.elements[e].region == r;
        });
        if (planar && members.size() > 1) {
            const glm::dvec3 c = members_centroid(members);
            if (on_member(r, c, s)) point = c;
        }
        return ShooterFrame::at(point, m_region_normal[r]);
    }

    // A cube of small faces shoots from one member's point, and a member that point cannot
    // see (the outer half of a window frame behind the glass, a fitting beyond a partition)
    // had its light shot from the wrong side of what stands between: on the FZK-Haus that was
    // 1.6 % of the living room's indirect light, and 83 lm sent out of the house. A member is
    // seen when the segment from the point to its centroid (both lifted off their faces by a
    // thousandth of a cell) crosses nothing. The members the point does not see form a cube
    // of their own, split again the same way, until every member is seen from its cube's
    // point. Returns the number of shooters after the split.
    std::size_t split_unseen_members(
        const std::map<std::array<std::int64_t, 5>, std::uint32_t>& key_shooter, std::size_t ns) {
        std::vector<std::vector<std::uint32_t>> members(ns);
        for (std::size_t e = 0; e < m_ne; ++e) members[m_shooter_of[e]].push_back(std::uint32_t(e));
        const double lift = 1e-3 * m_options.element_size;
        const auto lifted = [&](std::uint32_t e) {
            const auto& el = m_sol.elements[e];
            return el.centroid + lift * m_region_normal[el.region];
        };
        std::vector<std::uint32_t> cubes;
        for (const auto& [key, shooter] : key_shooter)
            if (key[0] == 1 && members[shooter].size() > 1) cubes.push_back(shooter);
        // Per cube, the point of its first group (which keeps the cube's shooter), and the
        // other groups (each shoots from its first element)
        std::vector<std::uint32_t> first_point(cubes.size());
        std::vector<std::vector<std::vector<std::uint32_t>>> more(cubes.size());
        tbb::parallel_for(std::size_t{0}, cubes.size(), [&](std::size_t k) {
            std::vector<std::uint32_t> left = members[cubes[k]], next;
            for (bool first = true; !left.empty(); first = false) {
                const std::uint32_t p = nearest_to_centroid(left);
                const glm::dvec3 eye = lifted(p);
                std::vector<std::uint32_t> seen{p};
                next.clear();
                for (const std::uint32_t e : left)
                    if (e != p)
                        (transmittance(m_vis, *m_bvh, lifted(e), eye) >= 1.0 ? seen : next)
                            .push_back(e);
                if (first)
                    first_point[k] = p;
                else
                    more[k].push_back(std::move(seen));
                left.swap(next);
            }
        });
        m_point.assign(ns, kNoPatch);
        for (std::size_t k = 0; k < cubes.size(); ++k) {
            m_point[cubes[k]] = first_point[k];
            for (const auto& group : more[k]) {
                for (const std::uint32_t e : group)
                    m_shooter_of[e] = static_cast<std::uint32_t>(ns);
                m_point.push_back(group.front());
                ++ns;
            }
        }
        return ns;
    }

    // The members' area centroid (the first member's centroid when they have no area)
    glm::dvec3 members_centroid(std::span<const std::uint32_t> members) const {
        glm::dvec3 c(0.0);
        double a = 0.0;
        for (const std::uint32_t e : members) {
            c += m_sol.elements[e].area * m_sol.elements[e].centroid;
            a += m_sol.elements[e].area;
        }
        return a > 0.0 ? c / a : m_sol.elements[members[0]].centroid;
    }

    // The member whose centroid is nearest to the members' area centroid
    std::uint32_t nearest_to_centroid(std::span<const std::uint32_t> members) const {
        const glm::dvec3 c = members_centroid(members);
        std::uint32_t nearest = members[0];
        for (const std::uint32_t e : members)
            if (glm::distance(m_sol.elements[e].centroid, c) <
                glm::distance(m_sol.elements[nearest].centroid, c))
                nearest = e;
        return nearest;
    }

    // A block shoots from one point, which misplaces the light of its cells by up to half its
    // diagonal: on a receiver nearer than the block's side (the foot of a wall on the floor,
    // a table on it) that is an error of ten percent and more. Blocks with a non-coplanar
    // triangle in front of them within half a side shoot cell by cell instead. Returns the
    // number of shooters after the split.
    std::size_t split_near_blocks(
        const std::map<std::array<std::int64_t, 5>, std::uint32_t>& key_shooter) {
        const double side = m_options.shooter_cells * m_options.element_size;
        const double reach = 0.5 * side;
        const std::size_t nk = key_shooter.size();
        std::vector<std::vector<std::uint32_t>> members(nk);
        for (std::size_t e = 0; e < m_ne; ++e) members[m_shooter_of[e]].push_back(std::uint32_t(e));
        std::vector<char> near(nk, 0);
        for (const auto& [key, shooter] : key_shooter) {
            const std::uint32_t s = shooter;  // a plain variable: lambdas capture it
            if (key[0] != 0 || members[s].size() < 2) continue;
            const std::uint32_t r = static_cast<std::uint32_t>(key[1]);
            const IndirectSolution::Grid& g = m_sol.grids[r];
            const glm::dvec3 n = m_region_normal[r];
            Box box;
            for (const std::uint32_t e : members[s])
                for (int c = 0; c < 4; ++c) {
                    const glm::ivec2 cell = m_sol.elements[e].cell + glm::ivec2(c & 1, c >> 1);
                    box.grow(g.origin + m_options.element_size *
                                            (double(cell.x) * g.u + double(cell.y) * g.v));
                }
            box.inflate(reach);
            const double plane = glm::dot(n, m_sol.elements[members[s][0]].centroid);
            const double eps = 1e-6 * (1.0 + std::abs(plane));
            m_bvh->query(box, [&](std::uint32_t t) {
                if (near[s]) return;
                bool in_front = false;
                for (const glm::dvec3& p : m_vis[t].p)
                    in_front = in_front || glm::dot(n, p) - plane > eps;
                near[s] = in_front;
            });
        }
        std::size_t ns = nk;
        for (std::size_t e = 0; e < m_ne; ++e)
            if (near[m_shooter_of[e]] && members[m_shooter_of[e]].front() != e)
                m_shooter_of[e] = static_cast<std::uint32_t>(ns++);
        return ns;
    }

    std::span<const std::uint32_t> members_of(std::uint32_t s) const {
        return {m_members.data() + m_member_start[s], m_member_start[s + 1] - m_member_start[s]};
    }

    // True when point p of region r's plane lies in a cell whose element belongs to shooter s
    bool on_member(std::uint32_t r, const glm::dvec3& p, std::uint32_t s) const {
        const std::uint32_t e = m_sol.element_at(r, p);
        return e != IndirectSolution::kNoElement && m_shooter_of[e] == s;
    }

    // A light's shot of `power` along `row` onto the elements (fronts receive, backs absorb,
    // what no pixel caught escapes); `share` is the part of the power the hemicube carries
    // (a point source's two hemicubes share it)
    void add_shot(const Row& row, const visdb::Rgb& power, double share = 1.0) {
        for (const Entry& x : row.entries) {
            if (x.element & kBack) {
                m_back_absorbed += channel_mean(power) * x.ff;
                continue;
            }
            m_H[x.element] += power * double(x.ff) / m_sol.elements[x.element].area;
        }
        m_escaped += channel_mean(power) * std::max(0.0, share - row.total);
    }

    // Direct light onto the elements: one hemicube per light triangle (the paper's shot), and
    // two per point source whose pixels carry fractions of its flux (point_source.h), so that
    // a luminaire's row holds flux fractions. The rows are made in parallel (over the ranks,
    // when shared) and added in order: the sums do not depend on which thread or rank made a
    // row.
    void shoot_lights() {
        m_H.assign(m_ne, visdb::Rgb(0.0));
        std::vector<std::uint32_t> lights;
        for (std::size_t t = 0; t < m_in.patches.size(); ++t)
            if (visdb::any_positive(m_in.emittance[t]))
                lights.push_back(static_cast<std::uint32_t>(t));
        if (lights.empty() && m_in.luminaires.empty()) {
            throw InputError(
                "the scene has no light sources (no material with emittance > 0, no luminaire)");
        }
        std::vector<std::array<PointShooter, 2>> points;
        for (const visdb::Luminaire& lum : m_in.luminaires) {
            m_sol.energy.emitted += channel_mean(luminaire_power(lum));
            points.push_back(point_shooters(lum, m_options.resolution));
        }
        for (const std::uint32_t l : lights)
            m_sol.energy.emitted += channel_mean(m_in.emittance[l]) * area(m_in.patches[l]);
        // Items: each luminaire's two hemicubes, then the light triangles (alike in cost)
        const std::size_t np = 2 * points.size();
        std::vector<Row> rows(np + lights.size());
        const std::vector<double> cost(rows.size(), 1.0);
        progress("interreflection: lights", 0, lights.size(), 1.0);
        make_rows(
            cost, [&](std::size_t k) -> Row& { return rows[k]; },
            [&](std::size_t k, Row& row) {
                if (k < np) {
                    const PointShooter& s = points[k / 2][k % 2];
                    fold_row(shoot(s.frame, m_vis, s.hemicube, m_shoot).hits, m_sol.elements,
                             s.frame, 0.0, nullptr, m_region_normal, row);
                    return;
                }
                const Patch& light = m_in.patches[lights[k - np]];
                const ShooterFrame frame = frame_of(light);
                fold_row(shoot(frame, m_vis, m_hemicube, m_shoot).hits, m_sol.elements, frame,
                         area(light), &m_small, m_region_normal, row);
            },
            "interreflection: lights");
        for (std::size_t k = 0; k < rows.size(); ++k) {
            if (k < np) {
                const std::vector<double>& w = points[k / 2][k % 2].hemicube.deltas();
                add_shot(rows[k], luminaire_power(m_in.luminaires[k / 2]),
                         std::accumulate(w.begin(), w.end(), 0.0));
            } else {
                const std::uint32_t l = lights[k - np];
                add_shot(rows[k], m_in.emittance[l] * area(m_in.patches[l]));
            }
        }
        for (std::size_t e = 0; e < m_ne; ++e) m_sol.elements[e].direct = m_H[e];
    }

    // Makes the rows of items 0..cost.size()−1: row_of(k) = make(k, row_of(k)). Alone, in
    // parallel; shared over MPI ranks, each rank makes its share (Cluster::share by `cost`) and
    // every rank receives every row, in slices so that no exchange grows without bound.
    // Returns the seconds each row took to make, the same on every rank.
    template <class RowOf, class Make>
    std::vector<double> make_rows(std::span<const double> cost, const RowOf& row_of,
                                  const Make& make, const char* label) {
        const std::size_t n = cost.size();
        Cluster* const cluster = m_options.cluster;
        const bool shared = cluster && cluster->size() > 1;
        std::vector<double> secs(n, 0.0);
        constexpr std::size_t kSlice = 4096;              // rows per exchange (a few tens of MB)
        for (std::size_t k0 = 0; k0 < n; k0 += kSlice) {  // (alone: one pass, then break)
            const std::size_t k1 = shared ? std::min(n, k0 + kSlice) : n;
            std::vector<std::uint32_t> mine;
            if (shared) {
                mine = cluster->share(cost.subspan(k0, k1 - k0));
                for (std::uint32_t& k : mine) k += static_cast<std::uint32_t>(k0);
            } else {
                mine.resize(n);
                std::iota(mine.begin(), mine.end(), 0u);
            }
            // A large batch reports its own hemicubes (a round can take minutes)
            std::optional<ParallelProgress> batch;
            if (mine.size() >= 64) batch.emplace(m_progress, label, mine.size());
            tbb::parallel_for(std::size_t{0}, mine.size(), [&](std::size_t i) {
                const auto t0 = Clock::now();
                make(std::size_t{mine[i]}, row_of(mine[i]));
                secs[mine[i]] = std::chrono::duration<double>(Clock::now() - t0).count();
                if (batch) batch->add(1);
            });
            batch.reset();
            if (!shared) break;
            std::vector<std::byte> bytes;
            for (const std::uint32_t k : mine) pack_row(k, row_of(k), secs[k], bytes);
            const std::vector<std::byte> all = cluster->all_gather(bytes, "interreflection");
            for (std::size_t at = 0; at < all.size();) {
                Row row;
                const RowHeader h = unpack_row(all, at, row);
                ABRAD_CHECK(h.item >= k0 && h.item < k1, "a row from another slice");
                row_of(h.item) = std::move(row);
                secs[h.item] = h.seconds;
            }
        }
        return secs;
    }

    double unshot_power() const {
        double u = 0.0;
        for (std::size_t e = 0; e < m_ne; ++e)
            u += std::abs(channel_mean(m_r[e])) * m_sol.elements[e].area;
        return u;
    }

    double power_of(std::uint32_t e) const {
        return std::abs(channel_mean(m_r[e])) * m_sol.elements[e].area;
    }

    double shooter_power(std::uint32_t s) const {
        double p = 0.0;
        for (const std::uint32_t e : members_of(s)) p += power_of(e);
        return p;
    }

    void record(double unshot) {
        const double emitted = m_sol.energy.emitted;
        m_sol.curve.push_back({m_sol.shots, seconds(), emitted > 0.0 ? unshot / emitted : 0.0});
    }

    // Rows (one per shooter): computed in parallel batches when first needed, kept while the
    // cache has room (counted by entries, which all ranks agree on)
    void compute_rows(const std::vector<std::uint32_t>& wanted) {
        std::vector<std::uint32_t> todo;
        for (const std::uint32_t e : wanted)
            if (!m_rows[e].known) todo.push_back(e);
        std::vector<double> cost(todo.size());
        for (std::size_t k = 0; k < todo.size(); ++k) cost[k] = row_cost(todo[k]);
        const std::vector<double> secs = make_rows(
            cost, [&](std::size_t k) -> Row& { return m_rows[todo[k]]; },
            [&](std::size_t k, Row& row) { make_row(todo[k], row); }, "interreflection: hemicubes");
        for (std::size_t k = 0; k < todo.size(); ++k) {
            const std::uint32_t r = region_of_shooter(todo[k]);
            m_region_row_seconds[r] += secs[k];
            ++m_region_rows[r];
            m_row_seconds += secs[k];
        }
        m_sol.rows_computed += todo.size();
        for (const std::uint32_t e : todo)
            m_cache_bytes += m_rows[e].entries.size() * sizeof(Entry);
    }

    // Shooter s's row: its hemicube's form factors folded onto the elements. A shooting point
    // inside another object (a floor cell's centroid under a cupboard, or under a wall
    // standing on the slab; a wall cell's behind a sill) sees only that object's backs, and
    // the shooter's power went to them, counted absorbed: in the FZK-Haus 453 rows put more
    // than 90 % there. When more than kEnclosedBack of a row lands on backs, the row is made
    // again from points of the members' pieces (the quarter points of their cells, nearest
    // first, at most kEnclosedTries), and the one with the least on backs is kept.
    void make_row(std::uint32_t s, Row& row) const {
        double shooter_area = 0.0;
        for (const std::uint32_t e : members_of(s)) shooter_area += m_sol.elements[e].area;
        const auto from = [&](const ShooterFrame& frame, Row& out) {
            const ShootResult shot = shoot(frame, m_vis, m_row_hemicube, m_shoot);
            const std::vector<double> ratio = near_ratios(s, frame, shooter_area, shot.hits);
            fold_row(shot.hits, m_sol.elements, frame, shooter_area, &m_small, m_region_normal, out,
                     ratio);
        };
        const ShooterFrame& frame = m_shooters[s];
        from(frame, row);
        const auto back = [](const Row& r) { return r.total - r.front; };
        const auto enclosed = [&](const Row& r) { return back(r) > kEnclosedBack * r.total; };
        if (!enclosed(row)) return;
        std::vector<glm::dvec3> points;
        area_samples(members_of(s), 2, points);
        std::sort(points.begin(), points.end(), [&](const glm::dvec3& a, const glm::dvec3& b) {
            const double da = glm::length(a - frame.origin), db = glm::length(b - frame.origin);
            return da != db ? da < db : lexicographically_less(a, b);
        });
        Row other;
        for (std::size_t k = 0; k < points.size() && k < kEnclosedTries; ++k) {
            from(ShooterFrame::at(points[k], frame.n), other);
            if (back(other) < back(row)) std::swap(row, other);
            if (!enclosed(row)) return;
        }
    }

    // Element e's pieces: its region's outline triangles that meet its cell, clipped to it
    std::vector<Polygon3> element_polygons(std::uint32_t e) const {
        const auto& el = m_sol.elements[e];
        const IndirectSolution::Grid& g = m_sol.grids[el.region];
        const double size = m_options.element_size;
        std::vector<Polygon3> out;
        const auto first = std::lower_bound(m_element_triangle.begin(), m_element_triangle.end(),
                                            std::pair<std::uint32_t, std::uint32_t>{e, 0u});
        for (auto it = first; it != m_element_triangle.end() && it->first == e; ++it) {
            Polygon3 poly;
            for (const glm::dvec3& x : m_vis[it->second].p) poly.push_back(x);
            const double i = el.cell.x, j = el.cell.y;
            poly = clip_polygon(
                poly, [&](const glm::dvec3& x) { return glm::dot(x - g.origin, g.u) / size - i; });
            poly = clip_polygon(poly, [&](const glm::dvec3& x) {
                return (i + 1.0) - glm::dot(x - g.origin, g.u) / size;
            });
            poly = clip_polygon(
                poly, [&](const glm::dvec3& x) { return glm::dot(x - g.origin, g.v) / size - j; });
            poly = clip_polygon(poly, [&](const glm::dvec3& x) {
                return (j + 1.0) - glm::dot(x - g.origin, g.v) / size;
            });
            if (poly.size() >= 3) out.push_back(poly);
        }
        return out;
    }

    // Unoccluded form factor from x (normal n) to the polygons
    static double polygons_form_factor(const glm::dvec3& x, const glm::dvec3& n,
                                       const std::vector<Polygon3>& polys) {
        double f = 0.0;
        for (const Polygon3& p : polys) {
            const Polygon3 c =
                clip_polygon(p, [&](const glm::dvec3& q) { return glm::dot(q - x, n); });
            if (c.size() >= 3) f += point_polygon_form_factor(x, n, {c.begin(), c.size()});
        }
        return f;
    }

    // Sample points of elements' area: m × m points of each member's cell (cell centres of
    // an m × m grid, the midpoint rule), those inside the member's pieces; the same points
    // however the region is triangulated
    void area_samples(std::span<const std::uint32_t> members, int m,
                      std::vector<glm::dvec3>& points) const {
        const double size = m_options.element_size;
        for (const std::uint32_t e : members) {
            const auto& el = m_sol.elements[e];
            const IndirectSolution::Grid& g = m_sol.grids[el.region];
            const glm::dvec3 n = m_region_normal[el.region];
            const std::vector<Polygon3> polys = element_polygons(e);
            const auto inside = [&](const glm::dvec3& x) {
                return std::any_of(polys.begin(), polys.end(), [&](const Polygon3& p) {
                    const double orient = glm::dot(area_vector(p), n) >= 0.0 ? 1.0 : -1.0;
                    for (std::size_t k = 0; k < p.size(); ++k) {
                        const glm::dvec3 p0 = p[k], p1 = p[(k + 1) % p.size()];
                        if (orient * glm::dot(glm::cross(p1 - p0, x - p0), n) < 0.0) return false;
                    }
                    return true;
                });
            };
            for (int b = 0; b < m; ++b)
                for (int a = 0; a < m; ++a) {
                    const glm::dvec3 x = g.origin + size * ((el.cell.x + (a + 0.5) / m) * g.u +
                                                            (el.cell.y + (b + 0.5) / m) * g.v);
                    if (inside(x)) points.push_back(x);
                }
        }
    }

    // A shooter's hemicube stands for its area by one point, and a receiver near it (the
    // foot of the wall beside a floor cell) sees that area under a form factor its point's
    // does not give: 5 % more for the wall cell beside a floor cell, 21 % less for the one
    // above it. For each non-coplanar receiver within kNearShooter shooter sides of the
    // point, the ratio of the form factor from the shooter's area (sampled) to the one from
    // its point, both unoccluded and exact (point_polygon_form_factor), per hit; empty when
    // no receiver is near. Occlusion stays the hemicube's. `shooter_area`: its members' area.
    std::vector<double> near_ratios(std::uint32_t s, const ShooterFrame& frame, double shooter_area,
                                    std::span<const PatchFormFactor> hits) const {
        const auto members = members_of(s);
        const double size = m_options.element_size;
        const std::uint32_t region = m_sol.elements[members[0]].region;
        for (const std::uint32_t e : members)
            if (m_sol.elements[e].region != region) return {};  // a cube of small faces
        if (shooter_area < kSmallElement * size * size) return {};
        const double side = members.size() > 1 ? m_options.shooter_cells * size : size;
        const glm::dvec3 ns = m_region_normal[region];
        std::vector<double> ratio;
        std::vector<glm::dvec3> samples;
        for (std::size_t k = 0; k < hits.size(); ++k) {
            const std::uint32_t e = hits[k].patch;
            const auto& el = m_sol.elements[e];
            if (el.region == region || el.area < kSmallElement * size * size) continue;
            const glm::dvec3 ne = m_region_normal[el.region];
            if (std::abs(glm::dot(ne, ns)) > 1.0 - 1e-6) continue;
            if (glm::distance(el.centroid, frame.origin) > kNearShooter * side) continue;
            if (glm::dot(frame.origin - el.centroid, ne) <= 0.0) continue;  // its back
            if (samples.empty()) {
                // 6 × 6 points of a cell, 3 × 3 of each cell of a block: the midpoint rule
                // is within 0.6 % of the wall cell above a floor cell's form factor
                area_samples(members, members.size() > 1 ? 3 : 6, samples);
                if (samples.empty()) return {};
            }
            const std::vector<Polygon3> polys = element_polygons(e);
            const double f_point = polygons_form_factor(frame.origin, frame.n, polys);
            if (!(f_point > 1e-9)) continue;
            double f_area = 0.0;
            for (const glm::dvec3& x : samples) f_area += polygons_form_factor(x, ns, polys);
            f_area /= double(samples.size());
            if (ratio.empty()) ratio.assign(hits.size(), 1.0);
            ratio[k] = std::clamp(f_area / f_point, 1.0 / kNearRatioBound, kNearRatioBound);
        }
        return ratio;
    }

    std::uint32_t region_of_shooter(std::uint32_t s) const {
        return m_sol.elements[members_of(s)[0]].region;
    }

    // What shooter s's row should cost, for sharing a batch over the ranks: the mean of the
    // rows measured in its region so far (a hemicube costs what it sees, and a region sees
    // about the same from each of its shooters), else of all rows, else alike
    double row_cost(std::uint32_t s) const {
        const std::uint32_t r = region_of_shooter(s);
        if (m_region_rows[r] > 0) return m_region_row_seconds[r] / m_region_rows[r];
        if (m_sol.rows_computed > 0) return m_row_seconds / double(m_sol.rows_computed);
        return 1.0;
    }

    void release_rows(const std::vector<std::uint32_t>& used) {
        if (m_cache_bytes <= m_options.row_cache_bytes) return;
        for (const std::uint32_t e : used) {
            m_cache_bytes -= m_rows[e].entries.size() * sizeof(Entry);
            m_rows[e] = Row{};
        }
    }

    // Shooter s shoots amount(e) (radiosity, RGB) of each of its elements along its row
    template <class Amount>
    void shoot_from(std::uint32_t s, const Amount& amount) {
        visdb::Rgb power(0.0);
        for (const std::uint32_t e : members_of(s)) {
            const visdb::Rgb a = amount(e);
            power += a * m_sol.elements[e].area;
            m_B[e] += a;
            m_r[e] -= a;
        }
        const Row& row = m_rows[s];
        for (const Entry& x : row.entries) {
            if (x.element & kBack) {
                m_back_absorbed += channel_mean(power) * x.ff;
                continue;
            }
            auto& rec = m_sol.elements[x.element];
            const visdb::Rgb dh = power * double(x.ff) / rec.area;
            m_H[x.element] += dh;
            m_r[x.element] += rec.reflectance * dh;
        }
        m_escaped += channel_mean(power) * (1.0 - row.total);
        ++m_sol.shots;
    }

    // Bounce k: every shooter shoots what its elements received in bounce k − 1 (a Jacobi
    // sweep)
    void run_bounces(double unshot) {
        const double emitted = m_sol.energy.emitted;
        for (int bounce = 0; bounce < m_options.bounces; ++bounce) {
            // A copy on purpose: the Jacobi sweep shoots bounce k − 1 while shoot_from changes
            // m_r
            // NOLINTNEXTLINE(performance-unnecessary-copy-initialization)
            const std::vector<visdb::Rgb> pending = m_r;
            std::vector<std::uint32_t> shooters;
            for (std::uint32_t s = 0; s < m_shooters.size(); ++s)
                for (const std::uint32_t e : members_of(s))
                    if (channel_mean(glm::abs(pending[e])) > 0.0) {
                        shooters.push_back(s);
                        break;
                    }
            if (shooters.empty()) break;
            // In slices, so that rows not kept in the cache are freed as we go
            const std::size_t slice = 256;
            for (std::size_t s0 = 0; s0 < shooters.size(); s0 += slice) {
                const std::vector<std::uint32_t> part(
                    shooters.begin() + static_cast<std::ptrdiff_t>(s0),
                    shooters.begin() +
                        static_cast<std::ptrdiff_t>(std::min(shooters.size(), s0 + slice)));
                compute_rows(part);
                for (const std::uint32_t i : part)
                    shoot_from(i, [&](std::uint32_t e) { return pending[e]; });
                release_rows(part);
            }
            ++m_sol.bounces_done;
            unshot = unshot_power();
            record(unshot);
            progress("interreflection: bounce", std::size_t(bounce) + 1,
                     std::size_t(m_options.bounces), unshot / emitted);
        }
    }

    // Southwell: in rounds, the elements with the most unshot power first; each shoots ω
    // times its unshot radiosity at the moment it shoots
    void run_southwell(double unshot) {
        const double target = m_options.converge;
        // Progress in thousandths of the way from the first fraction left to the target on a
        // log scale (Southwell's unshot power falls about geometrically with the shots)
        double left = left_fraction(unshot);
        const double start = left;
        const auto permille = [&](double u) -> std::size_t {
            if (!(start > target) || !(u > 0.0)) return 1000;
            const double f = std::log(start / u) / std::log(start / target);
            return static_cast<std::size_t>(std::clamp(f, 0.0, 1.0) * 1000.0);
        };
        const std::size_t ns = m_shooters.size();
        std::vector<std::uint32_t> order(ns);
        std::vector<double> power(ns);
        while (left > target && m_sol.shots < m_options.max_shots) {
            for (std::uint32_t s = 0; s < ns; ++s) power[s] = shooter_power(s);
            std::iota(order.begin(), order.end(), 0u);
            // The round: the fewest shooters holding half of the unshot power, at least 16
            std::sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
                return power[a] > power[b] || (power[a] == power[b] && a < b);
            });
            std::size_t m = 0;
            double held = 0.0;
            while (m < ns && (held < 0.5 * unshot || m < 16) && power[order[m]] > 0.0)
                held += power[order[m++]];
            if (m == 0) break;
            const std::vector<std::uint32_t> part(order.begin(),
                                                  order.begin() + static_cast<std::ptrdiff_t>(m));
            compute_rows(part);
            const double omega = m_options.overrelaxation;
            for (const std::uint32_t i : part) {
                if (shooter_power(i) <= 0.0) continue;
                shoot_from(i, [&](std::uint32_t e) { return omega * m_r[e]; });
            }
            release_rows(part);
            unshot = unshot_power();
            record(unshot);
            left = left_fraction(unshot);
            progress("interreflection: converging, " + std::to_string(m_sol.shots) + " shots",
                     permille(left), 1000, left);
        }
    }

    // The stop rule. With the ambient term, which spreads what is left, the unshot power U
    // against the emitted power. Without it, what is still to come as a fraction of the
    // converged reflected light: U is received, reflected through the area-weighted mean
    // reflectance ρ̄ and received again, U/(1 − ρ̄) in all (less what escapes), against that
    // plus the reflected light received so far. (U against the emitted power stopped early at
    // low ρ, where the reflected light is a small part of it: −7.3 % at ρ = 0.05.)
    double left_fraction(double unshot) const {
        if (m_options.ambient) {
            const double emitted = m_sol.energy.emitted;
            return emitted > 0.0 ? unshot / emitted : 0.0;
        }
        const double rest = unshot / std::max(1e-6, 1.0 - m_rho_mean);
        double received = 0.0;
        for (std::size_t e = 0; e < m_ne; ++e) {
            const auto& el = m_sol.elements[e];
            received += channel_mean(m_H[e] - el.direct) * el.area;
        }
        const double total = received + rest;
        return total > 0.0 ? rest / total : 0.0;
    }

    // Energy: emitted = Σ(1 − ρ)H·A + back + escaped + Σ r·A
    void account_energy() {
        EnergyBalance& energy = m_sol.energy;
        for (std::size_t e = 0; e < m_ne; ++e) {
            const auto& el = m_sol.elements[e];
            energy.absorbed += channel_mean((visdb::Rgb(1.0) - el.reflectance) * m_H[e]) * el.area;
            energy.unshot += channel_mean(m_r[e]) * el.area;
        }
        energy.absorbed += m_back_absorbed;
        energy.escaped = m_escaped;
    }

    // Ambient term: what is left unshot, spread evenly and reflected on through the average
    // reflectance; each element counts the part of its hemisphere that other elements fill
    void add_ambient() {
        visdb::Rgb first(0.0), rho_eff(0.0);
        for (std::size_t e = 0; e < m_ne; ++e) {
            const auto& el = m_sol.elements[e];
            const Row& row = m_rows[m_shooter_of[e]];
            const double kept = row.known ? row.front : 1.0;
            first += m_r[e] * el.area * kept;
            rho_eff += el.reflectance * el.area * kept;
        }
        rho_eff /= m_total_area;
        const visdb::Rgb amb =
            first / m_total_area / glm::max(visdb::Rgb(1e-6), visdb::Rgb(1.0) - rho_eff);
        m_sol.ambient_irradiance = amb;
        for (std::size_t e = 0; e < m_ne; ++e) m_H[e] += amb;
        m_sol.energy.ambient = channel_mean(amb) * m_total_area;
    }

    const IndirectInput& m_in;
    const IndirectOptions& m_options;
    const ProgressFn& m_progress;
    const Clock::time_point m_start = Clock::now();
    const Hemicube m_hemicube, m_row_hemicube;
    ShootOptions m_shoot;
    const std::vector<glm::dvec3> m_region_normal;
    // The hemicubes' patches (make_visibility): the input's outlines, or the solver's own
    // when the input has none; the BVH is over them
    Outlines m_own_outlines;
    std::span<const Patch> m_vis;
    std::unique_ptr<Bvh> m_bvh;
    // Per shooter, the member it shoots from when split_unseen_members chose it (else
    // kNoPatch: point_of chooses)
    std::vector<std::uint32_t> m_point;
    std::optional<Occluders> m_occluders;  // large_occluders: rasterized first by each row
    std::string m_label;
    IndirectSolution m_sol;
    std::vector<visdb::Rgb> m_rho_area;
    // (element, outline triangle) for every outline triangle whose box meets the element's
    // cell, sorted: the elements' polygons (element_polygons)
    std::vector<std::pair<std::uint32_t, std::uint32_t>> m_element_triangle;
    SmallElements m_small;  // needles and slivers, whose rows are bounded (fold_row)
    std::size_t m_ne = 0;
    double m_total_area = 0.0;
    double m_rho_mean = 0.0;  // area-weighted mean reflectance of the elements (channel mean)
    std::unique_ptr<ElementTargets> m_targets;
    std::vector<ShooterFrame> m_shooters;                  // each shooter's point and normal
    std::vector<std::uint32_t> m_shooter_of;               // per element
    std::vector<std::uint32_t> m_member_start, m_members;  // each shooter's elements
    std::vector<visdb::Rgb> m_H, m_r, m_B;
    std::vector<Row> m_rows;
    std::size_t m_cache_bytes = 0;
    // The cost model of rows (row_cost): seconds and rows per region, seconds in all
    std::vector<double> m_region_row_seconds;
    std::vector<std::uint32_t> m_region_rows;
    double m_row_seconds = 0.0;
    double m_back_absorbed = 0.0, m_escaped = 0.0;
};

}  // namespace

Outlines outline_patches(std::span<const Patch> patches, std::span<const std::uint32_t> region,
                         std::span<const glm::dvec3> region_normal) {
    const std::size_t nr = region_normal.size();
    std::vector<std::vector<std::uint32_t>> of_region(nr);
    for (std::size_t t = 0; t < patches.size(); ++t)
        of_region[region[t]].push_back(static_cast<std::uint32_t>(t));
    std::vector<MeshedRegion> outline(nr);
    tbb::parallel_for(std::size_t{0}, nr, [&](std::size_t r) {
        if (of_region[r].size() < 3) return;
        PlanarRegion pr;
        pr.normal = region_normal[r];
        std::map<std::array<double, 3>, std::uint32_t> index;  // exact positions
        Box box;
        for (const std::uint32_t t : of_region[r]) {
            glm::u32vec3 tri;
            for (int k = 0; k < 3; ++k) {
                const glm::dvec3& x = patches[t].p[k];
                const auto [it, added] = index.try_emplace(
                    {x.x, x.y, x.z}, static_cast<std::uint32_t>(pr.positions.size()));
                if (added) pr.positions.push_back(x);
                tri[k] = it->second;
                box.grow(x);
            }
            pr.triangles.push_back(tri);
        }
        outline[r] = outline_triangulation(pr, kOutlineTolerance * glm::distance(box.lo, box.hi));
    });
    Outlines out;
    for (std::size_t r = 0; r < nr; ++r) {
        const std::vector<std::uint32_t>& ts = of_region[r];
        const auto add = [&](const Patch& p, std::uint32_t source) {
            out.patches.push_back(p);
            out.region.push_back(static_cast<std::uint32_t>(r));
            out.source.push_back(source);
        };
        if (outline[r].triangles.empty()) {
            for (const std::uint32_t t : ts) add(patches[t], t);
            continue;
        }
        const std::vector<glm::dvec3>& x = outline[r].positions;
        for (const glm::u32vec3& t : outline[r].triangles)
            add({{x[t.x], x[t.y], x[t.z]}, patches[ts[0]].opacity}, kNoPatch);
    }
    return out;
}

IndirectSolution solve_indirect(const IndirectInput& in, const IndirectOptions& options,
                                const ProgressFn& progress) {
    validate(options);
    return Solver(in, options, progress).run();
}

namespace {

// A region's field from its elements' values at a point: bilinear between the four cell
// centres around it where all four hold elements, else the value of the element holding the
// point extended by its one- or two-sided differences to its neighbours along the grid's axes
// (linear, not constant, to the region's edge), at least 0.
template <class Value>
visdb::Rgb linear_at(const IndirectSolution& sol, std::uint32_t region, const glm::dvec3& p,
                     const Value& value) {
    const glm::dvec2 st = sol.centre_coordinates(region, p);
    const double s = st.x, t = st.y;
    if (sol.interpolates(region, p)) {
        const int i0 = static_cast<int>(std::floor(s)), j0 = static_cast<int>(std::floor(t));
        const double a = s - i0, b = t - j0;
        return (1 - a) * (1 - b) * value(sol.element_at(region, i0, j0)) +
               a * (1 - b) * value(sol.element_at(region, i0 + 1, j0)) +
               (1 - a) * b * value(sol.element_at(region, i0, j0 + 1)) +
               a * b * value(sol.element_at(region, i0 + 1, j0 + 1));
    }
    const int i = static_cast<int>(std::floor(s + 0.5)), j = static_cast<int>(std::floor(t + 0.5));
    const std::uint32_t e = sol.element_at(region, i, j);
    if (e == IndirectSolution::kNoElement) return sol.at(region, p);
    const visdb::Rgb c = value(e);
    const auto slope = [&](int di, int dj) {
        const std::uint32_t lo = sol.element_at(region, i - di, j - dj);
        const std::uint32_t hi = sol.element_at(region, i + di, j + dj);
        const bool has_lo = lo != IndirectSolution::kNoElement;
        const bool has_hi = hi != IndirectSolution::kNoElement;
        if (has_lo && has_hi) return 0.5 * (value(hi) - value(lo));
        if (has_hi) return value(hi) - c;
        if (has_lo) return c - value(lo);
        return visdb::Rgb(0.0);
    };
    return glm::max(c + (s - i) * slope(1, 0) + (t - j) * slope(0, 1), visdb::Rgb(0.0));
}

// The gathers' targets: each element's cell cut into kGatherCells × kGatherCells parts, so
// that a sample carries the radiosity at its part's centre (linear_at), not the element's
// mean; ids below `plain` are parts (element × kGatherCells² + part), the others an element
// whole (plain + element).
constexpr int kGatherCells = 8;

// The centre of part `id` (an element's part, PartTargets)
glm::dvec3 part_centre(const IndirectSolution& sol, std::uint32_t id) {
    const std::uint32_t e = id / (kGatherCells * kGatherCells);
    const std::uint32_t part = id % (kGatherCells * kGatherCells);
    const IndirectSolution::Element& el = sol.elements[e];
    const IndirectSolution::Grid& g = sol.grids[el.region];
    const std::uint32_t column = part % kGatherCells, row = part / kGatherCells;
    const double a = el.cell.x + (column + 0.5) / kGatherCells;
    const double b = el.cell.y + (row + 0.5) / kGatherCells;
    return g.origin + sol.element_size * (a * g.u + b * g.v);
}

class PartTargets final : public Targets {
  public:
    PartTargets(const IndirectSolution& sol, std::span<const std::uint32_t> region)
        : m_sol(sol),
          m_region(region),
          m_plain(static_cast<std::uint32_t>(sol.elements.size() * kGatherCells * kGatherCells)) {}

    std::uint32_t whole(std::uint32_t t) const override {
        const std::uint32_t e = m_sol.visibility_whole[t];
        return e != IndirectSolution::kNoElement ? m_plain + e : kNoPatch;
    }

    Grid grid(std::uint32_t t) const override {
        const IndirectSolution::Grid& g = m_sol.grids[m_region[t]];
        return {g.origin, g.u, g.v, m_sol.element_size / kGatherCells};
    }

    std::uint32_t cell(std::uint32_t t, int i, int j) const override {
        const int ci = floor_div(i), cj = floor_div(j);
        const std::uint32_t e = m_sol.element_at(m_region[t], ci, cj);
        if (e == IndirectSolution::kNoElement) return m_plain + m_sol.visibility_main[t];
        const auto part = static_cast<std::uint32_t>((j - cj * kGatherCells) * kGatherCells +
                                                     (i - ci * kGatherCells));
        return e * kGatherCells * kGatherCells + part;
    }

  private:
    static int floor_div(int i) {
        return i >= 0 ? i / kGatherCells : -((-i + kGatherCells - 1) / kGatherCells);
    }

    const IndirectSolution& m_sol;
    std::span<const std::uint32_t> m_region;
    std::uint32_t m_plain;
};

}  // namespace

IndirectGather::IndirectGather(const IndirectInput& in, const IndirectSolution& sol,
                               const IndirectOptions& options, std::span<const ProbePoint> points,
                               const ProgressFn& progress)
    : m_sol(sol),
      m_plain(static_cast<std::uint32_t>(sol.elements.size() * kGatherCells * kGatherCells)) {
    m_start.assign(points.size() + 1, 0);
    if (points.empty()) return;
    Outlines own;
    if (!in.outlines) own = outline_patches(in.patches, in.region, in.region_normal);
    const Outlines& o = in.outlines ? *in.outlines : own;
    ABRAD_CHECK(sol.visibility_whole.size() == o.patches.size() &&
                    sol.visibility_main.size() == o.patches.size(),
                "IndirectGather: the solution was made from other visibility triangles");
    const double size = sol.element_size;
    const Bvh bvh(o.patches);
    const Occluders occluders = large_occluders(o.patches, size * size, kNearOccluders * size);
    const PartTargets targets(sol, o.region);
    const Hemicube hemicube(options.row_resolution);
    const ShootOptions shoot_options{.method = options.method,
                                     .subpixels = options.row_subpixels,
                                     .occlusion = false,
                                     .bvh = &bvh,
                                     .sparse = true,
                                     .targets = &targets,
                                     .occluders_first = &occluders,
                                     .fine_masks = false};
    std::vector<std::vector<Hit>> hits(points.size());
    ParallelProgress report(progress, "indirect: gathers", points.size());
    tbb::parallel_for(std::size_t{0}, points.size(), [&](std::size_t k) {
        const ProbePoint& p = points[k];
        const ShootResult shot =
            shoot(ShooterFrame::at(p.x, p.n), o.patches, hemicube, shoot_options);
        for (const auto [id, f] : shot.hits) {
            const IndirectSolution::Element& el = sol.elements[element_of(id)];
            // An element reflects from its front only
            if (glm::dot(p.x - el.centroid, in.region_normal[el.region]) > 0.0)
                hits[k].push_back({id, static_cast<float>(f)});
        }
        report.add(1);
    });
    for (std::size_t k = 0; k < points.size(); ++k) {
        m_start[k + 1] = m_start[k] + hits[k].size();
        m_hits.insert(m_hits.end(), hits[k].begin(), hits[k].end());
    }
}

std::uint32_t IndirectGather::element_of(std::uint32_t id) const {
    return id < m_plain ? id / (kGatherCells * kGatherCells) : id - m_plain;
}

std::vector<visdb::Rgb> IndirectGather::values(const FieldAt& direct_at,
                                               const FieldAt& indirect_at) const {
    const IndirectSolution& sol = m_sol;
    const auto direct = [&](std::uint32_t e) { return sol.elements[e].direct; };
    const auto indirect = [&](std::uint32_t e) { return sol.elements[e].indirect; };
    std::vector<visdb::Rgb> h(m_start.size() - 1, visdb::Rgb(0.0));
    tbb::parallel_for(std::size_t{0}, h.size(), [&](std::size_t k) {
        visdb::Rgb sum(0.0);
        for (std::size_t n = m_start[k]; n < m_start[k + 1]; ++n) {
            const auto [id, f] = m_hits[n];
            const std::uint32_t e = element_of(id);
            const IndirectSolution::Element& el = sol.elements[e];
            // What the element reflects: ρ times all it receives (the ambient term's share
            // too), at the part's centre or, for a whole element, its mean
            if (id >= m_plain) {
                sum += double(f) * el.reflectance * (el.direct + el.indirect);
                continue;
            }
            const glm::dvec3 c = part_centre(sol, id);
            std::optional<visdb::Rgb> d, i;
            if (direct_at) d = direct_at(e, c);
            if (!d) d = linear_at(sol, el.region, c, direct);
            if (indirect_at) i = indirect_at(e, c);
            if (!i) i = linear_at(sol, el.region, c, indirect);
            sum += double(f) * el.reflectance * (*d + *i);
        }
        h[k] = sum;
    });
    return h;
}

}  // namespace abrad::radiosity

namespace abrad::radiosity {

IndirectField::IndirectField(const visdb::Scene& scene, const visdb::BakeMesh& mesh, int resolution)
    : m_hemicube(resolution) {
    // Survey coordinates: work in the local frame, as the bake does
    m_origin = visdb::local_origin(mesh.positions);
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
        const glm::u32vec3 tri = mesh.triangles[t];
        const std::uint32_t s = mesh.triangle_surface[t];
        if (s >= scene.surfaces.size() || scene.surfaces[s].material >= scene.materials.size())
            throw InputError("bake triangle " + std::to_string(t) +
                             " has no surface or material in the scene");
        const visdb::Material& m = scene.materials[scene.surfaces[s].material];
        Patch p{{mesh.positions[tri.x] - m_origin, mesh.positions[tri.y] - m_origin,
                 mesh.positions[tri.z] - m_origin},
                m.opacity};
        const glm::dvec3 c = glm::cross(p.p[1] - p.p[0], p.p[2] - p.p[0]);
        if (!(glm::length(c) > 0.0)) continue;
        visdb::Rgb b(0.0);
        for (int k = 0; k < 3; ++k) b += visdb::Rgb(mesh.radiosity[tri[k]]) - m.emittance;
        m_patches.push_back(p);
        m_centroid.push_back((p.p[0] + p.p[1] + p.p[2]) / 3.0);
        m_normal.push_back(glm::normalize(c));
        m_reflected.push_back(glm::max(b / 3.0, visdb::Rgb(0.0)));
    }
    m_bvh.emplace(m_patches);
    // Walls and slabs, rasterized first by every gather
    m_occluders.emplace(large_occluders(m_patches, kOccluderArea, kOccluderNear));
}

visdb::Rgb IndirectField::irradiance(const glm::dvec3& x_world, const glm::dvec3& n) const {
    const glm::dvec3 x = x_world - m_origin;
    const ShootResult shot = shoot(ShooterFrame::at(x, n), m_patches, m_hemicube,
                                   {.method = Visibility::ABuffer,
                                    .subpixels = 8,
                                    .occlusion = false,
                                    .bvh = &*m_bvh,
                                    .sparse = true,
                                    .occluders_first = &*m_occluders,
                                    .fine_masks = false});
    visdb::Rgb h(0.0);
    for (const auto [j, f] : shot.hits)
        // A surface reflects from its front only
        if (glm::dot(x - m_centroid[j], m_normal[j]) > 0.0) h += f * m_reflected[j];
    return h;
}

}  // namespace abrad::radiosity

namespace abrad::radiosity {

PointIrradiance::PointIrradiance(const visdb::Scene& scene, const visdb::Bake* bake)
    : m_direct(scene) {
    if (!bake) return;
    for (const auto& [key, value] : bake->parameters)
        if (key == "bounces" && value != "0") m_indirect.emplace(scene, bake->mesh);
}

std::vector<visdb::Rgb> PointIrradiance::at(std::span<const ProbePoint> points) const {
    std::vector<visdb::Rgb> h(points.size());
    tbb::parallel_for(std::size_t{0}, points.size(), [&](std::size_t i) {
        h[i] = m_direct.irradiance(points[i].x, points[i].n);
        if (m_indirect) h[i] += m_indirect->irradiance(points[i].x, points[i].n);
    });
    return h;
}

}  // namespace abrad::radiosity
