// filmgrain: what a process keeps between renders (P(develop | N) tables,
// pixel statistics): the last few values by key, shared and immutable.
#pragma once

#include <cstddef>
#include <memory>
#include <mutex>
#include <utility>
#include <vector>

namespace filmgrain {

/// The last `capacity` values put in, by key (compared with ==), oldest
/// dropped first. Thread safety: every member may be called concurrently;
/// two threads that miss the same key both build it and both put it (the
/// same value: harmless).
template<typename Key, typename Value> class ProcessCache {
public:
    explicit ProcessCache(size_t capacity) : m_capacity(capacity) {}

    /// The value kept for `key`, or null.
    std::shared_ptr<const Value> find(const Key& key) const
    {
        std::lock_guard<std::mutex> lock(m_mutex);
        for (const auto& [k, v] : m_entries)
            if (k == key)
                return v;
        return nullptr;
    }

    void put(Key key, std::shared_ptr<const Value> value)
    {
        std::lock_guard<std::mutex> lock(m_mutex);
        if (m_entries.size() >= m_capacity)
            m_entries.erase(m_entries.begin());
        m_entries.emplace_back(std::move(key), std::move(value));
    }

    /// Empties the cache; returns how many values it held.
    size_t clear()
    {
        std::lock_guard<std::mutex> lock(m_mutex);
        const size_t n = m_entries.size();
        m_entries.clear();
        return n;
    }

private:
    mutable std::mutex m_mutex;
    size_t m_capacity;
    std::vector<std::pair<Key, std::shared_ptr<const Value>>> m_entries;
};

}  // namespace filmgrain
