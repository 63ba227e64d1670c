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

    explicit StoreError(const std::string& what, Kind kind = Kind::BadInput)
        : std::runtime_error(what), m_kind(kind) {}

    /// BadInput or Failure (from the SQLite result code when SQLite reported the error).
    Kind kind() const { return m_kind; }

  private:
    Kind m_kind;
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
inline constexpr int kSchemaVersion = 2;

/// A handle on one .visdb file. Move-only.
class Store {
  public:
    /// Opens (or creates) `path`. Throws StoreError naming the path when the file is missing
    /// (ReadOnly/ReadWrite), is not an abrad database, or has a newer schema version. A
    /// connection waits up to 10 s for another process's lock (the environment variable
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
    void add_import(const Scene& imported);

    /// Stores a bake in one transaction and returns its id. A bake with the same name is
    /// replaced in that same transaction. `progress`, when set, is called with the fraction
    /// written (0..1) while the transaction is open (tests use it to kill the writer).
    /// `bake.name` must not be empty, and the mesh arrays must agree in length with in-range
    /// triangle indices; otherwise StoreError and nothing is written. `bake.id` is ignored.
    std::int64_t add_bake(const Bake& bake, const std::function<void(double)>& progress = {});

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
