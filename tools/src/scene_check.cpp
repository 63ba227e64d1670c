// Import sanity checks (scene_check.h): size, up axis, buried lights.

#include "scene_check.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <glm/geometric.hpp>
#include <limits>
#include <sstream>
#include <utility>

#include "abrad/radiosity/bvh.h"

namespace abrad::tools::cli {
namespace {

constexpr double kMaxSize = 2000.0;   // metres: larger than any building
constexpr double kMinSize = 0.5;      // metres: smaller than any room
constexpr double kUpCos = 0.8660254;  // cos 30°: a face "faces up"
constexpr double kReach = 0.01;       // metres: a buried light's light stops this close
constexpr double kMaxStorey = 50.0;   // metres: a floor-to-ceiling height no building has
constexpr double kStorey = 3.0;       // metres: a typical one

struct Unit {
    const char* name;
    double metres;
};
constexpr std::array<Unit, 5> kUnits = {
    {{"mm", 0.001}, {"cm", 0.01}, {"in", 0.0254}, {"ft", 0.3048}, {"m", 1.0}}};

double unit_metres(const std::string& unit) {
    for (const Unit& u : kUnits)
        if (unit == u.name) return u.metres;
    return 1.0;
}

std::string number(double v) {
    std::ostringstream s;
    s.precision(4);
    s << v;
    return s.str();
}

// The unit (other than the one read) that makes the largest side closest to 20 m, a building.
std::string size_warning(const visdb::Scene& scene, double size) {
    const std::string read = scene.sources.empty() ? "m" : scene.sources.front().unit;
    const double scale = unit_metres(read);
    const Unit* best = nullptr;
    double best_score = 0.0;
    for (const Unit& u : kUnits) {
        const double s = size * u.metres / scale;
        if (u.name == read || s < kMinSize || s > kMaxSize) continue;
        const double score = std::abs(std::log(s / 20.0));
        if (!best || score < best_score) best = &u, best_score = score;
    }
    std::string w = "the model's largest side is " + number(size) + " m (read in " + read +
                    "): " + (size > kMaxSize ? "over 2 km" : "under 0.5 m") +
                    ", implausible for a building";
    if (best)
        w += "; if the file is in " + std::string(best->name) + ", import it with --unit " +
             best->name + " (" + number(size * best->metres / scale) + " m)";
    return w;
}

// Up-facing share of the area, and the light power facing sideways.
std::string up_warning(const visdb::Scene& scene, const SceneCheck& c) {
    double light = 0.0, sideways = 0.0;
    for (const auto& s : scene.surfaces) {
        const auto& m = scene.materials[s.material];
        if (!m.is_emitter()) continue;
        for (const auto& t : s.mesh.triangles) {
            const glm::dvec3 a = s.mesh.positions[t.x], b = s.mesh.positions[t.y],
                             d = s.mesh.positions[t.z];
            const glm::dvec3 n2 = glm::cross(b - a, d - a);  // 2 × area along the normal
            const double power = 0.5 * glm::length(n2) * visdb::channel_mean(m.emittance);
            if (power <= 0.0) continue;
            light += power;
            if (std::abs(glm::normalize(n2).z) < 0.5) sideways += power;
        }
    }
    const bool flat = c.area > 0.0 && c.floor_area < 0.05 * c.area;
    const bool lights_sideways = light > 0.0 && sideways > 0.99 * light;
    if (!flat && !lights_sideways) return {};
    std::string why = flat ? number(100.0 * c.floor_area / c.area) +
                                 " % of the area faces up (+Z; floors, slabs, the ground)"
                           : "";
    if (lights_sideways)
        why += std::string(flat ? " and " : "") +
               "every light faces sideways (ceiling lights face down, -Z)";
    const std::string read = scene.sources.empty() ? "z" : scene.sources.front().up_axis;
    const std::string fix = read == "y" ? "--up z" : "--up y";
    return why + ": the up axis may be wrong; the file was read " + (read.empty() ? "Z" : read) +
           " up; try importing with " + fix;
}

// Directions over the unit hemisphere around +Z, cosine-weighted (equal weights): 16 points
// of a Fibonacci spiral on the disc, lifted to the hemisphere.
std::array<glm::dvec3, 16> hemisphere() {
    std::array<glm::dvec3, 16> d{};
    for (std::size_t i = 0; i < d.size(); ++i) {
        const double r = std::sqrt((static_cast<double>(i) + 0.5) / static_cast<double>(d.size()));
        const double phi = 2.399963229728653 * static_cast<double>(i);  // the golden angle
        d[i] = {r * std::cos(phi), r * std::sin(phi), std::sqrt(std::max(0.0, 1.0 - r * r))};
    }
    return d;
}

// Möller–Trumbore: the ray's parameter at triangle (a, b, c), or a negative number.
double ray_triangle(const glm::dvec3& o, const glm::dvec3& d, const glm::dvec3& a,
                    const glm::dvec3& b, const glm::dvec3& c) {
    const glm::dvec3 e1 = b - a, e2 = c - a, p = glm::cross(d, e2);
    const double det = glm::dot(e1, p);
    if (std::abs(det) < 1e-18) return -1.0;
    const glm::dvec3 s = o - a;
    const double u = glm::dot(s, p) / det;
    if (u < 0.0 || u > 1.0) return -1.0;
    const glm::dvec3 q = glm::cross(s, e1);
    const double v = glm::dot(d, q) / det;
    if (v < 0.0 || u + v > 1.0) return -1.0;
    return glm::dot(e2, q) / det;
}

struct Ref {
    std::uint32_t surface, triangle;
};

// Whether the ray from `p` along `dir` meets an opaque triangle of `near` within kReach.
bool stopped_near(const visdb::Scene& scene, const std::vector<Ref>& refs,
                  const std::vector<std::uint32_t>& near, const glm::dvec3& p,
                  const glm::dvec3& dir) {
    for (const std::uint32_t i : near) {
        const auto& o = scene.surfaces[refs[i].surface];
        if (scene.materials[o.material].opacity < 0.5) continue;
        const auto& tri = o.mesh.triangles[refs[i].triangle];
        const double hit = ray_triangle(p, dir, o.mesh.positions[tri.x], o.mesh.positions[tri.y],
                                        o.mesh.positions[tri.z]);
        if (hit > 1e-9 && hit <= kReach) return true;
    }
    return false;
}

// Every triangle of the scene and a BVH over their boxes.
struct Triangles {
    std::vector<Ref> refs;
    radiosity::Bvh bvh;
};

Triangles all_triangles(const visdb::Scene& scene) {
    std::vector<Ref> refs;
    std::vector<radiosity::Box> boxes;
    for (std::uint32_t s = 0; s < scene.surfaces.size(); ++s) {
        const auto& surface = scene.surfaces[s];
        for (std::uint32_t t = 0; t < surface.mesh.triangles.size(); ++t) {
            radiosity::Box b;
            for (int k = 0; k < 3; ++k)
                b.grow(surface.mesh.positions[surface.mesh.triangles[t][k]]);
            refs.push_back({s, t});
            boxes.push_back(b);
        }
    }
    return {std::move(refs), radiosity::Bvh(std::move(boxes))};
}

// The area-weighted median height from the up-facing faces to the first face straight above
// their centroids (faces with nothing above left out), or 0 when none has one: the storey
// height of a building, 100x in a centimetre model read as metres.
double storey_height(const visdb::Scene& scene, const Triangles& all, double top) {
    std::vector<std::pair<double, double>> gaps;  // height, area
    for (const Ref& r : all.refs) {
        const auto& mesh = scene.surfaces[r.surface].mesh;
        const auto& t = mesh.triangles[r.triangle];
        const glm::dvec3 a = mesh.positions[t.x], b = mesh.positions[t.y], d = mesh.positions[t.z];
        const glm::dvec3 n2 = glm::cross(b - a, d - a);
        const double area = 0.5 * glm::length(n2);
        if (!(area > 0.0) || n2.z < kUpCos * 2.0 * area) continue;
        const glm::dvec3 centre = (a + b + d) / 3.0;
        radiosity::Box column;
        column.grow(centre);
        column.grow(glm::dvec3(centre.x, centre.y, top));
        const double eps = 1e-9 * (std::abs(centre.z) + 1.0);
        double nearest = std::numeric_limits<double>::infinity();
        all.bvh.query(column, [&](std::size_t i) {
            const auto& o = scene.surfaces[all.refs[i].surface].mesh;
            const auto& u = o.triangles[all.refs[i].triangle];
            const double hit = ray_triangle(centre, glm::dvec3(0.0, 0.0, 1.0), o.positions[u.x],
                                            o.positions[u.y], o.positions[u.z]);
            if (hit > eps) nearest = std::min(nearest, hit);
        });
        if (std::isfinite(nearest)) gaps.emplace_back(nearest, area);
    }
    if (gaps.empty()) return 0.0;
    std::sort(gaps.begin(), gaps.end());
    double total = 0.0;
    for (const auto& g : gaps) total += g.second;
    double below = 0.0;
    for (const auto& [height, area] : gaps)
        if ((below += area) >= 0.5 * total) return height;
    return gaps.back().first;
}

// The unit (other than the one read) that makes `metres` closest to `typical`, or null.
const Unit* likely_unit(const visdb::Scene& scene, double metres, double typical) {
    const std::string read = scene.sources.empty() ? "m" : scene.sources.front().unit;
    const double scale = unit_metres(read);
    const Unit* best = nullptr;
    double best_score = 0.0;
    for (const Unit& u : kUnits) {
        if (u.name == read) continue;
        const double score = std::abs(std::log(metres * u.metres / scale / typical));
        if (!best || score < best_score) best = &u, best_score = score;
    }
    return best;
}

std::string storey_warning(const visdb::Scene& scene, double storey) {
    const std::string read = scene.sources.empty() ? "m" : scene.sources.front().unit;
    std::string w = "the typical floor-to-ceiling height is " + number(storey) + " m (read in " +
                    read + "): over " + number(kMaxStorey) + " m, implausible for a building";
    if (const Unit* u = likely_unit(scene, storey, kStorey))
        w += "; if the file is in " + std::string(u->name) + ", import it with --unit " + u->name +
             " (" + number(storey * u->metres / unit_metres(read)) + " m)";
    return w;
}

// The share of each emitter surface's emission stopped within kReach; warnings for > 1/2.
void buried_lights(const visdb::Scene& scene, const Triangles& all, SceneCheck& c) {
    bool any_light = false;
    for (const auto& surface : scene.surfaces)
        any_light = any_light || scene.materials[surface.material].is_emitter();
    if (!any_light) return;
    const std::vector<Ref>& refs = all.refs;
    const radiosity::Bvh& bvh = all.bvh;
    const auto dirs = hemisphere();
    for (std::uint32_t s = 0; s < scene.surfaces.size(); ++s) {
        const auto& surface = scene.surfaces[s];
        if (!scene.materials[surface.material].is_emitter()) continue;
        double total = 0.0, stopped = 0.0;
        for (const auto& t : surface.mesh.triangles) {
            const glm::dvec3 a = surface.mesh.positions[t.x], b = surface.mesh.positions[t.y],
                             d = surface.mesh.positions[t.z];
            const glm::dvec3 cross = glm::cross(b - a, d - a);
            const double area = 0.5 * glm::length(cross);
            if (!(area > 0.0)) continue;
            const glm::dvec3 n = cross / (2.0 * area);
            const auto [u, v] = visdb::orthonormal_basis(n);
            const glm::dvec3 centre = (a + b + d) / 3.0;
            radiosity::Box reach;
            for (const glm::dvec3& p : {a, b, d}) reach.grow(p);
            reach.inflate(kReach);
            std::vector<std::uint32_t> near;
            bvh.query(reach, [&](std::size_t i) {
                if (refs[i].surface != s) near.push_back(static_cast<std::uint32_t>(i));
            });
            for (const glm::dvec3& p : {centre, (2.0 * centre + a) / 3.0, (2.0 * centre + b) / 3.0,
                                        (2.0 * centre + d) / 3.0}) {
                for (const glm::dvec3& l : dirs) {
                    total += area;
                    if (stopped_near(scene, refs, near, p, l.x * u + l.y * v + l.z * n))
                        stopped += area;
                }
            }
        }
        if (total > 0.0 && stopped > 0.5 * total)
            c.warnings.push_back("light '" + surface.name +
                                 "': " + number(100.0 * stopped / total) +
                                 " % of its emission is stopped within 1 cm: buried in a wall "
                                 "or ceiling? Move it out, or check which way it faces");
    }
}

}  // namespace

SceneCheck check_scene(const visdb::Scene& scene) {
    SceneCheck c;
    glm::dvec3 lo{std::numeric_limits<double>::max()}, hi{std::numeric_limits<double>::lowest()};
    for (const auto& s : scene.surfaces) {
        visdb::grow_box(s.mesh.positions, lo, hi);
        for (const auto& t : s.mesh.triangles) {
            const glm::dvec3 n2 = glm::cross(s.mesh.positions[t.y] - s.mesh.positions[t.x],
                                             s.mesh.positions[t.z] - s.mesh.positions[t.x]);
            const double area = 0.5 * glm::length(n2);
            c.area += area;
            if (area > 0.0 && n2.z >= kUpCos * 2.0 * area) c.floor_area += area;
        }
    }
    if (!(lo.x <= hi.x)) return c;  // no geometry
    c.lo = lo;
    c.hi = hi;
    const glm::dvec3 size = hi - lo;
    const double largest = std::max({size.x, size.y, size.z});
    if (largest > kMaxSize || largest < kMinSize)
        c.warnings.push_back(size_warning(scene, largest));
    const Triangles all = all_triangles(scene);
    c.storey = storey_height(scene, all, hi.z + 1.0);
    if (largest <= kMaxSize && c.storey > kMaxStorey)
        c.warnings.push_back(storey_warning(scene, c.storey));
    if (std::string w = up_warning(scene, c); !w.empty()) c.warnings.push_back(std::move(w));
    buried_lights(scene, all, c);
    return c;
}

void print_scene_check(const SceneCheck& c, const std::string& command, std::ostream& out,
                       std::ostream& warn) {
    const glm::dvec3 size = c.hi - c.lo;
    out << "bounding box: (" << number(c.lo.x) << ", " << number(c.lo.y) << ", " << number(c.lo.z)
        << ") .. (" << number(c.hi.x) << ", " << number(c.hi.y) << ", " << number(c.hi.z)
        << ") m, size " << number(size.x) << " x " << number(size.y) << " x " << number(size.z)
        << " m\n";
    out << "floor area (faces within 30 degrees of facing up): " << number(c.floor_area)
        << " m2 of " << number(c.area) << " m2\n";
    if (c.storey > 0.0)
        out << "storey height (median, up-facing faces to the face above): " << number(c.storey)
            << " m\n";
    for (const auto& w : c.warnings) warn << "abrad " << command << ": warning: " << w << "\n";
}

}  // namespace abrad::tools::cli
