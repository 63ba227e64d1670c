#pragma once
// A full disk on demand, for root as for anyone: while a FileSizeLimit lives, this process
// (and every child it starts: rlimits and ignored signals are inherited across fork and exec)
// cannot write a regular file past `bytes`; such a write fails with EFBIG ("File too large")
// instead of raising SIGXFSZ. SQLite reports it as SQLITE_FULL. Files already larger stay
// readable; pipes and terminals are not limited.

#include <gtest/gtest.h>
#include <sys/resource.h>

#include <csignal>

namespace abrad::testing {

class FileSizeLimit {
  public:
    explicit FileSizeLimit(rlim_t bytes) {
        EXPECT_EQ(getrlimit(RLIMIT_FSIZE, &m_old), 0);
        m_old_handler = std::signal(SIGXFSZ, SIG_IGN);
        rlimit limit = m_old;
        limit.rlim_cur = bytes;
        EXPECT_EQ(setrlimit(RLIMIT_FSIZE, &limit), 0);
    }
    ~FileSizeLimit() {
        setrlimit(RLIMIT_FSIZE, &m_old);
        std::signal(SIGXFSZ, m_old_handler);
    }
    FileSizeLimit(const FileSizeLimit&) = delete;
    FileSizeLimit& operator=(const FileSizeLimit&) = delete;

  private:
    rlimit m_old{};
    void (*m_old_handler)(int) = SIG_DFL;
};

}  // namespace abrad::testing
