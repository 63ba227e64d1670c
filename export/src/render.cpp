// abrad's Gouraud rasterizer and camera choice (export/include/abrad/export/render.h).

#include "abrad/export/render.h"

#include <algorithm>
#include <cmath>
#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <limits>
#include <numbers>
#include <string>

#include "abrad/export/writers.h"

namespace abrad::exporter {

namespace {

/// The part of a floor's bounding box (xy) a ceiling's downward-facing faces must span.
constexpr double kCeilingCoverage = 0.5;

// The xy bounding box of a set of points (empty while lo > hi).
struct Box2 {
    glm::dvec2 lo{std::numeric_limits<double>::infinity()};
    glm::dvec2 hi{-std::numeric_limits<double>::infinity()};
    void add(const glm::dvec3& p) {
        lo = glm::min(lo, glm::dvec2(p));
        hi = glm::max(hi, glm::dvec2(p));
    }
    double area() const { return lo.x < hi.x && lo.y < hi.y ? (hi.x - lo.x) * (hi.y - lo.y) : 0.0; }
};

// The fraction of `floor`'s area that `b` covers.
double coverage(const Box2& b, const Box2& floor) {
    Box2 common;
    common.lo = glm::max(b.lo, floor.lo);
    common.hi = glm::min(b.hi, floor.hi);
    const double a = floor.area();
    return a > 0.0 ? common.area() / a : 0.0;
}

bool faces_down(const visdb::TriangleMesh& m, const glm::u32vec3& t) {
    const glm::dvec3& a = m.positions[t.x];
    return glm::cross(m.positions[t.y] - a, m.positions[t.z] - a).z < 0.0;
}

// Distance along +z from `origin` to the ceiling above it, or infinity. A ceiling is a
// non-emitting triangle whose front faces down (Möller–Trumbore with the ray fixed to +z) on a
// surface whose downward-facing part spans at least half of `floor`'s bounding box (xy): the
// underside of a table top or a shelf board over the floor's centre spans a small part of the
// room, and the ray passes it. Luminaires and faces looking up are not ceilings.
double ceiling_above(const visdb::Scene& scene, const glm::dvec3& origin, const Box2& floor) {
    double best = std::numeric_limits<double>::infinity();
    const glm::dvec3 dir(0.0, 0.0, 1.0);
    for (const auto& s : scene.surfaces) {
        if (s.material < scene.materials.size() && scene.materials[s.material].is_emitter())
            continue;
        Box2 down;
        for (const auto& t : s.mesh.triangles)
            if (faces_down(s.mesh, t))
                for (int k = 0; k < 3; ++k) down.add(s.mesh.positions[t[k]]);
        if (coverage(down, floor) < kCeilingCoverage) continue;
        for (const auto& t : s.mesh.triangles) {
            if (!faces_down(s.mesh, t)) continue;
            const glm::dvec3& a = s.mesh.positions[t.x];
            const glm::dvec3 e1 = s.mesh.positions[t.y] - a, e2 = s.mesh.positions[t.z] - a;
            const glm::dvec3 p = glm::cross(dir, e2);
            const double det = glm::dot(e1, p);
            if (std::abs(det) < 1e-14) continue;
            const glm::dvec3 q = origin - a;
            const double u = glm::dot(q, p) / det;
            if (u < 0.0 || u > 1.0) continue;
            const glm::dvec3 r = glm::cross(q, e1);
            const double v = glm::dot(dir, r) / det;
            if (v < 0.0 || u + v > 1.0) continue;
            const double d = glm::dot(e2, r) / det;
            if (d > 1e-6 && d < best) best = d;
        }
    }
    return best;
}

// One vertex of a triangle in camera space with its value.
struct ClipVertex {
    glm::dvec3 c;  // (right, up, forward) coordinates, metres
    glm::dvec3 v;  // the interpolated quantity
};

}  // namespace

visdb::Camera select_camera(const visdb::Scene& scene, std::string_view name) {
    if (name.empty()) return scene.cameras.empty() ? default_camera(scene) : scene.cameras.front();
    if (name == "default") {
        for (const auto& c : scene.cameras)
            if (c.name == name) return c;
        return default_camera(scene);
    }
    std::string known;
    for (const auto& c : scene.cameras) {
        if (c.name == name) return c;
        known += (known.empty() ? "" : ", ") + ("'" + c.name + "'");
    }
    throw CameraError("no camera '" + std::string(name) + "' in the scene (cameras: " +
                      (known.empty() ? std::string("none") : known) + "; 'default' is computed)");
}

visdb::Camera default_camera(const visdb::Scene& scene) {
    visdb::Camera cam;
    cam.name = "default";
    cam.fov_y_deg = 70.0;

    // Bounding box of the scene
    glm::dvec3 lo(std::numeric_limits<double>::infinity()),
        hi(-std::numeric_limits<double>::infinity());
    for (const auto& s : scene.surfaces)
        for (const auto& p : s.mesh.positions) lo = glm::min(lo, p), hi = glm::max(hi, p);
    if (!(lo.x <= hi.x)) return cam;

    // Floor candidates: upward-facing area of each non-emitting surface
    struct Floor {
        double area = 0.0;
        glm::dvec3 centroid{0.0};
        Box2 box;
    };
    std::vector<Floor> floors;
    for (const auto& s : scene.surfaces) {
        if (s.material < scene.materials.size() && scene.materials[s.material].is_emitter())
            continue;
        Floor f;
        for (const auto& t : s.mesh.triangles) {
            const glm::dvec3 &a = s.mesh.positions[t.x], &b = s.mesh.positions[t.y],
                             &c = s.mesh.positions[t.z];
            const glm::dvec3 n = glm::cross(b - a, c - a);
            const double len = glm::length(n);
            if (!(len > 0.0) || n.z / len < 0.9) continue;
            const double area = 0.5 * len;
            f.area += area;
            f.centroid += area * (a + b + c) / 3.0;
            for (const auto* p : {&a, &b, &c}) f.box.add(*p);
        }
        if (f.area > 0.0) {
            f.centroid /= f.area;
            floors.push_back(f);
        }
    }
    std::sort(floors.begin(), floors.end(),
              [](const Floor& a, const Floor& b) { return a.area > b.area; });

    // The largest floor with a ceiling above its centroid is the room
    for (std::size_t i = 0; i < floors.size() && i < 16; ++i) {
        const Floor& f = floors[i];
        const double h = ceiling_above(scene, f.centroid + glm::dvec3(0.0, 0.0, 1e-4), f.box);
        if (!std::isfinite(h) || h < 0.5) continue;
        const glm::dvec3 corner(f.box.lo.x, f.box.lo.y, f.centroid.z);
        cam.position = f.centroid + 0.75 * (corner - f.centroid);
        cam.position.z = f.centroid.z + std::min(1.6, 0.6 * h);
        cam.look_at = f.centroid + glm::dvec3(0.0, 0.0, 0.35 * h);
        return cam;
    }

    // No room: look at the whole model from outside
    const glm::dvec3 centre = 0.5 * (lo + hi);
    const double radius = std::max(0.5 * glm::length(hi - lo), 1e-3);
    const double half = 0.5 * cam.fov_y_deg * std::numbers::pi / 180.0;
    cam.position = centre + glm::normalize(glm::dvec3(-1.0, -1.4, 0.8)) * (radius / std::sin(half));
    cam.look_at = centre;
    return cam;
}

CameraFrame camera_frame(const visdb::Camera& camera, int width, int height) {
    if (width <= 0 || height <= 0)
        throw std::invalid_argument("image size " + std::to_string(width) + "x" +
                                    std::to_string(height) + " is not positive");
    const glm::dvec3 view = camera.look_at - camera.position;
    if (!(glm::length(view) > 0.0))
        throw CameraError("camera '" + camera.name + "': position and look_at coincide");
    if (!(camera.fov_y_deg > 0.0 && camera.fov_y_deg < 180.0))
        throw CameraError("camera '" + camera.name + "': fov " + std::to_string(camera.fov_y_deg) +
                          " is not in (0, 180) degrees");
    CameraFrame f;
    f.eye = camera.position;
    f.forward = glm::normalize(view);
    const glm::dvec3 side = glm::cross(f.forward, camera.up);
    if (!(glm::length(side) > 1e-9 * glm::length(camera.up)))
        throw CameraError("camera '" + camera.name + "': up is parallel to the view direction");
    f.right = glm::normalize(side);
    f.up = glm::cross(f.right, f.forward);
    f.up_extent = 2.0 * std::tan(0.5 * camera.fov_y_deg * std::numbers::pi / 180.0);
    f.right_extent = f.up_extent * static_cast<double>(width) / static_cast<double>(height);
    return f;
}

Raster render_bake(const visdb::BakeMesh& mesh, const visdb::Camera& camera,
                   const RenderOptions& options) {
    const int w = options.width, h = options.height;
    const CameraFrame f = camera_frame(camera, w, h);
    const std::size_t n = mesh.positions.size();
    const auto& values =
        options.quantity == RenderQuantity::Radiosity ? mesh.radiosity : mesh.irradiance;
    if (values.size() != n)
        throw ExportError("render: the bake mesh has " + std::to_string(values.size()) +
                          " vertex values for " + std::to_string(n) + " positions");

    Raster r{
        w, h,
        std::vector<glm::vec3>(static_cast<std::size_t>(w) * static_cast<std::size_t>(h),
                               glm::vec3(0.0f)),
        std::vector<std::uint8_t>(static_cast<std::size_t>(w) * static_cast<std::size_t>(h), 0),
        std::vector<std::uint32_t>(static_cast<std::size_t>(w) * static_cast<std::size_t>(h),
                                   kNoTriangle)};
    std::vector<double> depth(r.value.size(), std::numeric_limits<double>::infinity());

    // Camera space: (right, up, forward) relative to the eye, in double
    auto to_camera = [&](const glm::dvec3& p) {
        const glm::dvec3 d = p - f.eye;
        return glm::dvec3(glm::dot(d, f.right), glm::dot(d, f.up), glm::dot(d, f.forward));
    };
    const double W = static_cast<double>(w), H = static_cast<double>(h);
    // Screen position of a camera-space point (pixel units, x right, y down)
    auto to_screen = [&](const glm::dvec3& c) {
        return glm::dvec2((c.x / c.z / f.right_extent + 0.5) * W,
                          (0.5 - c.y / c.z / f.up_extent) * H);
    };

    std::vector<ClipVertex> poly, clipped;
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
        const auto& tri = mesh.triangles[t];
        if (tri.x >= n || tri.y >= n || tri.z >= n)
            throw ExportError("render: triangle " + std::to_string(t) +
                              " indexes a vertex out of range");
        poly.clear();
        for (int k = 0; k < 3; ++k) {
            const std::uint32_t i = tri[k];
            const glm::vec3 v = values[i];
            poly.push_back(
                {to_camera(mesh.positions[i]),
                 glm::dvec3(std::isfinite(v.x) ? v.x : 0.0f, std::isfinite(v.y) ? v.y : 0.0f,
                            std::isfinite(v.z) ? v.z : 0.0f)});
        }
        // A bake shades the front of each face only: its back shows black
        const glm::dvec3& p0 = mesh.positions[tri.x];
        const bool back =
            glm::dot(glm::cross(mesh.positions[tri.y] - p0, mesh.positions[tri.z] - p0),
                     f.eye - p0) < 0.0;
        // Clip the triangle at the near plane (Sutherland–Hodgman against forward >= near)
        clipped.clear();
        for (std::size_t k = 0; k < poly.size(); ++k) {
            const ClipVertex& a = poly[k];
            const ClipVertex& b = poly[(k + 1) % poly.size()];
            const bool ina = a.c.z >= options.near, inb = b.c.z >= options.near;
            if (ina) clipped.push_back(a);
            if (ina != inb) {
                const double s = (options.near - a.c.z) / (b.c.z - a.c.z);
                clipped.push_back({a.c + s * (b.c - a.c), a.v + s * (b.v - a.v)});
            }
        }
        if (clipped.size() < 3) continue;

        // Rasterize the fan of the clipped polygon
        for (std::size_t k = 1; k + 1 < clipped.size(); ++k) {
            const ClipVertex* v[3] = {&clipped[0], &clipped[k], &clipped[k + 1]};
            glm::dvec2 s[3];
            for (int m = 0; m < 3; ++m) s[m] = to_screen(v[m]->c);
            const double area =
                (s[1].x - s[0].x) * (s[2].y - s[0].y) - (s[2].x - s[0].x) * (s[1].y - s[0].y);
            if (!(std::abs(area) > 0.0)) continue;
            const double xmin = std::min({s[0].x, s[1].x, s[2].x}),
                         xmax = std::max({s[0].x, s[1].x, s[2].x});
            const double ymin = std::min({s[0].y, s[1].y, s[2].y}),
                         ymax = std::max({s[0].y, s[1].y, s[2].y});
            // Pixel range, clamped in double first: a vertex just past the near plane projects
            // far outside any int
            if (!(xmax >= 0.0 && ymax >= 0.0 && xmin <= W && ymin <= H)) continue;
            const int x0 = static_cast<int>(std::ceil(std::max(xmin - 0.5, 0.0)));
            const int x1 = static_cast<int>(std::floor(std::min(xmax - 0.5, W - 1.0)));
            const int y0 = static_cast<int>(std::ceil(std::max(ymin - 0.5, 0.0)));
            const int y1 = static_cast<int>(std::floor(std::min(ymax - 0.5, H - 1.0)));
            for (int y = y0; y <= y1; ++y) {
                const double py = y + 0.5;
                for (int x = x0; x <= x1; ++x) {
                    const double px = x + 0.5;
                    // Screen-space barycentrics _b_ of the pixel centre
                    double b[3];
                    for (int m = 0; m < 3; ++m) {
                        const glm::dvec2& p1 = s[(m + 1) % 3];
                        const glm::dvec2& p2 = s[(m + 2) % 3];
                        b[m] = ((p2.x - p1.x) * (py - p1.y) - (px - p1.x) * (p2.y - p1.y)) / area;
                    }
                    if (b[0] < 0.0 || b[1] < 0.0 || b[2] < 0.0) continue;
                    // Perspective-correct weights: screen barycentrics over view depth
                    const double w0 = b[0] / v[0]->c.z, w1 = b[1] / v[1]->c.z,
                                 w2 = b[2] / v[2]->c.z;
                    const double inv = w0 + w1 + w2;
                    const double z = 1.0 / inv;
                    const std::size_t o =
                        static_cast<std::size_t>(y) * static_cast<std::size_t>(w) +
                        static_cast<std::size_t>(x);
                    if (!(z < depth[o])) continue;
                    depth[o] = z;
                    const glm::dvec3 val = (w0 * v[0]->v + w1 * v[1]->v + w2 * v[2]->v) * z;
                    r.value[o] = back ? glm::vec3(0.0f) : glm::vec3(val);
                    r.covered[o] = back ? 2 : 1;
                    r.triangle[o] = static_cast<std::uint32_t>(t);
                }
            }
        }
    }
    return r;
}

}  // namespace abrad::exporter
