#pragma once
// What every radiosity stage shares: the one error type for input that cannot be baked, and
// the one progress callback. bake.h states the stages' common principles.

#include <atomic>
#include <chrono>
#include <cstddef>
#include <functional>
#include <mutex>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>

namespace abrad::radiosity {

/// Settings or a scene that cannot be baked (an option out of range, a setting the chosen
/// mode does not use, a scene without lights...): the caller's bad input (exit status 2).
/// Thrown by every stage, the field error and the point queries; the message names the option
/// or the scene element. (The building blocks under the stages, Hemicube, shoot and
/// mesh_regions, throw std::invalid_argument, a std::logic_error, for a broken precondition:
/// the stages validate first, so that is a bug of the caller, like a failed ABRAD_CHECK.)
class InputError : public std::runtime_error {
  public:
    using std::runtime_error::runtime_error;
};

/// Progress of long work: a stage label and `done` of `total` units (`total` 0 when the end
/// is not known in advance, as for shots until convergence). Called from the thread that runs
/// the stage, or from a worker thread under the stage's lock; it must be cheap.
using ProgressFn = std::function<void(std::string_view stage, std::size_t done, std::size_t total)>;

/// Progress of one step's parallel work: worker threads add what they finished, and whichever
/// finds the reporter free calls the ProgressFn (serialised, at most twice a second, and once
/// at the start and the end), so a long step reports work done out of work to do.
class ParallelProgress {
  public:
    ParallelProgress(const ProgressFn& progress, std::string label, std::size_t total)
        : m_progress(progress), m_label(std::move(label)), m_total(total) {
        if (m_progress) m_progress(m_label, 0, m_total);
    }
    ParallelProgress(const ParallelProgress&) = delete;
    ParallelProgress& operator=(const ParallelProgress&) = delete;
    ~ParallelProgress() {
        if (m_progress) m_progress(m_label, m_done.load(), m_total);
    }

    /// Adds `n` finished units; thread-safe.
    void add(std::size_t n) {
        const std::size_t done = m_done += n;
        if (!m_progress) return;
        const std::unique_lock lock(m_mutex, std::try_to_lock);
        if (!lock.owns_lock()) return;
        const auto now = std::chrono::steady_clock::now();
        if (now - m_last < std::chrono::milliseconds(500)) return;
        m_last = now;
        m_progress(m_label, done, m_total);
    }

  private:
    const ProgressFn& m_progress;
    std::string m_label;
    std::size_t m_total;
    std::atomic<std::size_t> m_done{0};
    std::mutex m_mutex;
    std::chrono::steady_clock::time_point m_last = std::chrono::steady_clock::now();
};

}  // namespace abrad::radiosity
