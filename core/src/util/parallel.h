// filmgrain: the core's one parallel loop (render tiles, table nodes).
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>

namespace filmgrain {

/// Thrown by a body that saw its loop's stop flag, to leave its item early
/// (parallel_for treats it as a stop, not an error).
struct Stopped {};

/// Calls body(worker, i) for every i in [0, n), on at most `nthreads`
/// threads (0: all hardware threads; never more than n) of a oneTBB arena,
/// each item a task of its own, in no set order; `worker` in [0, workers)
/// indexes per-worker scratch (no two items run on one worker at once).
/// Once `stop` is set no further item starts, and bodies may throw Stopped
/// to leave theirs early. The first exception a body throws sets `stop`
/// and is rethrown here after every item has finished. With `poll`, the
/// calling thread does not work but calls it about every 100 ms until the
/// loop ends (progress and cancellation: poll may set `stop`); without, it
/// is one of the workers. Returns the number of items that finished.
int64_t parallel_for(int64_t n, int nthreads, std::atomic<bool>& stop,
                     const std::function<void(int worker, int64_t i)>& body,
                     const std::function<void(int64_t done)>& poll = {});

/// Whether an optional cancel flag (set by another thread: a cancelled
/// render's planning) is set.
inline bool cancel_requested(const std::atomic<bool>* cancel) { return cancel && *cancel; }

/// Workers parallel_for(n, nthreads, ...) uses: the worker indices it
/// passes are below this.
int parallel_workers(int64_t n, int nthreads);

}  // namespace filmgrain
