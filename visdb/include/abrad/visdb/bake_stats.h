#pragma once
// What a bake measured, as named fields: written by the radiosity stages, stored by the
// visdb store (one row per field, by its key), read by the command line, the benchmark and
// the tests. The store's rows keep the historical keys (`dm_rounds`...), listed once, in
// `for_each_stat`.

#include <cmath>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <type_traits>
#include <unordered_map>
#include <utility>
#include <vector>

namespace abrad::visdb {

/// Shooting from the light-source triangles (summed over lights; times are CPU seconds summed
/// over threads).
struct ShootStats {
    std::uint64_t fragments = 0;               ///< A-buffer fragments stored
    std::uint64_t undersampled_fragments = 0;  ///< fragments that needed the finer mask
    std::uint64_t occlusion_pairs = 0;         ///< occlusion pairs kept (Algorithm 2)
    std::uint64_t occlusion_pairs_raw = 0;     ///< occlusion pairs before deduplication
    double form_factor_sum = 0.0;              ///< Σ over lights of Σ_j F_Lj
    double seconds_cpu = 0.0;                  ///< hemicube shots
    double seconds_occlusion_cpu = 0.0;        ///< merging occlusion lists

    ShootStats& operator+=(const ShootStats& o) {
        fragments += o.fragments;
        undersampled_fragments += o.undersampled_fragments;
        occlusion_pairs += o.occlusion_pairs;
        occlusion_pairs_raw += o.occlusion_pairs_raw;
        form_factor_sum += o.form_factor_sum;
        seconds_cpu += o.seconds_cpu;
        seconds_occlusion_cpu += o.seconds_occlusion_cpu;
        return *this;
    }
};

/// Exact vertex shading on the imported mesh (bakes without discontinuity meshing).
struct ExactShadeStats {
    std::uint64_t occluders_tested = 0;           ///< occluder candidates projected
    std::uint64_t occluders_hiding_light = 0;     ///< candidates that hid part of a light
    std::uint64_t occluders_missed_by_lists = 0;  ///< of those, not in the occlusion lists
    double seconds_cpu = 0.0;

    ExactShadeStats& operator+=(const ExactShadeStats& o) {
        occluders_tested += o.occluders_tested;
        occluders_hiding_light += o.occluders_hiding_light;
        occluders_missed_by_lists += o.occluders_missed_by_lists;
        seconds_cpu += o.seconds_cpu;
        return *this;
    }
};

/// Shadow edges projected from the lights onto the receivers (Algorithm 3).
struct ShadowEdgeStats {
    std::uint64_t receivers = 0;               ///< receivers with some occluder
    std::uint64_t occluders_listed = 0;        ///< occluders from the occlusion lists
    std::uint64_t occluders_added_by_bvh = 0;  ///< occluders added by the shaft query
    std::uint64_t edges_projected = 0;         ///< occluder edge × light point projections
    std::uint64_t shared_edges_skipped = 0;    ///< edges shared by two occluders, not projected
    std::uint64_t segments_split = 0;          ///< segments cut by an opaque occluder in front
    std::uint64_t segments_weak = 0;  ///< segments dropped: a jump or length under the tolerances
    double seconds_cpu = 0.0;

    ShadowEdgeStats& operator+=(const ShadowEdgeStats& o) {
        receivers += o.receivers;
        occluders_listed += o.occluders_listed;
        occluders_added_by_bvh += o.occluders_added_by_bvh;
        edges_projected += o.edges_projected;
        shared_edges_skipped += o.shared_edges_skipped;
        segments_split += o.segments_split;
        segments_weak += o.segments_weak;
        seconds_cpu += o.seconds_cpu;
        return *this;
    }
};

/// Discontinuity meshing: shadow edges, the constrained triangulations and their refinement.
struct DiscontinuityStats {
    std::uint64_t regions = 0;           ///< planar regions meshed
    std::uint64_t triangles_before = 0;  ///< triangles of the imported mesh
    ShadowEdgeStats shadow;
    std::uint64_t segments = 0;             ///< shadow segments given to the mesher
    std::uint64_t constraints_dropped = 0;  ///< segments too short or outside their region
    std::uint64_t points_merged = 0;        ///< points snapped to another point or an edge
    std::uint64_t conformity_points = 0;    ///< points added so shared boundaries conform
    std::uint64_t refine_points = 0;        ///< points added by illumination refinement
    std::uint64_t rounds = 0;               ///< meshing rounds
    std::uint64_t exact_evaluations = 0;    ///< exact irradiance evaluations (cached by point)
    double seconds_mesh = 0.0;              ///< wall seconds in the mesher
    double seconds = 0.0;                   ///< wall seconds of the whole stage
    /// The coarsening after the bake (abrad bake --coarsen): the triangles meshed before it (0
    /// when it did not run), the area-weighted mean change of irradiance it made (a fraction
    /// of the mean), and its wall seconds
    std::uint64_t triangles_meshed = 0;
    double coarsen_change = 0.0;
    double seconds_coarsen = 0.0;
};

/// Interreflection (progressive refinement on elements).
struct InterreflectionStats {
    std::uint64_t elements = 0;
    std::uint64_t pieces = 0;                ///< parts of triangles in elements (triangle ∩ cell)
    std::uint64_t visibility_triangles = 0;  ///< triangles the hemicubes rasterize (outlines)
    std::uint64_t shooters = 0;              ///< groups of elements that shoot as one
    std::uint64_t shots = 0;                 ///< shooter shots
    std::uint64_t rows = 0;                  ///< hemicubes placed at shooters
    std::uint64_t bounces = 0;               ///< complete bounces (bounce mode)
    double unshot_fraction = 0.0;
    double ambient = 0.0;                 ///< mean over channels of the ambient irradiance
    double mean_at_vertices = 0.0;        ///< mean indirect irradiance added at the output vertices
    std::uint64_t gathered_vertices = 0;  ///< output vertices whose indirect part was gathered
    double seconds_gather = 0.0;          ///< wall seconds of those gathers
    double energy_emitted_w = 0.0;
    double energy_absorbed_w = 0.0;
    double energy_escaped_w = 0.0;
    double energy_unshot_w = 0.0;
    double seconds = 0.0;  ///< wall seconds
};

/// Everything a bake measured. Groups that a bake's settings do not run are empty.
struct BakeStats {
    std::uint64_t triangles = 0;  ///< of the output mesh
    std::uint64_t vertices = 0;   ///< of the output mesh
    std::uint64_t degenerate_skipped = 0;
    double contact_hidden_m2 = 0.0;       ///< faces' area against or inside another solid, cut away
    std::uint64_t contact_faces_cut = 0;  ///< faces cut there
    std::uint64_t light_triangles = 0;
    double light_area_m2 = 0.0;
    ShootStats shoot;
    double mean_form_factor_sum = 0.0;             ///< shoot.form_factor_sum / light_triangles
    double emitted_power_w = 0.0;                  ///< Σ mean(E)·A over light triangles
    double received_power_w = 0.0;                 ///< Σ mean(H)·A from the lights' hemicubes
    std::optional<ExactShadeStats> exact_shade;    ///< without discontinuity meshing
    std::optional<DiscontinuityStats> dm;          ///< with discontinuity meshing
    std::optional<InterreflectionStats> indirect;  ///< with interreflection
    /// Wall seconds of the shades per light group (0 when the bake stored none)
    double seconds_light_groups = 0.0;
    double seconds_total = 0.0;  ///< wall seconds of the whole bake
    /// Stored keys this build does not know (from other versions), kept as read.
    std::vector<std::pair<std::string, double>> other;
};

namespace stats_detail {
// The stored keys of each group, in stored order: the one table of keys.
template <class S, class F>
void shoot_keys(S& s, F& f) {
    f("triangles", s.triangles);
    f("vertices", s.vertices);
    f("degenerate_skipped", s.degenerate_skipped);
    f("contact_hidden_m2", s.contact_hidden_m2);
    f("contact_faces_cut", s.contact_faces_cut);
    f("light_triangles", s.light_triangles);
    f("light_area_m2", s.light_area_m2);
    f("fragments", s.shoot.fragments);
    f("undersampled_fragments", s.shoot.undersampled_fragments);
    f("occlusion_pairs", s.shoot.occlusion_pairs);
    f("occlusion_pairs_raw", s.shoot.occlusion_pairs_raw);
    f("mean_form_factor_sum", s.mean_form_factor_sum);
    f("emitted_power_w", s.emitted_power_w);
    f("received_power_w", s.received_power_w);
    f("seconds_shoot_cpu", s.shoot.seconds_cpu);
    f("seconds_occlusion_cpu", s.shoot.seconds_occlusion_cpu);
}
template <class E, class F>
void exact_keys(E& e, F& f) {
    f("occluders_tested", e.occluders_tested);
    f("occluders_hiding_light", e.occluders_hiding_light);
    f("occluders_missed_by_lists", e.occluders_missed_by_lists);
    f("seconds_shade_cpu", e.seconds_cpu);
}
template <class D, class F>
void dm_keys(D& d, F& f) {
    f("dm_regions", d.regions);
    f("dm_triangles_before", d.triangles_before);
    f("dm_shadow_receivers", d.shadow.receivers);
    f("dm_shadow_occluders_listed", d.shadow.occluders_listed);
    f("dm_shadow_occluders_added_by_bvh", d.shadow.occluders_added_by_bvh);
    f("dm_shadow_edges_projected", d.shadow.edges_projected);
    f("dm_shadow_shared_edges_skipped", d.shadow.shared_edges_skipped);
    f("dm_shadow_segments_split", d.shadow.segments_split);
    f("dm_shadow_segments_weak", d.shadow.segments_weak);
    f("dm_shadow_segments", d.segments);
    f("dm_constraints_dropped", d.constraints_dropped);
    f("dm_points_merged", d.points_merged);
    f("dm_conformity_points", d.conformity_points);
    f("dm_refine_points", d.refine_points);
    f("dm_rounds", d.rounds);
    f("dm_exact_evaluations", d.exact_evaluations);
    f("seconds_shadow_edges_cpu", d.shadow.seconds_cpu);
    f("seconds_mesh", d.seconds_mesh);
    f("seconds_dm", d.seconds);
    f("dm_triangles_meshed", d.triangles_meshed);
    f("dm_coarsen_change", d.coarsen_change);
    f("seconds_coarsen", d.seconds_coarsen);
}
template <class I, class F>
void indirect_keys(I& i, F& f) {
    f("indirect_elements", i.elements);
    f("indirect_pieces", i.pieces);
    f("indirect_visibility_triangles", i.visibility_triangles);
    f("indirect_shooters", i.shooters);
    f("indirect_shots", i.shots);
    f("indirect_rows", i.rows);
    f("indirect_bounces", i.bounces);
    f("indirect_unshot_fraction", i.unshot_fraction);
    f("indirect_ambient", i.ambient);
    f("indirect_mean_at_vertices", i.mean_at_vertices);
    f("energy_emitted_w", i.energy_emitted_w);
    f("energy_absorbed_w", i.energy_absorbed_w);
    f("energy_escaped_w", i.energy_escaped_w);
    f("energy_unshot_w", i.energy_unshot_w);
    f("seconds_indirect", i.seconds);
    f("indirect_gathered_vertices", i.gathered_vertices);
    f("seconds_gather", i.seconds_gather);
}
template <class S, class F>
void total_keys(S& s, F& f) {
    f("seconds_light_groups", s.seconds_light_groups);
    f("seconds_total", s.seconds_total);
}
}  // namespace stats_detail

/// Calls `f(key, field)` for every field of `s` in stored order, skipping empty groups. `S`
/// is BakeStats or const BakeStats; `field` is a std::uint64_t or double lvalue.
template <class S, class F>
void for_each_stat(S& s, F&& f) {
    static_assert(std::is_same_v<std::remove_const_t<S>, BakeStats>);
    stats_detail::shoot_keys(s, f);
    if (s.exact_shade) stats_detail::exact_keys(*s.exact_shade, f);
    if (s.dm) stats_detail::dm_keys(*s.dm, f);
    if (s.indirect) stats_detail::indirect_keys(*s.indirect, f);
    stats_detail::total_keys(s, f);
}

/// The stored form: (key, value) in `for_each_stat` order, then `other`.
inline std::vector<std::pair<std::string, double>> to_pairs(const BakeStats& s) {
    std::vector<std::pair<std::string, double>> out;
    for_each_stat(s, [&](std::string_view key, const auto& v) {
        out.emplace_back(std::string(key), static_cast<double>(v));
    });
    out.insert(out.end(), s.other.begin(), s.other.end());
    return out;
}

/// Reads the stored form back. A group is present when any of its keys is; unknown keys go
/// to `other`. Counts are rounded to the nearest integer (they are stored as doubles; a NaN
/// or negative count reads as 0).
inline BakeStats stats_from_pairs(const std::vector<std::pair<std::string, double>>& pairs) {
    std::unordered_map<std::string_view, std::size_t> index;
    for (std::size_t i = 0; i < pairs.size(); ++i) index.emplace(pairs[i].first, i);
    std::vector<char> used(pairs.size(), 0);
    std::size_t found = 0;
    auto read = [&](std::string_view key, auto& field) {
        const auto it = index.find(key);
        if (it == index.end()) return;
        used[it->second] = 1;
        ++found;
        const double v = pairs[it->second].second;
        using T = std::remove_reference_t<decltype(field)>;
        if constexpr (std::is_integral_v<T>) {
            field = v >= 0.0 && v < 1.8e19 ? static_cast<T>(std::nearbyint(v)) : T{0};
        } else {
            field = v;
        }
    };
    // Reads one optional group; keeps it only when some key of it was stored
    auto group = [&](auto& optional, auto&& keys) {
        const std::size_t before = found;
        keys(optional.emplace(), read);
        if (found == before) optional.reset();
    };
    BakeStats s;
    stats_detail::shoot_keys(s, read);
    group(s.exact_shade, [](auto& g, auto& f) { stats_detail::exact_keys(g, f); });
    group(s.dm, [](auto& g, auto& f) { stats_detail::dm_keys(g, f); });
    group(s.indirect, [](auto& g, auto& f) { stats_detail::indirect_keys(g, f); });
    stats_detail::total_keys(s, read);
    for (std::size_t i = 0; i < pairs.size(); ++i)
        if (!used[i]) s.other.push_back(pairs[i]);
    return s;
}

}  // namespace abrad::visdb
