#pragma once
// Isolines (isolux contours) of values on a regular lattice by marching squares (Lorensen &
// Cline's marching cubes in two dimensions), and the round contour levels a lighting designer
// reads off a plan.
//
// Numerics: a crossing is placed by linear interpolation along the lattice edge whose ends lie
// on either side of the level (a value equal to the level counts as above it, so no segment
// degenerates to a point on a lattice node); the position is exact up to that interpolation's
// rounding. A cell with four corners alternating above and below (a saddle) is split by the
// mean of its corners.

#include <span>
#include <string>
#include <vector>

namespace abrad::exporter {

/// A point in lattice coordinates: (i, j) is the value at column i, row j; fractions lie
/// between lattice points.
struct LatticePoint {
    double i = 0.0;
    double j = 0.0;
};

/// One straight piece of an isoline, inside one lattice cell.
struct IsoSegment {
    LatticePoint a;
    LatticePoint b;
    /// "(i j)-(i j)".
    std::string to_string() const;
};

/// The isoline of `values` (nx × ny, row-major: index j · nx + i) at `level`, as segments in
/// lattice coordinates, one or two per cell the line crosses. Cells with a NaN corner are left
/// out. Requires values.size() == nx · ny (std::invalid_argument otherwise); nx or ny below 2
/// gives no segment.
std::vector<IsoSegment> isoline(std::span<const double> values, int nx, int ny, double level);

/// Round contour levels strictly between `lo` and `hi`: the multiples of the step s · 10^k
/// (s in 1, 2, 2.5, 5) that gives the most levels not above `max_count`, in increasing order.
/// Empty when the range is empty or not finite, or max_count < 1.
std::vector<double> contour_levels(double lo, double hi, int max_count = 6);

}  // namespace abrad::exporter
