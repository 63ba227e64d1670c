// Light meshes: Garland & Heckbert, "Surface Simplification Using Quadric Error Metrics"
// (SIGGRAPH 1997), through OpenMesh's Decimater (half-edge collapses, a quadric module), with
// a module of abrad's own that bounds the change of the baked irradiance field.
//
// Every removed vertex becomes a sample (its position and baked irradiance) owned by the face
// of the current mesh that contains it; a collapse is legal only when every sample in the
// faces it changes, the removed vertex included, is reproduced by the new faces' linear
// interpolation within the bound. So the bound holds at every vertex of the bake, not only
// at the last one removed. Numeric assumptions: the bake's connected pieces are planar (bake
// vertices are shared only by faces whose normals agree to 1e-9), barycentric coordinates
// are computed in double in a local frame around the mesh's centre, and a sample counts as
// inside a triangle down to a barycentric coordinate of -1e-6.

#include "abrad/export/simplify.h"

// OpenMesh's property arrays grow by pushing a default-constructed VectorT (uninitialised by
// design); GCC 12 warns about that inside OpenMesh's templates when sanitizers are on.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif

#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
#include <OpenMesh/Tools/Decimater/DecimaterT.hh>
#include <OpenMesh/Tools/Decimater/ModBaseT.hh>
#include <OpenMesh/Tools/Decimater/ModQuadricT.hh>
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
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

// A triangle of the mesh as it would be after a collapse: corners and their irradiance.
struct Corner3 {
    std::array<Vec3, 3> p;
    std::array<Vec3, 3> h;
};

// The shared state of the decimation: the mesh's properties and the bound.
struct Context {
    OpenMesh::VPropHandleT<Vec3> irradiance;            // baked H of the vertex
    OpenMesh::FPropHandleT<std::vector<Sample>> owned;  // removed vertices inside the face
    double error = 0.02;
    Vec3 floor{0.0, 0.0, 0.0};  // absolute floor per channel (error excluded)
};

constexpr double kInside = -1e-6;        // barycentric slack for a sample on an edge
constexpr double kStraightSine = 1e-7;   // a boundary runs straight through a vertex
constexpr double kMinAreaRatio = 1e-10;  // a new triangle keeps this fraction of its area

// The irradiance-bound module: non-binary, its priority the worst sample's error as a
// fraction of its bound (so collapses that change the field least go first).
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

    float collapse_priority(const CollapseInfo& ci) override {
        if (!boundary_kept(ci)) return ILLEGAL_COLLAPSE;
        const Mesh& m = m_mesh;
        // New triangles: the faces of v0 but fl and fr, with v0 moved onto v1
        m_fan.clear();
        for (auto f : m.vf_range(ci.v0)) {
            if (f == ci.fl || f == ci.fr) continue;
            Corner3 before{};
            Corner3 after{};
            int k = 0;
            for (auto v : m.fv_range(f)) {
                before.p[k] = m.point(v);
                after.p[k] = v == ci.v0 ? ci.p1 : m.point(v);
                after.h[k] = m.property(m_context->irradiance, v == ci.v0 ? ci.v1 : v);
                ++k;
            }
            // Refuse a flipped or collapsed triangle
            const Vec3 n_before = (before.p[1] - before.p[0]) % (before.p[2] - before.p[0]);
            const Vec3 n_after = (after.p[1] - after.p[0]) % (after.p[2] - after.p[0]);
            if (!((n_before | n_after) > kMinAreaRatio * (n_before | n_before)))
                return ILLEGAL_COLLAPSE;
            m_fan.push_back(after);
        }
        // Every sample the collapse moves must stay within its bound
        double worst = check(Sample{ci.p0, m.property(m_context->irradiance, ci.v0)});
        for (auto f : m.vf_range(ci.v0))
            for (const Sample& s : m.property(m_context->owned, f)) {
                if (worst > 1.0) break;
                worst = std::max(worst, check(s));
            }
        return worst > 1.0 ? float(ILLEGAL_COLLAPSE) : static_cast<float>(worst);
    }

    void preprocess_collapse(const CollapseInfo& ci) override {
        Mesh& m = m_mesh;
        m_moving.clear();
        m_moving.push_back({ci.p0, m.property(m_context->irradiance, ci.v0)});
        for (auto f : m.vf_range(ci.v0)) {
            auto& owned = m.property(m_context->owned, f);
            m_moving.insert(m_moving.end(), owned.begin(), owned.end());
            owned.clear();
        }
    }

    void postprocess_collapse(const CollapseInfo& ci) override {
        Mesh& m = m_mesh;
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
    // A boundary vertex goes only along its boundary, and only where the boundary runs
    // straight through it, so every surface keeps its outline.
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
        return t > 0.0 && t < 1.0 &&
               (along % off).sqrnorm() <=
                   kStraightSine * kStraightSine * along.sqrnorm() * off.sqrnorm();
    }

    // The sample's error as a fraction of its bound (> 1: out of bound; inf: outside the fan).
    double check(const Sample& s) const {
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
        if (!best || best_inside < kInside) return std::numeric_limits<double>::infinity();
        double worst = 0.0;
        for (int c = 0; c < 3; ++c) {
            const double value =
                best_b[0] * best->h[0][c] + best_b[1] * best->h[1][c] + best_b[2] * best->h[2][c];
            const double bound =
                m_context->error * std::max(std::abs(s.irradiance[c]), m_context->floor[c]);
            const double diff = std::abs(value - s.irradiance[c]);
            if (diff > 0.0) worst = std::max(worst, bound > 0.0 ? diff / bound : 2.0);
        }
        return worst;
    }

    Mesh& m_mesh;  // the module's mesh (ModBaseT gives it only to non-const members)
    const Context* m_context = nullptr;
    std::vector<Corner3> m_fan;    // the new triangles of the collapse being rated
    std::vector<Sample> m_moving;  // samples of the faces a collapse changes
};

void check_mesh(const visdb::BakeMesh& mesh, const SimplifyOptions& options) {
    const std::size_t nv = mesh.positions.size();
    if (!(options.error > 0.0 && options.error <= 1.0))
        throw ExportError("simplify: the error bound must be in (0, 1], got " +
                          std::to_string(options.error));
    if (!(options.floor >= 0.0 && options.floor <= 1.0))
        throw ExportError("simplify: the floor must be in [0, 1], got " +
                          std::to_string(options.floor));
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

void build(const visdb::BakeMesh& in, const glm::dvec3& origin, Built& out) {
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
    // made[i]: the mesh vertices made from bake vertex i, with their surface
    std::vector<std::vector<std::pair<std::uint32_t, Mesh::VertexHandle>>> made(
        in.positions.size());
    const auto vertex_of = [&](std::uint32_t i, std::uint32_t surface) {
        for (const auto& [s, v] : made[i])
            if (s == surface) return v;
        made[i].emplace_back(surface, add_vertex(i));
        return made[i].back().second;
    };
    for (std::size_t t = 0; t < in.triangles.size(); ++t) {
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

// The brightest irradiance channel of any vertex.
double brightest(const visdb::BakeMesh& mesh) {
    double top = 0.0;
    for (const glm::vec3& h : mesh.irradiance)
        top = std::max({top, double(h.x), double(h.y), double(h.z)});
    return top;
}

// The simplified bake mesh from the decimated OpenMesh mesh: kept vertices carry the bake's
// exact position, normal, irradiance and radiosity.
visdb::BakeMesh collect(const visdb::BakeMesh& in, const Built& b) {
    const Mesh& m = b.mesh;
    visdb::BakeMesh out;
    std::vector<std::uint32_t> index(m.n_vertices(), std::numeric_limits<std::uint32_t>::max());
    for (auto f : m.faces()) {
        glm::u32vec3 tri{};
        int k = 0;
        for (auto v : m.fv_range(f)) {
            std::uint32_t& id = index[v.idx()];
            if (id == std::numeric_limits<std::uint32_t>::max()) {
                const std::uint32_t src = m.property(b.source, v);
                id = static_cast<std::uint32_t>(out.positions.size());
                out.positions.push_back(in.positions[src]);
                out.normals.push_back(in.normals[src]);
                out.irradiance.push_back(in.irradiance[src]);
                out.radiosity.push_back(in.radiosity[src]);
            }
            tri[k++] = id;
        }
        out.triangles.push_back(tri);
        out.triangle_surface.push_back(m.property(b.surface, f));
    }
    return out;
}

}  // namespace

std::string to_string(const SimplifyStats& s) {
    char line[256];
    std::snprintf(line, sizeof line,
                  "triangles %zu -> %zu (%.2fx fewer), vertices %zu -> %zu, locked faces %zu, "
                  "%.3g s",
                  s.triangles_before, s.triangles_after,
                  s.triangles_after ? double(s.triangles_before) / double(s.triangles_after) : 0.0,
                  s.vertices_before, s.vertices_after, s.locked_faces, s.seconds);
    return line;
}

visdb::BakeMesh simplify(const visdb::BakeMesh& in, const SimplifyOptions& options,
                         SimplifyStats* stats) {
    const auto start = std::chrono::steady_clock::now();
    check_mesh(in, options);
    Built b;
    build(in, visdb::local_origin(in.positions), b);
    Mesh& m = b.mesh;

    // Samples and the bound: H per vertex, no removed vertex yet
    Context context;
    m.add_property(context.irradiance);
    m.add_property(context.owned);
    for (auto v : m.vertices()) {
        const glm::vec3 h = in.irradiance[m.property(b.source, v)];
        m.property(context.irradiance, v) = Vec3(h.x, h.y, h.z);
    }
    context.error = options.error;
    const double floor = options.floor * brightest(in);
    context.floor = Vec3(floor, floor, floor);

    // Decimate: the quadric keeps the shape (a vertex leaves its faces' planes by at most
    // 1e-6 of the mesh's size), the irradiance bound orders the collapses and limits them
    OpenMesh::Decimater::DecimaterT<Mesh> decimater(m);
    OpenMesh::Decimater::ModQuadricT<Mesh>::Handle quadric;
    ModIrradianceBound::Handle bound;
    decimater.add(quadric);
    decimater.add(bound);
    Vec3 lo(std::numeric_limits<double>::max());
    Vec3 hi(std::numeric_limits<double>::lowest());
    for (auto v : m.vertices()) {
        lo.minimize(m.point(v));
        hi.maximize(m.point(v));
    }
    const double size = m.n_vertices() ? (hi - lo).norm() : 1.0;
    decimater.module(quadric).set_max_err(1e-12 * size * size * size * size, true);
    decimater.module(bound).set_context(&context);
    if (!decimater.initialize()) throw ExportError("simplify: OpenMesh's decimater did not start");
    decimater.decimate();
    m.garbage_collection();

    visdb::BakeMesh out = collect(in, b);
    if (stats) {
        *stats = {
            .triangles_before = in.triangles.size(),
            .triangles_after = out.triangles.size(),
            .vertices_before = in.positions.size(),
            .vertices_after = out.positions.size(),
            .locked_faces = b.locked_faces,
            .seconds =
                std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count()};
    }
    return out;
}

}  // namespace abrad::exporter
