// filmgrain CLI: messages and progress on stderr, and interruption.
#pragma once

#include <chrono>
#include <csignal>
#include <iomanip>
#include <iostream>
#include <optional>
#include <sstream>
#include <string>

#include "cli_args.h"
#include "filmgrain/status.h"

namespace filmgrain::cli {

using Clock = std::chrono::steady_clock;

inline double seconds_since(Clock::time_point t)
{
    return std::chrono::duration<double>(Clock::now() - t).count();
}

// Interruption: SIGINT/SIGTERM/SIGHUP only set a flag. The render polls it
// through the progress callback (and cancels), the other stages check it
// between steps; the outputs' temporary files are then removed and nothing
// is renamed into place.

/// Installs the handlers that set the flag.
void install_signal_handlers();
/// Whether a signal arrived, and which (0: none).
bool interrupted();
int interrupt_signal();

// Messages: everything goes to stderr; -q keeps only errors.

class Console {
public:
    /// Progress is shown on a terminal once a run has taken a second, and
    /// from the start with --progress (`forced`); never with -q.
    Console(bool quiet, bool terminal, bool forced = false)
        : m_quiet(quiet)
        , m_show_progress((terminal || forced) && !quiet)
        , m_delay_s(forced ? 0.0 : 1.0)
        , m_start(Clock::now())
    {
    }

    void info(const std::string& msg) const
    {
        if (m_quiet)
            return;
        end_progress();
        std::cerr << "filmgrain: " << msg << std::endl;
    }
    void warning(const std::string& msg) const
    {
        if (m_quiet)
            return;
        end_progress();
        std::cerr << "filmgrain: warning: " << msg << std::endl;
    }
    int fail(const std::string& msg) const
    {
        end_progress();
        std::cerr << "filmgrain: error: " << msg << std::endl;
        return kExitError;
    }
    int fail(const Status& s) const { return fail(s.message()); }
    int fail_interrupted(const std::string& what) const
    {
        const int sig = interrupt_signal();
        const char* name = sig == SIGINT ? "SIGINT" : sig == SIGTERM ? "SIGTERM"
                                                    : sig == SIGHUP  ? "SIGHUP"
                                                                     : "a signal";
        fail(std::string("interrupted by ") + name + ": " + what);
        return kExitSignalBase + sig;
    }

    /// The sequence position shown by progress(): frame `index` (0-based)
    /// of `count`, numbered `number`; count 0: a single image.
    void set_frame(size_t index, size_t count, std::optional<int> number) const
    {
        m_index  = index;
        m_count  = count;
        m_number = number;
    }

    /// A single updating line:
    /// "filmgrain: frame 3/100 (1003)  42%  elapsed 0:12  left ~4:10".
    /// The fraction is the current image's; elapsed and left are the run's.
    void progress(double fraction) const
    {
        const double elapsed = seconds_since(m_start);
        if (!m_show_progress || elapsed < m_delay_s)
            return;
        const int percent = static_cast<int>(fraction * 100.0);
        if (percent == m_percent && elapsed - m_shown_at < 1.0)
            return;
        m_percent  = percent;
        m_shown_at = elapsed;
        std::ostringstream line;
        line << "\rfilmgrain: ";
        if (m_count > 0)
            line << "frame " << m_index + 1 << "/" << m_count << " (" << *m_number << ") ";
        else
            line << "simulating ";
        line << std::setw(3) << percent << "%  elapsed " << clock_text(elapsed);
        const double done = m_count > 0 ? (static_cast<double>(m_index) + fraction)
                                              / static_cast<double>(m_count)
                                        : fraction;
        if (done > 0.01)
            line << "  left ~" << clock_text(elapsed * (1.0 - done) / done);
        line << "   ";
        std::cerr << line.str() << std::flush;
        m_line_open = true;
    }
    void end_progress() const
    {
        if (m_line_open)
            std::cerr << std::endl;
        m_line_open = false;
        m_percent   = -1;
    }

private:
    static std::string clock_text(double seconds)
    {
        const long s = static_cast<long>(seconds + 0.5);
        std::ostringstream out;
        if (s >= 3600)
            out << s / 3600 << ":" << std::setw(2) << std::setfill('0') << s / 60 % 60;
        else
            out << s / 60;
        out << ":" << std::setw(2) << std::setfill('0') << s % 60;
        return out.str();
    }

    bool m_quiet;
    bool m_show_progress;
    double m_delay_s;
    Clock::time_point m_start;
    mutable size_t m_index = 0, m_count = 0;
    mutable std::optional<int> m_number;
    mutable int m_percent    = -1;
    mutable double m_shown_at = 0.0;
    mutable bool m_line_open = false;
};

}  // namespace filmgrain::cli
