// filmgrain: per-grain film simulation.
#pragma once

#include <sstream>
#include <string>
#include <utility>

namespace filmgrain {

/// Result of a fallible call. No exception crosses a filmgrain library
/// boundary: every entry point that can fail returns a Status whose message
/// names the offending field, its value and the rule it broke.
/// Thread safety: a value type; distinct objects are independent.
class Status {
public:
    /// Success.
    Status() = default;

    /// Failure with a human-readable message (never empty).
    static Status error(std::string message)
    {
        Status s;
        s.m_ok      = false;
        s.m_message = message.empty() ? std::string("unknown error")
                                      : std::move(message);
        return s;
    }

    /// Failure whose message is the concatenation of the arguments, streamed.
    template<typename... Args> static Status errorf(const Args&... args)
    {
        std::ostringstream out;
        out.precision(17);
        (out << ... << args);
        return error(out.str());
    }

    bool ok() const { return m_ok; }
    explicit operator bool() const { return m_ok; }
    const std::string& message() const { return m_message; }

private:
    bool m_ok = true;
    std::string m_message;
};

}  // namespace filmgrain
