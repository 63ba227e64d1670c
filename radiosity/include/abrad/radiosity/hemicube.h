#pragma once
// The hemicube (Cohen & Greenberg 1985): five faces around a shooter's normal, each pixel
// carrying its delta form factor.
//
// Frames. The shooter frame has origin o and orthonormal axes (u, v, n), n the normal. Local
// coordinates (x, y, z) = ((p-o)·u, (p-o)·v, (p-o)·n). Each face maps local coordinates to
// face coordinates (sx, sy, d) by a signed permutation, d being the depth along the face's
// view axis; the projection (sx/d, sy/d) lies in [-1,1]² on the top face and in
// [-1,1]×[0,1] on the side faces (sy is always the height z on the sides).
//
// Delta form factors are the exact form factors of each pixel's rectangle (Lambert's
// formula), not the midpoint approximation ΔA/(π(x²+y²+1)²); they sum to 1 to rounding.

#include <array>
#include <cstdint>
#include <functional>
#include <glm/vec3.hpp>
#include <string>
#include <vector>

namespace abrad::radiosity {

/// An orthonormal frame at a shooting point: `n` is the normal (the top face looks along it).
struct ShooterFrame {
    glm::dvec3 origin{0.0};
    glm::dvec3 u{1.0, 0.0, 0.0};
    glm::dvec3 v{0.0, 1.0, 0.0};
    glm::dvec3 n{0.0, 0.0, 1.0};

    /// Builds a frame at `origin` around the unit normal `normal` (u, v chosen stably).
    static ShooterFrame at(const glm::dvec3& origin, const glm::dvec3& normal);

    /// Local coordinates of a world point.
    glm::dvec3 to_local(const glm::dvec3& p) const;
};

/// The five faces: kTop looks along n; the sides look along +u, -u, +v, -v.
enum Face : int { kTop = 0, kPosU = 1, kNegU = 2, kPosV = 3, kNegV = 4 };
inline constexpr int kFaceCount = 5;

/// Face coordinates (sx, sy, d) of a local point for `face`.
glm::dvec3 to_face(int face, const glm::dvec3& local);
/// Local coordinates of face coordinates (the inverse of to_face).
inline glm::dvec3 from_face(int face, const glm::dvec3& f) {
    switch (face) {
        case kTop:
            return {f.x, f.y, f.z};
        case kPosU:
            return {f.z, f.x, f.y};
        case kNegU:
            return {-f.z, -f.x, f.y};
        case kPosV:
            return {-f.x, f.z, f.y};
        default:
            return {f.x, -f.z, f.y};  // kNegV
    }
}

/// A hemicube of resolution R (R×R top face, four R×R/2 half faces; R even, >= 2).
class Hemicube {
  public:
    explicit Hemicube(int resolution);

    /// A hemicube of resolution R whose pixels carry `intensity(ω)`·Δω instead of delta form
    /// factors: ω a unit direction in the shooter frame's local coordinates, Δω the pixel's
    /// exact solid angle (sr), the intensity sampled at 4 × 4 points of the pixel, each
    /// weighted by its own solid angle. A point source shot through it stops, on each patch,
    /// the power it sends there (in the intensity's units times sr: cd·sr = lm).
    Hemicube(int resolution, const std::function<double(const glm::dvec3&)>& intensity);

    int resolution() const { return m_resolution; }
    /// Pixel columns and rows of a face.
    int width(int /*face*/) const { return m_resolution; }
    int height(int face) const { return face == kTop ? m_resolution : m_resolution / 2; }
    /// Index of the first pixel of a face in the flat pixel arrays.
    std::size_t face_offset(int face) const { return m_offset[static_cast<std::size_t>(face)]; }
    /// Total number of pixels over the five faces (3 R²).
    std::size_t pixel_count() const { return m_delta.size(); }
    /// Delta form factor of a flat pixel index.
    double delta(std::size_t pixel) const { return m_delta[pixel]; }
    const std::vector<double>& deltas() const { return m_delta; }
    /// Multiplies every pixel's weight by `factor` (normalizing a weighted hemicube).
    void scale(double factor) {
        for (double& d : m_delta) d *= factor;
    }

    /// Pixel coordinates (X, Y) in [0, width] × [0, height] of a projected point (sx/d, sy/d).
    double pixel_x(double a) const { return (a + 1.0) * 0.5 * m_resolution; }
    double pixel_y(int face, double b) const {
        return face == kTop ? (b + 1.0) * 0.5 * m_resolution : b * 0.5 * m_resolution;
    }
    /// Projected coordinates (sx/d, sy/d) of a pixel position (X, Y).
    double proj_a(double x) const { return x * 2.0 / m_resolution - 1.0; }
    double proj_b(int face, double y) const {
        return face == kTop ? y * 2.0 / m_resolution - 1.0 : y * 2.0 / m_resolution;
    }

    std::string to_string() const;

  private:
    int m_resolution;
    std::array<std::size_t, kFaceCount> m_offset{};
    std::vector<double> m_delta;
};

}  // namespace abrad::radiosity
