// Tests of the SQLite store: exact round trips, schema checks, corruption on load, and
// writers that fail or are killed inside their transaction.

#include "abrad/visdb/store.h"

#include <gtest/gtest.h>
#include <signal.h>
#include <sqlite3.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "file_size_limit.h"
#include "temp_dir.h"

namespace {

namespace fs = std::filesystem;
namespace visdb = abrad::visdb;
using visdb::OpenMode;
using visdb::StoreError;

// ---------------------------------------------------------------------------------------
// Scratch files and raw SQLite access

// A fresh directory per test, removed when the test passes.
using abrad::testing::TempDir;

// A raw connection, for inspecting and damaging files behind the store's back.
class RawDb {
  public:
    explicit RawDb(const std::string& path, int flags = SQLITE_OPEN_READWRITE) {
        if (sqlite3_open_v2(path.c_str(), &m_db, flags, nullptr) != SQLITE_OK) {
            throw std::runtime_error("raw open failed: " + path);
        }
    }
    ~RawDb() { sqlite3_close(m_db); }
    RawDb(const RawDb&) = delete;
    RawDb& operator=(const RawDb&) = delete;

    void exec(const std::string& sql) {
        char* message = nullptr;
        if (sqlite3_exec(m_db, sql.c_str(), nullptr, nullptr, &message) != SQLITE_OK) {
            const std::string text = message != nullptr ? message : "?";
            sqlite3_free(message);
            throw std::runtime_error("raw exec failed: " + sql + ": " + text);
        }
    }

    // Rows of a query, each row's columns rendered exactly (REAL as bits, BLOB as hex).
    std::vector<std::vector<std::string>> rows(const std::string& sql) {
        sqlite3_stmt* stmt = nullptr;
        if (sqlite3_prepare_v2(m_db, sql.c_str(), -1, &stmt, nullptr) != SQLITE_OK) {
            throw std::runtime_error("raw prepare failed: " + sql + ": " + sqlite3_errmsg(m_db));
        }
        std::vector<std::vector<std::string>> out;
        int rc = 0;
        while ((rc = sqlite3_step(stmt)) == SQLITE_ROW) {
            auto& row = out.emplace_back();
            for (int i = 0; i < sqlite3_column_count(stmt); ++i) row.push_back(render(stmt, i));
        }
        sqlite3_finalize(stmt);
        if (rc != SQLITE_DONE) throw std::runtime_error("raw step failed: " + sql);
        return out;
    }

    std::string scalar(const std::string& sql) {
        const auto r = rows(sql);
        return r.empty() || r[0].empty() ? std::string("<none>") : r[0][0];
    }

  private:
    static std::string render(sqlite3_stmt* stmt, int i) {
        std::ostringstream out;
        switch (sqlite3_column_type(stmt, i)) {
            case SQLITE_INTEGER:
                out << "i" << sqlite3_column_int64(stmt, i);
                break;
            case SQLITE_FLOAT:
                out << "f" << std::hex
                    << std::bit_cast<std::uint64_t>(sqlite3_column_double(stmt, i));
                break;
            case SQLITE_TEXT:
                out << reinterpret_cast<const char*>(sqlite3_column_text(stmt, i));
                break;
            case SQLITE_BLOB: {
                const auto* p = static_cast<const unsigned char*>(sqlite3_column_blob(stmt, i));
                const int n = sqlite3_column_bytes(stmt, i);
                out << "x" << std::hex;
                for (int b = 0; b < n; ++b) out << static_cast<int>(p[b]) << ".";
                break;
            }
            default:
                out << "NULL";
        }
        return out.str();
    }

    sqlite3* m_db = nullptr;
};

// The logical content of a database file: every row of every table, exactly, plus the header
// fields the store sets.
std::string dump(const std::string& path) {
    RawDb db(path, SQLITE_OPEN_READONLY);
    std::string out = "application_id=" + db.scalar("PRAGMA application_id") +
                      " user_version=" + db.scalar("PRAGMA user_version") + "\n";
    for (const auto& table :
         db.rows("SELECT name, sql FROM sqlite_master WHERE type = 'table' ORDER BY name")) {
        out += "table " + table[0] + ": " + table[1] + "\n";
        for (const auto& row : db.rows("SELECT * FROM \"" + table[0] + "\" ORDER BY rowid")) {
            for (const auto& value : row) out += value + "|";
            out += "\n";
        }
    }
    return out;
}

std::string read_file(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// Runs `fn`, which must throw StoreError whose message contains every one of `parts`.
void expect_store_error(const std::function<void()>& fn, const std::vector<std::string>& parts) {
    try {
        fn();
        ADD_FAILURE() << "no StoreError thrown";
    } catch (const StoreError& e) {
        const std::string message = e.what();
        for (const auto& part : parts) {
            EXPECT_NE(message.find(part), std::string::npos)
                << "message '" << message << "' lacks '" << part << "'";
        }
    }
}

// ---------------------------------------------------------------------------------------
// Exact comparisons

std::array<std::uint64_t, 3> bits(const glm::dvec3& v) {
    return {std::bit_cast<std::uint64_t>(v.x), std::bit_cast<std::uint64_t>(v.y),
            std::bit_cast<std::uint64_t>(v.z)};
}
std::array<std::uint32_t, 3> bits(const glm::vec3& v) {
    return {std::bit_cast<std::uint32_t>(v.x), std::bit_cast<std::uint32_t>(v.y),
            std::bit_cast<std::uint32_t>(v.z)};
}
std::array<std::uint32_t, 3> bits(const glm::u32vec3& v) { return {v.x, v.y, v.z}; }
std::uint32_t bits(std::uint32_t v) { return v; }
std::uint64_t bits(double v) { return std::bit_cast<std::uint64_t>(v); }

// Element-wise bit-exact comparison that reports the first difference only.
template <typename T>
void expect_same(const std::vector<T>& expected, const std::vector<T>& actual,
                 const std::string& what) {
    ASSERT_EQ(expected.size(), actual.size()) << what;
    for (std::size_t i = 0; i < expected.size(); ++i) {
        if (bits(expected[i]) != bits(actual[i])) {
            ADD_FAILURE() << what << " differs first at element " << i;
            return;
        }
    }
}

void expect_same_scene(const visdb::Scene& expected, const visdb::Scene& actual) {
    ASSERT_EQ(expected.sources.size(), actual.sources.size());
    for (std::size_t i = 0; i < expected.sources.size(); ++i) {
        const auto& e = expected.sources[i];
        const auto& a = actual.sources[i];
        SCOPED_TRACE("source " + std::to_string(i));
        EXPECT_EQ(e.path, a.path);
        EXPECT_EQ(e.format, a.format);
        EXPECT_EQ(e.checksum, a.checksum);
        EXPECT_EQ(e.size_bytes, a.size_bytes);
        EXPECT_EQ(e.unit, a.unit);
        EXPECT_EQ(e.up_axis, a.up_axis);
        EXPECT_EQ(e.imported_at, a.imported_at);
        EXPECT_EQ(e.report, a.report);
    }
    ASSERT_EQ(expected.materials.size(), actual.materials.size());
    for (std::size_t i = 0; i < expected.materials.size(); ++i) {
        const auto& e = expected.materials[i];
        const auto& a = actual.materials[i];
        SCOPED_TRACE("material " + std::to_string(i));
        EXPECT_EQ(e.name, a.name);
        EXPECT_EQ(bits(e.reflectance), bits(a.reflectance));
        EXPECT_EQ(bits(e.emittance), bits(a.emittance));
        EXPECT_EQ(bits(e.opacity), bits(a.opacity));
        EXPECT_EQ(e.group, a.group);
    }
    ASSERT_EQ(expected.surfaces.size(), actual.surfaces.size());
    for (std::size_t i = 0; i < expected.surfaces.size(); ++i) {
        const auto& e = expected.surfaces[i];
        const auto& a = actual.surfaces[i];
        SCOPED_TRACE("surface " + std::to_string(i));
        EXPECT_EQ(e.name, a.name);
        EXPECT_EQ(e.layer, a.layer);
        EXPECT_EQ(e.material, a.material);
        EXPECT_EQ(e.source, a.source);
        expect_same(e.mesh.positions, a.mesh.positions, "positions");
        expect_same(e.mesh.triangles, a.mesh.triangles, "triangles");
    }
    ASSERT_EQ(expected.cameras.size(), actual.cameras.size());
    for (std::size_t i = 0; i < expected.cameras.size(); ++i) {
        const auto& e = expected.cameras[i];
        const auto& a = actual.cameras[i];
        SCOPED_TRACE("camera " + std::to_string(i));
        EXPECT_EQ(e.name, a.name);
        EXPECT_EQ(bits(e.position), bits(a.position));
        EXPECT_EQ(bits(e.look_at), bits(a.look_at));
        EXPECT_EQ(bits(e.up), bits(a.up));
        EXPECT_EQ(bits(e.fov_y_deg), bits(a.fov_y_deg));
    }
    ASSERT_EQ(expected.grids.size(), actual.grids.size());
    for (std::size_t i = 0; i < expected.grids.size(); ++i) {
        const auto& e = expected.grids[i];
        const auto& a = actual.grids[i];
        SCOPED_TRACE("grid " + std::to_string(i));
        EXPECT_EQ(e.name, a.name);
        EXPECT_EQ(bits(glm::dvec3(e.min, e.z)), bits(glm::dvec3(a.min, a.z)));
        EXPECT_EQ(bits(glm::dvec3(e.max, e.spacing)), bits(glm::dvec3(a.max, a.spacing)));
        EXPECT_EQ(bits(e.normal), bits(a.normal));
    }
    ASSERT_EQ(expected.luminaires.size(), actual.luminaires.size());
    for (std::size_t i = 0; i < expected.luminaires.size(); ++i) {
        const auto& e = expected.luminaires[i];
        const auto& a = actual.luminaires[i];
        SCOPED_TRACE("luminaire " + std::to_string(i));
        EXPECT_EQ(e.name, a.name);
        EXPECT_EQ(e.file, a.file);
        EXPECT_EQ(e.checksum, a.checksum);
        EXPECT_EQ(bits(e.position), bits(a.position));
        EXPECT_EQ(bits(e.axis_x), bits(a.axis_x));
        EXPECT_EQ(bits(e.axis_y), bits(a.axis_y));
        EXPECT_EQ(bits(e.axis_z), bits(a.axis_z));
        EXPECT_EQ(bits(glm::dvec3(e.flux_scale, e.maintenance_factor, 0.0)),
                  bits(glm::dvec3(a.flux_scale, a.maintenance_factor, 0.0)));
        EXPECT_EQ(bits(e.color), bits(a.color));
        EXPECT_EQ(e.opening.shape, a.opening.shape);
        EXPECT_EQ(bits(glm::dvec3(e.opening.width, e.opening.length, e.opening.height)),
                  bits(glm::dvec3(a.opening.width, a.opening.length, a.opening.height)));
        EXPECT_EQ(e.web.type, a.web.type);
        EXPECT_EQ(e.web.horizontal, a.web.horizontal);
        EXPECT_EQ(e.web.vertical, a.web.vertical);
        EXPECT_EQ(e.web.candela, a.web.candela);
        EXPECT_EQ(e.group, a.group);
        EXPECT_EQ(bits(glm::dvec3(e.tilt_factor)), bits(glm::dvec3(a.tilt_factor)));
    }
    EXPECT_EQ(expected.emittance_unit, actual.emittance_unit);
}

void expect_same_bake(const visdb::Bake& expected, const visdb::Bake& actual) {
    EXPECT_EQ(expected.name, actual.name);
    EXPECT_EQ(expected.created_at, actual.created_at);
    EXPECT_EQ(expected.unit, actual.unit);
    EXPECT_EQ(expected.parameters, actual.parameters);
    const auto want = visdb::to_pairs(expected.statistics);
    const auto got = visdb::to_pairs(actual.statistics);
    ASSERT_EQ(want.size(), got.size());
    for (std::size_t i = 0; i < want.size(); ++i) {
        EXPECT_EQ(want[i].first, got[i].first);
        if (std::isnan(want[i].second)) {
            EXPECT_TRUE(std::isnan(got[i].second)) << want[i].first;
        } else {
            EXPECT_EQ(bits(want[i].second), bits(got[i].second)) << want[i].first;
        }
    }
    expect_same(expected.mesh.positions, actual.mesh.positions, "positions");
    expect_same(expected.mesh.normals, actual.mesh.normals, "normals");
    expect_same(expected.mesh.triangles, actual.mesh.triangles, "triangles");
    expect_same(expected.mesh.triangle_surface, actual.mesh.triangle_surface, "triangle_surface");
    expect_same(expected.mesh.irradiance, actual.mesh.irradiance, "irradiance");
    expect_same(expected.mesh.radiosity, actual.mesh.radiosity, "radiosity");
    ASSERT_EQ(expected.light_groups.size(), actual.light_groups.size());
    for (std::size_t i = 0; i < expected.light_groups.size(); ++i) {
        SCOPED_TRACE("light group " + std::to_string(i));
        EXPECT_EQ(expected.light_groups[i].name, actual.light_groups[i].name);
        expect_same(expected.light_groups[i].irradiance, actual.light_groups[i].irradiance,
                    "group irradiance");
        expect_same(expected.light_groups[i].radiosity, actual.light_groups[i].radiosity,
                    "group radiosity");
    }
}

// ---------------------------------------------------------------------------------------
// Test data

// Survey coordinates: 1e6 m offsets with millimetre detail, which float would lose.
constexpr double kEast = 1e6 + 0.001;
constexpr double kNorth = 2e6 + 0.002;

visdb::Scene make_scene() {
    visdb::Scene scene;
    scene.sources.push_back({"models/site.obj", "obj", "0123456789abcdef", 123456789, "mm", "y",
                             "2024-05-01T10:00:00Z", "welded 3 vertices\ndropped 1 face"});
    scene.sources.push_back({"models/roof.dxf", "dxf", "fedcba9876543210",
                             std::numeric_limits<std::uint64_t>::max(), "ft", "z",
                             "2024-05-01T10:00:01Z", ""});

    visdb::Material plaster{"plaster", {0.7, 0.65, 1.0 / 3.0}, {0.0, 0.0, 0.0}, 1.0};
    visdb::Material glass{"glass", {0.1, 0.1, 0.1}, {0.0, 0.0, 0.0}, 0.25};
    visdb::Material lamp{"lamp \"Ke\" ünïcode", {0.0, 0.0, 0.0}, {1500.5, 1200.25, 1e-7}, 1.0};
    scene.materials = {plaster, glass, lamp};

    visdb::Surface wall;
    wall.name = "wall";
    wall.layer = "A-WALL";
    wall.material = 0;
    wall.source = 1;
    wall.mesh.positions = {{kEast, kNorth, 0.0},
                           {kEast + 3.0, kNorth, 0.0},
                           {kEast + 3.0, kNorth, 2.5 + 1e-9},
                           {kEast, kNorth + std::nextafter(0.0, 1.0), -0.001}};
    wall.mesh.triangles = {{0, 1, 2}, {0, 2, 3}};

    visdb::Surface light;
    light.name = "light";
    light.layer = "";
    light.material = 2;
    light.source = 0;
    light.mesh.positions = {{-1.5, 1e300, 1e-300}, {0.1, 0.2, 0.3}, {7.0, 8.0, 9.0}};
    light.mesh.triangles = {{2, 1, 0}};

    visdb::Surface empty;  // no geometry at all: empty BLOBs
    empty.name = "empty";
    empty.material = 1;
    empty.source = 0;

    scene.surfaces = {wall, light, empty};
    scene.cameras.push_back({"entrance",
                             {kEast - 10.0, kNorth - 5.0, 1.7},
                             {kEast, kNorth, 1.5},
                             {0.0, 0.0, 1.0},
                             55.0});
    scene.cameras.push_back(
        {"top", {0.0, 0.0, 100.0}, {0.0, 0.0, 0.0}, {0.0, 1.0, 0.0}, 1.0 / 7.0});
    scene.grids.push_back({"work plane",
                           {kEast + 0.5, kNorth + 0.5},
                           {kEast + 2.5, kNorth + 1.0 / 3.0 + 1.0},
                           0.8,
                           0.25,
                           {0.0, 0.0, 1.0}});
    return scene;
}

// A photometric scene: make_scene's in lm/m2 with a type B luminaire at survey coordinates.
visdb::Scene make_luminaire_scene() {
    visdb::Scene scene = make_scene();
    scene.emittance_unit = "lm/m2";
    visdb::Luminaire l;
    l.name = "flood \"1\" ünïcode";
    l.file = "photometry/flood.ies";
    l.checksum = "00112233aabbccdd";
    l.position = {kEast + 1.0 / 3.0, kNorth, 6.5};
    l.axis_x = {0.0, 1.0, 0.0};
    l.axis_y = {-1.0, 0.0, 0.0};
    l.axis_z = {0.0, 0.0, 1.0};
    l.flux_scale = 1.0 / 7.0;
    l.maintenance_factor = 0.8;
    l.color = {1.1, 0.9, 1e-9};
    l.opening = {visdb::LuminousOpening::Shape::CylinderAlongX, 0.1, 1.2, 1.0 / 3.0};
    l.web.type = visdb::PhotometricType::B;
    l.web.horizontal = {-90.0, 0.0, 90.0};
    l.web.vertical = {-45.0, 0.0, 1.0 / 3.0, 45.0};
    l.web.candela = {0.0, 1.0, 2.0, 3.0, 4.0, 5e300, 6.0, 7.0, 8.0, 9.0, 10.0, 1e-300};
    l.group = "corridor ünïcode";
    l.tilt_factor = 1.0 / 3.0;
    scene.luminaires.push_back(l);
    return scene;
}

// A bake mesh of `quads` quads, two triangles each, with distinct values everywhere.
visdb::Bake make_bake(const std::string& name, std::size_t quads, float tint) {
    visdb::Bake bake;
    bake.name = name;
    bake.created_at = "2024-05-02T03:04:05Z";
    bake.unit = "lux";
    bake.parameters = {
        {"method", "abuffer"}, {"resolution", "50"}, {"bounces", "0"}, {"a_comes_last", name}};
    bake.statistics.seconds_total = 0.4;
    bake.statistics.received_power_w = 1.0 / 3.0;
    bake.statistics.emitted_power_w = std::numeric_limits<double>::quiet_NaN();  // NULL
    bake.statistics.light_area_m2 = 1e300;
    bake.statistics.triangles = 2 * quads;
    bake.statistics.indirect.emplace().unshot_fraction = 0.004;
    bake.statistics.other = {{"from_another_version", 2.5}};
    auto& m = bake.mesh;
    for (std::size_t q = 0; q < quads; ++q) {
        const double x = kEast + static_cast<double>(q) * 0.001;
        const auto v0 = static_cast<std::uint32_t>(m.positions.size());
        m.positions.insert(m.positions.end(), {{x, kNorth, 0.0},
                                               {x + 0.001, kNorth, 0.0},
                                               {x + 0.001, kNorth + 0.001, 0.0},
                                               {x, kNorth + 0.001, 0.0}});
        for (int k = 0; k < 4; ++k) {
            const float f = static_cast<float>(q * 4 + static_cast<std::size_t>(k));
            m.normals.emplace_back(0.0f, 0.0f, 1.0f);
            m.irradiance.emplace_back(tint + f, tint * 0.5f + f, f / 3.0f);
            m.radiosity.emplace_back(tint * 0.7f + f, f + 0.25f, f / 7.0f);
        }
        m.triangles.push_back({v0, v0 + 1, v0 + 2});
        m.triangles.push_back({v0, v0 + 2, v0 + 3});
        m.triangle_surface.push_back(static_cast<std::uint32_t>(q % 3));
        m.triangle_surface.push_back(static_cast<std::uint32_t>(q % 3));
    }
    return bake;
}

// ---------------------------------------------------------------------------------------
// Round trips

TEST(Store, SceneRoundTripIsBitExact) {
    const TempDir dir("visdb");
    const std::string path = dir.file("scene.visdb");
    const visdb::Scene scene = make_scene();
    {
        auto store = visdb::Store::open(path, OpenMode::CreateOrOpen);
        EXPECT_EQ(store.path(), path);
        store.add_import(scene);
    }
    const auto store = visdb::Store::open(path, OpenMode::ReadOnly);
    const visdb::Scene loaded = store.load_scene();
    expect_same_scene(scene, loaded);
    EXPECT_EQ(loaded.surfaces[0].mesh.positions[0].x, 1e6 + 0.001);
}

TEST(Store, SecondImportAppendsAndRemapsIndices) {
    const TempDir dir("visdb");
    const std::string path = dir.file("two.visdb");
    const visdb::Scene first = make_scene();

    visdb::Scene second;
    second.sources.push_back(
        {"extra.ply", "ply", "00000000000000ff", 42, "m", "z", "2024-05-03T00:00:00Z", "ok"});
    second.materials.push_back({"steel", {0.5, 0.5, 0.55}, {0.0, 0.0, 0.0}, 1.0});
    second.materials.push_back({"neon", {0.2, 0.2, 0.2}, {10.0, 0.0, 5.0}, 1.0});
    visdb::Surface tube;
    tube.name = "tube";
    tube.material = 1;
    tube.source = 0;
    tube.mesh.positions = {{0.0, 0.0, 3.0}, {1.0, 0.0, 3.0}, {0.0, 1.0, 3.0}};
    tube.mesh.triangles = {{0, 1, 2}};
    visdb::Surface beam = tube;
    beam.name = "beam";
    beam.material = 0;
    second.surfaces = {tube, beam};
    second.cameras.push_back({"side", {5.0, 0.0, 1.0}, {0.0, 0.0, 1.0}, {0.0, 0.0, 1.0}, 40.0});

    {
        auto store = visdb::Store::open(path, OpenMode::CreateOrOpen);
        store.add_import(first);
        store.add_import(second);
    }

    // Expected: both scenes concatenated, the second one's indices shifted
    visdb::Scene expected = first;
    for (const auto& s : second.sources) expected.sources.push_back(s);
    for (const auto& m : second.materials) expected.materials.push_back(m);
    for (auto s : second.surfaces) {
        s.material += 3;
        s.source += 2;
        expected.surfaces.push_back(s);
    }
    for (const auto& c : second.cameras) expected.cameras.push_back(c);

    const visdb::Scene loaded = visdb::Store::open(path, OpenMode::ReadWrite).load_scene();
    expect_same_scene(expected, loaded);
    ASSERT_EQ(loaded.surfaces.size(), 5u);
    EXPECT_EQ(loaded.surfaces[3].material, 4u);
    EXPECT_EQ(loaded.materials[loaded.surfaces[3].material].name, "neon");
    EXPECT_EQ(loaded.sources[loaded.surfaces[4].source].path, "extra.ply");
}

TEST(Store, BakeRoundTripKeepsOrderAndArrays) {
    const TempDir dir("visdb");
    const std::string path = dir.file("bake.visdb");
    const visdb::Bake bake = make_bake("nightly", 7, 3.5f);
    std::int64_t id = 0;
    {
        auto store = visdb::Store::open(path, OpenMode::CreateOrOpen);
        store.add_import(make_scene());
        id = store.add_bake(bake);
        EXPECT_GT(id, 0);
    }
    const auto loaded = visdb::Store::open(path, OpenMode::ReadOnly).load_bake("nightly");
    EXPECT_EQ(loaded.id, id);
    expect_same_bake(bake, loaded);
    ASSERT_EQ(loaded.parameters.size(), 4u);
    EXPECT_EQ(loaded.parameters.back().first, "a_comes_last");  // insertion order, not sorted
}

TEST(Store, EmptyBakeMeshRoundTrips) {
    const TempDir dir("visdb");
    const std::string path = dir.file("empty.visdb");
    auto store = visdb::Store::open(path, OpenMode::CreateOrOpen);
    visdb::Bake bake = make_bake("nothing", 0, 0.0f);
    bake.parameters.clear();
    bake.statistics = {};
    store.add_bake(bake);
    expect_same_bake(bake, store.load_bake("nothing"));
}

TEST(Store, ListBakesSummarisesOldestFirst) {
    const TempDir dir("visdb");
    auto store = visdb::Store::open(dir.file("list.visdb"), OpenMode::CreateOrOpen);
    EXPECT_TRUE(store.list_bakes().empty());
    const std::vector<visdb::Bake> bakes = {make_bake("a", 1, 1.0f), make_bake("b", 2, 2.0f),
                                            make_bake("c", 3, 3.0f)};
    std::vector<std::int64_t> ids;
    for (const auto& b : bakes) ids.push_back(store.add_bake(b));

    const auto list = store.list_bakes();
    ASSERT_EQ(list.size(), 3u);
    for (std::size_t i = 0; i < 3; ++i) {
        SCOPED_TRACE(bakes[i].name);
        EXPECT_EQ(list[i].id, ids[i]);
        EXPECT_EQ(list[i].name, bakes[i].name);
        EXPECT_EQ(list[i].created_at, bakes[i].created_at);
        EXPECT_EQ(list[i].unit, bakes[i].unit);
        EXPECT_EQ(list[i].parameters, bakes[i].parameters);
        EXPECT_EQ(list[i].statistics.seconds_total, bakes[i].statistics.seconds_total);
        EXPECT_EQ(list[i].statistics.received_power_w, bakes[i].statistics.received_power_w);
        EXPECT_TRUE(std::isnan(list[i].statistics.emitted_power_w));
        EXPECT_EQ(list[i].statistics.triangles, bakes[i].statistics.triangles);
        ASSERT_TRUE(list[i].statistics.indirect.has_value());
        EXPECT_EQ(list[i].statistics.indirect->unshot_fraction, 0.004);
        EXPECT_FALSE(list[i].statistics.dm.has_value());
        EXPECT_EQ(list[i].statistics.other, bakes[i].statistics.other);
        EXPECT_EQ(list[i].vertex_count, bakes[i].mesh.positions.size());
        EXPECT_EQ(list[i].triangle_count, bakes[i].mesh.triangles.size());
    }
    EXPECT_LT(ids[0], ids[1]);
    EXPECT_LT(ids[1], ids[2]);
}

TEST(Store, EmptyNameLoadsLatestBake) {
    const TempDir dir("visdb");
    const std::string path = dir.file("latest.visdb");
    auto store = visdb::Store::open(path, OpenMode::CreateOrOpen);
    expect_store_error([&] { store.load_bake(); }, {path, "no bakes"});
    store.add_bake(make_bake("first", 1, 1.0f));
    const auto second = make_bake("second", 2, 2.0f);
    const auto id = store.add_bake(second);
    const auto latest = store.load_bake("");
    EXPECT_EQ(latest.id, id);
    expect_same_bake(second, latest);
}

TEST(Store, SameNameReplacesBakeAndItsRows) {
    const TempDir dir("visdb");
    const std::string path = dir.file("replace.visdb");
    auto store = visdb::Store::open(path, OpenMode::CreateOrOpen);
    const auto old_id = store.add_bake(make_bake("nightly", 2, 1.0f));
    store.add_bake(make_bake("other", 1, 2.0f));
    visdb::Bake replacement = make_bake("nightly", 5, 9.0f);
    replacement.parameters = {{"method", "zbuffer"}};
    const auto new_id = store.add_bake(replacement);
    EXPECT_GT(new_id, old_id);

    const auto list = store.list_bakes();
    ASSERT_EQ(list.size(), 2u);
    EXPECT_EQ(list[0].name, "other");
    EXPECT_EQ(list[1].name, "nightly");
    EXPECT_EQ(list[1].vertex_count, 20u);
    expect_same_bake(replacement, store.load_bake("nightly"));
    EXPECT_EQ(store.load_bake().id, new_id);

    // The old bake's children are gone (ON DELETE CASCADE)
    RawDb raw(path);
    EXPECT_EQ(raw.scalar("SELECT count(*) FROM bake_parameters WHERE bake_id = " +
                         std::to_string(old_id)),
              "i0");
    EXPECT_EQ(raw.scalar("SELECT count(*) FROM bake_meshes"), "i2");
    // Two bakes' statistics rows: every key of the groups they have, and the unknown one
    const std::size_t rows = visdb::to_pairs(make_bake("x", 1, 0.0f).statistics).size();
    EXPECT_EQ(raw.scalar("SELECT count(*) FROM bake_statistics"), "i" + std::to_string(2 * rows));
}

TEST(Store, UnknownBakeNameThrows) {
    const TempDir dir("visdb");
    const std::string path = dir.file("unknown.visdb");
    auto store = visdb::Store::open(path, OpenMode::CreateOrOpen);
    store.add_bake(make_bake("nightly", 1, 1.0f));
    expect_store_error([&] { store.load_bake("nope"); }, {path, "no bake named 'nope'"});
}

TEST(Store, InvalidBakeIsRejectedBeforeWriting) {
    const TempDir dir("visdb");
    const std::string path = dir.file("invalid_bake.visdb");
    auto store = visdb::Store::open(path, OpenMode::CreateOrOpen);
    const std::string before = dump(path);
    visdb::Bake short_normals = make_bake("bad", 2, 1.0f);
    short_normals.mesh.normals.pop_back();
    expect_store_error([&] { store.add_bake(short_normals); }, {path, "bad"});
    visdb::Bake bad_index = make_bake("bad", 2, 1.0f);
    bad_index.mesh.triangles[1].z = 8;
    expect_store_error([&] { store.add_bake(bad_index); }, {path, "out of range"});
    expect_store_error([&] { store.add_bake(make_bake("", 1, 1.0f)); }, {path, "name"});
    EXPECT_EQ(dump(path), before);
}

// ---------------------------------------------------------------------------------------
// Transactions

TEST(Store, ProgressIsReportedInsideTheTransaction) {
    const TempDir dir("visdb");
    const std::string path = dir.file("progress.visdb");
    auto store = visdb::Store::open(path, OpenMode::CreateOrOpen);
    std::vector<double> fractions;
    std::vector<std::string> visible;  // what another connection sees during the callback
    store.add_bake(make_bake("nightly", 10, 1.0f), [&](double f) {
        fractions.push_back(f);
        RawDb reader(path, SQLITE_OPEN_READONLY);
        visible.push_back(reader.scalar("SELECT count(*) FROM bakes"));
    });
    ASSERT_GE(fractions.size(), 3u);
    EXPECT_EQ(fractions.front(), 0.0);
    EXPECT_EQ(fractions.back(), 1.0);
    EXPECT_TRUE(std::is_sorted(fractions.begin(), fractions.end()));
    EXPECT_TRUE(std::any_of(fractions.begin(), fractions.end(),
                            [](double f) { return f > 0.0 && f < 1.0; }));
    for (const auto& v : visible) EXPECT_EQ(v, "i0") << "the bake is visible before COMMIT";
    EXPECT_EQ(store.list_bakes().size(), 1u);
}

TEST(Store, ThrowingProgressRollsBackAndKeepsOldBake) {
    const TempDir dir("visdb");
    const std::string path = dir.file("cancel.visdb");
    auto store = visdb::Store::open(path, OpenMode::CreateOrOpen);
    const visdb::Bake original = make_bake("nightly", 3, 1.0f);
    store.add_bake(original);
    const std::string before = dump(path);

    // Replacing "nightly" deletes it inside the transaction; the throw must bring it back
    bool nested_seen = false;
    try {
        store.add_bake(make_bake("nightly", 4, 2.0f), [](double f) {
            if (f > 0.5) throw std::runtime_error("cancelled by user");
        });
        ADD_FAILURE() << "no StoreError thrown";
    } catch (const StoreError& e) {
        EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("cancelled by user"), std::string::npos);
        try {
            std::rethrow_if_nested(e);
        } catch (const std::runtime_error& inner) {
            nested_seen = std::string(inner.what()) == "cancelled by user";
        }
    }
    EXPECT_TRUE(nested_seen);
    EXPECT_EQ(dump(path), before);
    expect_same_bake(original, store.load_bake("nightly"));
    EXPECT_EQ(store.add_bake(make_bake("later", 1, 1.0f)) > 0, true);  // the store still works
}

TEST(Store, FailingImportWritesNothing) {
    const TempDir dir("visdb");
    const std::string path = dir.file("bad_import.visdb");
    auto store = visdb::Store::open(path, OpenMode::CreateOrOpen);
    store.add_import(make_scene());
    const std::string before = dump(path);

    // Rejected before the transaction: a reference out of range
    visdb::Scene bad_ref = make_scene();
    bad_ref.surfaces[1].material = 3;
    expect_store_error([&] { store.add_import(bad_ref); }, {path, "light", "material 3"});

    // Rejected inside it, after the sources were written: NaN becomes NULL, a NOT NULL column
    visdb::Scene nan_material = make_scene();
    nan_material.materials[2].opacity = std::numeric_limits<double>::quiet_NaN();
    expect_store_error([&] { store.add_import(nan_material); }, {path, "opacity"});

    EXPECT_EQ(dump(path), before);
    EXPECT_EQ(store.load_scene().sources.size(), 2u);
}

TEST(Store, EmittanceUnitIsKeptAndNeverMixed) {
    const TempDir dir("visdb");
    const std::string path = dir.file("units.visdb");
    visdb::Scene lit = make_scene();  // has an emitter (the lamp)
    lit.emittance_unit = "lm/m2";
    auto store = visdb::Store::open(path, OpenMode::CreateOrOpen);
    EXPECT_EQ(store.load_scene().emittance_unit, "W/m2");  // the default of an empty database
    store.add_import(lit);
    EXPECT_EQ(store.load_scene().emittance_unit, "lm/m2");

    // A radiometric import without emitters joins; one with emitters is refused, unwritten
    visdb::Scene dark = make_scene();
    dark.materials[2].emittance = visdb::Rgb(0.0);
    store.add_import(dark);
    EXPECT_EQ(store.load_scene().emittance_unit, "lm/m2");
    const std::string before = dump(path);
    expect_store_error([&] { store.add_import(make_scene()); },
                       {path, "W/m2", "lm/m2", "cannot be mixed"});
    EXPECT_EQ(dump(path), before);

    visdb::Scene odd = make_scene();
    odd.emittance_unit = "cd";
    expect_store_error([&] { store.add_import(odd); }, {path, "'cd'"});
}

// ---------------------------------------------------------------------------------------
// Schema and opening

TEST(Store, Version1DatabaseMigratesKeepingItsScene) {
    const TempDir dir("visdb");
    const std::string path = dir.file("v1.visdb");
    visdb::Scene scene = make_scene();
    scene.grids.clear();
    visdb::Store::open(path, OpenMode::CreateOrOpen).add_import(scene);
    // Turn the file back into what schema version 1 wrote
    RawDb(path).exec(
        "DROP TABLE grids; DROP TABLE luminaires; DROP TABLE bake_light_groups; "
        "ALTER TABLE materials DROP COLUMN light_group; "
        "UPDATE meta SET value = '1' WHERE key = 'schema_version'; "
        "PRAGMA user_version = 1");
    expect_store_error([&] { visdb::Store::open(path, OpenMode::ReadOnly); },
                       {path, "read-write once to migrate"});
    auto store = visdb::Store::open(path, OpenMode::ReadWrite);
    EXPECT_EQ(store.schema_version(), visdb::kSchemaVersion);
    expect_same_scene(scene, store.load_scene());
    visdb::Scene with_grid = make_scene();
    store.add_import(with_grid);
    EXPECT_EQ(store.load_scene().grids.size(), 1u);
}

TEST(Store, Version2DatabaseMigratesAndTakesLuminaires) {
    const TempDir dir("visdb");
    const std::string path = dir.file("v2.visdb");
    visdb::Scene scene = make_scene();
    visdb::Store::open(path, OpenMode::CreateOrOpen).add_import(scene);
    // Turn the file back into what schema version 2 wrote
    RawDb(path).exec(
        "DROP TABLE luminaires; DROP TABLE bake_light_groups; "
        "ALTER TABLE materials DROP COLUMN light_group; "
        "UPDATE meta SET value = '2' WHERE key = 'schema_version'; "
        "PRAGMA user_version = 2");
    expect_store_error([&] { visdb::Store::open(path, OpenMode::ReadOnly); },
                       {path, "read-write once to migrate"});
    auto store = visdb::Store::open(path, OpenMode::ReadWrite);
    EXPECT_EQ(store.schema_version(), visdb::kSchemaVersion);
    expect_same_scene(scene, store.load_scene());
    // Its emitters are W/m2: photometric luminaires cannot join them
    expect_store_error([&] { store.add_import(make_luminaire_scene()); },
                       {path, "cannot be mixed"});
}

TEST(Store, Version3DatabaseMigratesKeepingItsBakeAsOneLightGroup) {
    const TempDir dir("visdb");
    const std::string path = dir.file("v3.visdb");
    visdb::Scene scene = make_luminaire_scene();
    scene.luminaires[0].group.clear();  // version 3 had no groups nor tilt factors
    scene.luminaires[0].tilt_factor = 1.0;
    const visdb::Bake bake = make_bake("before groups", 3, 2.0f);
    {
        auto store = visdb::Store::open(path, OpenMode::CreateOrOpen);
        store.add_import(scene);
        store.add_bake(bake);
    }
    // Turn the file back into what schema version 3 wrote
    RawDb(path).exec(
        "DROP TABLE bake_light_groups; ALTER TABLE materials DROP COLUMN light_group; "
        "ALTER TABLE luminaires DROP COLUMN light_group; "
        "ALTER TABLE luminaires DROP COLUMN tilt_factor; "
        "UPDATE meta SET value = '3' WHERE key = 'schema_version'; PRAGMA user_version = 3");
    expect_store_error([&] { visdb::Store::open(path, OpenMode::ReadOnly); },
                       {path, "read-write once to migrate"});
    auto store = visdb::Store::open(path, OpenMode::ReadWrite);
    EXPECT_EQ(store.schema_version(), visdb::kSchemaVersion);
    expect_same_scene(scene, store.load_scene());
    expect_same_bake(bake, store.load_bake("before groups"));  // no light groups
    // A bake with groups joins it
    visdb::Bake grouped = make_bake("grouped", 3, 1.0f);
    grouped.light_groups.push_back({"office", grouped.mesh.irradiance, grouped.mesh.radiosity});
    store.add_bake(grouped);
    expect_same_bake(grouped, store.load_bake("grouped"));
}

TEST(Store, LightGroupsRoundTripAndAreChecked) {
    const TempDir dir("visdb");
    const std::string path = dir.file("groups.visdb");
    visdb::Scene scene = make_scene();
    scene.materials[2].group = "office";
    visdb::Bake bake = make_bake("groups", 4, 1.5f);
    visdb::Bake other = make_bake("other", 4, 7.5f);
    bake.light_groups.push_back({"office", other.mesh.irradiance, other.mesh.radiosity});
    bake.light_groups.push_back({"corridor", bake.mesh.radiosity, bake.mesh.irradiance});
    {
        auto store = visdb::Store::open(path, OpenMode::CreateOrOpen);
        store.add_import(scene);
        store.add_bake(bake);
    }
    auto store = visdb::Store::open(path, OpenMode::ReadWrite);
    expect_same_scene(scene, store.load_scene());
    expect_same_bake(bake, store.load_bake("groups"));
    // A group's shades must cover every vertex; nothing is written otherwise
    visdb::Bake short_group = bake;
    short_group.name = "short";
    short_group.light_groups[1].radiosity.pop_back();
    expect_store_error([&] { store.add_bake(short_group); },
                       {path, "light group 'corridor' needs one shade per vertex"});
    EXPECT_EQ(store.list_bakes().size(), 1u);
    // A truncated BLOB is corrupt
    RawDb(path).exec(
        "UPDATE bake_light_groups SET irradiance = substr(irradiance, 1, 12) WHERE seq = 1");
    expect_store_error([&] { store.load_bake("groups"); },
                       {path, "corrupt light group 'corridor' of bake 'groups'"});
}

TEST(Store, LuminairesRoundTripBitExact) {
    const TempDir dir("visdb");
    const std::string path = dir.file("luminaires.visdb");
    const visdb::Scene scene = make_luminaire_scene();
    visdb::Store::open(path, OpenMode::CreateOrOpen).add_import(scene);
    expect_same_scene(scene, visdb::Store::open(path, OpenMode::ReadOnly).load_scene());
}

TEST(Store, CorruptLuminaireWebIsRejected) {
    const TempDir dir("visdb");
    const std::string path = dir.file("web.visdb");
    visdb::Store::open(path, OpenMode::CreateOrOpen).add_import(make_luminaire_scene());
    const std::string name = make_luminaire_scene().luminaires[0].name;
    RawDb(path).exec("UPDATE luminaires SET candela = substr(candela, 1, length(candela) - 8)");
    expect_store_error([&] { visdb::Store::open(path, OpenMode::ReadOnly).load_scene(); },
                       {path + ": corrupt luminaire '" + name + "'"});
    // Angles out of order: the web is not what PhotometricWeb states
    RawDb(path).exec(
        "UPDATE luminaires SET candela = zeroblob(96), vertical = "
        "X'000000000000F03F000000000000000000000000000008400000000000001040'");  // 1, 0, 3, 4
    expect_store_error([&] { visdb::Store::open(path, OpenMode::ReadOnly).load_scene(); },
                       {path + ": corrupt photometric web of luminaire '" + name + "'"});
    // An invalid web is refused at import, nothing written
    visdb::Scene bad = make_luminaire_scene();
    bad.luminaires[0].web.candela[3] = -1.0;
    const std::string other = dir.file("other.visdb");
    auto store = visdb::Store::open(other, OpenMode::CreateOrOpen);
    expect_store_error([&] { store.add_import(bad); }, {other, "invalid web"});
    EXPECT_TRUE(store.load_scene().surfaces.empty());
}

TEST(Store, SchemaIsVersionedAndMarked) {
    const TempDir dir("visdb");
    const std::string path = dir.file("schema.visdb");
    EXPECT_EQ(visdb::Store::open(path, OpenMode::CreateOrOpen).schema_version(),
              visdb::kSchemaVersion);
    EXPECT_EQ(visdb::Store::open(path, OpenMode::ReadOnly).schema_version(), visdb::kSchemaVersion);
    RawDb raw(path, SQLITE_OPEN_READONLY);
    EXPECT_EQ(raw.scalar("SELECT value FROM meta WHERE key = 'schema_version'"),
              std::to_string(visdb::kSchemaVersion));
    EXPECT_EQ(raw.scalar("SELECT value FROM meta WHERE key = 'application'"), "abrad");
    EXPECT_EQ(raw.scalar("PRAGMA application_id"), "i" + std::to_string(0x41425244));
    EXPECT_EQ(raw.scalar("PRAGMA user_version"), "i" + std::to_string(visdb::kSchemaVersion));
    EXPECT_EQ(raw.scalar("PRAGMA journal_mode"), "delete");
}

TEST(Store, EmptyFileGetsSchemaOnlyWithCreateOrOpen) {
    const TempDir dir("visdb");
    const std::string path = dir.file("empty.visdb");
    std::ofstream(path).close();
    expect_store_error([&] { visdb::Store::open(path, OpenMode::ReadWrite); },
                       {path, "not an abrad visual database"});
    EXPECT_EQ(fs::file_size(path), 0u);
    EXPECT_EQ(visdb::Store::open(path, OpenMode::CreateOrOpen).schema_version(),
              visdb::kSchemaVersion);
}

TEST(Store, PlainTextFileIsNotAnAbradDatabase) {
    const TempDir dir("visdb");
    const std::string path = dir.file("notes.txt");
    const std::string text = "these are not the bytes you are looking for\n";
    std::ofstream(path) << text;
    for (const auto mode : {OpenMode::ReadOnly, OpenMode::ReadWrite, OpenMode::CreateOrOpen}) {
        expect_store_error([&] { visdb::Store::open(path, mode); },
                           {path + ": not an abrad visual database"});
    }
    EXPECT_EQ(read_file(path), text);
}

TEST(Store, SqliteFileWithoutMetaIsNotAnAbradDatabase) {
    const TempDir dir("visdb");
    const std::string foreign = dir.file("foreign.db");
    RawDb(foreign, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE)
        .exec("CREATE TABLE t(x); INSERT INTO t VALUES (1)");
    const std::string before = dump(foreign);
    for (const auto mode : {OpenMode::ReadOnly, OpenMode::ReadWrite, OpenMode::CreateOrOpen}) {
        expect_store_error([&] { visdb::Store::open(foreign, mode); },
                           {foreign + ": not an abrad visual database"});
    }
    EXPECT_EQ(dump(foreign), before);

    // A meta table without the rows is not enough either
    const std::string no_rows = dir.file("no_rows.db");
    RawDb(no_rows, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE)
        .exec("CREATE TABLE meta(key TEXT PRIMARY KEY, value TEXT)");
    expect_store_error([&] { visdb::Store::open(no_rows, OpenMode::CreateOrOpen); },
                       {no_rows + ": not an abrad visual database"});

    // Nor is an abrad database whose meta row was removed
    const std::string stripped = dir.file("stripped.visdb");
    visdb::Store::open(stripped, OpenMode::CreateOrOpen);
    RawDb(stripped).exec("DELETE FROM meta WHERE key = 'schema_version'");
    expect_store_error([&] { visdb::Store::open(stripped, OpenMode::ReadWrite); },
                       {stripped + ": not an abrad visual database"});
}

TEST(Store, NewerSchemaVersionIsRejected) {
    const TempDir dir("visdb");
    const std::string path = dir.file("future.visdb");
    visdb::Store::open(path, OpenMode::CreateOrOpen);
    const int future = visdb::kSchemaVersion + 1;
    RawDb(path).exec("UPDATE meta SET value = '" + std::to_string(future) +
                     "' WHERE key = 'schema_version'");
    for (const auto mode : {OpenMode::ReadOnly, OpenMode::ReadWrite, OpenMode::CreateOrOpen}) {
        expect_store_error([&] { visdb::Store::open(path, mode); },
                           {path, "schema version " + std::to_string(future),
                            "version " + std::to_string(visdb::kSchemaVersion) + ")"});
    }
}

TEST(Store, MissingFileThrowsAndIsNotCreated) {
    const TempDir dir("visdb");
    const std::string path = dir.file("missing.visdb");
    expect_store_error([&] { visdb::Store::open(path, OpenMode::ReadOnly); },
                       {path + ": no such database"});
    EXPECT_FALSE(fs::exists(path));
    expect_store_error([&] { visdb::Store::open(path, OpenMode::ReadWrite); },
                       {path + ": no such database"});
    EXPECT_FALSE(fs::exists(path));
    EXPECT_FALSE(fs::exists(path + "-journal"));
}

TEST(Store, ReadOnlyStoreRefusesWrites) {
    const TempDir dir("visdb");
    const std::string path = dir.file("ro.visdb");
    visdb::Store::open(path, OpenMode::CreateOrOpen);
    const std::string before = read_file(path);
    auto store = visdb::Store::open(path, OpenMode::ReadOnly);
    expect_store_error([&] { store.add_import(make_scene()); }, {path, "read-only"});
    expect_store_error([&] { store.add_bake(make_bake("x", 1, 1.0f)); }, {path, "read-only"});
    EXPECT_EQ(read_file(path), before);
}

// Unnamed bakes are numbered inside the write transaction: the number after the count of
// bakes that no bake has, so a numbered bake never replaces one, whichever connection wrote it.
TEST(Store, NumberedBakesTakeFreeNamesAndReplaceNone) {
    const TempDir dir("visdb");
    const std::string path = dir.file("numbered.visdb");
    auto a = visdb::Store::open(path, OpenMode::CreateOrOpen);
    auto b = visdb::Store::open(path, OpenMode::ReadWrite);
    a.add_bake(make_bake("bake-2", 1, 1.0f));
    EXPECT_EQ(a.add_numbered_bake(make_bake("", 1, 2.0f)), "bake-3");  // bake-2 is taken
    EXPECT_EQ(b.add_numbered_bake(make_bake("ignored", 1, 3.0f)), "bake-4");
    EXPECT_EQ(a.add_numbered_bake(make_bake("", 1, 4.0f)), "bake-5");
    std::vector<std::string> names;
    for (const auto& summary : b.list_bakes()) names.push_back(summary.name);
    EXPECT_EQ(names, (std::vector<std::string>{"bake-2", "bake-3", "bake-4", "bake-5"}));
    EXPECT_FLOAT_EQ(a.load_bake("bake-4").mesh.radiosity.front().x,
                    make_bake("", 1, 3.0f).mesh.radiosity.front().x);
}

// A source whose checksum is stored already is refused inside the import's transaction when
// asked, naming both paths; nothing is written. Allowed by default.
TEST(Store, SameSourceIsRefusedWhenAsked) {
    const TempDir dir("visdb");
    const std::string path = dir.file("twice.visdb");
    auto store = visdb::Store::open(path, OpenMode::CreateOrOpen);
    const visdb::Scene scene = make_scene();
    ASSERT_FALSE(scene.sources.empty());
    store.add_import(scene, visdb::SameSource::Refuse);
    const std::string before = read_file(path);
    try {
        store.add_import(scene, visdb::SameSource::Refuse);
        ADD_FAILURE() << "imported the same source twice";
    } catch (const StoreError& e) {
        EXPECT_EQ(e.kind(), StoreError::Kind::BadInput);
        const std::string what = e.what();
        EXPECT_NE(what.find(path + ": " + scene.sources.front().path + ": already imported as " +
                            scene.sources.front().path),
                  std::string::npos)
            << what;
    }
    EXPECT_EQ(read_file(path), before);
    store.add_import(scene);  // SameSource::Allow
    EXPECT_EQ(store.load_scene().sources.size(), 2 * scene.sources.size());
}

// A new database is created whole or not at all: on a full disk (a file-size limit) the open
// fails as a failure of the system and leaves nothing in the folder, not an empty file.
TEST(Store, CreationOnAFullDiskLeavesNoFile) {
    const TempDir dir("visdb");
    const std::string path = dir.file("new.visdb");
    try {
        const abrad::testing::FileSizeLimit full(1024);
        (void)visdb::Store::open(path, OpenMode::CreateOrOpen);
        ADD_FAILURE() << "created a database on a full disk";
    } catch (const StoreError& e) {
        EXPECT_EQ(e.kind(), StoreError::Kind::Failure) << e.what();
        EXPECT_EQ(std::string(e.what()).rfind(path + ": ", 0), 0u) << e.what();
    }
    EXPECT_EQ(dir.entry_count(), 0u);
    visdb::Store::open(path, OpenMode::CreateOrOpen).add_import(make_scene());  // with room
    EXPECT_EQ(dir.entry_count(), 1u);
}

TEST(Store, CheckWritableRefusesAReadOnlyStore) {
    const TempDir dir("visdb");
    const std::string path = dir.file("check.visdb");
    visdb::Store::open(path, OpenMode::CreateOrOpen).check_writable();  // no throw
    try {
        visdb::Store::open(path, OpenMode::ReadOnly).check_writable();
        ADD_FAILURE() << "a read-only store passed check_writable";
    } catch (const StoreError& e) {
        EXPECT_EQ(e.kind(), StoreError::Kind::Failure) << e.what();
    }
}

TEST(Store, MovedStoreKeepsWorking) {
    const TempDir dir("visdb");
    const std::string path = dir.file("moved.visdb");
    auto a = visdb::Store::open(path, OpenMode::CreateOrOpen);
    visdb::Store b = std::move(a);
    b.add_bake(make_bake("x", 1, 1.0f));
    EXPECT_EQ(b.list_bakes().size(), 1u);
    EXPECT_THROW(static_cast<void>(a.list_bakes()), StoreError);  // NOLINT(bugprone-use-after-move)
}

// ---------------------------------------------------------------------------------------
// Corruption

TEST(Store, TruncatedPositionsBlobIsCorrupt) {
    const TempDir dir("visdb");
    const std::string path = dir.file("truncated.visdb");
    visdb::Store::open(path, OpenMode::CreateOrOpen).add_import(make_scene());
    RawDb(path).exec(
        "UPDATE surfaces SET positions = substr(positions, 1, length(positions) - 8) "
        "WHERE name = 'wall'");
    const auto store = visdb::Store::open(path, OpenMode::ReadOnly);
    expect_store_error([&] { store.load_scene(); }, {path + ": corrupt mesh for surface 'wall'"});
}

TEST(Store, TriangleIndexOutOfRangeIsCorrupt) {
    const TempDir dir("visdb");
    const std::string path = dir.file("index.visdb");
    visdb::Store::open(path, OpenMode::CreateOrOpen).add_import(make_scene());
    // One triangle {0, 1, 3}, little-endian, on a surface of 3 vertices
    RawDb(path).exec(
        "UPDATE surfaces SET triangles = X'000000000100000003000000', triangle_count = 1 "
        "WHERE name = 'light'");
    const auto store = visdb::Store::open(path, OpenMode::ReadOnly);
    expect_store_error([&] { store.load_scene(); }, {path + ": corrupt mesh for surface 'light'"});
}

TEST(Store, CountMismatchIsCorrupt) {
    const TempDir dir("visdb");
    const std::string path = dir.file("count.visdb");
    visdb::Store::open(path, OpenMode::CreateOrOpen).add_import(make_scene());
    RawDb(path).exec("UPDATE surfaces SET vertex_count = 5 WHERE name = 'wall'");
    const auto store = visdb::Store::open(path, OpenMode::ReadOnly);
    expect_store_error([&] { store.load_scene(); }, {path + ": corrupt mesh for surface 'wall'"});
}

TEST(Store, CorruptBakeMeshIsRejected) {
    const TempDir dir("visdb");
    const std::string path = dir.file("bake_corrupt.visdb");
    {
        auto store = visdb::Store::open(path, OpenMode::CreateOrOpen);
        store.add_bake(make_bake("good", 2, 1.0f));
        store.add_bake(make_bake("bad", 2, 1.0f));
    }
    RawDb(path).exec(
        "UPDATE bake_meshes SET irradiance = substr(irradiance, 1, 12) WHERE bake_id = "
        "(SELECT id FROM bakes WHERE name = 'bad')");
    const auto store = visdb::Store::open(path, OpenMode::ReadOnly);
    expect_store_error([&] { store.load_bake("bad"); }, {path + ": corrupt mesh for bake 'bad'"});
    EXPECT_NO_THROW(store.load_bake("good"));
}

// ---------------------------------------------------------------------------------------
// Killed writers

// SQLite's test for a hot journal: it exists and its header is not zeroed (the header is written
// when the journal is synced, before the first change to the database file).
bool is_hot_journal(const std::string& journal) {
    const std::string bytes = read_file(journal);
    return !bytes.empty() && bytes[0] != 0;
}

// Writes `scene` and `original` to `path`, then lets a child process write `intruder` and
// kill itself with SIGKILL from the progress callback once `kill_when(fraction)` holds. The
// file must afterwards read exactly as before the child ran. `expect_hot`: the child must
// have changed the database file before dying (its journal is hot).
void expect_kill_leaves_file_as_before(const std::string& path, const visdb::Bake& intruder,
                                       const std::function<bool(double)>& kill_when,
                                       bool expect_hot) {
    const visdb::Scene scene = make_scene();
    const visdb::Bake original = make_bake("nightly", 3, 1.0f);
    std::int64_t original_id = 0;
    {
        auto store = visdb::Store::open(path, OpenMode::CreateOrOpen);
        store.add_import(scene);
        original_id = store.add_bake(original);
    }
    const std::string before = dump(path);

    // The child writes and dies inside the transaction
    std::fflush(nullptr);
    const pid_t pid = ::fork();
    ASSERT_NE(pid, -1);
    if (pid == 0) {
        try {
            auto store = visdb::Store::open(path, OpenMode::ReadWrite);
            store.add_bake(intruder, [&](double f) {
                if (kill_when(f)) ::raise(SIGKILL);
            });
        } catch (...) {
            ::_exit(3);
        }
        ::_exit(4);  // the callback never killed us
    }
    int status = 0;
    ASSERT_EQ(::waitpid(pid, &status, 0), pid);
    ASSERT_TRUE(WIFSIGNALED(status)) << "child exited with " << WEXITSTATUS(status);
    ASSERT_EQ(WTERMSIG(status), SIGKILL);

    // A journal is left behind. It is hot (must be rolled back) once the writer has synced it
    // and started changing the database file itself.
    ASSERT_TRUE(fs::exists(path + "-journal"));
    const bool hot = is_hot_journal(path + "-journal");
    if (expect_hot) {
        EXPECT_TRUE(hot) << "the writer never touched the database file";
    }
    if (hot) {
        // A read-only store cannot roll the journal back, and says so
        expect_store_error([&] { visdb::Store::open(path, OpenMode::ReadOnly); },
                           {path, "interrupted write"});
    } else {
        // An unsynced journal is ignored: the database file was never changed
        expect_same_bake(original, visdb::Store::open(path, OpenMode::ReadOnly).load_bake());
    }

    // Reopening read-write rolls back: the file is as before
    {
        auto store = visdb::Store::open(path, OpenMode::ReadWrite);
        const auto list = store.list_bakes();
        ASSERT_EQ(list.size(), 1u);
        EXPECT_EQ(list[0].name, "nightly");
        EXPECT_EQ(list[0].id, original_id);
        const auto loaded = store.load_bake("nightly");
        EXPECT_EQ(loaded.id, original_id);
        expect_same_bake(original, loaded);
        expect_same_scene(scene, store.load_scene());
    }
    EXPECT_FALSE(is_hot_journal(path + "-journal"));
    EXPECT_EQ(RawDb(path, SQLITE_OPEN_READONLY).scalar("PRAGMA integrity_check"), "ok");
    EXPECT_EQ(RawDb(path, SQLITE_OPEN_READONLY).scalar("PRAGMA foreign_key_check"), "<none>");
    EXPECT_EQ(dump(path), before);
}

TEST(StoreKill, KilledAfterFirstRowsLeavesFileAsBefore) {
    const TempDir dir("visdb");
    expect_kill_leaves_file_as_before(
        dir.file("kill_early.visdb"), make_bake("second", 5, 2.0f),
        [](double f) { return f > 0.0; }, false);
}

TEST(StoreKill, KilledWhileReplacingBeforeCommitLeavesFileAsBefore) {
    // Same name: the original is deleted inside the transaction. The mesh (~13 MB) is larger
    // than SQLite's page cache, so pages spill into the database file before the kill and the
    // rollback has real work to do.
    const TempDir dir("visdb");
    const std::string path = dir.file("kill_late.visdb");
    expect_kill_leaves_file_as_before(
        path, make_bake("nightly", 50000, 2.0f), [](double f) { return f >= 1.0; }, true);
}

TEST(StoreKill, KilledMidBlobLeavesFileAsBefore) {
    const TempDir dir("visdb");
    expect_kill_leaves_file_as_before(
        dir.file("kill_mid.visdb"), make_bake("nightly", 50000, 2.0f),
        [](double f) { return f > 0.5; }, true);
}

}  // namespace

// The typed statistics: the stored keys of each group, a group present iff one of its keys
// was stored, counts rounded, unknown keys kept in order.
TEST(BakeStats, StoredFormRoundTripsGroupsAndUnknownKeys) {
    visdb::BakeStats s;
    s.triangles = 12;
    s.dm.emplace().segments = 7;
    s.dm->shadow.receivers = 3;
    s.seconds_total = 1.5;
    const auto pairs = visdb::to_pairs(s);
    EXPECT_EQ(pairs.front().first, "triangles");
    EXPECT_EQ(pairs.back().first, "seconds_total");
    const auto has = [&](const std::string& key) {
        return std::any_of(pairs.begin(), pairs.end(),
                           [&](const auto& p) { return p.first == key; });
    };
    EXPECT_TRUE(has("dm_shadow_segments"));
    EXPECT_TRUE(has("dm_shadow_receivers"));
    EXPECT_FALSE(has("indirect_shots"));    // no interreflection group
    EXPECT_FALSE(has("occluders_tested"));  // no exact-shading group

    auto stored = pairs;
    stored.emplace_back("a_key_of_tomorrow", 4.0);
    for (auto& [k, v] : stored)
        if (k == "triangles") v = 11.9999999;  // counts come back rounded
    const visdb::BakeStats back = visdb::stats_from_pairs(stored);
    EXPECT_EQ(back.triangles, 12u);
    ASSERT_TRUE(back.dm.has_value());
    EXPECT_EQ(back.dm->segments, 7u);
    EXPECT_EQ(back.dm->shadow.receivers, 3u);
    EXPECT_FALSE(back.indirect.has_value());
    EXPECT_FALSE(back.exact_shade.has_value());
    EXPECT_EQ(back.seconds_total, 1.5);
    ASSERT_EQ(back.other.size(), 1u);
    EXPECT_EQ(back.other[0].first, "a_key_of_tomorrow");

    // One key of a group is enough for the group to be there
    const visdb::BakeStats one = visdb::stats_from_pairs({{"indirect_shots", 5.0}});
    ASSERT_TRUE(one.indirect.has_value());
    EXPECT_EQ(one.indirect->shots, 5u);
    EXPECT_FALSE(one.dm.has_value());
}
