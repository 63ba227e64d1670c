// Hemicube geometry and delta form factor tables (Cohen & Greenberg 1985).

#include "abrad/radiosity/hemicube.h"

#include <cmath>
#include <glm/geometric.hpp>
#include <stdexcept>

#include "abrad/radiosity/form_factor.h"

namespace abrad::radiosity {

ShooterFrame ShooterFrame::at(const glm::dvec3& origin, const glm::dvec3& normal) {
    ShooterFrame f;
    f.origin = origin;
    f.n = glm::normalize(normal);
    // Pick the world axis least aligned with n for a stable tangent _u_
    const glm::dvec3 a = std::abs(f.n.x) < 0.57   ? glm::dvec3(1, 0, 0)
                         : std::abs(f.n.y) < 0.57 ? glm::dvec3(0, 1, 0)
                                                  : glm::dvec3(0, 0, 1);
    f.u = glm::normalize(glm::cross(a, f.n));
    f.v = glm::cross(f.n, f.u);
    return f;
}

glm::dvec3 ShooterFrame::to_local(const glm::dvec3& p) const {
    const glm::dvec3 d = p - origin;
    return {glm::dot(d, u), glm::dot(d, v), glm::dot(d, n)};
}

glm::dvec3 to_face(int face, const glm::dvec3& l) {
    switch (face) {
        case kTop:
            return {l.x, l.y, l.z};
        case kPosU:
            return {l.y, l.z, l.x};
        case kNegU:
            return {-l.y, l.z, -l.x};
        case kPosV:
            return {-l.x, l.z, l.y};
        default:
            return {l.x, l.z, -l.y};  // kNegV
    }
}

Hemicube::Hemicube(int resolution) : m_resolution(resolution) {
    if (resolution < 2 || resolution % 2 != 0)
        throw std::invalid_argument("hemicube resolution must be even and >= 2, got " +
                                    std::to_string(resolution));
    std::size_t offset = 0;
    for (int f = 0; f < kFaceCount; ++f) {
        m_offset[static_cast<std::size_t>(f)] = offset;
        offset += static_cast<std::size_t>(width(f)) * static_cast<std::size_t>(height(f));
    }
    m_delta.resize(offset);
    // Exact form factor of each pixel rectangle on the face plane d = 1
    const glm::dvec3 origin(0.0), normal(0.0, 0.0, 1.0);
    for (int f = 0; f < kFaceCount; ++f) {
        for (int y = 0; y < height(f); ++y) {
            for (int x = 0; x < width(f); ++x) {
                const double a0 = proj_a(x), a1 = proj_a(x + 1);
                const double b0 = proj_b(f, y), b1 = proj_b(f, y + 1);
                const glm::dvec3 quad[4] = {
                    from_face(f, {a0, b0, 1.0}), from_face(f, {a1, b0, 1.0}),
                    from_face(f, {a1, b1, 1.0}), from_face(f, {a0, b1, 1.0})};
                m_delta[face_offset(f) + static_cast<std::size_t>(y * width(f) + x)] =
                    point_polygon_form_factor(origin, normal, quad);
            }
        }
    }
}

namespace {

// Solid angle (sr) of the rectangle [a0, a1] × [b0, b1] of the plane at distance 1 from the
// eye, its coordinates measured from the foot of the perpendicular: Σ ± atan(ab / √(1+a²+b²))
// over the corners.
double rectangle_solid_angle(double a0, double a1, double b0, double b1) {
    auto corner = [](double a, double b) {
        return std::atan(a * b / std::sqrt(1.0 + a * a + b * b));
    };
    return corner(a1, b1) - corner(a0, b1) - corner(a1, b0) + corner(a0, b0);
}

}  // namespace

Hemicube::Hemicube(int resolution, const std::function<double(const glm::dvec3&)>& intensity)
    : Hemicube(resolution) {
    // Each pixel: 4 x 4 sub-rectangles, the intensity at each one's centre times its solid angle
    constexpr int kSub = 4;
    for (int f = 0; f < kFaceCount; ++f) {
        for (int y = 0; y < height(f); ++y) {
            for (int x = 0; x < width(f); ++x) {
                double w = 0.0;
                for (int sy = 0; sy < kSub; ++sy)
                    for (int sx = 0; sx < kSub; ++sx) {
                        const double a0 = proj_a(x + double(sx) / kSub);
                        const double a1 = proj_a(x + double(sx + 1) / kSub);
                        const double b0 = proj_b(f, y + double(sy) / kSub);
                        const double b1 = proj_b(f, y + double(sy + 1) / kSub);
                        const glm::dvec3 dir =
                            glm::normalize(from_face(f, {0.5 * (a0 + a1), 0.5 * (b0 + b1), 1.0}));
                        w += intensity(dir) * rectangle_solid_angle(a0, a1, b0, b1);
                    }
                m_delta[face_offset(f) + static_cast<std::size_t>(y * width(f) + x)] = w;
            }
        }
    }
}

std::string Hemicube::to_string() const {
    double sum = 0.0;
    for (double d : m_delta) sum += d;
    return "Hemicube(R=" + std::to_string(m_resolution) +
           ", pixels=" + std::to_string(m_delta.size()) + ", sum dF=" + std::to_string(sum) + ")";
}

}  // namespace abrad::radiosity
