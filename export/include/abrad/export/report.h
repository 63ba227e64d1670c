#pragma once
// `abrad report`: a bake as one HTML page for a person, in a folder that opens offline (no
// network at view time): per calculation grid its statistics and a false-colour plan with
// isolux contours, the luminaire schedule and the emitting surfaces, the bake's settings and
// energy balance, and an interactive 3D view of the bake's glTF export (three.js, vendored into
// the folder) when the viewer is installed.

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "abrad/export/writers.h"
#include "abrad/visdb/model.h"

namespace abrad::exporter {

/// A calculation grid evaluated on the bake.
struct ReportGrid {
    std::string name;
    int nx = 0;  ///< points along x
    int ny = 0;  ///< points along y
    /// The rectangle the points' cells cover (metres; the points are the cell centres) and the
    /// work plane's height.
    double min_x = 0.0, min_y = 0.0, max_x = 0.0, max_y = 0.0, z = 0.0;
    /// nx × ny values (illuminance, lux, or irradiance luminance, W/m²), row-major from
    /// (min_x, min_y): index j · nx + i, j growing with y.
    std::vector<double> value;
    double e_avg = 0.0, e_min = 0.0, e_max = 0.0;
    /// The grid's CSV file in the report's folder (a link on the page); empty: none.
    std::string csv;
};

/// One line of the luminaire schedule: the luminaires of one photometric file and scale.
struct ReportLuminaireType {
    std::string file;                ///< the photometric file as the scene file resolved it
    std::string description;         ///< what the file says it is; empty when it was not read
    std::vector<std::string> names;  ///< the luminaires of this line
    double web_flux = 0.0;           ///< lm per luminaire: the integrated web × scale
    double scale = 1.0;              ///< flux_scale × maintenance factor
    double lamp_lumens = 0.0;        ///< the file's lamp lumens; 0: absolute photometry, unread
    double input_watts = 0.0;        ///< W per luminaire as the file states it; 0: not stated
    /// Why the file's own figures are missing ("not found", "changed since the import");
    /// empty when the file was read.
    std::string file_note;
};

/// The camera the 3D view opens with, in abrad's frame (metres, Z up).
struct ReportView {
    visdb::Camera camera;
};

/// Everything the page shows besides what the scene and the bake hold.
struct ReportInput {
    std::string database;  ///< the database's path as given, for the title
    std::vector<ReportGrid> grids;
    std::vector<ReportLuminaireType> luminaires;
    ToneMap tone;  ///< the display colours of the 3D view (the glTF export's)
    std::optional<ReportView> view;
    /// The bundled viewer script (abrad-viewer.js, with LICENSE-three.txt beside it); empty or
    /// missing: the page goes without the 3D view and says how to get it (`viewer_hint`).
    std::filesystem::path viewer_script;
    std::string viewer_hint;
};

/// What write_report wrote.
struct ReportFiles {
    std::vector<std::filesystem::path> files;  ///< every file, index.html first
    bool has_3d_view = false;                  ///< the viewer was copied and the model embedded
};

/// Writes the report of `bake` (a bake of `scene`) into the existing folder `dir`: index.html
/// (the page: inline CSS, inline SVG plans), grid-N.png (each grid's cells in false colour, one
/// pixel per point), model.glb (the bake's glTF export with `input.tone`), and with the viewer
/// model.js (the GLB as base64, which a page opened from file:// can load as a script) and
/// viewer/abrad-viewer.js, viewer/LICENSE-three.txt. Numbers on the page carry their exact
/// value in `data-value` (shortest text that reads back the same double). Throws ExportError
/// naming the file on a write failure.
ReportFiles write_report(const std::filesystem::path& dir, const visdb::Scene& scene,
                         const visdb::Bake& bake, const ReportInput& input);

}  // namespace abrad::exporter
