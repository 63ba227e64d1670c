#pragma once
// Calculation grids (work planes) and probe points evaluated on a bake: the points of a grid,
// the illuminance statistics lighting designers quote (E_avg, E_min, E_max, U0 = E_min/E_avg),
// the grid's CSV, and the reader of probe-point CSV files.

#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include "abrad/radiosity/indirect.h"
#include "abrad/visdb/model.h"

namespace abrad::radiosity {

/// A malformed input file (probe points); `what()` is "FILE:LINE: message" or "FILE: message".
class InputFileError : public std::runtime_error {
  public:
    using std::runtime_error::runtime_error;
};

/// The luminance-weighted value of an RGB irradiance (Rec. 709 weights: 0.2126, 0.7152,
/// 0.0722): illuminance for photometric bakes, "luminance" irradiance for radiometric ones.
double luminance(const visdb::Rgb& h);

/// A calculation grid evaluated on a field.
struct GridValues {
    int nx = 0;  ///< points along x
    int ny = 0;  ///< points along y
    /// nx × ny points, row-major from (min.x, min.y): index j * nx + i, at the centres of the
    /// cells of a (max - min) / (nx, ny) split (cells no larger than the spacing).
    std::vector<ProbePoint> points;
    std::vector<visdb::Rgb> irradiance;  ///< per point, RGB
    std::vector<double> value;           ///< per point, luminance(irradiance)
    double e_avg = 0.0;                  ///< mean of value
    double e_min = 0.0;                  ///< smallest value
    double e_max = 0.0;                  ///< largest value

    /// Uniformity U0 = E_min / E_avg (0 when E_avg is 0).
    double u0() const { return e_avg > 0.0 ? e_min / e_avg : 0.0; }

    /// The values as an image: width nx, height ny, row-major with the top row at the largest
    /// y (as seen from above with x to the right).
    std::vector<double> image() const;
};

/// The points of `grid`: nx = ceil((max.x - min.x) / spacing) (at least 1), likewise ny, at
/// the cell centres at height grid.z with the grid's normal. Sets nx, ny and points only.
GridValues grid_points(const visdb::CalculationGrid& grid);

/// `grid` evaluated on `field`: its points, their irradiance and the statistics.
GridValues evaluate_grid(const PointIrradiance& field, const visdb::CalculationGrid& grid);

/// Writes the grid's values as CSV, one line per point after the header
/// "x,y,z,illuminance,irradiance_r,irradiance_g,irradiance_b", atomically
/// (abrad/atomic_file.h). Throws OutputError "PATH: cannot write: ..." when it cannot be written.
void write_grid_csv(const std::filesystem::path& path, const GridValues& grid);

/// Reads probe points: one "x,y,z,nx,ny,nz" line per point (metres, six finite numbers
/// separated by commas, blanks around them allowed). Blank lines are skipped, and so is a
/// first line without any digit (a header). Normals are normalised. Throws InputFileError
/// "PATH:LINE: ..." on a malformed line or a zero normal, "PATH: ..." when the file cannot be
/// opened or holds no point.
std::vector<ProbePoint> read_probe_points(const std::filesystem::path& path);

}  // namespace abrad::radiosity
