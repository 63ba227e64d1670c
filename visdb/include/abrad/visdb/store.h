#pragma once
// The visual database: one SQLite file per project holding the imported scene and its bakes.
// Every write (an import, a bake) is one transaction: a failure or a kill leaves the file as
// it was.

#include <cstdint>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "abrad/visdb/model.h"

namespace abrad::visdb {

/// An error reading or writing the database; `what()` names the file.
class StoreError : public std::runtime_error {
  public:
    /// Whose fault the error is.
    enum class Kind {
        BadInput,  ///< the file: missing, not an abrad database, corrupt, wrong schema, no such
                   ///< bake
        Failure,   ///< the system: disk full, I/O error, locked by another writer, out of memory,
                   ///< a file that cannot be created
    };

    explicit StoreError(const std::string& what, Kind kind = Kind::BadInput, bool busy = false)
        : std::runtime_error(what), m_kind(kind), m_busy(busy) {}

    /// BadInput or Failure (from the SQLite result code when SQLite reported the error).
    Kind kind() const { return m_kind; }

    /// True when another connection held the database past the busy timeout (SQLITE_BUSY or
    /// SQLITE_LOCKED; kind Failure): the same write may succeed later.
    bool busy() const { return m_busy; }

  private:
    Kind m_kind;
    bool m_busy;
};

/// What Store::add_import does with a source whose checksum the database already holds.
enum class SameSource {
    Allow,   ///< import it again
    Refuse,  ///< StoreError (BadInput) naming both paths; checked inside the write transaction,
             ///< so of two concurrent imports of one file only the first is stored
};

/// How to open a database file.
enum class OpenMode {
    ReadOnly,      ///< the file must exist and is never written
    ReadWrite,     ///< the file must exist
    CreateOrOpen,  ///< create the file (and schema) when missing
};

/// What `list_bakes` tells about a bake without loading its mesh.
struct BakeSummary {
    std::int64_t id = 0;
    std::string name;
    std::string created_at;
    std::string unit;
    std::vector<std::pair<std::string, std::string>> parameters;
    BakeStats statistics;
    std::size_t vertex_count = 0;
    std::size_t triangle_count = 0;
};

/// Current schema version written by this build.
inline constexpr int kSchemaVersion = 4;

/// A handle on one .visdb file. Move-only. Writers take the lock with BEGIN IMMEDIATE and
/// wait for it, and for readers to finish at COMMIT, up to the busy timeout.
class Store {
  public:
    /// Opens (or creates) `path`. A new file is created whole or not at all: its schema is
    /// written to a temporary beside it that gets the name once committed, so a failure (a full
    /// disk: kind Failure) leaves no file at `path`. Throws StoreError naming the path when the
    /// file is missing (ReadOnly/ReadWrite), is not an abrad database, or has a newer schema
    /// version. A connection waits up to 10 s for another process's lock (the environment variable
    /// ABRAD_BUSY_TIMEOUT_MS overrides that), then fails with kind Failure.
    static Store open(const std::string& path, OpenMode mode);

    Store(Store&&) noexcept;
    Store& operator=(Store&&) noexcept;
    ~Store();

    /// Schema version stored in the file.
    int schema_version() const;

    /// Loads everything imported so far (sources, materials, surfaces with meshes, cameras).
    Scene load_scene() const;

    /// Appends an imported scene in one transaction. Material and source indices in
    /// `imported.surfaces` refer to `imported.materials`/`imported.sources` and are remapped.
    /// `same_source` says whether a source already in the database (same checksum) is refused.
    void add_import(const Scene& imported, SameSource same_source = SameSource::Allow);

    /// Stores a bake in one transaction and returns its id. A bake with the same name is
    /// replaced in that same transaction. `progress`, when set, is called with the fraction
    /// written (0..1) while the transaction is open (tests use it to kill the writer).
    /// `bake.name` must not be empty, and the mesh arrays must agree in length with in-range
    /// triangle indices; otherwise StoreError and nothing is written. `bake.id` is ignored.
    std::int64_t add_bake(const Bake& bake, const std::function<void(double)>& progress = {});

    /// Stores a bake that has no name yet (`bake.name` is ignored): names it `bake-N` inside
    /// the write transaction, N the smallest number above the count of bakes that no bake has,
    /// so concurrent writers never take the same name and neither replaces the other. Returns
    /// the name. Otherwise as add_bake.
    std::string add_numbered_bake(const Bake& bake,
                                  const std::function<void(double)>& progress = {});

    /// Throws StoreError (kind Failure) unless a write can succeed as far as permissions tell:
    /// the store was opened read-only, the file is not writable (SQLite then opened it
    /// read-only), or its directory is not writable (SQLite creates its journal there). For
    /// commands to call before long work whose result they will store.
    void check_writable() const;

    /// All bakes, oldest first, without meshes.
    std::vector<BakeSummary> list_bakes() const;

    /// Loads a bake with its mesh; an empty name means the latest. Throws StoreError when
    /// there is no such bake.
    Bake load_bake(const std::string& name = {}) const;

    /// The path the store was opened with.
    const std::string& path() const;

  private:
    struct Impl;
    explicit Store(std::unique_ptr<Impl> impl);
    std::unique_ptr<Impl> m_impl;
};

}  // namespace abrad::visdb
