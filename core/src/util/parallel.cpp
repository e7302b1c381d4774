// The core's one parallel loop, on oneTBB (Debian's libtbb-dev): a render
// inside a host application that already uses oneTBB shares its workers
// instead of starting its own.
#include "util/parallel.h"

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <exception>
#include <mutex>
#include <thread>

#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/parallel_for.h>
#include <oneapi/tbb/partitioner.h>
#include <oneapi/tbb/task_arena.h>

namespace filmgrain {

int parallel_workers(int64_t n, int nthreads)
{
    const int hw = std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
    const int64_t want = nthreads > 0 ? nthreads : hw;
    return static_cast<int>(std::clamp<int64_t>(want, 1, std::max<int64_t>(1, n)));
}

int64_t parallel_for(int64_t n, int nthreads, std::atomic<bool>& stop,
                     const std::function<void(int, int64_t)>& body,
                     const std::function<void(int64_t)>& poll)
{
    const int workers = parallel_workers(n, nthreads);
    std::atomic<int64_t> done { 0 };
    std::mutex mutex;
    std::exception_ptr error;
    const auto item = [&](int64_t i) {
        if (stop)
            return;
        // Slots of the arena below: [0, workers), the one it was entered
        // from first.
        const int worker = tbb::this_task_arena::current_thread_index();
        try {
            body(worker, i);
            ++done;
        } catch (const Stopped&) {
            stop = true;
        } catch (...) {
            std::lock_guard<std::mutex> lock(mutex);
            if (!error)
                error = std::current_exception();
            stop = true;
        }
    };
    // An arena of `workers` slots, one for the thread that enters it: each
    // item is a task of its own (simple_partitioner, grain 1), so the
    // threads balance unequal items as they finish them. Nested loops (a
    // plan inside a polled loop, table nodes inside a plan) get arenas of
    // their own: a thread waiting for one runs only that loop's items.
    tbb::task_arena arena(workers, 1);
    const auto run = [&] {
        arena.execute([&] {
            tbb::parallel_for(
                tbb::blocked_range<int64_t>(0, n, 1),
                [&](const tbb::blocked_range<int64_t>& r) {
                    for (int64_t i = r.begin(); i != r.end(); ++i)
                        item(i);
                },
                tbb::simple_partitioner());
        });
    };
    if (!poll) {
        run();
    } else {
        // The calling thread polls; a thread of its own enters the arena
        // (oneTBB has no timed wait), with the arena's other workers.
        std::condition_variable wake;
        bool finished = false;
        std::thread runner([&] {
            run();
            std::lock_guard<std::mutex> lock(mutex);
            finished = true;
            wake.notify_all();
        });
        std::unique_lock<std::mutex> lock(mutex);
        while (!finished) {
            wake.wait_for(lock, std::chrono::milliseconds(100));
            if (!finished) {
                lock.unlock();
                poll(done);
                lock.lock();
            }
        }
        lock.unlock();
        runner.join();
    }
    if (error)
        std::rethrow_exception(error);
    return done;
}

}  // namespace filmgrain
