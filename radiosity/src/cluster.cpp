// The ranks of a distributed bake: the only translation unit that includes mpi.h
// (ABRAD_HAVE_MPI, set by the ABRAD_MPI build option). Without MPI a Cluster is this process
// alone, and joining a job fails with a message.

#include "abrad/radiosity/cluster.h"

#include <unistd.h>

#include <algorithm>
#include <climits>
#include <csignal>
#include <cstdlib>
#include <numeric>
#include <stdexcept>

#ifdef ABRAD_HAVE_MPI
#include <mpi.h>
#endif

namespace abrad::radiosity {

namespace {

// The launchers' variables that give the number of ranks: Open MPI's mpirun, a PMI-1/2
// launcher (srun --mpi=pmi2, MPICH's hydra), srun with PMIx (its rank variable and the step's
// task count).
int launched_size() {
    for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE"})
        if (const char* v = std::getenv(name)) return std::atoi(v);
    if (std::getenv("PMIX_RANK"))
        if (const char* v = std::getenv("SLURM_STEP_NUM_TASKS")) return std::atoi(v);
    return 1;
}

#ifdef ABRAD_HAVE_MPI
// What rank 0 writes when the launcher terminates it. A signal handler sees only static
// storage: this is the one piece of process-wide state, set once by Cluster::join.
char g_on_terminate[512];
std::size_t g_on_terminate_size = 0;

extern "C" void on_sigterm(int) {
    [[maybe_unused]] const ssize_t n = ::write(STDERR_FILENO, g_on_terminate, g_on_terminate_size);
    ::_exit(1);
}

void check(int code, const char* call, const char* stage) {
    if (code == MPI_SUCCESS) return;
    char text[MPI_MAX_ERROR_STRING];
    int length = 0;
    MPI_Error_string(code, text, &length);
    throw std::runtime_error(std::string(call) + " failed in the " + stage +
                             " stage: " + std::string(text, static_cast<std::size_t>(length)));
}
#endif

}  // namespace

Cluster::Cluster(Cluster&& other) noexcept
    : m_rank(other.m_rank),
      m_size(other.m_size),
      m_joined(std::exchange(other.m_joined, false)),
      m_kill_rank(other.m_kill_rank),
      m_sent(std::move(other.m_sent)),
      m_sent_all(std::move(other.m_sent_all)) {}

Cluster::~Cluster() {
#ifdef ABRAD_HAVE_MPI
    if (m_joined) MPI_Finalize();
#endif
}

bool Cluster::launched_as_ranks() { return launched_size() > 1; }

Cluster Cluster::join(const std::string& on_terminate) {
#ifdef ABRAD_HAVE_MPI
    int provided = 0;
    if (MPI_Init_thread(nullptr, nullptr, MPI_THREAD_FUNNELED, &provided) != MPI_SUCCESS)
        throw std::runtime_error("MPI_Init_thread failed");
    Cluster c;
    c.m_joined = true;
    MPI_Comm_rank(MPI_COMM_WORLD, &c.m_rank);
    MPI_Comm_size(MPI_COMM_WORLD, &c.m_size);
    MPI_Comm_set_errhandler(MPI_COMM_WORLD, MPI_ERRORS_RETURN);
    // Test hook: the rank named here kills itself (SIGKILL) at its first collective, as a
    // node lost mid-bake would (tests/tools/mpi_bake_test.sh)
    if (const char* k = std::getenv("ABRAD_TEST_KILL_RANK")) c.m_kill_rank = std::atoi(k);
    if (c.m_rank == 0) {
        g_on_terminate_size = std::min(on_terminate.size(), sizeof g_on_terminate);
        std::memcpy(g_on_terminate, on_terminate.data(), g_on_terminate_size);
        struct sigaction action {};
        action.sa_handler = on_sigterm;
        sigemptyset(&action.sa_mask);
        sigaction(SIGTERM, &action, nullptr);
    }
    return c;
#else
    (void)on_terminate;
    throw std::runtime_error(
        "launched as one of " + std::to_string(launched_size()) +
        " ranks, but this abrad was built without MPI (ABRAD_MPI=OFF): each rank would bake and "
        "store alone. Rebuild with Open MPI (libopenmpi-dev), or run it without mpirun");
#endif
}

std::vector<int> owners_by_cost(std::span<const double> cost, int ranks) {
    std::vector<std::uint32_t> order(cost.size());
    std::iota(order.begin(), order.end(), 0u);
    std::stable_sort(order.begin(), order.end(),
                     [&](std::uint32_t a, std::uint32_t b) { return cost[a] > cost[b]; });
    std::vector<double> load(static_cast<std::size_t>(std::max(ranks, 1)), 0.0);
    std::vector<int> owner(cost.size(), 0);
    for (const std::uint32_t item : order) {
        const auto least = std::min_element(load.begin(), load.end()) - load.begin();
        load[static_cast<std::size_t>(least)] += cost[item];
        owner[item] = static_cast<int>(least);
    }
    return owner;
}

std::vector<std::uint32_t> Cluster::share(std::span<const double> cost) const {
    const std::vector<int> owner = owners_by_cost(cost, m_size);
    std::vector<std::uint32_t> mine;
    for (std::size_t i = 0; i < owner.size(); ++i)
        if (owner[i] == m_rank) mine.push_back(static_cast<std::uint32_t>(i));
    return mine;
}

void Cluster::count(const char* stage, std::uint64_t bytes) {
    for (auto& [name, total] : m_sent)
        if (name == stage) {
            total += bytes;
            return;
        }
    m_sent.emplace_back(stage, bytes);
}

void Cluster::before_collective() const {
    if (m_kill_rank == m_rank) std::raise(SIGKILL);
}

void Cluster::sum(std::span<std::int64_t> values, const char* stage) {
    if (m_size == 1) return;
    before_collective();
    count(stage, values.size_bytes());
#ifdef ABRAD_HAVE_MPI
    constexpr std::size_t kChunk = std::size_t{1} << 26;  // counts are int
    for (std::size_t at = 0; at < values.size(); at += kChunk) {
        const int n = static_cast<int>(std::min(kChunk, values.size() - at));
        check(MPI_Allreduce(MPI_IN_PLACE, values.data() + at, n, MPI_INT64_T, MPI_SUM,
                            MPI_COMM_WORLD),
              "MPI_Allreduce", stage);
    }
#endif
}

double Cluster::max(double value, const char* stage) {
    if (m_size == 1) return value;
    before_collective();
    count(stage, sizeof value);
#ifdef ABRAD_HAVE_MPI
    check(MPI_Allreduce(MPI_IN_PLACE, &value, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD),
          "MPI_Allreduce", stage);
#endif
    return value;
}

std::vector<std::byte> Cluster::all_gather(std::span<const std::byte> mine, const char* stage,
                                           std::vector<std::size_t>* offsets) {
    if (m_size == 1) {
        if (offsets) *offsets = {0, mine.size()};
        return {mine.begin(), mine.end()};
    }
    before_collective();
    count(stage, mine.size() + sizeof(std::uint64_t));
    std::vector<std::byte> all;
#ifdef ABRAD_HAVE_MPI
    // Each rank's size first, then the parts (MPI counts are int: at most 2 GiB a rank)
    std::uint64_t size = mine.size();
    std::vector<std::uint64_t> sizes(static_cast<std::size_t>(m_size));
    check(MPI_Allgather(&size, 1, MPI_UINT64_T, sizes.data(), 1, MPI_UINT64_T, MPI_COMM_WORLD),
          "MPI_Allgather", stage);
    std::vector<int> counts(sizes.size()), starts(sizes.size());
    std::size_t total = 0;
    for (std::size_t r = 0; r < sizes.size(); ++r) {
        if (sizes[r] > static_cast<std::uint64_t>(INT_MAX) || total > INT_MAX - sizes[r])
            throw std::runtime_error(std::string("the ") + stage +
                                     " stage's exchange is larger than 2 GiB (rank " +
                                     std::to_string(r) + ")");
        counts[r] = static_cast<int>(sizes[r]);
        starts[r] = static_cast<int>(total);
        total += sizes[r];
    }
    all.resize(total);
    check(MPI_Allgatherv(mine.data(), static_cast<int>(mine.size()), MPI_BYTE, all.data(),
                         counts.data(), starts.data(), MPI_BYTE, MPI_COMM_WORLD),
          "MPI_Allgatherv", stage);
    if (offsets) {
        offsets->assign(starts.begin(), starts.end());
        offsets->push_back(total);
    }
#endif
    return all;
}

void Cluster::add_up_sent() {
    // Every rank made the same collectives in the same order: the same stage names
    std::vector<std::int64_t> bytes;
    for (const auto& [stage, n] : m_sent) bytes.push_back(static_cast<std::int64_t>(n));
    m_sent_all = m_sent;
    if (m_size == 1) return;
    before_collective();
#ifdef ABRAD_HAVE_MPI
    check(MPI_Allreduce(MPI_IN_PLACE, bytes.data(), static_cast<int>(bytes.size()), MPI_INT64_T,
                        MPI_SUM, MPI_COMM_WORLD),
          "MPI_Allreduce", "report");
#endif
    for (std::size_t i = 0; i < bytes.size(); ++i)
        m_sent_all[i].second = static_cast<std::uint64_t>(bytes[i]);
}

void Cluster::abort(int status) const {
#ifdef ABRAD_HAVE_MPI
    if (m_joined) MPI_Abort(MPI_COMM_WORLD, status);
#endif
    std::exit(status);
}

}  // namespace abrad::radiosity
