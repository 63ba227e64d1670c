// The SQLite store of the visual database: schema and migrations, transactions, and the
// mesh BLOB codec.
//
// Durability: the file uses the rollback journal (journal_mode=DELETE). A writer killed inside
// a transaction leaves a hot journal, and the next connection that opens the file read-write
// rolls it back, so an import or a bake is in the file completely or not at all.
//
// Meshes are BLOBs of little-endian scalars (float64 xyz, float32 xyz, uint32 triplets) with
// their element counts in separate columns; every BLOB size and every triangle index is
// checked on load. Scene indices (Surface::material, Surface::source) are 0-based positions
// in the Scene vectors; in the file they are row ids, mapped back on load (load order = id
// order).
//
// A Store is one sqlite3 connection: use it from one thread at a time.

#include "abrad/visdb/store.h"

#include <sqlite3.h>
#include <unistd.h>

#include <algorithm>
#include <bit>
#include <cerrno>
#include <charconv>
#include <climits>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <filesystem>
#include <iterator>
#include <limits>
#include <span>
#include <string_view>
#include <system_error>
#include <type_traits>
#include <unordered_map>
#include <utility>

#include "abrad/atomic_file.h"

namespace abrad::visdb {
namespace {

// "ABRD": the PRAGMA application_id of every abrad visual database.
constexpr int kApplicationId = 0x41425244;

// How long a connection waits for another process's lock before failing with SQLITE_BUSY.
constexpr int kBusyTimeoutMs = 10000;

// Bytes written per sqlite3_blob_write call; add_bake reports progress between chunks.
constexpr std::size_t kBlobChunkBytes = std::size_t{1} << 20;

// One schema migration: the SQL that takes a database at `from_version` to from_version + 1.
// Version 0 is an empty file. Append new steps; never edit a released one.
struct Migration {
    int from_version;
    const char* sql;
};

constexpr Migration kMigrations[] = {
    {0, R"sql(
CREATE TABLE meta(
    key   TEXT PRIMARY KEY,
    value TEXT NOT NULL
);
CREATE TABLE sources(
    id          INTEGER PRIMARY KEY,
    path        TEXT NOT NULL,
    format      TEXT NOT NULL,
    checksum    TEXT NOT NULL,
    size_bytes  INTEGER NOT NULL,
    unit        TEXT NOT NULL,
    up_axis     TEXT NOT NULL,
    imported_at TEXT NOT NULL,
    report      TEXT NOT NULL
);
CREATE TABLE materials(
    id          INTEGER PRIMARY KEY,
    name        TEXT NOT NULL,
    rho_r       REAL NOT NULL,
    rho_g       REAL NOT NULL,
    rho_b       REAL NOT NULL,
    emittance_r REAL NOT NULL,
    emittance_g REAL NOT NULL,
    emittance_b REAL NOT NULL,
    opacity     REAL NOT NULL
);
-- positions: vertex_count x 3 float64 LE (metres); triangles: triangle_count x 3 uint32 LE.
CREATE TABLE surfaces(
    id             INTEGER PRIMARY KEY,
    name           TEXT NOT NULL,
    layer          TEXT NOT NULL,
    material_id    INTEGER NOT NULL REFERENCES materials(id),
    source_id      INTEGER NOT NULL REFERENCES sources(id),
    vertex_count   INTEGER NOT NULL,
    triangle_count INTEGER NOT NULL,
    positions      BLOB NOT NULL,
    triangles      BLOB NOT NULL
);
CREATE TABLE cameras(
    id         INTEGER PRIMARY KEY,
    name       TEXT NOT NULL,
    position_x REAL NOT NULL,
    position_y REAL NOT NULL,
    position_z REAL NOT NULL,
    look_at_x  REAL NOT NULL,
    look_at_y  REAL NOT NULL,
    look_at_z  REAL NOT NULL,
    up_x       REAL NOT NULL,
    up_y       REAL NOT NULL,
    up_z       REAL NOT NULL,
    fov_y_deg  REAL NOT NULL
);
-- AUTOINCREMENT: a replaced bake gets a new, higher id; ids are never reused.
CREATE TABLE bakes(
    id         INTEGER PRIMARY KEY AUTOINCREMENT,
    name       TEXT NOT NULL UNIQUE,
    created_at TEXT NOT NULL,
    unit       TEXT NOT NULL,
    status     TEXT NOT NULL
);
CREATE TABLE bake_parameters(
    bake_id INTEGER NOT NULL REFERENCES bakes(id) ON DELETE CASCADE,
    seq     INTEGER NOT NULL,
    key     TEXT NOT NULL,
    value   TEXT NOT NULL,
    PRIMARY KEY(bake_id, seq)
);
-- value NULL stands for NaN (SQLite stores no NaN).
CREATE TABLE bake_statistics(
    bake_id INTEGER NOT NULL REFERENCES bakes(id) ON DELETE CASCADE,
    seq     INTEGER NOT NULL,
    key     TEXT NOT NULL,
    value   REAL,
    PRIMARY KEY(bake_id, seq)
);
-- positions float64 xyz, normals/irradiance/radiosity float32 xyz (per vertex);
-- triangles uint32 triplets, triangle_surface uint32 (per triangle); all little-endian.
CREATE TABLE bake_meshes(
    bake_id          INTEGER PRIMARY KEY REFERENCES bakes(id) ON DELETE CASCADE,
    vertex_count     INTEGER NOT NULL,
    triangle_count   INTEGER NOT NULL,
    positions        BLOB NOT NULL,
    normals          BLOB NOT NULL,
    triangles        BLOB NOT NULL,
    triangle_surface BLOB NOT NULL,
    irradiance       BLOB NOT NULL,
    radiosity        BLOB NOT NULL
);
)sql"},
    {1, R"sql(
-- Calculation grids (work planes) declared by scene files; the scene's emittance unit lives in
-- meta under 'emittance_unit' ('W/m2' when absent).
CREATE TABLE grids(
    id      INTEGER PRIMARY KEY,
    name    TEXT NOT NULL,
    min_x   REAL NOT NULL,
    min_y   REAL NOT NULL,
    max_x   REAL NOT NULL,
    max_y   REAL NOT NULL,
    z       REAL NOT NULL,
    spacing REAL NOT NULL,
    normal_x REAL NOT NULL,
    normal_y REAL NOT NULL,
    normal_z REAL NOT NULL
);
)sql"},
    {2, R"sql(
-- Luminaires placed by scene files: a photometric web (candela on a grid of angles, degrees,
-- little-endian doubles; candela[h * vertical_count + v]) in a frame at a position (metres).
-- web_type: 1 C, 2 B, 3 A (LM-63's codes); opening_shape: visdb::LuminousOpening::Shape.
CREATE TABLE luminaires(
    id                 INTEGER PRIMARY KEY,
    name               TEXT NOT NULL,
    file               TEXT NOT NULL,
    checksum           TEXT NOT NULL,
    position_x         REAL NOT NULL,
    position_y         REAL NOT NULL,
    position_z         REAL NOT NULL,
    axis_x_x           REAL NOT NULL,
    axis_x_y           REAL NOT NULL,
    axis_x_z           REAL NOT NULL,
    axis_y_x           REAL NOT NULL,
    axis_y_y           REAL NOT NULL,
    axis_y_z           REAL NOT NULL,
    axis_z_x           REAL NOT NULL,
    axis_z_y           REAL NOT NULL,
    axis_z_z           REAL NOT NULL,
    flux_scale         REAL NOT NULL,
    maintenance_factor REAL NOT NULL,
    color_r            REAL NOT NULL,
    color_g            REAL NOT NULL,
    color_b            REAL NOT NULL,
    opening_shape      INTEGER NOT NULL,
    opening_width      REAL NOT NULL,
    opening_length     REAL NOT NULL,
    opening_height     REAL NOT NULL,
    web_type           INTEGER NOT NULL,
    horizontal_count   INTEGER NOT NULL,
    vertical_count     INTEGER NOT NULL,
    horizontal         BLOB NOT NULL,
    vertical           BLOB NOT NULL,
    candela            BLOB NOT NULL
);
)sql"},
    {3, R"sql(
-- Light groups (light scenes without re-baking): the group a scene file gave an emitting
-- material or a luminaire ('' = the default: 'emitters', the photometric file's stem), and a
-- bake's shades per group (float32 xyz per vertex of its bake_meshes row, little-endian), one
-- row per group in seq order; a bake without rows is one group.
ALTER TABLE materials ADD COLUMN light_group TEXT NOT NULL DEFAULT '';
ALTER TABLE luminaires ADD COLUMN light_group TEXT NOT NULL DEFAULT '';
-- The lamp-tilt multiplier of a TILT=INCLUDE file at the luminaire's tilt (1: none)
ALTER TABLE luminaires ADD COLUMN tilt_factor REAL NOT NULL DEFAULT 1;
CREATE TABLE bake_light_groups(
    bake_id    INTEGER NOT NULL REFERENCES bakes(id) ON DELETE CASCADE,
    seq        INTEGER NOT NULL,
    name       TEXT NOT NULL,
    irradiance BLOB NOT NULL,
    radiosity  BLOB NOT NULL,
    PRIMARY KEY(bake_id, seq)
);
)sql"},
};

static_assert(std::size(kMigrations) == static_cast<std::size_t>(kSchemaVersion),
              "one migration step per schema version");

// ---------------------------------------------------------------------------------------
// Little-endian BLOB codec

template <typename Scalar>
using UintOf = std::conditional_t<sizeof(Scalar) == 8, std::uint64_t, std::uint32_t>;

template <typename Scalar>
void put_le(unsigned char* out, Scalar value) {
    static_assert(sizeof(Scalar) == 4 || sizeof(Scalar) == 8);
    const auto bits = std::bit_cast<UintOf<Scalar>>(value);
    for (std::size_t b = 0; b < sizeof(Scalar); ++b) {
        out[b] = static_cast<unsigned char>(bits >> (8 * b));
    }
}

template <typename Scalar>
Scalar get_le(const unsigned char* in) {
    UintOf<Scalar> bits = 0;
    for (std::size_t b = 0; b < sizeof(Scalar); ++b) {
        bits |= static_cast<UintOf<Scalar>>(in[b]) << (8 * b);
    }
    return std::bit_cast<Scalar>(bits);
}

template <typename T, glm::qualifier Q>
std::vector<unsigned char> encode(const std::vector<glm::vec<3, T, Q>>& values) {
    std::vector<unsigned char> out(values.size() * 3 * sizeof(T));
    unsigned char* p = out.data();
    for (const auto& v : values) {
        for (glm::length_t c = 0; c < 3; ++c, p += sizeof(T)) put_le<T>(p, v[c]);
    }
    return out;
}

std::vector<unsigned char> encode(const std::vector<std::uint32_t>& values) {
    std::vector<unsigned char> out(values.size() * sizeof(std::uint32_t));
    unsigned char* p = out.data();
    for (const auto v : values) {
        put_le<std::uint32_t>(p, v);
        p += sizeof(std::uint32_t);
    }
    return out;
}

// Decodes `count` elements; false when the BLOB does not hold exactly that many.
template <typename T, glm::qualifier Q>
bool decode(std::span<const unsigned char> bytes, std::int64_t count,
            std::vector<glm::vec<3, T, Q>>& out) {
    constexpr std::size_t kElement = 3 * sizeof(T);
    if (count < 0 || static_cast<std::uint64_t>(count) != bytes.size() / kElement ||
        bytes.size() % kElement != 0) {
        return false;
    }
    out.resize(static_cast<std::size_t>(count));
    const unsigned char* p = bytes.data();
    for (auto& v : out) {
        for (glm::length_t c = 0; c < 3; ++c, p += sizeof(T)) v[c] = get_le<T>(p);
    }
    return true;
}

bool decode(std::span<const unsigned char> bytes, std::int64_t count,
            std::vector<std::uint32_t>& out) {
    constexpr std::size_t kElement = sizeof(std::uint32_t);
    if (count < 0 || static_cast<std::uint64_t>(count) != bytes.size() / kElement ||
        bytes.size() % kElement != 0) {
        return false;
    }
    out.resize(static_cast<std::size_t>(count));
    const unsigned char* p = bytes.data();
    for (auto& v : out) {
        v = get_le<std::uint32_t>(p);
        p += kElement;
    }
    return true;
}

std::vector<unsigned char> encode(const std::vector<double>& values) {
    std::vector<unsigned char> out(values.size() * sizeof(double));
    unsigned char* p = out.data();
    for (const double v : values) {
        put_le<double>(p, v);
        p += sizeof(double);
    }
    return out;
}

bool decode(std::span<const unsigned char> bytes, std::int64_t count, std::vector<double>& out) {
    constexpr std::size_t kElement = sizeof(double);
    if (count < 0 || static_cast<std::uint64_t>(count) != bytes.size() / kElement ||
        bytes.size() % kElement != 0) {
        return false;
    }
    out.resize(static_cast<std::size_t>(count));
    const unsigned char* p = bytes.data();
    for (double& v : out) {
        v = get_le<double>(p);
        p += kElement;
    }
    return true;
}

// A web as PhotometricWeb states it: increasing angles, one candela >= 0 per pair.
bool valid_web(const PhotometricWeb& w) {
    const auto increasing = [](const std::vector<double>& a) {
        return !a.empty() && std::is_sorted(a.begin(), a.end()) &&
               std::adjacent_find(a.begin(), a.end()) == a.end();
    };
    return increasing(w.horizontal) && increasing(w.vertical) && w.vertical.size() >= 2 &&
           w.candela.size() == w.horizontal.size() * w.vertical.size() &&
           std::all_of(w.candela.begin(), w.candela.end(),
                       [](double c) { return std::isfinite(c) && c >= 0.0; });
}

bool indices_below(const std::vector<glm::u32vec3>& triangles, std::size_t vertex_count) {
    return std::all_of(triangles.begin(), triangles.end(), [&](const glm::u32vec3& t) {
        return t.x < vertex_count && t.y < vertex_count && t.z < vertex_count;
    });
}

// Whose fault a SQLite error is: the system's (disk full, I/O, locks held by another
// process, memory, a file that cannot be opened or written) or the file's (everything else:
// corrupt, not a database, constraint violations).
StoreError::Kind kind_of(int result_code) {
    switch (result_code & 0xff) {
        case SQLITE_FULL:
        case SQLITE_IOERR:
        case SQLITE_BUSY:
        case SQLITE_LOCKED:
        case SQLITE_NOMEM:
        case SQLITE_CANTOPEN:
        case SQLITE_PERM:
        case SQLITE_READONLY:
        case SQLITE_NOLFS:
        case SQLITE_PROTOCOL:
        case SQLITE_INTERRUPT:
            return StoreError::Kind::Failure;
        default:
            return StoreError::Kind::BadInput;
    }
}

// Whether a SQLite error is another connection's lock held past the busy timeout.
bool is_busy(int result_code) {
    return (result_code & 0xff) == SQLITE_BUSY || (result_code & 0xff) == SQLITE_LOCKED;
}

// The busy timeout: ABRAD_BUSY_TIMEOUT_MS when set to a number >= 0, else kBusyTimeoutMs.
int busy_timeout_ms() {
    const char* text = std::getenv("ABRAD_BUSY_TIMEOUT_MS");
    if (text == nullptr) return kBusyTimeoutMs;
    int ms = 0;
    const char* end = text + std::strlen(text);
    const auto [ptr, ec] = std::from_chars(text, end, ms);
    return ec == std::errc() && ptr == end && ms >= 0 ? ms : kBusyTimeoutMs;
}

// ---------------------------------------------------------------------------------------
// RAII wrappers of the SQLite C API

struct DbCloser {
    void operator()(sqlite3* db) const { sqlite3_close_v2(db); }
};
using DbHandle = std::unique_ptr<sqlite3, DbCloser>;

// A connection and the file name its errors carry.
class Connection {
  public:
    Connection(DbHandle db, std::string path) : m_db(std::move(db)), m_path(std::move(path)) {}

    sqlite3* get() const { return m_db.get(); }
    const std::string& path() const { return m_path; }

    // "PATH: what"
    [[noreturn]] void fail(std::string_view what,
                           StoreError::Kind kind = StoreError::Kind::BadInput,
                           bool busy = false) const {
        throw StoreError(m_path + ": " + std::string(what), kind, busy);
    }

    // "PATH: what: <SQLite's message>", of the kind the connection's last result code calls for
    [[noreturn]] void fail_sqlite(std::string_view what) const {
        const int code = sqlite3_extended_errcode(m_db.get());
        fail(std::string(what) + ": " + sqlite3_errmsg(m_db.get()), kind_of(code), is_busy(code));
    }

    void exec(const char* sql, std::string_view what) const {
        char* message = nullptr;
        if (sqlite3_exec(m_db.get(), sql, nullptr, nullptr, &message) != SQLITE_OK) {
            std::string text = message != nullptr ? message : sqlite3_errmsg(m_db.get());
            sqlite3_free(message);
            const int code = sqlite3_extended_errcode(m_db.get());
            fail(std::string(what) + ": " + text, kind_of(code), is_busy(code));
        }
    }

  private:
    DbHandle m_db;
    std::string m_path;
};

// A prepared statement. Bound BLOBs and texts are copied (SQLITE_TRANSIENT) unless the
// caller keeps them alive until the statement is reset (bind_blob_static).
class Statement {
  public:
    Statement(const Connection& connection, std::string_view sql) : m_connection(connection) {
        if (sqlite3_prepare_v2(connection.get(), sql.data(), static_cast<int>(sql.size()), &m_stmt,
                               nullptr) != SQLITE_OK) {
            connection.fail_sqlite("cannot prepare '" + std::string(sql) + "'");
        }
    }
    ~Statement() { sqlite3_finalize(m_stmt); }
    Statement(const Statement&) = delete;
    Statement& operator=(const Statement&) = delete;

    void bind(int index, std::int64_t value) {
        check_bind(sqlite3_bind_int64(m_stmt, index, value));
    }
    void bind(int index, double value) { check_bind(sqlite3_bind_double(m_stmt, index, value)); }
    void bind(int index, std::string_view text) {
        check_bind(sqlite3_bind_text64(m_stmt, index, text.data(), text.size(), SQLITE_TRANSIENT,
                                       SQLITE_UTF8));
    }
    void bind_null(int index) { check_bind(sqlite3_bind_null(m_stmt, index)); }
    // `bytes` must outlive the next step() of this statement.
    void bind_blob_static(int index, std::span<const unsigned char> bytes) {
        if (bytes.empty()) {
            check_bind(sqlite3_bind_zeroblob(m_stmt, index, 0));  // a null pointer binds NULL
        } else {
            check_bind(
                sqlite3_bind_blob64(m_stmt, index, bytes.data(), bytes.size(), SQLITE_STATIC));
        }
    }
    void bind_zeroblob(int index, std::size_t size) {
        check_bind(sqlite3_bind_zeroblob64(m_stmt, index, size));
    }

    // Steps once: true when a row is ready, false when done.
    bool step() {
        const int rc = sqlite3_step(m_stmt);
        if (rc == SQLITE_ROW) return true;
        if (rc == SQLITE_DONE) return false;
        m_connection.fail_sqlite("'" + std::string(sqlite3_sql(m_stmt)) + "' failed");
    }

    // Resets the statement for the next bindings.
    void reset() { sqlite3_reset(m_stmt); }

    // Runs a statement that returns no rows, then resets it for the next bindings.
    void run() {
        while (step()) {
        }
        sqlite3_reset(m_stmt);
    }

    bool is_null(int column) const { return sqlite3_column_type(m_stmt, column) == SQLITE_NULL; }
    std::int64_t int64(int column) const { return sqlite3_column_int64(m_stmt, column); }
    double real(int column) const { return sqlite3_column_double(m_stmt, column); }
    std::string text(int column) const {
        const auto* p = sqlite3_column_text(m_stmt, column);
        const int n = sqlite3_column_bytes(m_stmt, column);
        return p != nullptr ? std::string(reinterpret_cast<const char*>(p), n) : std::string();
    }
    // Valid until the next step/reset of this statement.
    std::span<const unsigned char> blob(int column) const {
        const auto* p = static_cast<const unsigned char*>(sqlite3_column_blob(m_stmt, column));
        const int n = sqlite3_column_bytes(m_stmt, column);
        return p != nullptr ? std::span<const unsigned char>(p, static_cast<std::size_t>(n))
                            : std::span<const unsigned char>();
    }

  private:
    void check_bind(int rc) const {
        if (rc != SQLITE_OK) {
            m_connection.fail(std::string("cannot bind a value of '") + sqlite3_sql(m_stmt) +
                                  "': " + sqlite3_errstr(rc),
                              StoreError::Kind::Failure);
        }
    }

    const Connection& m_connection;
    sqlite3_stmt* m_stmt = nullptr;
};

// An open incremental-I/O handle on one BLOB cell.
class BlobWriter {
  public:
    BlobWriter(const Connection& connection, const char* table, const char* column,
               std::int64_t rowid)
        : m_connection(connection) {
        if (sqlite3_blob_open(connection.get(), "main", table, column, rowid, 1, &m_blob) !=
            SQLITE_OK) {
            sqlite3_blob_close(m_blob);  // the handle may be set even on failure
            m_blob = nullptr;
            connection.fail_sqlite(std::string("cannot open ") + table + "." + column);
        }
    }
    ~BlobWriter() { sqlite3_blob_close(m_blob); }
    BlobWriter(const BlobWriter&) = delete;
    BlobWriter& operator=(const BlobWriter&) = delete;

    void write(const unsigned char* data, std::size_t size, std::size_t offset) {
        if (size > INT_MAX || offset > static_cast<std::size_t>(INT_MAX) - size) {
            m_connection.fail("a mesh BLOB is larger than 2 GiB", StoreError::Kind::Failure);
        }
        if (sqlite3_blob_write(m_blob, data, static_cast<int>(size), static_cast<int>(offset)) !=
            SQLITE_OK) {
            m_connection.fail_sqlite("cannot write a mesh BLOB");
        }
    }

  private:
    const Connection& m_connection;
    sqlite3_blob* m_blob = nullptr;
};

// BEGIN (IMMEDIATE for writers) ... COMMIT; the destructor rolls back an open transaction.
class Transaction {
  public:
    enum class Kind { Read, Write };

    Transaction(const Connection& connection, Kind kind) : m_connection(connection) {
        connection.exec(kind == Kind::Write ? "BEGIN IMMEDIATE" : "BEGIN",
                        "cannot begin a transaction");
        m_open = true;
    }
    ~Transaction() {
        // SQLite may already have rolled back by itself (e.g. after SQLITE_FULL).
        if (m_open && sqlite3_get_autocommit(m_connection.get()) == 0) {
            sqlite3_exec(m_connection.get(), "ROLLBACK", nullptr, nullptr, nullptr);
        }
    }
    Transaction(const Transaction&) = delete;
    Transaction& operator=(const Transaction&) = delete;

    void commit() {
        m_connection.exec("COMMIT", "cannot commit");
        m_open = false;
    }

  private:
    const Connection& m_connection;
    bool m_open = false;
};

// ---------------------------------------------------------------------------------------
// Schema probing and migration

[[noreturn]] void fail_not_abrad(const Connection& c) { c.fail("not an abrad visual database"); }

// The schema version of the file: 0 for an empty file. Throws when the file is not an abrad
// database (not SQLite, foreign tables without our meta rows, another application id).
int probe_schema_version(const Connection& c) {
    // The first read of the file: a non-SQLite file fails here with SQLITE_NOTADB.
    sqlite3_stmt* raw = nullptr;
    int rc = sqlite3_prepare_v2(c.get(), "SELECT count(*) FROM sqlite_master", -1, &raw, nullptr);
    std::int64_t object_count = 0;
    if (rc == SQLITE_OK) {
        rc = sqlite3_step(raw);
        if (rc == SQLITE_ROW) {
            object_count = sqlite3_column_int64(raw, 0);
            rc = SQLITE_OK;
        }
    }
    sqlite3_finalize(raw);
    if (rc != SQLITE_OK) {
        const int extended = sqlite3_extended_errcode(c.get());
        if ((rc & 0xff) == SQLITE_NOTADB || (extended & 0xff) == SQLITE_NOTADB) fail_not_abrad(c);
        if (extended == SQLITE_READONLY_ROLLBACK) {
            c.fail("an interrupted write must be rolled back; open the database read-write once");
        }
        c.fail_sqlite("cannot read the database");
    }
    if (object_count == 0) return 0;

    {
        Statement q(c, "PRAGMA application_id");
        if (q.step() && q.int64(0) != 0 && q.int64(0) != kApplicationId) fail_not_abrad(c);
    }
    {
        Statement q(c, "SELECT 1 FROM sqlite_master WHERE type = 'table' AND name = 'meta'");
        if (!q.step()) fail_not_abrad(c);
    }
    std::string application;
    std::string version_text;
    {
        Statement q(c,
                    "SELECT key, value FROM meta WHERE key IN ('application', 'schema_version')");
        while (q.step()) {
            (q.text(0) == "application" ? application : version_text) = q.text(1);
        }
    }
    int version = 0;
    const char* end = version_text.data() + version_text.size();
    const auto [ptr, ec] = std::from_chars(version_text.data(), end, version);
    if (application != "abrad" || ec != std::errc() || ptr != end || version < 1) {
        fail_not_abrad(c);
    }
    return version;
}

// Runs the migration steps from `version` to kSchemaVersion inside the caller's transaction.
void migrate(const Connection& c, int version) {
    if (version == 0) {
        c.exec(("PRAGMA application_id = " + std::to_string(kApplicationId)).c_str(),
               "cannot set the application id");
    }
    for (const Migration& step : kMigrations) {
        if (step.from_version != version) continue;
        c.exec(step.sql, "cannot migrate schema version " + std::to_string(version));
        version = step.from_version + 1;
        Statement upsert(c,
                         "INSERT INTO meta(key, value) VALUES (?1, ?2) "
                         "ON CONFLICT(key) DO UPDATE SET value = excluded.value");
        upsert.bind(1, std::string_view("application"));
        upsert.bind(2, std::string_view("abrad"));
        upsert.run();
        upsert.bind(1, std::string_view("schema_version"));
        upsert.bind(2, std::string_view(std::to_string(version)));
        upsert.run();
        c.exec(("PRAGMA user_version = " + std::to_string(version)).c_str(),
               "cannot set the user version");
    }
    if (version != kSchemaVersion) {
        c.fail("no migration from schema version " + std::to_string(version));
    }
}

}  // namespace

// ---------------------------------------------------------------------------------------
// Store

struct Store::Impl {
    Connection m_connection;
    OpenMode m_mode;
    int m_schema_version = 0;

    void require_writable() const {
        if (m_mode == OpenMode::ReadOnly) m_connection.fail("the database is open read-only");
    }
};

Store::Store(std::unique_ptr<Impl> impl) : m_impl(std::move(impl)) {}
Store::Store(Store&&) noexcept = default;
Store& Store::operator=(Store&&) noexcept = default;
Store::~Store() = default;

namespace {

// The Impl of a live store; a moved-from Store has none. (A template: Store::Impl is private.)
template <typename ImplPtr>
auto& live(const ImplPtr& impl) {
    if (!impl) throw StoreError("visdb: use of a moved-from Store");
    return *impl;
}

// Creates the database file `path` with the current schema, atomically: the schema is written
// to a temporary beside it (`PATH.tmp-PID-N`), committed and closed, then hard-linked to `path`,
// so a failure (a full disk) leaves no file at `path` for a later command to take for a
// foreign one. When another process created `path` meanwhile, the link fails and its file is
// kept. Errors name `path`; the temporary is removed either way.
void create_database(const std::string& path) {
    const std::string tmp = temporary_name(path);
    const auto remove_tmp = [&] {
        std::remove(tmp.c_str());
        std::remove((tmp + "-journal").c_str());
    };
    {
        sqlite3* raw = nullptr;
        const int rc =
            sqlite3_open_v2(tmp.c_str(), &raw, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE, nullptr);
        DbHandle db(raw);
        if (rc != SQLITE_OK) {
            const int code = raw != nullptr ? sqlite3_extended_errcode(raw) : rc;
            const std::string message = raw != nullptr ? sqlite3_errmsg(raw) : sqlite3_errstr(rc);
            db.reset();
            remove_tmp();
            throw StoreError(path + ": cannot open: " + message, kind_of(code));
        }
        const Connection c(std::move(db), path);
        sqlite3_extended_result_codes(c.get(), 1);
        try {
            c.exec("PRAGMA journal_mode = DELETE", "cannot select the rollback journal");
            Transaction transaction(c, Transaction::Kind::Write);
            migrate(c, 0);
            transaction.commit();
        } catch (...) {
            remove_tmp();
            throw;
        }
    }
    // Give it its name unless another process was first (link never replaces a file)
    if (::link(tmp.c_str(), path.c_str()) != 0 && errno != EEXIST) {
        const int err = errno;
        remove_tmp();
        throw StoreError(path + ": cannot create: " + std::generic_category().message(err),
                         StoreError::Kind::Failure);
    }
    remove_tmp();
}

constexpr const char* kLuminaireColumns =
    "name, file, checksum, position_x, position_y, position_z, axis_x_x, axis_x_y, axis_x_z, "
    "axis_y_x, axis_y_y, axis_y_z, axis_z_x, axis_z_y, axis_z_z, flux_scale, "
    "maintenance_factor, color_r, color_g, color_b, opening_shape, opening_width, "
    "opening_length, opening_height, web_type, horizontal_count, vertical_count, horizontal, "
    "vertical, candela, light_group, tilt_factor";

// Appends the luminaires of the database to `scene`; a row that does not make a valid web or
// frame is corrupt.
void load_luminaires(const Connection& c, Scene& scene) {
    Statement q(c, std::string("SELECT ") + kLuminaireColumns + " FROM luminaires ORDER BY id");
    while (q.step()) {
        Luminaire& l = scene.luminaires.emplace_back();
        l.name = q.text(0);
        l.file = q.text(1);
        l.checksum = q.text(2);
        const auto vec = [&q](int first) {
            return glm::dvec3(q.real(first), q.real(first + 1), q.real(first + 2));
        };
        l.position = vec(3);
        l.axis_x = vec(6);
        l.axis_y = vec(9);
        l.axis_z = vec(12);
        l.flux_scale = q.real(15);
        l.maintenance_factor = q.real(16);
        l.color = vec(17);
        const std::int64_t shape = q.int64(20);
        l.opening.width = q.real(21);
        l.opening.length = q.real(22);
        l.opening.height = q.real(23);
        const std::int64_t type = q.int64(24);
        const bool ok =
            shape >= 0 &&
            shape <= static_cast<std::int64_t>(LuminousOpening::Shape::VerticalDiscFacingY) &&
            type >= 1 && type <= 3 && decode(q.blob(27), q.int64(25), l.web.horizontal) &&
            decode(q.blob(28), q.int64(26), l.web.vertical) &&
            decode(q.blob(29), q.int64(25) * q.int64(26), l.web.candela);
        if (!ok) c.fail("corrupt luminaire '" + l.name + "'");
        l.opening.shape = static_cast<LuminousOpening::Shape>(shape);
        l.web.type = static_cast<PhotometricType>(type);
        if (!valid_web(l.web)) c.fail("corrupt photometric web of luminaire '" + l.name + "'");
        l.group = q.text(30);
        l.tilt_factor = q.real(31);
        if (!(l.tilt_factor > 0.0 && std::isfinite(l.tilt_factor)))
            c.fail("corrupt tilt factor of luminaire '" + l.name + "'");
    }
}

void insert_luminaires(const Connection& c, const std::vector<Luminaire>& luminaires) {
    Statement insert(c, std::string("INSERT INTO luminaires(") + kLuminaireColumns +
                            ") VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13, "
                            "?14, ?15, ?16, ?17, ?18, ?19, ?20, ?21, ?22, ?23, ?24, ?25, ?26, "
                            "?27, ?28, ?29, ?30, ?31, ?32)");
    for (const Luminaire& l : luminaires) {
        if (!valid_web(l.web)) c.fail("import: luminaire '" + l.name + "' has an invalid web");
        const auto horizontal = encode(l.web.horizontal);
        const auto vertical = encode(l.web.vertical);
        const auto candela = encode(l.web.candela);
        insert.bind(1, l.name);
        insert.bind(2, l.file);
        insert.bind(3, l.checksum);
        for (glm::length_t i = 0; i < 3; ++i) {
            insert.bind(4 + i, l.position[i]);
            insert.bind(7 + i, l.axis_x[i]);
            insert.bind(10 + i, l.axis_y[i]);
            insert.bind(13 + i, l.axis_z[i]);
            insert.bind(18 + i, l.color[i]);
        }
        insert.bind(16, l.flux_scale);
        insert.bind(17, l.maintenance_factor);
        insert.bind(21, static_cast<std::int64_t>(l.opening.shape));
        insert.bind(22, l.opening.width);
        insert.bind(23, l.opening.length);
        insert.bind(24, l.opening.height);
        insert.bind(25, static_cast<std::int64_t>(l.web.type));
        insert.bind(26, static_cast<std::int64_t>(l.web.horizontal.size()));
        insert.bind(27, static_cast<std::int64_t>(l.web.vertical.size()));
        insert.bind_blob_static(28, horizontal);
        insert.bind_blob_static(29, vertical);
        insert.bind_blob_static(30, candela);
        insert.bind(31, l.group);
        insert.bind(32, l.tilt_factor);
        insert.run();
    }
}

}  // namespace

Store Store::open(const std::string& path, OpenMode mode) {
    std::error_code ec;
    const bool exists = std::filesystem::exists(path, ec);
    if (mode != OpenMode::CreateOrOpen && !exists) throw StoreError(path + ": no such database");
    if (mode == OpenMode::CreateOrOpen && !exists) create_database(path);

    // Open the connection
    const int flags = mode == OpenMode::ReadOnly    ? SQLITE_OPEN_READONLY
                      : mode == OpenMode::ReadWrite ? SQLITE_OPEN_READWRITE
                                                    : SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE;
    sqlite3* raw = nullptr;
    const int rc = sqlite3_open_v2(path.c_str(), &raw, flags, nullptr);
    DbHandle db(raw);
    if (rc != SQLITE_OK) {
        throw StoreError(
            path + ": cannot open: " + (raw != nullptr ? sqlite3_errmsg(raw) : sqlite3_errstr(rc)),
            kind_of(raw != nullptr ? sqlite3_extended_errcode(raw) : rc));
    }
    auto impl = std::make_unique<Impl>(Impl{Connection(std::move(db), path), mode, 0});
    const Connection& c = impl->m_connection;
    sqlite3_busy_timeout(c.get(), busy_timeout_ms());
    sqlite3_extended_result_codes(c.get(), 1);

    // Check what the file is, then set the connection up
    int version = probe_schema_version(c);
    if (version > kSchemaVersion) {
        c.fail("schema version " + std::to_string(version) +
               " is newer than this build supports (version " + std::to_string(kSchemaVersion) +
               ")");
    }
    if (version == 0 && mode != OpenMode::CreateOrOpen) fail_not_abrad(c);
    c.exec("PRAGMA foreign_keys = ON", "cannot enable foreign keys");
    if (mode != OpenMode::ReadOnly) {
        c.exec("PRAGMA journal_mode = DELETE", "cannot select the rollback journal");
    }

    // Create or migrate the schema
    if (version < kSchemaVersion) {
        if (mode == OpenMode::ReadOnly) {
            c.fail("schema version " + std::to_string(version) + " is older than version " +
                   std::to_string(kSchemaVersion) + "; open it read-write once to migrate");
        }
        Transaction transaction(c, Transaction::Kind::Write);
        version = probe_schema_version(c);  // another process may have been first
        if (version < kSchemaVersion) migrate(c, version);
        transaction.commit();
        version = kSchemaVersion;
    }
    impl->m_schema_version = version;
    return Store(std::move(impl));
}

int Store::schema_version() const { return live(m_impl).m_schema_version; }

const std::string& Store::path() const { return live(m_impl).m_connection.path(); }

Scene Store::load_scene() const {
    const Connection& c = live(m_impl).m_connection;
    Transaction transaction(c, Transaction::Kind::Read);
    Scene scene;

    // Load sources and materials, remembering id -> index
    std::unordered_map<std::int64_t, std::uint32_t> source_index;
    std::unordered_map<std::int64_t, std::uint32_t> material_index;
    {
        Statement q(c,
                    "SELECT id, path, format, checksum, size_bytes, unit, up_axis, imported_at, "
                    "report FROM sources ORDER BY id");
        while (q.step()) {
            source_index.emplace(q.int64(0), static_cast<std::uint32_t>(scene.sources.size()));
            Source& s = scene.sources.emplace_back();
            s.path = q.text(1);
            s.format = q.text(2);
            s.checksum = q.text(3);
            s.size_bytes = static_cast<std::uint64_t>(q.int64(4));
            s.unit = q.text(5);
            s.up_axis = q.text(6);
            s.imported_at = q.text(7);
            s.report = q.text(8);
        }
    }
    {
        Statement q(c,
                    "SELECT id, name, rho_r, rho_g, rho_b, emittance_r, emittance_g, emittance_b, "
                    "opacity, light_group FROM materials ORDER BY id");
        while (q.step()) {
            material_index.emplace(q.int64(0), static_cast<std::uint32_t>(scene.materials.size()));
            Material& m = scene.materials.emplace_back();
            m.name = q.text(1);
            m.reflectance = Rgb(q.real(2), q.real(3), q.real(4));
            m.emittance = Rgb(q.real(5), q.real(6), q.real(7));
            m.opacity = q.real(8);
            m.group = q.text(9);
        }
    }

    // Load surfaces with their meshes, checking BLOB sizes and indices
    {
        Statement q(c,
                    "SELECT name, layer, material_id, source_id, vertex_count, triangle_count, "
                    "positions, triangles FROM surfaces ORDER BY id");
        while (q.step()) {
            Surface& s = scene.surfaces.emplace_back();
            s.name = q.text(0);
            s.layer = q.text(1);
            const auto material = material_index.find(q.int64(2));
            const auto source = source_index.find(q.int64(3));
            const bool ok = material != material_index.end() && source != source_index.end() &&
                            decode(q.blob(6), q.int64(4), s.mesh.positions) &&
                            decode(q.blob(7), q.int64(5), s.mesh.triangles) &&
                            indices_below(s.mesh.triangles, s.mesh.positions.size());
            if (!ok) c.fail("corrupt mesh for surface '" + s.name + "'");
            s.material = material->second;
            s.source = source->second;
        }
    }
    {
        Statement q(c,
                    "SELECT name, position_x, position_y, position_z, look_at_x, look_at_y, "
                    "look_at_z, up_x, up_y, up_z, fov_y_deg FROM cameras ORDER BY id");
        while (q.step()) {
            Camera& cam = scene.cameras.emplace_back();
            cam.name = q.text(0);
            cam.position = glm::dvec3(q.real(1), q.real(2), q.real(3));
            cam.look_at = glm::dvec3(q.real(4), q.real(5), q.real(6));
            cam.up = glm::dvec3(q.real(7), q.real(8), q.real(9));
            cam.fov_y_deg = q.real(10);
        }
    }
    {
        Statement q(c,
                    "SELECT name, min_x, min_y, max_x, max_y, z, spacing, normal_x, normal_y, "
                    "normal_z FROM grids ORDER BY id");
        while (q.step()) {
            CalculationGrid& g = scene.grids.emplace_back();
            g.name = q.text(0);
            g.min = glm::dvec2(q.real(1), q.real(2));
            g.max = glm::dvec2(q.real(3), q.real(4));
            g.z = q.real(5);
            g.spacing = q.real(6);
            g.normal = glm::dvec3(q.real(7), q.real(8), q.real(9));
        }
    }
    load_luminaires(c, scene);
    {
        Statement q(c, "SELECT value FROM meta WHERE key = 'emittance_unit'");
        if (q.step()) scene.emittance_unit = q.text(0);
    }
    transaction.commit();
    return scene;
}

void Store::add_import(const Scene& imported, SameSource same_source) {
    const Impl& impl = live(m_impl);
    impl.require_writable();
    const Connection& c = impl.m_connection;

    // Check the references before writing anything
    for (const Surface& s : imported.surfaces) {
        if (s.material >= imported.materials.size()) {
            c.fail("import: surface '" + s.name + "' refers to material " +
                   std::to_string(s.material) + " of " + std::to_string(imported.materials.size()));
        }
        if (s.source >= imported.sources.size()) {
            c.fail("import: surface '" + s.name + "' refers to source " + std::to_string(s.source) +
                   " of " + std::to_string(imported.sources.size()));
        }
        if (!indices_below(s.mesh.triangles, s.mesh.positions.size())) {
            c.fail("import: surface '" + s.name + "' has a triangle index out of range");
        }
    }
    if (imported.emittance_unit != "W/m2" && imported.emittance_unit != "lm/m2") {
        c.fail("import: emittance unit '" + imported.emittance_unit +
               "' is neither 'W/m2' nor 'lm/m2'");
    }
    const auto has_emitters = [](const Scene& scene) {
        if (!scene.luminaires.empty()) return true;
        for (const Surface& s : scene.surfaces)
            if (scene.materials[s.material].is_emitter()) return true;
        return false;
    };

    try {
        Transaction transaction(c, Transaction::Kind::Write);

        // One emittance unit per database: an import with emitters in the other unit is refused
        {
            std::string stored = "W/m2";
            {
                Statement q(c, "SELECT value FROM meta WHERE key = 'emittance_unit'");
                if (q.step()) stored = q.text(0);
            }
            if (imported.emittance_unit != stored) {
                bool stored_emitters = false;
                {
                    Statement q(c,
                                "SELECT 1 FROM materials WHERE emittance_r > 0 OR "
                                "emittance_g > 0 OR emittance_b > 0 UNION ALL "
                                "SELECT 1 FROM luminaires LIMIT 1");
                    stored_emitters = q.step();
                }
                const bool new_emitters = has_emitters(imported);
                if (stored_emitters && new_emitters) {
                    c.fail("import: its emitters are in " + imported.emittance_unit +
                           " but the database's are in " + stored +
                           "; radiometric and photometric emitters cannot be mixed");
                }
                if (!stored_emitters && (new_emitters || imported.emittance_unit != "W/m2")) {
                    Statement upsert(c,
                                     "INSERT INTO meta(key, value) VALUES ('emittance_unit', ?1) "
                                     "ON CONFLICT(key) DO UPDATE SET value = excluded.value");
                    upsert.bind(1, imported.emittance_unit);
                    upsert.run();
                }
            }
        }

        // A source already imported (same checksum), checked under the write lock
        if (same_source == SameSource::Refuse) {
            Statement q(c, "SELECT path FROM sources WHERE checksum = ?1");
            for (const Source& s : imported.sources) {
                q.bind(1, s.checksum);
                if (q.step()) {
                    c.fail(s.path + ": already imported as " + q.text(0) +
                           " (same FNV-1a checksum " + s.checksum + "); nothing written");
                }
                q.reset();
            }
        }

        // Insert sources and materials, collecting their new ids
        std::vector<std::int64_t> source_ids;
        std::vector<std::int64_t> material_ids;
        {
            Statement insert(c,
                             "INSERT INTO sources(path, format, checksum, size_bytes, unit, "
                             "up_axis, imported_at, report) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, "
                             "?8)");
            for (const Source& s : imported.sources) {
                insert.bind(1, s.path);
                insert.bind(2, s.format);
                insert.bind(3, s.checksum);
                insert.bind(4, static_cast<std::int64_t>(s.size_bytes));  // bits kept
                insert.bind(5, s.unit);
                insert.bind(6, s.up_axis);
                insert.bind(7, s.imported_at);
                insert.bind(8, s.report);
                insert.run();
                source_ids.push_back(sqlite3_last_insert_rowid(c.get()));
            }
        }
        {
            Statement insert(c,
                             "INSERT INTO materials(name, rho_r, rho_g, rho_b, emittance_r, "
                             "emittance_g, emittance_b, opacity, light_group) VALUES (?1, ?2, "
                             "?3, ?4, ?5, ?6, ?7, ?8, ?9)");
            for (const Material& m : imported.materials) {
                insert.bind(1, m.name);
                for (glm::length_t i = 0; i < 3; ++i) {
                    insert.bind(2 + i, m.reflectance[i]);
                    insert.bind(5 + i, m.emittance[i]);
                }
                insert.bind(8, m.opacity);
                insert.bind(9, m.group);
                insert.run();
                material_ids.push_back(sqlite3_last_insert_rowid(c.get()));
            }
        }

        // Insert surfaces with remapped references and their meshes as BLOBs
        {
            Statement insert(c,
                             "INSERT INTO surfaces(name, layer, material_id, source_id, "
                             "vertex_count, triangle_count, positions, triangles) VALUES (?1, ?2, "
                             "?3, ?4, ?5, ?6, ?7, ?8)");
            for (const Surface& s : imported.surfaces) {
                const auto positions = encode(s.mesh.positions);
                const auto triangles = encode(s.mesh.triangles);
                insert.bind(1, s.name);
                insert.bind(2, s.layer);
                insert.bind(3, material_ids[s.material]);
                insert.bind(4, source_ids[s.source]);
                insert.bind(5, static_cast<std::int64_t>(s.mesh.positions.size()));
                insert.bind(6, static_cast<std::int64_t>(s.mesh.triangles.size()));
                insert.bind_blob_static(7, positions);
                insert.bind_blob_static(8, triangles);
                insert.run();
            }
        }
        {
            Statement insert(c,
                             "INSERT INTO cameras(name, position_x, position_y, position_z, "
                             "look_at_x, look_at_y, look_at_z, up_x, up_y, up_z, fov_y_deg) "
                             "VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11)");
            for (const Camera& cam : imported.cameras) {
                insert.bind(1, cam.name);
                for (glm::length_t i = 0; i < 3; ++i) {
                    insert.bind(2 + i, cam.position[i]);
                    insert.bind(5 + i, cam.look_at[i]);
                    insert.bind(8 + i, cam.up[i]);
                }
                insert.bind(11, cam.fov_y_deg);
                insert.run();
            }
        }
        {
            Statement insert(c,
                             "INSERT INTO grids(name, min_x, min_y, max_x, max_y, z, spacing, "
                             "normal_x, normal_y, normal_z) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, "
                             "?8, ?9, ?10)");
            for (const CalculationGrid& g : imported.grids) {
                insert.bind(1, g.name);
                insert.bind(2, g.min.x);
                insert.bind(3, g.min.y);
                insert.bind(4, g.max.x);
                insert.bind(5, g.max.y);
                insert.bind(6, g.z);
                insert.bind(7, g.spacing);
                for (glm::length_t i = 0; i < 3; ++i) insert.bind(8 + i, g.normal[i]);
                insert.run();
            }
        }
        insert_luminaires(c, imported.luminaires);
        transaction.commit();
    } catch (const StoreError&) {
        throw;  // already names the file; the transaction was rolled back on the way out
    } catch (const std::exception& e) {
        std::throw_with_nested(
            StoreError(c.path() + ": import not written (rolled back): " + e.what(),
                       StoreError::Kind::Failure));
    }
}

namespace {

// The bake `name` or, when `numbered`, the name `bake-N` with N the smallest number above the
// count of bakes that no bake has. Call inside the write transaction.
std::string bake_name(const Connection& c, const Bake& bake, bool numbered) {
    if (!numbered) return bake.name;
    std::int64_t n = 0;
    {
        Statement q(c, "SELECT count(*) FROM bakes");
        if (q.step()) n = q.int64(0);
    }
    Statement taken(c, "SELECT 1 FROM bakes WHERE name = ?1");
    for (;;) {
        std::string name = "bake-" + std::to_string(++n);
        taken.bind(1, name);
        const bool exists = taken.step();
        taken.reset();
        if (!exists) return name;
    }
}

// Stores `bake` (named, or numbered by bake_name) in one transaction: its id and name.
// The shades per light group of bake `id` (each group one row; bound, not streamed).
void insert_light_groups(const Connection& c, std::int64_t id,
                         const std::vector<LightGroupShades>& groups) {
    Statement insert(c,
                     "INSERT INTO bake_light_groups(bake_id, seq, name, irradiance, radiosity) "
                     "VALUES (?1, ?2, ?3, ?4, ?5)");
    std::int64_t seq = 0;
    for (const LightGroupShades& g : groups) {
        const auto irradiance = encode(g.irradiance);
        const auto radiosity = encode(g.radiosity);
        insert.bind(1, id);
        insert.bind(2, seq++);
        insert.bind(3, g.name);
        insert.bind_blob_static(4, irradiance);
        insert.bind_blob_static(5, radiosity);
        insert.run();
    }
}

std::pair<std::int64_t, std::string> write_bake(const Connection& c, const Bake& bake,
                                                bool numbered,
                                                const std::function<void(double)>& progress) {
    const auto report = [&](double fraction) {
        if (progress) progress(fraction);
    };

    // Check the bake before writing anything
    std::string label = numbered ? std::string("bake") : "bake '" + bake.name + "'";
    const BakeMesh& mesh = bake.mesh;
    const std::size_t vertex_count = mesh.positions.size();
    if (!numbered && bake.name.empty()) c.fail("a bake needs a name");
    if (mesh.normals.size() != vertex_count || mesh.irradiance.size() != vertex_count ||
        mesh.radiosity.size() != vertex_count) {
        c.fail(label + ": normals, irradiance and radiosity need one entry per vertex");
    }
    if (mesh.triangle_surface.size() != mesh.triangles.size()) {
        c.fail(label + ": triangle_surface needs one entry per triangle");
    }
    if (!indices_below(mesh.triangles, vertex_count)) {
        c.fail(label + ": a triangle index is out of range");
    }
    for (const LightGroupShades& g : bake.light_groups) {
        if (g.irradiance.size() != vertex_count || g.radiosity.size() != vertex_count)
            c.fail(label + ": light group '" + g.name + "' needs one shade per vertex");
    }

    try {
        Transaction transaction(c, Transaction::Kind::Write);
        report(0.0);
        const std::string name = bake_name(c, bake, numbered);
        label = "bake '" + name + "'";

        // Replace a bake of the same name (its children go by ON DELETE CASCADE)
        {
            Statement remove(c, "DELETE FROM bakes WHERE name = ?1");
            remove.bind(1, name);
            remove.run();
        }

        // Insert the bake row, its parameters and statistics in order
        std::int64_t id = 0;
        {
            Statement insert(c,
                             "INSERT INTO bakes(name, created_at, unit, status) "
                             "VALUES (?1, ?2, ?3, 'complete')");
            insert.bind(1, name);
            insert.bind(2, bake.created_at);
            insert.bind(3, bake.unit);
            insert.run();
            id = sqlite3_last_insert_rowid(c.get());
        }
        {
            Statement insert(c,
                             "INSERT INTO bake_parameters(bake_id, seq, key, value) "
                             "VALUES (?1, ?2, ?3, ?4)");
            std::int64_t seq = 0;
            for (const auto& [key, value] : bake.parameters) {
                insert.bind(1, id);
                insert.bind(2, seq++);
                insert.bind(3, key);
                insert.bind(4, value);
                insert.run();
            }
        }
        {
            Statement insert(c,
                             "INSERT INTO bake_statistics(bake_id, seq, key, value) "
                             "VALUES (?1, ?2, ?3, ?4)");
            std::int64_t seq = 0;
            for (const auto& [key, value] : to_pairs(bake.statistics)) {
                insert.bind(1, id);
                insert.bind(2, seq++);
                insert.bind(3, key);
                if (std::isnan(value)) {
                    insert.bind_null(4);
                } else {
                    insert.bind(4, value);
                }
                insert.run();
            }
        }
        report(0.05);

        // Encode the mesh arrays and reserve their BLOBs
        struct Column {
            const char* name;
            std::vector<unsigned char> bytes;
        };
        Column columns[] = {
            {"positions", encode(mesh.positions)},
            {"normals", encode(mesh.normals)},
            {"triangles", encode(mesh.triangles)},
            {"triangle_surface", encode(mesh.triangle_surface)},
            {"irradiance", encode(mesh.irradiance)},
            {"radiosity", encode(mesh.radiosity)},
        };
        {
            Statement insert(c,
                             "INSERT INTO bake_meshes(bake_id, vertex_count, triangle_count, "
                             "positions, normals, triangles, triangle_surface, irradiance, "
                             "radiosity) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9)");
            insert.bind(1, id);
            insert.bind(2, static_cast<std::int64_t>(vertex_count));
            insert.bind(3, static_cast<std::int64_t>(mesh.triangles.size()));
            int index = 4;
            for (const Column& column : columns) insert.bind_zeroblob(index++, column.bytes.size());
            insert.run();
        }
        report(0.1);

        // Write the BLOBs in chunks, reporting progress between them
        std::size_t total = 0;
        for (const Column& column : columns) total += column.bytes.size();
        std::size_t written = 0;
        for (const Column& column : columns) {
            if (column.bytes.empty()) continue;
            BlobWriter blob(c, "bake_meshes", column.name, id);
            for (std::size_t offset = 0; offset < column.bytes.size(); offset += kBlobChunkBytes) {
                const std::size_t n = std::min(kBlobChunkBytes, column.bytes.size() - offset);
                blob.write(column.bytes.data() + offset, n, offset);
                written += n;
                report(0.1 + 0.89 * static_cast<double>(written) / static_cast<double>(total));
            }
        }

        insert_light_groups(c, id, bake.light_groups);
        report(1.0);
        transaction.commit();
        return {id, name};
    } catch (const StoreError&) {
        throw;  // already names the file; the transaction was rolled back on the way out
    } catch (const std::exception& e) {
        std::throw_with_nested(
            StoreError(c.path() + ": " + label + " not written (rolled back): " + e.what(),
                       StoreError::Kind::Failure));
    }
}

}  // namespace

std::int64_t Store::add_bake(const Bake& bake, const std::function<void(double)>& progress) {
    const Impl& impl = live(m_impl);
    impl.require_writable();
    return write_bake(impl.m_connection, bake, false, progress).first;
}

std::string Store::add_numbered_bake(const Bake& bake,
                                     const std::function<void(double)>& progress) {
    const Impl& impl = live(m_impl);
    impl.require_writable();
    return write_bake(impl.m_connection, bake, true, progress).second;
}

void Store::check_writable() const {
    const Impl& impl = live(m_impl);
    const Connection& c = impl.m_connection;
    if (impl.m_mode == OpenMode::ReadOnly) {
        c.fail("the database is open read-only", StoreError::Kind::Failure);
    }
    if (sqlite3_db_readonly(c.get(), "main") == 1) {
        c.fail("the database file is read-only: nothing can be stored in it",
               StoreError::Kind::Failure);
    }
    const std::filesystem::path file(c.path());
    const std::filesystem::path dir = file.has_parent_path() ? file.parent_path() : ".";
    if (::access(dir.c_str(), W_OK | X_OK) != 0) {
        c.fail("its directory " + dir.string() + " is not writable (" +
                   std::generic_category().message(errno) +
                   "): SQLite cannot create its journal there, so nothing can be stored",
               StoreError::Kind::Failure);
    }
}

std::vector<BakeSummary> Store::list_bakes() const {
    const Connection& c = live(m_impl).m_connection;
    Transaction transaction(c, Transaction::Kind::Read);
    std::vector<BakeSummary> bakes;
    std::unordered_map<std::int64_t, std::size_t> index;
    {
        Statement q(c,
                    "SELECT b.id, b.name, b.created_at, b.unit, m.vertex_count, m.triangle_count "
                    "FROM bakes AS b LEFT JOIN bake_meshes AS m ON m.bake_id = b.id "
                    "ORDER BY b.id");
        while (q.step()) {
            index.emplace(q.int64(0), bakes.size());
            BakeSummary& b = bakes.emplace_back();
            b.id = q.int64(0);
            b.name = q.text(1);
            b.created_at = q.text(2);
            b.unit = q.text(3);
            b.vertex_count = static_cast<std::size_t>(std::max<std::int64_t>(q.int64(4), 0));
            b.triangle_count = static_cast<std::size_t>(std::max<std::int64_t>(q.int64(5), 0));
        }
    }
    {
        Statement q(c, "SELECT bake_id, key, value FROM bake_parameters ORDER BY bake_id, seq");
        while (q.step()) {
            const auto it = index.find(q.int64(0));
            if (it != index.end()) bakes[it->second].parameters.emplace_back(q.text(1), q.text(2));
        }
    }
    {
        Statement q(c, "SELECT bake_id, key, value FROM bake_statistics ORDER BY bake_id, seq");
        std::vector<std::vector<std::pair<std::string, double>>> stored(bakes.size());
        while (q.step()) {
            const auto it = index.find(q.int64(0));
            const double value =
                q.is_null(2) ? std::numeric_limits<double>::quiet_NaN() : q.real(2);
            if (it != index.end()) stored[it->second].emplace_back(q.text(1), value);
        }
        for (std::size_t i = 0; i < bakes.size(); ++i)
            bakes[i].statistics = stats_from_pairs(stored[i]);
    }
    transaction.commit();
    return bakes;
}

Bake Store::load_bake(const std::string& name) const {
    const Connection& c = live(m_impl).m_connection;
    Transaction transaction(c, Transaction::Kind::Read);
    Bake bake;

    // Find the bake: by name, or the latest
    {
        Statement q(c, name.empty() ? "SELECT id, name, created_at, unit FROM bakes "
                                      "ORDER BY id DESC LIMIT 1"
                                    : "SELECT id, name, created_at, unit FROM bakes "
                                      "WHERE name = ?1");
        if (!name.empty()) q.bind(1, name);
        if (!q.step()) {
            c.fail(name.empty() ? std::string("the database has no bakes")
                                : "no bake named '" + name + "'");
        }
        bake.id = q.int64(0);
        bake.name = q.text(1);
        bake.created_at = q.text(2);
        bake.unit = q.text(3);
    }
    {
        Statement q(c, "SELECT key, value FROM bake_parameters WHERE bake_id = ?1 ORDER BY seq");
        q.bind(1, bake.id);
        while (q.step()) bake.parameters.emplace_back(q.text(0), q.text(1));
    }
    {
        Statement q(c, "SELECT key, value FROM bake_statistics WHERE bake_id = ?1 ORDER BY seq");
        q.bind(1, bake.id);
        std::vector<std::pair<std::string, double>> stored;
        while (q.step()) {
            stored.emplace_back(
                q.text(0), q.is_null(1) ? std::numeric_limits<double>::quiet_NaN() : q.real(1));
        }
        bake.statistics = stats_from_pairs(stored);
    }

    // Load and check the mesh
    {
        Statement q(c,
                    "SELECT vertex_count, triangle_count, positions, normals, triangles, "
                    "triangle_surface, irradiance, radiosity FROM bake_meshes WHERE bake_id = ?1");
        q.bind(1, bake.id);
        BakeMesh& m = bake.mesh;
        const bool ok = q.step() && decode(q.blob(2), q.int64(0), m.positions) &&
                        decode(q.blob(3), q.int64(0), m.normals) &&
                        decode(q.blob(4), q.int64(1), m.triangles) &&
                        decode(q.blob(5), q.int64(1), m.triangle_surface) &&
                        decode(q.blob(6), q.int64(0), m.irradiance) &&
                        decode(q.blob(7), q.int64(0), m.radiosity) &&
                        indices_below(m.triangles, m.positions.size());
        if (!ok) c.fail("corrupt mesh for bake '" + bake.name + "'");
    }
    {
        Statement q(c,
                    "SELECT name, irradiance, radiosity FROM bake_light_groups WHERE bake_id = ?1 "
                    "ORDER BY seq");
        q.bind(1, bake.id);
        const auto n = static_cast<std::int64_t>(bake.mesh.positions.size());
        while (q.step()) {
            LightGroupShades& g = bake.light_groups.emplace_back();
            g.name = q.text(0);
            if (!decode(q.blob(1), n, g.irradiance) || !decode(q.blob(2), n, g.radiosity))
                c.fail("corrupt light group '" + g.name + "' of bake '" + bake.name + "'");
        }
    }
    transaction.commit();
    return bake;
}

}  // namespace abrad::visdb
