// filmgrain: the names of enumerations as the command line, stock files,
// Python, metadata and --stats spell them: one table an enumeration, read
// both ways (a value's name, the value of a name, the list for --help and
// errors). An enumeration E declares its table beside it and an overload
// `names_of(E)` returning it; name_of and parse_name then serve every one.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>

namespace filmgrain {

/// One value of an enumeration and its name.
template<typename E> struct Named {
    E value;
    const char* name;
};

/// The name of `value` in `table`; "unknown" for a value it lacks.
template<typename E, size_t N>
constexpr const char* name_in(const Named<E> (&table)[N], E value)
{
    for (const Named<E>& n : table)
        if (n.value == value)
            return n.name;
    return "unknown";
}

/// The value `name` names in `table`; false (out unchanged) for a name it
/// lacks.
template<typename E, size_t N>
bool value_in(const Named<E> (&table)[N], std::string_view name, E& out)
{
    for (const Named<E>& n : table)
        if (name == n.name) {
            out = n.value;
            return true;
        }
    return false;
}

/// The table's names in its order, each between `quote`s, joined by
/// `separator`: "auto|exact|fast", "'disc', 'ring', 'base'".
template<typename E, size_t N>
std::string names_in(const Named<E> (&table)[N], std::string_view separator,
                     std::string_view quote = "")
{
    std::string s;
    for (const Named<E>& n : table) {
        if (!s.empty())
            s += separator;
        s.append(quote).append(n.name).append(quote);
    }
    return s;
}

/// The name of an enumeration's value (names_of(E) found by
/// argument-dependent lookup): name_of(Engine::automatic) is "auto".
template<typename E> const char* name_of(E value) { return name_in(names_of(value), value); }

/// The value of `name` for out's enumeration; false (out unchanged) for a
/// name it lacks.
template<typename E> bool parse_name(std::string_view name, E& out)
{
    return value_in(names_of(out), name, out);
}

}  // namespace filmgrain
