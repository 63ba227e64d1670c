// Light meshes: Garland & Heckbert, "Surface Simplification Using Quadric Error Metrics"
// (SIGGRAPH 1997), through OpenMesh's Decimater (half-edge collapses, a quadric module), with
// a module of abrad's own that bounds the change of the baked irradiance field.
//
// Every removed vertex becomes a sample (its position and baked irradiance) owned by the face
// of the current mesh that contains it; a collapse is legal only when every sample in the
// faces it changes, the removed vertex included, is reproduced by the new faces' linear
// interpolation within the bound. So the bound holds at every vertex of the bake, not only
// at the last one removed. Options: a budget on the area-weighted mean change (collapses
// rated by what they add to it), and a least-squares refit of the kept vertices' values
// (docs/algorithms.md#simplification). Numeric assumptions: the bake's connected pieces are
// planar (bake vertices are shared only by faces whose normals agree to 1e-9), barycentric
// coordinates are computed in double in a local frame around the mesh's centre, a sample
// counts as inside a triangle down to a barycentric coordinate of -1e-6, the quadric's
// round-off below 0 counts as 0 (ModPlanarQuadric), and an outline is straight through a
// vertex within 1e-7 of the mesh's diagonal (float input coordinates are off by ~1e-7 relative).

#include "abrad/export/simplify.h"

// OpenMesh's property arrays grow by pushing a default-constructed VectorT (uninitialised by
// design); GCC 12 warns about that inside OpenMesh's templates when sanitizers are on.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif

#include <tbb/parallel_for.h>

#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
#include <OpenMesh/Tools/Decimater/DecimaterT.hh>
#include <OpenMesh/Tools/Decimater/ModBaseT.hh>
#include <OpenMesh/Tools/Decimater/ModQuadricT.hh>
#include <OpenMesh/Tools/Decimater/Observer.hh>
#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <glm/geometric.hpp>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <unordered_map>
#include <utility>
#include <vector>

#include "abrad/export/writers.h"

namespace abrad::exporter {
namespace {

struct MeshTraits : public OpenMesh::DefaultTraits {
    using Point = OpenMesh::Vec3d;
    using Normal = OpenMesh::Vec3d;
    VertexAttributes(OpenMesh::Attributes::Status);
    EdgeAttributes(OpenMesh::Attributes::Status);
    FaceAttributes(OpenMesh::Attributes::Status);
    HalfedgeAttributes(OpenMesh::Attributes::PrevHalfedge);
};
using Mesh = OpenMesh::TriMesh_ArrayKernelT<MeshTraits>;
using Vec3 = OpenMesh::Vec3d;

// A removed vertex of the bake: where it was and what it carried.
struct Sample {
    Vec3 position;  // local frame
    Vec3 irradiance;
    Vec3 radiosity;
    double weight = 0.0;  // the bake vertex's share of its triangles' area (m²)
};

// A point's barycentric coordinates in triangle (a, b, c), projected onto its plane; a
// degenerate triangle gives {-inf, ...} so it never contains anything.
std::array<double, 3> barycentric(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
    const Vec3 e0 = b - a;
    const Vec3 e1 = c - a;
    const Vec3 ep = p - a;
    const double d00 = e0 | e0;
    const double d01 = e0 | e1;
    const double d11 = e1 | e1;
    const double d20 = ep | e0;
    const double d21 = ep | e1;
    const double denom = d00 * d11 - d01 * d01;
    constexpr double kInf = std::numeric_limits<double>::infinity();
    if (!(denom > 1e-14 * d00 * d11)) return {-kInf, -kInf, -kInf};
    const double v = (d11 * d20 - d01 * d21) / denom;
    const double w = (d00 * d21 - d01 * d20) / denom;
    return {1.0 - v - w, v, w};
}

double min3(const std::array<double, 3>& b) { return std::min({b[0], b[1], b[2]}); }

// A triangle of the mesh as it would be after a collapse: corners, their irradiance and
// radiosity, and which corner is the kept vertex v1.
struct Corner3 {
    std::array<Vec3, 3> p;
    std::array<Vec3, 3> h;
    std::array<Vec3, 3> b;
    int pivot = -1;
};

// The shared state of the decimation: the mesh's properties and the bound.
struct Context {
    OpenMesh::VPropHandleT<Vec3> irradiance;            // H of the vertex (refitted or baked)
    OpenMesh::VPropHandleT<Vec3> radiosity;             // B of the vertex (refitted or baked)
    OpenMesh::VPropHandleT<Sample> own;                 // the vertex as the bake has it
    OpenMesh::FPropHandleT<std::vector<Sample>> owned;  // removed vertices inside the face
    double error = 0.02;
    Vec3 floor{0.0, 0.0, 0.0};  // absolute floor per channel (error excluded)
    bool refit = false;         // v1's values refitted at each collapse
    double budget = 0.0;        // the area-weighted error allowed in all (0: no budget)
    double straight = 0.0;      // an outline is straight within this distance (m)
    std::size_t max_held = 0;   // SimplifyOptions::max_held
};

constexpr double kInside = -1e-6;        // barycentric slack for a sample on an edge
constexpr double kStraight = 1e-7;       // an outline runs straight (a fraction of the size)
constexpr double kMinAreaRatio = 1e-10;  // a new triangle keeps this fraction of its area

// A sample seen from the fan of a collapse: its interpolated value is a + c × (v1's value).
struct Located {
    Vec3 a_h, a_b;  // the other two corners' part, irradiance and radiosity
    double c = 0.0;
    const Sample* sample = nullptr;
    double before = 0.0;  // its error before the collapse (mean over the channels)
};

// A sample and its error in the current mesh (mean of the channels' absolute errors).
struct Held {
    const Sample* sample;
    double error;
};

double mean_error(const Vec3& value, const Vec3& baked) {
    return (std::abs(value[0] - baked[0]) + std::abs(value[1] - baked[1]) +
            std::abs(value[2] - baked[2])) /
           3.0;
}

// The irradiance-bound module: non-binary, its priority the worst sample's error as a
// fraction of its bound (so collapses that change the field least go first). With refit,
// the kept vertex v1 takes the values that fit the samples of its new faces best (least
// squares, area-weighted), and every sample of those faces is checked.
class ModIrradianceBound : public OpenMesh::Decimater::ModBaseT<Mesh> {
  public:
    using Base = OpenMesh::Decimater::ModBaseT<Mesh>;
    using Handle = OpenMesh::Decimater::ModHandleT<ModIrradianceBound>;

    explicit ModIrradianceBound(Mesh& mesh) : Base(mesh, false), m_mesh(mesh) {}

    const std::string& name() const override {
        static const std::string kName = "IrradianceBound";
        return kName;
    }

    void set_context(const Context* context) { m_context = context; }

    /// Collapses whose bound no longer held when they were carried out (their rating was
    /// stale: a neighbour's refit after it was rated).
    std::size_t stale() const { return m_stale; }

    /// The area-weighted error the collapses so far added (the budget's spent part).
    double spent() const { return m_spent; }

    float collapse_priority(const CollapseInfo& ci) override {
        if (!boundary_kept(ci) || !build_fan(ci)) return ILLEGAL_COLLAPSE;
        const double worst = rate(ci);
        if (worst > 1.0) return ILLEGAL_COLLAPSE;
        if (m_context->budget > 0.0) {
            if (m_spent + m_delta > m_context->budget) return ILLEGAL_COLLAPSE;
            return static_cast<float>(std::max(m_delta, 0.0) / m_context->budget);
        }
        return static_cast<float>(worst);
    }

    void preprocess_collapse(const CollapseInfo& ci) override {
        Mesh& m = m_mesh;
        // Rate it again: a rating is stale when a neighbour's refit moved a value since
        if (!build_fan(ci) || rate(ci) > 1.0) ++m_stale;
        m_spent += m_delta;
        m_moving.clear();
        m_moving.push_back(m.property(m_context->own, ci.v0));
        for (auto f : m.vf_range(ci.v0)) {
            auto& owned = m.property(m_context->owned, f);
            m_moving.insert(m_moving.end(), owned.begin(), owned.end());
            owned.clear();
        }
    }

    void postprocess_collapse(const CollapseInfo& ci) override {
        Mesh& m = m_mesh;
        if (m_context->refit) {
            m.property(m_context->irradiance, ci.v1) = m_fit_h;
            m.property(m_context->radiosity, ci.v1) = m_fit_b;
        }
        for (const Sample& s : m_moving) {
            Mesh::FaceHandle best;
            double best_inside = -std::numeric_limits<double>::infinity();
            for (auto f : m.vf_range(ci.v1)) {
                std::array<Vec3, 3> p;
                int k = 0;
                for (auto v : m.fv_range(f)) p[k++] = m.point(v);
                const double inside = min3(barycentric(s.position, p[0], p[1], p[2]));
                if (inside > best_inside) {
                    best_inside = inside;
                    best = f;
                }
            }
            if (best.is_valid()) m.property(m_context->owned, best).push_back(s);
        }
        m_moving.clear();
    }

  private:
    // The triangles around v1 after the collapse: the faces of v0 but fl and fr with v0
    // moved onto v1, and with refit the other faces of v1 (whose values change with v1's).
    // False for a triangle that would flip or lose its area.
    bool build_fan(const CollapseInfo& ci) {
        const Mesh& m = m_mesh;
        m_fan.clear();
        for (auto f : m.vf_range(ci.v0)) {
            if (f == ci.fl || f == ci.fr) continue;
            Corner3 after{};
            std::array<Vec3, 3> before;
            int k = 0;
            for (auto v : m.fv_range(f)) {
                before[k] = m.point(v);
                const auto value_of = v == ci.v0 ? ci.v1 : v;
                after.p[k] = v == ci.v0 ? ci.p1 : m.point(v);
                after.h[k] = m.property(m_context->irradiance, value_of);
                after.b[k] = m.property(m_context->radiosity, value_of);
                if (v == ci.v0) after.pivot = k;
                ++k;
            }
            const Vec3 n_before = (before[1] - before[0]) % (before[2] - before[0]);
            const Vec3 n_after = (after.p[1] - after.p[0]) % (after.p[2] - after.p[0]);
            if (!((n_before | n_after) > kMinAreaRatio * (n_before | n_before))) return false;
            m_fan.push_back(after);
        }
        m_samples.clear();
        hold_own(ci.v0);
        for (auto f : m.vf_range(ci.v0)) hold_owned(f);
        if (m_context->max_held > 0 && m_samples.size() > m_context->max_held) return false;
        if (!m_context->refit) return true;
        hold_own(ci.v1);
        for (auto f : m.vf_range(ci.v1)) {
            if (f == ci.fl || f == ci.fr) continue;
            hold_owned(f);
            Corner3 same{};
            int k = 0;
            for (auto v : m.fv_range(f)) {
                same.p[k] = m.point(v);
                same.h[k] = m.property(m_context->irradiance, v);
                same.b[k] = m.property(m_context->radiosity, v);
                if (v == ci.v1) same.pivot = k;
                ++k;
            }
            m_fan.push_back(same);
        }
        return true;
    }

    // A vertex's own sample with its current error.
    void hold_own(Mesh::VertexHandle v) {
        const Sample& s = m_mesh.property(m_context->own, v);
        m_samples.push_back(
            {&s, mean_error(m_mesh.property(m_context->irradiance, v), s.irradiance)});
    }

    // The samples a face owns with their current errors.
    void hold_owned(Mesh::FaceHandle f) {
        const Mesh& m = m_mesh;
        std::array<Vec3, 3> p, h;
        int k = 0;
        for (auto v : m.fv_range(f)) {
            p[k] = m.point(v);
            h[k++] = m.property(m_context->irradiance, v);
        }
        for (const Sample& s : m.property(m_context->owned, f)) {
            std::array<double, 3> b = barycentric(s.position, p[0], p[1], p[2]);
            const Vec3 value =
                std::isfinite(b[0]) ? b[0] * h[0] + b[1] * h[1] + b[2] * h[2] : s.irradiance;
            m_samples.push_back({&s, mean_error(value, s.irradiance)});
        }
    }

    // The worst sample's error as a fraction of its bound (> 1: out of bound, inf: a sample
    // outside the fan), v1's values fitted first with refit (m_fit_h, m_fit_b).
    double rate(const CollapseInfo& ci) {
        const Mesh& m = m_mesh;
        m_located.clear();
        double h_num[3] = {0, 0, 0}, b_num[3] = {0, 0, 0}, den = 0.0;
        for (const auto& [s, error] : m_samples) {
            Located l{};
            l.before = error;
            if (!locate(*s, l)) return std::numeric_limits<double>::infinity();
            for (int c = 0; c < 3; ++c) {
                h_num[c] += s->weight * l.c * (s->irradiance[c] - l.a_h[c]);
                b_num[c] += s->weight * l.c * (s->radiosity[c] - l.a_b[c]);
            }
            den += s->weight * l.c * l.c;
            m_located.push_back(l);
        }
        m_fit_h = m.property(m_context->irradiance, ci.v1);
        m_fit_b = m.property(m_context->radiosity, ci.v1);
        if (m_context->refit && den > 0.0)
            for (int c = 0; c < 3; ++c) {
                m_fit_h[c] = std::max(h_num[c] / den, 0.0);
                m_fit_b[c] = std::max(b_num[c] / den, 0.0);
            }
        double worst = 0.0;
        m_delta = 0.0;
        for (const Located& l : m_located) {
            double after = 0.0;
            for (int c = 0; c < 3; ++c) {
                const double y = l.sample->irradiance[c];
                const double diff = std::abs(l.a_h[c] + l.c * m_fit_h[c] - y);
                const double bound = m_context->error * std::max(std::abs(y), m_context->floor[c]);
                if (diff > 0.0) worst = std::max(worst, bound > 0.0 ? diff / bound : 2.0);
                after += diff / 3.0;
            }
            m_delta += l.sample->weight * (after - l.before);
        }
        return worst;
    }

    // Where the sample lies in the fan: false outside it.
    bool locate(const Sample& s, Located& out) const {
        const Corner3* best = nullptr;
        std::array<double, 3> best_b{};
        double best_inside = -std::numeric_limits<double>::infinity();
        for (const Corner3& t : m_fan) {
            const std::array<double, 3> b = barycentric(s.position, t.p[0], t.p[1], t.p[2]);
            if (min3(b) > best_inside) {
                best_inside = min3(b);
                best_b = b;
                best = &t;
            }
        }
        if (!best || best_inside < kInside) return false;
        out.sample = &s;
        out.a_h = Vec3(0.0);
        out.a_b = Vec3(0.0);
        for (int k = 0; k < 3; ++k) {
            if (k == best->pivot) {
                out.c = best_b[k];
                continue;
            }
            out.a_h += best_b[k] * best->h[k];
            out.a_b += best_b[k] * best->b[k];
        }
        return true;
    }

  private:
    // A boundary vertex goes only along its boundary, and only where the boundary runs
    // straight through it (within kStraight of the mesh's size of the line through its two
    // boundary neighbours, and between them), so every surface keeps its outline.
    bool boundary_kept(const CollapseInfo& ci) const {
        const Mesh& m = m_mesh;
        if (!m.is_boundary(ci.v0)) return true;
        if (!m.is_boundary(m.edge_handle(ci.v0v1))) return false;
        int boundary_edges = 0;
        Mesh::VertexHandle other;
        for (auto h : m.voh_range(ci.v0)) {
            if (!m.is_boundary(m.edge_handle(h))) continue;
            ++boundary_edges;
            if (m.to_vertex_handle(h) != ci.v1) other = m.to_vertex_handle(h);
        }
        if (boundary_edges != 2 || !other.is_valid()) return false;
        const Vec3 along = ci.p1 - m.point(other);
        const Vec3 off = ci.p0 - m.point(other);
        const double t = (off | along) / (along | along);
        // v0's distance from the line through its neighbours, |along × off| / |along|
        return t > 0.0 && t < 1.0 &&
               (along % off).sqrnorm() <=
                   m_context->straight * m_context->straight * along.sqrnorm();
    }

    Mesh& m_mesh;  // the module's mesh (ModBaseT gives it only to non-const members)
    const Context* m_context = nullptr;
    std::vector<Corner3> m_fan;      // the new triangles of the collapse being rated
    std::vector<Held> m_samples;     // the samples whose interpolation it changes
    std::vector<Located> m_located;  // them, located in m_fan
    Vec3 m_fit_h, m_fit_b;           // v1's values after the collapse
    std::vector<Sample> m_moving;    // samples of the faces a collapse changes
    std::size_t m_stale = 0;
    double m_delta = 0.0;  // the area-weighted error the rated collapse adds
    double m_spent = 0.0;
};

// OpenMesh's quadric module without its round-off. The quadric error of a point on all of
// its planes is 0, but evaluated as pᵀAp + 2bᵀp + c in double it comes out as often at
// -1e-13 as at +1e-13 (a wall 10 m from the mesh's centre), and the Decimater takes a binary
// module's negative priority for an illegal collapse: exact in-plane collapses, straight
// outline vertices among them, were refused at random (on the FZK-Haus, 2,900 triangles of
// the 38,493 that no irradiance bound at all left).
class ModPlanarQuadric : public OpenMesh::Decimater::ModQuadricT<Mesh> {
  public:
    using Base = OpenMesh::Decimater::ModQuadricT<Mesh>;
    using Handle = OpenMesh::Decimater::ModHandleT<ModPlanarQuadric>;

    explicit ModPlanarQuadric(Mesh& mesh) : Base(mesh) {}

    float collapse_priority(const CollapseInfo& ci) override {
        constexpr auto kIllegal = static_cast<float>(ILLEGAL_COLLAPSE);
        const float error = Base::collapse_priority(ci);
        return error == kIllegal ? kIllegal : std::max(error, 0.0F);
    }
};

// The progress of a simplification's parts, decimated side by side: each part's own count
// (the area-weighted error its collapses added, or without a budget its collapses), and
// their sum reported as the thousandths of the whole budget spent, or the vertices removed
// out of the mesh's. Reports come from the decimating threads, one at a time, never falling.
class PartsProgress {
  public:
    PartsProgress(const SimplifyProgress* progress, std::size_t parts, double budget,
                  std::size_t vertices)
        : m_progress(progress),
          m_budget(budget),
          m_total(budget > 0.0 ? 1000 : std::max<std::size_t>(vertices, 1)),
          m_count(parts) {}

    std::size_t total() const { return m_total; }
    bool reporting() const { return m_progress != nullptr; }

    /// Part `part` has spent `spent` of the area-weighted error in `collapses` collapses.
    void update(std::size_t part, double spent, std::size_t collapses) {
        m_count[part].store(m_budget > 0.0 ? spent : double(collapses), std::memory_order_relaxed);
        const std::unique_lock lock(m_mutex, std::try_to_lock);
        if (!lock.owns_lock()) return;
        double sum = 0.0;
        for (const auto& c : m_count) sum += c.load(std::memory_order_relaxed);
        const double done = m_budget > 0.0 ? 1000.0 * sum / m_budget : sum;
        m_done = std::max(m_done, std::min(static_cast<std::size_t>(done), m_total - 1));
        (*m_progress)(m_done, m_total);
    }

  private:
    const SimplifyProgress* m_progress;
    double m_budget;
    std::size_t m_total;
    std::vector<std::atomic<double>> m_count;
    std::mutex m_mutex;
    std::size_t m_done = 0;
};

// With a budget (> 0), stops the decimation after the first collapse past it, remembering
// how many came before it. Every kProgressStep collapses, hands its part's count to the
// progress (PartsProgress).
class BudgetObserver : public OpenMesh::Decimater::Observer {
  public:
    BudgetObserver(const ModIrradianceBound& bound, double budget, PartsProgress* progress,
                   std::size_t part)
        : Observer(1), m_bound(bound), m_budget(budget), m_progress(progress), m_part(part) {}
    void notify(std::size_t step) override {
        if (m_budget <= 0.0 || m_bound.spent() <= m_budget) within = step;
        if (m_progress && step % kProgressStep == 0)
            m_progress->update(m_part, m_bound.spent(), step);
    }
    bool abort() const override { return m_budget > 0.0 && m_bound.spent() > m_budget; }

    std::size_t within = 0;  ///< collapses carried out within the budget

  private:
    static constexpr std::size_t kProgressStep = 64;
    const ModIrradianceBound& m_bound;
    double m_budget;
    PartsProgress* m_progress;
    std::size_t m_part;
};

void check_mesh(const visdb::BakeMesh& mesh, const SimplifyOptions& options) {
    const std::size_t nv = mesh.positions.size();
    if (!(options.error > 0.0 && options.error <= 1.0))
        throw ExportError("simplify: the error bound must be in (0, 1], got " +
                          std::to_string(options.error));
    if (!(options.floor >= 0.0 && options.floor <= 1.0))
        throw ExportError("simplify: the floor must be in [0, 1], got " +
                          std::to_string(options.floor));
    if (!(options.budget >= 0.0 && options.budget <= 1.0))
        throw ExportError("simplify: the budget must be in [0, 1], got " +
                          std::to_string(options.budget));
    if (mesh.irradiance.empty() && nv > 0)
        throw ExportError("simplify: the bake has no irradiance per vertex");
    if (mesh.normals.size() != nv || mesh.irradiance.size() != nv || mesh.radiosity.size() != nv ||
        mesh.triangle_surface.size() != mesh.triangles.size())
        throw ExportError("simplify: the mesh's arrays disagree in length");
    for (const glm::u32vec3& t : mesh.triangles)
        if (t.x >= nv || t.y >= nv || t.z >= nv)
            throw ExportError("simplify: a triangle index is out of range");
}

// The OpenMesh mesh of a bake: one vertex per (bake vertex, surface), so surfaces never
// share a vertex; a face OpenMesh cannot join (it would make the mesh non-manifold) gets
// vertices of its own, locked.
struct Built {
    Mesh mesh;
    OpenMesh::VPropHandleT<std::uint32_t> source;  // the bake vertex
    OpenMesh::FPropHandleT<std::uint32_t> surface;
    std::size_t locked_faces = 0;
};

void build(const visdb::BakeMesh& in, std::span<const std::uint32_t> triangles,
           const glm::dvec3& origin, Built& out) {
    Mesh& m = out.mesh;
    m.add_property(out.source);
    m.add_property(out.surface);
    const auto point_of = [&](std::uint32_t i) {
        const glm::dvec3 p = in.positions[i] - origin;
        return Vec3(p.x, p.y, p.z);
    };
    const auto add_vertex = [&](std::uint32_t i) {
        const Mesh::VertexHandle v = m.add_vertex(point_of(i));
        m.property(out.source, v) = i;
        return v;
    };
    // The mesh vertex made from (bake vertex, surface)
    std::unordered_map<std::uint64_t, Mesh::VertexHandle> made;
    const auto vertex_of = [&](std::uint32_t i, std::uint32_t surface) {
        const auto [it, fresh] = made.try_emplace(std::uint64_t{i} << 32 | surface);
        if (fresh) it->second = add_vertex(i);
        return it->second;
    };
    for (const std::uint32_t t : triangles) {
        const glm::u32vec3 tri = in.triangles[t];
        const std::uint32_t surface = in.triangle_surface[t];
        Mesh::FaceHandle f;
        if (tri.x != tri.y && tri.y != tri.z && tri.z != tri.x)
            f = m.add_face(vertex_of(tri.x, surface), vertex_of(tri.y, surface),
                           vertex_of(tri.z, surface));
        if (!f.is_valid()) {
            const std::array<Mesh::VertexHandle, 3> own = {add_vertex(tri.x), add_vertex(tri.y),
                                                           add_vertex(tri.z)};
            f = m.add_face(own[0], own[1], own[2]);
            for (const auto& v : own) m.status(v).set_locked(true);
            ++out.locked_faces;
        }
        m.property(out.surface, f) = surface;
    }
}

// Flags every bake vertex that lies within `tolerance` of another bake vertex
// (SimplifyOptions::keep_shared): twins where regions meet, also those a mesher's rounding
// left a few ulps apart. Found through a hash grid of cells 4 × `tolerance` wide.
std::vector<char> shared_vertices(const visdb::BakeMesh& in, double tolerance) {
    const double cell = std::max(4.0 * tolerance, std::numeric_limits<double>::min());
    using Key = std::array<std::int64_t, 3>;
    // (clamped: a tiny model far from the origin must not overflow the cell numbers)
    const auto cell_of = [&](double x) {
        return static_cast<std::int64_t>(std::clamp(std::floor(x / cell), -4e18, 4e18));
    };
    const auto key_of = [&](const glm::dvec3& p) {
        return Key{cell_of(p.x), cell_of(p.y), cell_of(p.z)};
    };
    struct KeyHash {
        std::size_t operator()(const Key& k) const {
            const auto u = [](std::int64_t x) { return static_cast<std::uint64_t>(x); };
            return std::hash<std::uint64_t>()(u(k[0]) * 73856093u ^ u(k[1]) * 19349663u ^
                                              u(k[2]) * 83492791u);
        }
    };
    std::unordered_map<Key, std::vector<std::uint32_t>, KeyHash> grid;
    for (std::uint32_t i = 0; i < in.positions.size(); ++i)
        grid[key_of(in.positions[i])].push_back(i);
    std::vector<char> shared(in.positions.size(), 0);
    // The neighbour cells a point within `tolerance` of this one may lie in, per axis: the
    // one below only when the point is that near its cell's low side, the one above likewise
    // (most points are deep inside their cell of 4 × tolerance: one cell, not 27)
    const auto reach = [&](double x, std::int64_t c, std::int64_t& lo, std::int64_t& hi) {
        lo = cell_of(x - tolerance) < c ? -1 : 0;
        hi = cell_of(x + tolerance) > c ? 1 : 0;
    };
    for (std::uint32_t i = 0; i < in.positions.size(); ++i) {
        const glm::dvec3& p = in.positions[i];
        const Key k = key_of(p);
        std::int64_t lx, hx, ly, hy, lz, hz;
        reach(p.x, k[0], lx, hx);
        reach(p.y, k[1], ly, hy);
        reach(p.z, k[2], lz, hz);
        for (std::int64_t dx = lx; dx <= hx && !shared[i]; ++dx)
            for (std::int64_t dy = ly; dy <= hy && !shared[i]; ++dy)
                for (std::int64_t dz = lz; dz <= hz && !shared[i]; ++dz) {
                    const auto it = grid.find({k[0] + dx, k[1] + dy, k[2] + dz});
                    if (it == grid.end()) continue;
                    for (const std::uint32_t j : it->second)
                        if (j != i && glm::length(in.positions[j] - in.positions[i]) <= tolerance)
                            shared[i] = 1;
                }
    }
    return shared;
}

// The least-squares refit of the kept vertices' values: the values that minimise the
// area-weighted squared difference between the simplified mesh's linear interpolation and
// every sample of the bake (the removed vertices, owned by the faces, and the kept vertices
// themselves), each sample weighted by its bake vertex's share of the bake's area. Solved
// per channel by conjugate gradients (Jacobi-preconditioned) on the normal equations, from
// the baked values; a constant field stays exactly constant, so B = E + ρH still holds.
class Refit {
  public:
    Refit(const Mesh& m, const Context& c) : m_n(m.n_vertices()) {
        for (auto v : m.vertices()) {
            m_col.push_back(v.idx());
            for (auto w : m.vv_range(v)) m_col.push_back(w.idx());
            m_start.push_back(m_col.size());
        }
        m_value.assign(m_col.size(), 0.0);
        m_rhs.assign(m_n, {});
        double mean_weight = 0.0;
        for (auto v : m.vertices()) mean_weight += m.property(c.own, v).weight;
        mean_weight = m_n ? mean_weight / double(m_n) : 1.0;
        for (auto v : m.vertices()) {
            Sample own = m.property(c.own, v);
            own.weight = std::max(own.weight, 1e-9 * mean_weight);
            add({v.idx(), v.idx(), v.idx()}, {1.0, 0.0, 0.0}, own);
        }
        for (auto f : m.faces()) {
            std::array<int, 3> id{};
            std::array<Vec3, 3> p;
            int k = 0;
            for (auto v : m.fv_range(f)) {
                id[k] = v.idx();
                p[k++] = m.point(v);
            }
            for (const Sample& s : m.property(c.owned, f)) {
                std::array<double, 3> b = barycentric(s.position, p[0], p[1], p[2]);
                if (!std::isfinite(b[0])) continue;
                for (double& x : b) x = std::max(x, 0.0);
                const double sum = b[0] + b[1] + b[2];
                for (double& x : b) x /= sum;
                add(id, b, s);
            }
        }
    }

    // Solves for channel `k` (0-2 irradiance, 3-5 radiosity) from `x`, in place.
    void solve(int k, std::vector<double>& x) const {
        std::vector<double> diag(m_n), r(m_n), z(m_n), p(m_n), q(m_n);
        for (std::size_t i = 0; i < m_n; ++i) diag[i] = m_value[m_start[i]];
        multiply(x, q);
        double rhs_norm = 0.0;
        for (std::size_t i = 0; i < m_n; ++i) {
            r[i] = m_rhs[i][k] - q[i];
            z[i] = r[i] / diag[i];
            p[i] = z[i];
            rhs_norm += m_rhs[i][k] * m_rhs[i][k];
        }
        double rz = dot(r, z);
        for (int it = 0; it < kMaxIterations && dot(r, r) > kTolerance * rhs_norm; ++it) {
            multiply(p, q);
            const double pq = dot(p, q);
            if (!(pq > 0.0)) break;
            const double alpha = rz / pq;
            for (std::size_t i = 0; i < m_n; ++i) {
                x[i] += alpha * p[i];
                r[i] -= alpha * q[i];
                z[i] = r[i] / diag[i];
            }
            const double rz_next = dot(r, z);
            for (std::size_t i = 0; i < m_n; ++i) p[i] = z[i] + rz_next / rz * p[i];
            rz = rz_next;
        }
    }

  private:
    static constexpr int kMaxIterations = 1000;
    static constexpr double kTolerance = 1e-16;  // on the squared residual, relative

    static double dot(const std::vector<double>& a, const std::vector<double>& b) {
        double s = 0.0;
        for (std::size_t i = 0; i < a.size(); ++i) s += a[i] * b[i];
        return s;
    }

    void multiply(const std::vector<double>& x, std::vector<double>& y) const {
        for (std::size_t i = 0; i < m_n; ++i) {
            double s = 0.0;
            for (std::size_t e = m_start[i]; e < m_start[i + 1]; ++e)
                s += m_value[e] * x[std::size_t(m_col[e])];
            y[i] = s;
        }
    }

    double& entry(int row, int col) {
        for (std::size_t e = m_start[std::size_t(row)]; e < m_start[std::size_t(row) + 1]; ++e)
            if (m_col[e] == col) return m_value[e];
        throw ExportError("simplify: internal error, a face's vertices are not neighbours");
    }

    void add(const std::array<int, 3>& id, const std::array<double, 3>& b, const Sample& s) {
        for (int a = 0; a < 3; ++a) {
            if (b[a] == 0.0) continue;
            for (int c = 0; c < 3; ++c)
                if (b[c] != 0.0) entry(id[a], id[c]) += s.weight * b[a] * b[c];
            auto& rhs = m_rhs[std::size_t(id[a])];
            for (int c = 0; c < 3; ++c) {
                rhs[c] += s.weight * b[a] * s.irradiance[c];
                rhs[3 + c] += s.weight * b[a] * s.radiosity[c];
            }
        }
    }

    std::size_t m_n;
    std::vector<std::size_t> m_start{0};  // row i's entries: [m_start[i], m_start[i + 1])
    std::vector<int> m_col;               // the row's vertex first, then its neighbours
    std::vector<double> m_value;
    std::vector<std::array<double, 6>> m_rhs;
};

// Replaces the vertices' irradiance and radiosity by their least-squares refit (Refit),
// clamped at zero.
void refit(Mesh& m, const Context& c) {
    const Refit fit(m, c);
    std::vector<double> x(m.n_vertices());
    for (int k = 0; k < 6; ++k) {
        const auto& prop = k < 3 ? c.irradiance : c.radiosity;
        for (auto v : m.vertices()) x[std::size_t(v.idx())] = m.property(prop, v)[k % 3];
        fit.solve(k, x);
        for (auto v : m.vertices())
            m.property(prop, v)[k % 3] = std::max(x[std::size_t(v.idx())], 0.0);
    }
}

// The brightest irradiance channel of any vertex.
double brightest(const visdb::BakeMesh& mesh) {
    double top = 0.0;
    for (const glm::vec3& h : mesh.irradiance)
        top = std::max({top, double(h.x), double(h.y), double(h.z)});
    return top;
}

// One decimation of a part of a bake: the OpenMesh mesh with its samples, and what the
// modules counted.
struct Decimation {
    Built b;
    Context context;
    double total = 0.0;  // the area-weighted irradiance of the part (mean of the channels)
    double spent = 0.0;  // the area-weighted error the collapses added
    std::size_t within_budget = 0;  // collapses before the first past the budget
    std::size_t stale = 0;
};

// What the parts of one simplification share: the whole mesh's values, so that a part
// decimates as it would inside the whole.
struct Whole {
    const visdb::BakeMesh& in;
    const SimplifyOptions& options;
    glm::dvec3 origin{0.0};    // of the local frame (the bake's survey coordinates)
    double size = 1.0;         // the diagonal of the mesh's box (m)
    double floor = 0.0;        // the bound's absolute floor (options.floor × brightest)
    std::vector<char> shared;  // per bake vertex: has a twin (keep_shared)
};

// Sets up `d` from the triangles `part` of the bake and decimates them: at most `limit`
// collapses when given; progress to `progress` (as part `index`) when not null.
void decimate(const Whole& w, std::span<const std::uint32_t> part, std::optional<std::size_t> limit,
              PartsProgress* progress, std::size_t index, Decimation& d) {
    const visdb::BakeMesh& in = w.in;
    const SimplifyOptions& options = w.options;
    build(in, part, w.origin, d.b);
    Mesh& m = d.b.mesh;
    Context& context = d.context;

    // Samples and the bound: H per vertex, no removed vertex yet
    m.add_property(context.irradiance);
    m.add_property(context.radiosity);
    m.add_property(context.own);
    m.add_property(context.owned);
    for (auto v : m.vertices()) {
        const glm::vec3 h = in.irradiance[m.property(d.b.source, v)];
        const glm::vec3 r = in.radiosity[m.property(d.b.source, v)];
        m.property(context.irradiance, v) = Vec3(h.x, h.y, h.z);
        m.property(context.radiosity, v) = Vec3(r.x, r.y, r.z);
        m.property(context.own, v) = {m.point(v), Vec3(h.x, h.y, h.z), Vec3(r.x, r.y, r.z), 0.0};
    }
    // Each vertex's weight: a third of its faces' area
    for (auto f : m.faces()) {
        std::array<Vec3, 3> p;
        int k = 0;
        for (auto v : m.fv_range(f)) p[k++] = m.point(v);
        const double share = ((p[1] - p[0]) % (p[2] - p[0])).norm() / 6.0;
        for (auto v : m.fv_range(f)) m.property(context.own, v).weight += share;
    }
    context.error = options.error;
    context.refit = options.refit;
    context.max_held = options.max_held;
    context.floor = Vec3(w.floor, w.floor, w.floor);
    for (auto v : m.vertices()) {
        const Sample& s = m.property(context.own, v);
        d.total += s.weight * (s.irradiance[0] + s.irradiance[1] + s.irradiance[2]) / 3.0;
    }
    context.budget = options.budget * d.total;

    // Decimate: the quadric keeps the shape (a vertex leaves its faces' planes by at most
    // 1e-6 of the mesh's size), the irradiance bound orders the collapses and limits them
    OpenMesh::Decimater::DecimaterT<Mesh> decimater(m);
    ModPlanarQuadric::Handle quadric;
    ModIrradianceBound::Handle bound;
    decimater.add(quadric);
    decimater.add(bound);
    decimater.module(quadric).set_max_err(1e-12 * w.size * w.size * w.size * w.size, true);
    context.straight = kStraight * w.size;
    // Twins where regions meet: as near as an outline must be to run straight
    if (options.keep_shared)
        for (auto v : m.vertices())
            if (w.shared[m.property(d.b.source, v)]) m.status(v).set_locked(true);
    decimater.module(bound).set_context(&context);
    if (!decimater.initialize()) throw ExportError("simplify: OpenMesh's decimater did not start");
    BudgetObserver observer(decimater.module(bound), context.budget, progress, index);
    if (context.budget > 0.0 || progress) decimater.set_observer(&observer);
    if (!limit)
        decimater.decimate();
    else if (*limit > 0)
        decimater.decimate(*limit);  // (0 would mean no limit to OpenMesh)
    m.garbage_collection();
    if (options.refit) refit(m, context);
    d.spent = decimater.module(bound).spent();
    d.within_budget = observer.within;
    d.stale = decimater.module(bound).stale();
}

// Without exact_budget, how far the whole may pass the budget (a fraction of it) through the
// parts' last collapses: each passes its own share by that collapse's error, which for a small
// part can be a large share of its own (the furnished room's parts passed the whole by 2.6 %)
constexpr double kPastBudget = 1e-3;

// The parts of a decimation: whole surfaces (no collapse reaches from one surface into
// another), dealt out largest first, each to the part with the fewest triangles so far (the
// first of those), into at most kParts parts: about the same size, and the same parts
// whatever the number of threads. Each part's triangles in the bake's order.
constexpr std::size_t kParts = 16;

std::vector<std::vector<std::uint32_t>> parts_of(const visdb::BakeMesh& in) {
    std::unordered_map<std::uint32_t, std::size_t> count;
    for (const std::uint32_t s : in.triangle_surface) ++count[s];
    std::vector<std::pair<std::size_t, std::uint32_t>> surfaces;  // (triangles, surface)
    surfaces.reserve(count.size());
    for (const auto& [s, n] : count) surfaces.emplace_back(n, s);
    std::sort(surfaces.begin(), surfaces.end(), [](const auto& a, const auto& b) {
        return a.first > b.first || (a.first == b.first && a.second < b.second);
    });
    const std::size_t n = std::min(kParts, surfaces.size());
    std::vector<std::size_t> size(n, 0);
    std::unordered_map<std::uint32_t, std::uint32_t> part_of;
    for (const auto& [triangles, s] : surfaces) {
        const auto k =
            static_cast<std::size_t>(std::min_element(size.begin(), size.end()) - size.begin());
        size[k] += triangles;
        part_of[s] = static_cast<std::uint32_t>(k);
    }
    std::vector<std::vector<std::uint32_t>> parts(n);
    for (std::size_t k = 0; k < n; ++k) parts[k].reserve(size[k]);
    for (std::uint32_t t = 0; t < in.triangles.size(); ++t)
        parts[part_of[in.triangle_surface[t]]].push_back(t);
    return parts;
}

// The simplified bake mesh from the decimated parts: triangles by surface (a surface lies in
// one part: its faces in that part's order), vertices in the order the triangles first use
// them; kept vertices carry the bake's exact position and normal, and the irradiance and
// radiosity of the decimation (the bake's, or the refit's).
visdb::BakeMesh collect(const visdb::BakeMesh& in,
                        const std::vector<std::unique_ptr<Decimation>>& parts,
                        std::vector<std::uint32_t>* kept) {
    struct FaceOf {
        std::uint32_t surface, part;
        int face;
    };
    std::vector<FaceOf> faces;
    for (std::uint32_t k = 0; k < parts.size(); ++k) {
        const Built& b = parts[k]->b;
        for (auto f : b.mesh.faces()) faces.push_back({b.mesh.property(b.surface, f), k, f.idx()});
    }
    std::stable_sort(faces.begin(), faces.end(),
                     [](const FaceOf& a, const FaceOf& b) { return a.surface < b.surface; });
    constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();
    std::vector<std::vector<std::uint32_t>> index(parts.size());
    for (std::size_t k = 0; k < parts.size(); ++k)
        index[k].assign(parts[k]->b.mesh.n_vertices(), kNone);
    visdb::BakeMesh out;
    if (kept) kept->clear();
    out.triangles.reserve(faces.size());
    out.triangle_surface.reserve(faces.size());
    for (const FaceOf& face : faces) {
        const Decimation& d = *parts[face.part];
        const Mesh& m = d.b.mesh;
        glm::u32vec3 tri{};
        int k = 0;
        for (auto v : m.fv_range(Mesh::FaceHandle(face.face))) {
            std::uint32_t& id = index[face.part][static_cast<std::size_t>(v.idx())];
            if (id == kNone) {
                const std::uint32_t src = m.property(d.b.source, v);
                id = static_cast<std::uint32_t>(out.positions.size());
                out.positions.push_back(in.positions[src]);
                if (kept) kept->push_back(src);
                out.normals.push_back(in.normals[src]);
                const Vec3& h = m.property(d.context.irradiance, v);
                const Vec3& r = m.property(d.context.radiosity, v);
                out.irradiance.emplace_back(h[0], h[1], h[2]);
                out.radiosity.emplace_back(r[0], r[1], r[2]);
            }
            tri[k++] = id;
        }
        out.triangles.push_back(tri);
        out.triangle_surface.push_back(face.surface);
    }
    return out;
}

}  // namespace

std::string to_string(const SimplifyStats& s) {
    char line[256];
    std::snprintf(line, sizeof line,
                  "triangles %zu -> %zu (%.2fx fewer), vertices %zu -> %zu, locked faces %zu, "
                  "stale collapses %zu, area-weighted change %.3g, %.3g s",
                  s.triangles_before, s.triangles_after,
                  s.triangles_after ? double(s.triangles_before) / double(s.triangles_after) : 0.0,
                  s.vertices_before, s.vertices_after, s.locked_faces, s.stale_collapses,
                  s.mean_change, s.seconds);
    return line;
}

visdb::BakeMesh simplify(const visdb::BakeMesh& in, const SimplifyOptions& options,
                         SimplifyStats* stats, std::vector<std::uint32_t>* kept,
                         const SimplifyProgress& progress) {
    const auto start = std::chrono::steady_clock::now();
    check_mesh(in, options);
    // What every part takes from the whole mesh
    Whole whole{.in = in, .options = options, .shared = {}};
    whole.origin = visdb::local_origin(in.positions);
    glm::dvec3 lo(std::numeric_limits<double>::max()), hi(std::numeric_limits<double>::lowest());
    double total = 0.0;  // the area-weighted irradiance, for the progress
    for (const glm::u32vec3& t : in.triangles) {
        const glm::dvec3 p[3] = {in.positions[t.x] - whole.origin, in.positions[t.y] - whole.origin,
                                 in.positions[t.z] - whole.origin};
        double h = 0.0;
        for (int k = 0; k < 3; ++k) {
            lo = glm::min(lo, p[k]);
            hi = glm::max(hi, p[k]);
            const glm::vec3 e = in.irradiance[t[k]];
            h += (double(e.x) + double(e.y) + double(e.z)) / 3.0;
        }
        total += glm::length(glm::cross(p[1] - p[0], p[2] - p[0])) / 6.0 * h;
    }
    whole.size = in.triangles.empty() ? 1.0 : glm::length(hi - lo);
    whole.floor = options.floor * brightest(in);
    if (options.keep_shared) whole.shared = shared_vertices(in, kStraight * whole.size);

    // The parts, side by side, each with the budget's share of its own irradiance (so that
    // the whole keeps within the budget)
    const std::vector<std::vector<std::uint32_t>> parts = parts_of(in);
    PartsProgress reports(progress ? &progress : nullptr, parts.size(), options.budget * total,
                          in.positions.size());
    if (reports.reporting()) progress(0, reports.total());
    std::vector<std::unique_ptr<Decimation>> done(parts.size());
    // A part whose last collapse went past its share: the same decimation again (it is
    // deterministic), stopped before it
    const auto redo = [&](std::size_t k) {
        const std::size_t within = done[k]->within_budget;
        done[k] = std::make_unique<Decimation>();
        decimate(whole, parts[k], within, nullptr, k, *done[k]);  // (its progress was reported)
    };
    const auto past = [&](std::size_t k) { return done[k]->spent - done[k]->context.budget; };
    tbb::parallel_for(std::size_t{0}, parts.size(), [&](std::size_t k) {
        done[k] = std::make_unique<Decimation>();
        decimate(whole, parts[k], std::nullopt, reports.reporting() ? &reports : nullptr, k,
                 *done[k]);
        if (options.exact_budget && done[k]->context.budget > 0.0 && past(k) > 0.0) redo(k);
    });
    if (!options.exact_budget && options.budget > 0.0) {
        // The parts' last collapses may pass their shares; those that pass most are redone
        // until the whole passes the budget by at most kPastBudget of it
        double excess = 0.0, budget = 0.0;
        std::vector<std::size_t> order;
        for (std::size_t k = 0; k < done.size(); ++k) {
            excess += past(k);
            budget += done[k]->context.budget;
            if (past(k) > 0.0) order.push_back(k);
        }
        std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
            return past(a) > past(b) || (past(a) == past(b) && a < b);
        });
        std::size_t redone = 0;
        while (redone < order.size() && excess > kPastBudget * budget)
            excess -= past(order[redone++]);
        tbb::parallel_for(std::size_t{0}, redone, [&](std::size_t i) { redo(order[i]); });
    }
    if (reports.reporting()) progress(reports.total(), reports.total());
    visdb::BakeMesh out = collect(in, done, kept);
    if (stats) {
        SimplifyStats s{.triangles_before = in.triangles.size(),
                        .triangles_after = out.triangles.size(),
                        .vertices_before = in.positions.size(),
                        .vertices_after = out.positions.size()};
        double spent = 0.0, weighed = 0.0;
        for (const auto& d : done) {
            s.locked_faces += d->b.locked_faces;
            s.stale_collapses += d->stale;
            spent += d->spent;
            weighed += d->total;
        }
        s.mean_change = weighed > 0.0 ? spent / weighed : 0.0;
        s.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        *stats = s;
    }
    return out;
}

}  // namespace abrad::exporter
