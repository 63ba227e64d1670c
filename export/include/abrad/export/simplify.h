#pragma once
// Light meshes: decimation of a baked mesh with OpenMesh's Decimater, a quadric module for
// the shape and a module of abrad's own that bounds the change of irradiance at every
// removed vertex (docs/algorithms.md#simplification). OpenMesh stays inside simplify.cpp.

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "abrad/visdb/model.h"

namespace abrad::exporter {

/// How far the simplified mesh may depart from the bake.
struct SimplifyOptions {
    /// Relative change of irradiance allowed at every removed vertex, per channel: the
    /// simplified mesh's interpolated value there differs from the baked one by at most
    /// `error` × max(baked value, `floor` × the brightest value of the bake). In (0, 1].
    double error = 0.02;
    /// The absolute floor of the bound, a fraction of the brightest irradiance channel of
    /// any vertex: dark areas are held to an absolute error instead of a relative one.
    double floor = 0.1;
    /// Refit the kept vertices' irradiance and radiosity by least squares to every sample of
    /// the bake (the removed vertices and the kept ones, weighted by area) after the
    /// decimation, instead of keeping their baked values.
    bool refit = false;
    /// The area-weighted mean change of irradiance the whole simplification may add, as a
    /// fraction of the bake's area-weighted mean irradiance (0: none; then `error` alone
    /// limits it). The mesh is decimated in parts side by side (whole surfaces dealt into at
    /// most 16 parts of about the same size, the same whatever the number of threads), each
    /// within this fraction of its own area-weighted irradiance, so the whole within it too;
    /// in each part the collapses that add the least go first.
    double budget = 0.0;
    /// With a budget, the collapse that passes a part's share is found only once made. True:
    /// that part's decimation is redone (it is deterministic) and stopped before that collapse,
    /// so that the budget bounds the change. False: those last collapses are kept, in half the
    /// time, but for the parts that pass their shares most, redone so, until the whole passes
    /// the budget by at most a thousandth of it.
    bool exact_budget = true;
    /// Keep every vertex at the position of another vertex of the mesh (within 1e-7 of the
    /// mesh's size: where regions or surfaces meet), so that a mesh without T-vertices, such as
    /// a bake's discontinuity mesh, stays without them. False: such a vertex may go where its own
    /// boundary runs straight through it, though its neighbour keeps its twin.
    bool keep_shared = false;
    /// A collapse whose new triangles would hold more than this many removed vertices of the
    /// bake is not made (0: no limit). Rating a collapse visits them all, so on a finely and
    /// evenly meshed plane (a quality-refined discontinuity mesh) the decimation's time grows
    /// with their count; the limit bounds it, and each triangle's size against the bake's.
    std::size_t max_held = 0;
};

/// Called now and then while the decimation runs (from the threads decimating the parts,
/// one call at a time) with (done, total): with a budget, the thousandths of it spent (total
/// 1000; the cheapest collapses go first, so a rate from the start overestimates what is
/// left); without, the vertices removed out of the mesh's vertices. Starts with done = 0 and
/// ends with done = total (on the calling thread); done never falls.
using SimplifyProgress = std::function<void(std::size_t done, std::size_t total)>;

/// What a simplification did.
struct SimplifyStats {
    std::size_t triangles_before = 0;
    std::size_t triangles_after = 0;
    std::size_t vertices_before = 0;
    std::size_t vertices_after = 0;
    std::size_t locked_faces =
        0;  ///< faces OpenMesh could not join (non-manifold), kept as they are
    /// Collapses carried out past the bound: with refit, a neighbour's refit moved a value
    /// after the decimater rated them (it re-rates only the removed vertex's neighbours).
    std::size_t stale_collapses = 0;
    /// The area-weighted mean change of irradiance at the bake's vertices that the collapses
    /// made (before the final refit), a fraction of the bake's area-weighted mean: what a
    /// budget limits.
    double mean_change = 0.0;
    double seconds = 0.0;  ///< wall seconds
};

/// "triangles 6552 -> 1203 (5.45x), vertices ..., locked faces N, 0.12 s".
std::string to_string(const SimplifyStats& stats);

/// Returns `mesh` with vertices removed by half-edge collapses while, at every removed
/// vertex, the Gouraud-interpolated irradiance of the new triangles stays within the bound
/// of `options`. What stays: every surface's boundary (a boundary vertex is removed only
/// where its boundary runs straight through it), every kept vertex's exact position, normal,
/// irradiance and radiosity, each face's surface and front. A crease is a boundary already
/// (bake vertices are not shared across normals or surfaces). Faces that do not form a
/// manifold are kept unchanged. Throws ExportError for a mesh whose arrays disagree in
/// length, whose indices are out of range, or that has no irradiance, and for options
/// outside their ranges. With `kept`, also the index in `mesh` of every vertex of the result
/// (the values of other per-vertex arrays, such as light groups' shades, carry over through
/// it unless `refit` is set).
visdb::BakeMesh simplify(const visdb::BakeMesh& mesh, const SimplifyOptions& options,
                         SimplifyStats* stats = nullptr, std::vector<std::uint32_t>* kept = nullptr,
                         const SimplifyProgress& progress = {});

}  // namespace abrad::exporter
