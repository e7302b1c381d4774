// Stability suite: run a piece of work in a child process with a deadline,
// so that a test can assert "finishes in time" about code that might hang
// (a hung thread cannot be stopped; a child process can be killed).
#pragma once

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <functional>
#include <thread>

#include <gtest/gtest.h>

namespace filmgrain::stability {

/// Runs `work` in a forked child. Success if the child returns true within
/// `seconds`; failure (with the reason) if it returns false, crashes or is
/// still running at the deadline (it is then killed). Call it only from a
/// single-threaded test body (fork copies only the calling thread).
inline ::testing::AssertionResult finishes_within(double seconds, const std::function<bool()>& work)
{
    const pid_t pid = ::fork();
    if (pid < 0)
        return ::testing::AssertionFailure() << "fork failed";
    if (pid == 0) {
        bool ok = false;
        try {
            ok = work();
        } catch (...) {
            ok = false;
        }
        ::_exit(ok ? 0 : 1);
    }
    const auto start = std::chrono::steady_clock::now();
    for (;;) {
        int status = 0;
        const pid_t r = ::waitpid(pid, &status, WNOHANG);
        if (r == pid) {
            if (WIFEXITED(status) && WEXITSTATUS(status) == 0)
                return ::testing::AssertionSuccess();
            if (WIFEXITED(status))
                return ::testing::AssertionFailure() << "the work failed (exit status "
                                                     << WEXITSTATUS(status) << ")";
            return ::testing::AssertionFailure() << "the work crashed (signal "
                                                 << WTERMSIG(status) << ")";
        }
        const double elapsed
            = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        if (elapsed > seconds) {
            ::kill(pid, SIGKILL);
            ::waitpid(pid, &status, 0);
            return ::testing::AssertionFailure()
                   << "still running after " << seconds << " s: killed (a hang)";
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
}

}  // namespace filmgrain::stability
