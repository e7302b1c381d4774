// filmgrain: plain values appended to and read from a byte string, for the
// on-disk caches (cache_file.h). This machine's representation: a cache
// file is read only by a build with the same code id (compiler, flags and
// processor included), never shipped.
#pragma once

#include <cstdint>
#include <cstring>
#include <string>
#include <type_traits>
#include <vector>

namespace filmgrain {

struct Bytes {
    std::string data;
    size_t at = 0;
    bool ok   = true;

    template<typename T> void put(const T& v)
    {
        static_assert(std::is_trivially_copyable_v<T>);
        data.append(reinterpret_cast<const char*>(&v), sizeof v);
    }
    template<typename T> void put(const std::vector<T>& v)
    {
        put(static_cast<uint64_t>(v.size()));
        for (const T& x : v)
            put(x);
    }
    /// The next value; on a short string `ok` turns false and T{} comes back.
    template<typename T> T get()
    {
        T v {};
        if (!ok || data.size() - at < sizeof v) {
            ok = false;
            return v;
        }
        std::memcpy(&v, data.data() + at, sizeof v);
        at += sizeof v;
        return v;
    }
    template<typename T> std::vector<T> get_vector()
    {
        const uint64_t n = get<uint64_t>();
        if (!ok || n > (data.size() - at) / sizeof(T)) {
            ok = false;
            return {};
        }
        std::vector<T> v(static_cast<size_t>(n));
        for (T& x : v)
            x = get<T>();
        return v;
    }
    /// Whether every byte was read and none was missing.
    bool done() const { return ok && at == data.size(); }
};

}  // namespace filmgrain
