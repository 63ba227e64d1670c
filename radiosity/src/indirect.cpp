// Interreflection: progressive refinement as (over-relaxed) Southwell relaxation on clustered
// elements (Cohen et al. 1988; Gortler, Cohen & Slusallek 1993), with the ambient term.

#include "abrad/radiosity/indirect.h"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <mutex>
#include <numeric>

#include "abrad/radiosity/bake.h"
#include "abrad/radiosity/hemicube.h"

namespace abrad::radiosity {

namespace {

using Clock = std::chrono::steady_clock;

double mean(const visdb::Rgb& c) { return (c.x + c.y + c.z) / 3.0; }
bool emits(const visdb::Rgb& e) { return e.x > 0.0 || e.y > 0.0 || e.z > 0.0; }

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

// Triangles the hemicubes rasterize: the scene's, those larger than a grid cell cut into n²
// similar pieces, each piece knowing its element.
struct Pieces {
    std::vector<Patch> patch;
    std::vector<std::uint32_t> element;
    std::vector<glm::dvec3> centroid;
};

double area_of(const Patch& p) {
    return 0.5 * glm::length(glm::cross(p.p[1] - p.p[0], p.p[2] - p.p[0]));
}

// Form factors from one shooting point onto the elements, fronts and backs apart, given the
// hemicube's form factor of every piece.
void fold_row(const std::vector<double>& piece_ff, const Pieces& pieces,
              const std::vector<IndirectSolution::Element>& elements, const glm::dvec3& from,
              std::vector<double>& front, std::vector<double>& back,
              std::vector<std::uint32_t>& touched, Row& row,
              const std::vector<glm::dvec3>& region_normal) {
    touched.clear();
    for (std::size_t j = 0; j < piece_ff.size(); ++j) {
        const double f = piece_ff[j];
        if (!(f > 0.0)) continue;
        const std::uint32_t e = pieces.element[j];
        if (front[e] == 0.0 && back[e] == 0.0) touched.push_back(e);
        // The shooter lights the element's front when it lies in front of the element's plane
        if (glm::dot(from - pieces.centroid[j], region_normal[elements[e].region]) > 0.0)
            front[e] += f;
        else
            back[e] += f;
    }
    std::sort(touched.begin(), touched.end());
    row.entries.clear();
    row.front = row.total = 0.0;
    for (const std::uint32_t e : touched) {
        if (front[e] > 0.0) row.entries.push_back({e, static_cast<float>(front[e])});
        if (back[e] > 0.0) row.entries.push_back({e | kBack, static_cast<float>(back[e])});
        row.front += front[e];
        row.total += front[e] + back[e];
        front[e] = back[e] = 0.0;
    }
    row.known = true;
}

}  // namespace

std::uint64_t IndirectSolution::cell_key(std::uint32_t region, int i, int j) {
    // 24 bits of region, 20 bits per cell coordinate (cells of a region span ±2^19)
    return (std::uint64_t{region} << 40) ^ (std::uint64_t(std::uint32_t(i) & 0xFFFFFu) << 20) ^
           std::uint64_t(std::uint32_t(j) & 0xFFFFFu);
}

visdb::Rgb IndirectSolution::at(std::uint32_t region, const glm::dvec3& p) const {
    if (region >= grids.size()) return visdb::Rgb(0.0);
    const Grid& g = grids[region];
    // Cell-centre coordinates: centre of cell (i, j) at (i, j)
    const double s = glm::dot(p - g.origin, g.u) / element_size - 0.5;
    const double t = glm::dot(p - g.origin, g.v) / element_size - 0.5;
    const double fs = std::floor(s), ft = std::floor(t);
    const int i0 = static_cast<int>(fs), j0 = static_cast<int>(ft);
    const double a = s - fs, b = t - ft;
    visdb::Rgb sum(0.0);
    double weight = 0.0;
    for (int dj = 0; dj < 2; ++dj)
        for (int di = 0; di < 2; ++di) {
            const auto it = cell_element.find(cell_key(region, i0 + di, j0 + dj));
            if (it == cell_element.end()) continue;
            const double w = (di ? a : 1.0 - a) * (dj ? b : 1.0 - b);
            sum += w * elements[it->second].indirect;
            weight += w;
        }
    if (weight > 1e-9) return sum / weight;
    // Near the corner of a cell whose neighbours are empty: the nearest element of the 3×3 block
    double best = std::numeric_limits<double>::max();
    visdb::Rgb value(0.0);
    for (int dj = -1; dj <= 2; ++dj)
        for (int di = -1; di <= 2; ++di) {
            const auto it = cell_element.find(cell_key(region, i0 + di, j0 + dj));
            if (it == cell_element.end()) continue;
            const double d = glm::length(elements[it->second].centroid - p);
            if (d < best) {
                best = d;
                value = elements[it->second].indirect;
            }
        }
    return value;
}

void validate(const IndirectOptions& o) {
    if (o.bounces < 0 || o.bounces > 1000)
        throw BakeError("--bounces must be in [0, 1000], got " + std::to_string(o.bounces));
    if (!(o.converge > 0.0 && o.converge < 1.0))
        throw BakeError("--converge must be in (0, 1), got " + std::to_string(o.converge));
    if (!(o.element_size > 0.0 && std::isfinite(o.element_size)))
        throw BakeError("--element-size must be > 0 metres, got " + std::to_string(o.element_size));
    if (!(o.overrelaxation >= 1.0 && o.overrelaxation < 2.0))
        throw BakeError("--overrelax must be in [1, 2), got " + std::to_string(o.overrelaxation));
}

IndirectSolution solve_indirect(const IndirectInput& in, const IndirectOptions& options,
                                const IndirectProgressFn& progress) {
    validate(options);
    const auto t_start = Clock::now();
    const std::size_t nt = in.patches.size(), nr = in.region_normal.size();
    IndirectSolution sol;
    sol.element_size = options.element_size;
    const double size = options.element_size;

    // Region grids: origin at a vertex of the region's first triangle, axes in its plane
    sol.grids.resize(nr);
    std::vector<char> grid_set(nr, 0);
    for (std::size_t t = 0; t < nt; ++t) {
        const std::uint32_t r = in.region[t];
        if (grid_set[r]) continue;
        grid_set[r] = 1;
        const ShooterFrame f = ShooterFrame::at(in.patches[t].p[0], in.region_normal[r]);
        sol.grids[r] = {f.origin, f.u, f.v};
    }

    // Pieces and elements: triangles larger than a cell cut into n² similar pieces, each piece
    // in the element of the cell holding its centroid
    Pieces pieces;
    std::vector<visdb::Rgb> rho_area;
    auto element_of = [&](std::uint32_t r, const glm::dvec3& c) {
        const auto& g = sol.grids[r];
        const int i = static_cast<int>(std::floor(glm::dot(c - g.origin, g.u) / size));
        const int j = static_cast<int>(std::floor(glm::dot(c - g.origin, g.v) / size));
        const auto [it, inserted] = sol.cell_element.try_emplace(
            IndirectSolution::cell_key(r, i, j), static_cast<std::uint32_t>(sol.elements.size()));
        if (inserted) {
            sol.elements.push_back({.region = r, .cell = {i, j}});
            rho_area.emplace_back(0.0);
        }
        return it->second;
    };
    for (std::size_t t = 0; t < nt; ++t) {
        const Patch& p = in.patches[t];
        double longest = 0.0;
        for (int k = 0; k < 3; ++k)
            longest = std::max(longest, glm::length(p.p[(k + 1) % 3] - p.p[k]));
        const int n = static_cast<int>(std::clamp(std::ceil(longest / size), 1.0, 64.0));
        const glm::dvec3 e1 = (p.p[1] - p.p[0]) / double(n), e2 = (p.p[2] - p.p[0]) / double(n);
        auto at = [&](int i, int j) { return p.p[0] + double(i) * e1 + double(j) * e2; };
        auto add = [&](const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c) {
            const Patch piece{{a, b, c}, p.opacity};
            const glm::dvec3 centroid = (a + b + c) / 3.0;
            const std::uint32_t e = element_of(in.region[t], centroid);
            const double area = area_of(piece);
            auto& el = sol.elements[e];
            el.area += area;
            el.centroid += area * centroid;
            rho_area[e] += area * in.reflectance[t];
            pieces.patch.push_back(piece);
            pieces.element.push_back(e);
            pieces.centroid.push_back(centroid);
        };
        // Corner coordinates are whole multiples: a piece's corners are exact where n = 1
        for (int i = 0; i < n; ++i)
            for (int j = 0; i + j < n; ++j) {
                add(n == 1 ? p.p[0] : at(i, j), n == 1 ? p.p[1] : at(i + 1, j),
                    n == 1 ? p.p[2] : at(i, j + 1));
                if (i + j + 2 <= n) add(at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
            }
    }
    const std::size_t ne = sol.elements.size(), np = pieces.patch.size();
    sol.pieces = np;
    double total_area = 0.0;
    for (std::size_t e = 0; e < ne; ++e) {
        auto& el = sol.elements[e];
        if (el.area > 0.0) {
            el.centroid /= el.area;
            el.reflectance = rho_area[e] / el.area;
        }
        total_area += el.area;
    }
    std::vector<glm::dvec3> region_normal(in.region_normal.begin(), in.region_normal.end());

    const Hemicube hemicube(options.resolution);
    const ShootOptions so{
        .method = options.method, .subpixels = options.subpixels, .occlusion = false};

    // Scratch per thread for folding piece form factors into element rows
    struct Scratch {
        std::vector<double> front, back;
        std::vector<std::uint32_t> touched;
    };
    tbb::enumerable_thread_specific<Scratch> scratch([&] {
        return Scratch{std::vector<double>(ne, 0.0), std::vector<double>(ne, 0.0), {}};
    });

    // Direct light onto the elements: one hemicube per light triangle (the paper's shot)
    std::vector<visdb::Rgb> H(ne, visdb::Rgb(0.0));
    EnergyBalance& energy = sol.energy;
    double back_absorbed = 0.0, escaped = 0.0;
    std::mutex merge;
    std::vector<std::uint32_t> lights;
    for (std::size_t t = 0; t < nt; ++t)
        if (emits(in.emittance[t])) lights.push_back(static_cast<std::uint32_t>(t));
    if (lights.empty())
        throw BakeError("the scene has no light sources (no material with emittance > 0)");
    for (const std::uint32_t l : lights)
        energy.emitted += mean(in.emittance[l]) * area_of(in.patches[l]);
    if (progress) progress("interreflection: lights", 0, lights.size(), 1.0);
    tbb::parallel_for(std::size_t{0}, lights.size(), [&](std::size_t li) {
        const Patch& light = in.patches[lights[li]];
        const ShooterFrame frame = frame_of(light);
        const ShootResult shot = shoot(frame, pieces.patch, hemicube, so);
        Scratch& s = scratch.local();
        Row row;
        fold_row(shot.form_factor, pieces, sol.elements, frame.origin, s.front, s.back, s.touched,
                 row, region_normal);
        const visdb::Rgb power = in.emittance[lights[li]] * area_of(light);
        std::lock_guard lock(merge);
        for (const Entry& x : row.entries) {
            if (x.element & kBack) {
                back_absorbed += mean(power) * x.ff;
                continue;
            }
            H[x.element] += power * double(x.ff) / sol.elements[x.element].area;
        }
        escaped += mean(power) * std::max(0.0, 1.0 - row.total);
    });
    for (std::size_t e = 0; e < ne; ++e) sol.elements[e].direct = H[e];

    // Southwell state: H received (front), B shot so far, r unshot = ρH − B
    std::vector<visdb::Rgb> r(ne), B(ne, visdb::Rgb(0.0));
    for (std::size_t e = 0; e < ne; ++e) r[e] = sol.elements[e].reflectance * H[e];
    auto unshot_power = [&] {
        double u = 0.0;
        for (std::size_t e = 0; e < ne; ++e) u += std::abs(mean(r[e])) * sol.elements[e].area;
        return u;
    };

    // Rows: computed in parallel batches when first needed, kept while the cache has room
    std::vector<Row> rows(ne);
    std::size_t cache_bytes = 0;
    auto compute_rows = [&](const std::vector<std::uint32_t>& wanted) {
        std::vector<std::uint32_t> todo;
        for (const std::uint32_t e : wanted)
            if (!rows[e].known) todo.push_back(e);
        tbb::parallel_for(std::size_t{0}, todo.size(), [&](std::size_t k) {
            const auto& el = sol.elements[todo[k]];
            const ShooterFrame frame = ShooterFrame::at(el.centroid, region_normal[el.region]);
            const ShootResult shot = shoot(frame, pieces.patch, hemicube, so);
            Scratch& s = scratch.local();
            fold_row(shot.form_factor, pieces, sol.elements, frame.origin, s.front, s.back,
                     s.touched, rows[todo[k]], region_normal);
        });
        sol.rows_computed += todo.size();
        for (const std::uint32_t e : todo)
            cache_bytes += rows[e].entries.capacity() * sizeof(Entry);
    };
    auto release_rows = [&](const std::vector<std::uint32_t>& used) {
        if (cache_bytes <= options.row_cache_bytes) return;
        for (const std::uint32_t e : used) {
            cache_bytes -= rows[e].entries.capacity() * sizeof(Entry);
            rows[e] = Row{};
        }
    };
    // Shoot `amount` (radiosity, RGB) from element i along its row
    auto shoot_from = [&](std::uint32_t i, const visdb::Rgb& amount) {
        const auto& el = sol.elements[i];
        const visdb::Rgb power = amount * el.area;
        const Row& row = rows[i];
        B[i] += amount;
        r[i] -= amount;
        for (const Entry& x : row.entries) {
            if (x.element & kBack) {
                back_absorbed += mean(power) * x.ff;
                continue;
            }
            auto& rec = sol.elements[x.element];
            const visdb::Rgb dh = power * double(x.ff) / rec.area;
            H[x.element] += dh;
            r[x.element] += rec.reflectance * dh;
        }
        escaped += mean(power) * (1.0 - row.total);
        ++sol.shots;
    };

    const double emitted = energy.emitted;
    auto record = [&](double unshot) {
        sol.curve.push_back({sol.shots,
                             std::chrono::duration<double>(Clock::now() - t_start).count(),
                             emitted > 0.0 ? unshot / emitted : 0.0});
    };
    double unshot = unshot_power();
    record(unshot);

    if (options.bounces > 0) {
        // Bounce k: every element shoots what it received in bounce k − 1 (a Jacobi sweep)
        for (int bounce = 0; bounce < options.bounces; ++bounce) {
            // A copy on purpose: the Jacobi sweep shoots bounce k − 1 while shoot_from changes r
            // (through its reference capture, which clang-tidy does not see)
            // NOLINTNEXTLINE(performance-unnecessary-copy-initialization)
            const std::vector<visdb::Rgb> pending = r;
            std::vector<std::uint32_t> shooters;
            for (std::size_t e = 0; e < ne; ++e)
                if (mean(glm::abs(pending[e])) > 0.0)
                    shooters.push_back(static_cast<std::uint32_t>(e));
            if (shooters.empty()) break;
            // In slices, so that rows not kept in the cache are freed as we go
            const std::size_t slice = 256;
            for (std::size_t s0 = 0; s0 < shooters.size(); s0 += slice) {
                const std::vector<std::uint32_t> part(
                    shooters.begin() + static_cast<std::ptrdiff_t>(s0),
                    shooters.begin() +
                        static_cast<std::ptrdiff_t>(std::min(shooters.size(), s0 + slice)));
                compute_rows(part);
                for (const std::uint32_t i : part) shoot_from(i, pending[i]);
                release_rows(part);
            }
            ++sol.bounces_done;
            unshot = unshot_power();
            record(unshot);
            if (progress)
                progress("interreflection: bounce", std::size_t(bounce) + 1,
                         std::size_t(options.bounces), unshot / emitted);
        }
    } else {
        // Southwell: in rounds, the elements with the most unshot power first; each shoots ω
        // times its unshot radiosity at the moment it shoots
        const double target = options.converge * emitted;
        std::vector<std::uint32_t> order(ne);
        while (unshot > target && sol.shots < options.max_shots) {
            std::iota(order.begin(), order.end(), 0u);
            auto power_of = [&](std::uint32_t e) {
                return std::abs(mean(r[e])) * sol.elements[e].area;
            };
            // The round: the fewest elements holding half of the unshot power, at least 16
            std::sort(order.begin(), order.end(),
                      [&](std::uint32_t a, std::uint32_t b) { return power_of(a) > power_of(b); });
            std::size_t m = 0;
            double held = 0.0;
            while (m < ne && (held < 0.5 * unshot || m < 16) && power_of(order[m]) > 0.0)
                held += power_of(order[m++]);
            if (m == 0) break;
            const std::vector<std::uint32_t> part(order.begin(),
                                                  order.begin() + static_cast<std::ptrdiff_t>(m));
            compute_rows(part);
            for (const std::uint32_t i : part) {
                if (power_of(i) <= 0.0) continue;
                shoot_from(i, options.overrelaxation * r[i]);
            }
            release_rows(part);
            unshot = unshot_power();
            record(unshot);
            if (progress) progress("interreflection: shots", sol.shots, 0, unshot / emitted);
        }
    }

    // Energy: emitted = Σ(1 − ρ)H·A + back + escaped + Σ r·A
    for (std::size_t e = 0; e < ne; ++e) {
        const auto& el = sol.elements[e];
        energy.absorbed += mean((visdb::Rgb(1.0) - el.reflectance) * H[e]) * el.area;
        energy.unshot += mean(r[e]) * el.area;
    }
    energy.absorbed += back_absorbed;
    energy.escaped = escaped;

    // Ambient term: what is left unshot, spread evenly and reflected on through the average
    // reflectance; each element counts the part of its hemisphere that other elements fill
    if (options.bounces == 0 && options.ambient && total_area > 0.0) {
        visdb::Rgb first(0.0), rho_eff(0.0);
        for (std::size_t e = 0; e < ne; ++e) {
            const auto& el = sol.elements[e];
            const double kept = rows[e].known ? rows[e].front : 1.0;
            first += r[e] * el.area * kept;
            rho_eff += el.reflectance * el.area * kept;
        }
        rho_eff /= total_area;
        const visdb::Rgb amb =
            first / total_area / glm::max(visdb::Rgb(1e-6), visdb::Rgb(1.0) - rho_eff);
        sol.ambient_irradiance = amb;
        for (std::size_t e = 0; e < ne; ++e) H[e] += amb;
        energy.ambient = mean(amb) * total_area;
    }

    for (std::size_t e = 0; e < ne; ++e) sol.elements[e].indirect = H[e] - sol.elements[e].direct;
    for (const Row& row : rows) sol.rows_cached += row.known;
    sol.seconds = std::chrono::duration<double>(Clock::now() - t_start).count();
    return sol;
}

}  // namespace abrad::radiosity

namespace abrad::radiosity {

IndirectField::IndirectField(const visdb::Scene& scene, const visdb::BakeMesh& mesh, int resolution)
    : m_hemicube(resolution) {
    glm::dvec3 lo(std::numeric_limits<double>::max()), hi(std::numeric_limits<double>::lowest());
    for (const glm::dvec3& p : mesh.positions) {
        lo = glm::min(lo, p);
        hi = glm::max(hi, p);
    }
    // Survey coordinates: work around the rounded centre, as the bake does
    if (lo.x <= hi.x && glm::length(0.5 * (lo + hi)) >= 1e3) m_origin = glm::round(0.5 * (lo + hi));
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
        const glm::u32vec3 tri = mesh.triangles[t];
        const std::uint32_t s = mesh.triangle_surface[t];
        if (s >= scene.surfaces.size() || scene.surfaces[s].material >= scene.materials.size())
            throw BakeError("bake triangle " + std::to_string(t) +
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
}

visdb::Rgb IndirectField::irradiance(const glm::dvec3& x_world, const glm::dvec3& n) const {
    const glm::dvec3 x = x_world - m_origin;
    const ShootResult shot =
        shoot(ShooterFrame::at(x, n), m_patches, m_hemicube,
              {.method = Visibility::ABuffer, .subpixels = 8, .occlusion = false});
    visdb::Rgb h(0.0);
    for (std::size_t j = 0; j < m_patches.size(); ++j) {
        const double f = shot.form_factor[j];
        // A surface reflects from its front only
        if (f > 0.0 && glm::dot(x - m_centroid[j], m_normal[j]) > 0.0) h += f * m_reflected[j];
    }
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
