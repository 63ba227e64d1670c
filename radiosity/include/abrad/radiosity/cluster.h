#pragma once
// The ranks of a bake distributed over MPI (docs/design.md#the-distributed-bake). The bake's
// stages split their work lists with `share` and combine what each rank made with the
// collectives below; only radiosity/src/cluster.cpp includes mpi.h (it is compiled without
// MPI when the build has none: ABRAD_MPI=OFF).
//
// A Cluster made by `Cluster()` is this process alone: `share` gives it every item and the
// collectives return their input, so a stage runs the same code with or without MPI.

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>
#include <string>
#include <utility>
#include <vector>

namespace abrad::radiosity {

/// The MPI job this process is a rank of, or this process alone.
class Cluster {
  public:
    /// This process alone (no MPI call).
    Cluster() = default;
    Cluster(const Cluster&) = delete;
    Cluster& operator=(const Cluster&) = delete;
    Cluster(Cluster&& other) noexcept;
    Cluster& operator=(Cluster&&) = delete;
    /// Leaves the MPI job (MPI_Finalize) when this object joined it.
    ~Cluster();

    /// True when a launcher started this process as one rank of several: mpirun (Open MPI's
    /// OMPI_COMM_WORLD_SIZE), srun or a PMI launcher (PMI_SIZE, PMIX_SIZE... see cluster.cpp).
    /// Reads the environment only; calls no MPI function.
    static bool launched_as_ranks();

    /// Joins the MPI job this process was launched in (MPI_Init_thread, funneled: the thread
    /// that joins makes every later call), with MPI_ERRORS_RETURN on its communicator.
    /// `on_terminate` is written to stderr by rank 0 when the launcher terminates it (SIGTERM:
    /// mpirun does so when another rank died), before it exits with status 1. Throws
    /// std::runtime_error when the build has no MPI or MPI cannot start.
    static Cluster join(const std::string& on_terminate);

    int rank() const { return m_rank; }
    int size() const { return m_size; }

    /// The items (indices into `cost`) this rank works on, ascending, by owners_by_cost. Every
    /// rank computes the same split from the same costs; no communication.
    std::vector<std::uint32_t> share(std::span<const double> cost) const;

    /// Element-wise sum over the ranks of `values`, in place on every rank (MPI_Allreduce of
    /// 64-bit integers: exact, so the sum does not depend on the ranks' order or count).
    void sum(std::span<std::int64_t> values, const char* stage);

    /// The largest of each rank's `value`, on every rank.
    double max(double value, const char* stage);

    /// Every rank's `mine`, concatenated in rank order, on every rank; `offsets` (when given)
    /// receives where each rank's part starts (size()+1 entries).
    std::vector<std::byte> all_gather(std::span<const std::byte> mine, const char* stage,
                                      std::vector<std::size_t>* offsets = nullptr);

    /// Bytes this rank put into the collectives so far, per stage name in order of first use
    /// (payload: what the rank contributes, not what the network carried).
    const std::vector<std::pair<std::string, std::uint64_t>>& sent() const { return m_sent; }

    /// Adds up `sent()` over the ranks into `sent_by_all()` (a collective: every rank calls it
    /// at the same point, once its share of the bake is done).
    void add_up_sent();

    /// The bytes all the ranks put into the collectives, per stage (after add_up_sent).
    const std::vector<std::pair<std::string, std::uint64_t>>& sent_by_all() const {
        return m_sent_all;
    }

    /// Ends the whole job now with `status` (MPI_Abort); for a rank that failed while the
    /// others may wait for it in a collective.
    [[noreturn]] void abort(int status) const;

  private:
    void count(const char* stage, std::uint64_t bytes);
    void before_collective() const;

    int m_rank = 0;
    int m_size = 1;
    bool m_joined = false;
    int m_kill_rank = -1;  // test hook: ABRAD_TEST_KILL_RANK (cluster.cpp)
    std::vector<std::pair<std::string, std::uint64_t>> m_sent, m_sent_all;
};

/// The rank each item goes to: the items sorted by decreasing cost (ties by index) go one by
/// one to the rank with the least cost so far (ties to the lowest rank), the
/// longest-processing-time rule (its largest load is at most 4/3 of the best split's).
std::vector<int> owners_by_cost(std::span<const double> cost, int ranks);

/// Trivially copyable values as bytes, for Cluster::all_gather.
template <typename T>
std::span<const std::byte> as_bytes_of(const std::vector<T>& v) {
    return std::as_bytes(std::span<const T>(v));
}

/// Bytes made by all_gather back into values of T (the size must be a multiple of T's).
template <typename T>
std::vector<T> values_of(std::span<const std::byte> bytes) {
    std::vector<T> out(bytes.size() / sizeof(T));
    if (!out.empty()) std::memcpy(out.data(), bytes.data(), out.size() * sizeof(T));
    return out;
}

}  // namespace abrad::radiosity
