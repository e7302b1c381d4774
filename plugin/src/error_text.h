// filmgrain CLI: OpenImageIO's error text as a message part.
#pragma once

#include <string>

namespace filmgrain::cli {

/// `s` without the newlines and spaces OpenImageIO ends its errors with.
inline std::string trim(std::string s)
{
    while (!s.empty() && (s.back() == '\n' || s.back() == ' '))
        s.pop_back();
    return s;
}

}  // namespace filmgrain::cli
