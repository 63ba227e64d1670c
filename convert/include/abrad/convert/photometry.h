#pragma once
// Photometric files: IES LM-63 (1986, 1991, 1995, 2002 and 2019) and EULUMDAT (.ldt) readers
// into the model's photometric web (abrad/visdb/photometry.h). No Debian package reads these,
// so the readers are abrad's own; every malformed file is refused with an ImportError
// "FILE:LINE: FIELD: message" (a truncated table, a wrong count, a negative or NaN candela, an
// angle out of order or of range).
//
// IES LM-63: the version line (IESNA91, IESNA:LM-63-1995, IESNA:LM-63-2002, IES:LM-63-2019;
// none for 1986), [KEYWORD] lines, TILT=NONE or TILT=INCLUDE (a separate tilt file is
// refused), then the numbers, separated by blanks, line ends or commas:
//   lamps, lumens per lamp (-1: absolute photometry), candela multiplier, number of vertical
//   angles, number of horizontal angles, photometric type (1 C, 2 B, 3 A), units (1 feet,
//   2 metres), width, length, height of the luminous opening (the LM-63-2002 table of signs:
//   0 0 0 point, W L 0 rectangle, W L H box, -D -D 0 disc, -D -D H vertical cylinder, -D -D -D
//   sphere, -D L -D and W -D -D horizontal cylinders, -D 0 -D and 0 -D -D vertical discs;
//   ellipses and ellipsoids with unequal values), ballast factor, the 1995 ballast-lamp
//   photometric factor (future use in 2002, the file generation type in 2019: then not
//   applied), input watts, the vertical angles, the horizontal angles, and the candela, one
//   run of vertical values per horizontal angle.
//   Candela = value × multiplier × ballast factor (× the ballast-lamp factor before 2002).
//   Type C horizontal angles run 0 (rotationally symmetric), 0..90 (quadrant symmetric),
//   0..180 (symmetric about the C0-C180 plane), 90..270 (about the C90-C270 plane) or 0..360;
//   vertical angles lie in [0, 180]. Types A and B: horizontal angles in [-180, 180] (0..x is
//   mirrored to -x..x), vertical in [-90, 90] (0..x mirrored likewise).
//
// EULUMDAT: one value a line, the layout of the format's 1990 definition: lines 1-26 (company,
// type, symmetry indicator Isym 0-4, Mc C-planes, Dc, Ng γ angles, Dg, names, dimensions in
// mm, DFF, LORL %, the intensity conversion factor, tilt, n lamp sets), six lines per lamp
// set (number, type, total flux lm, colour, CRI, watts), ten direct ratios, the Mc C angles,
// the Ng γ angles, then the intensities in cd/klm for the planes Isym gives: all Mc (0),
// one (1), C0..C180 (2), C90..C270 (3), C0..C90 (4). Candela = value × the first lamp set's
// flux / 1000 × the conversion factor. Decimal commas are read as points.

#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "abrad/convert/obj_import.h"
#include "abrad/visdb/photometry.h"

namespace abrad::convert {

/// A parsed photometric file.
struct PhotometricFile {
    std::string path;      ///< the name given, for messages
    std::string format;    ///< "ies" or "ldt"
    std::string version;   ///< "LM-63-1986", "LM-63-1991", ..., "LM-63-2019", or "EULUMDAT"
    std::string checksum;  ///< FNV-1a 64 of the bytes, 16 hex digits
    std::uint64_t size_bytes = 0;
    std::string description;  ///< manufacturer, luminaire and catalogue number, as the file says

    visdb::PhotometricWeb web;       ///< candela with every factor of the file applied
    visdb::LuminousOpening opening;  ///< metres
    /// The lamps' flux the intensities belong to, with the same factors applied as to the
    /// candela (lumens); 0 for absolute photometry (LM-63 lumens per lamp -1).
    double lamp_lumens = 0.0;
    /// The light output ratio the file states (EULUMDAT LORL as a fraction); 0 when it states
    /// none.
    double stated_lor = 0.0;
    double input_watts = 0.0;  ///< W, 0 when not given

    /// TILT=INCLUDE: lamp-to-luminaire geometry (1-3), tilt angles (degrees) and their
    /// multiplying factors. Empty for TILT=NONE and EULUMDAT.
    int tilt_geometry = 0;
    std::vector<double> tilt_angles;
    std::vector<double> tilt_factors;

    /// The lamp-tilt multiplier at a luminaire tilt of `tilt_degrees` (visdb::Luminaire::
    /// tilt_degrees): the TILT=INCLUDE table interpolated linearly, its end values beyond its
    /// first and last angle; 1 without a table (TILT=NONE, EULUMDAT). The table's angles are
    /// the luminaire's tilt whatever its lamp-to-luminaire geometry (1-3), which says only how
    /// the lamp turned when the table was measured.
    double tilt_multiplier(double tilt_degrees) const;

    /// The flux of the web, lm (web.flux()).
    double flux() const { return web.flux(); }
    /// "web 2400 lm, lamps 3000 lm: LOR 0.800 (file states 0.800)" or "web 2400 lm (absolute
    /// photometry)".
    std::string flux_report() const;
    /// One line: version, description, web, opening, flux report.
    std::string to_string() const;
};

/// Reads an IES LM-63 file given as text; `name` names it in errors. Throws ImportError
/// "NAME:LINE: FIELD: message" on malformed input.
PhotometricFile read_ies(std::string_view text, const std::string& name);

/// Reads an EULUMDAT file given as text; `name` names it in errors. Throws ImportError
/// "NAME:LINE: FIELD: message" on malformed input.
PhotometricFile read_eulumdat(std::string_view text, const std::string& name);

/// Reads text by the extension of `name` (.ies or .ldt, any case); throws ImportError for
/// another extension.
PhotometricFile read_photometric_text(std::string_view text, const std::string& name);

/// Reads the photometric file at `path` (a regular file; .ies or .ldt); errors name the path
/// as given.
PhotometricFile read_photometric_file(const std::filesystem::path& path);

}  // namespace abrad::convert
