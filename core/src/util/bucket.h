// filmgrain: a counting sort of items into the rows they reach (the
// coverage kernels' and the dye clouds' row buckets).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace filmgrain {

/// Buckets `count` items by row: range(i, r0, r1) sets the rows [r0, r1]
/// (inclusive, inside [0, rows); empty when r1 < r0) that item i reaches,
/// and entry(i, r) makes the entry of item i in row r. On return the
/// entries of row r are entries[offsets[r]], ..., entries[offsets[r + 1] -
/// 1], in increasing i: the order is fixed by the items' order alone.
/// `fill` is scratch. range is called twice for each item.
template<typename T, typename Range, typename Entry>
void bucket_by_row(size_t count, int64_t rows, const Range& range, const Entry& entry,
                   std::vector<size_t>& offsets, std::vector<size_t>& fill,
                   std::vector<T>& entries)
{
    offsets.assign(static_cast<size_t>(rows + 1), 0);
    for (size_t i = 0; i < count; ++i) {
        int64_t r0, r1;
        range(i, r0, r1);
        for (int64_t r = r0; r <= r1; ++r)
            ++offsets[static_cast<size_t>(r + 1)];
    }
    for (size_t i = 1; i < offsets.size(); ++i)
        offsets[i] += offsets[i - 1];
    entries.resize(offsets.back());
    fill.assign(offsets.begin(), offsets.end() - 1);
    for (size_t i = 0; i < count; ++i) {
        int64_t r0, r1;
        range(i, r0, r1);
        for (int64_t r = r0; r <= r1; ++r)
            entries[fill[static_cast<size_t>(r)]++] = entry(i, r);
    }
}

}  // namespace filmgrain
