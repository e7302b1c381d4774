// The core's one parallel loop.
#include "parallel.h"

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

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
    std::atomic<int64_t> next { 0 }, done { 0 };
    std::mutex mutex;
    std::condition_variable wake;
    std::exception_ptr error;
    int running = workers;
    const auto work = [&](int worker) {
        try {
            for (int64_t i; !stop && (i = next++) < n;) {
                try {
                    body(worker, i);
                    ++done;
                } catch (const Stopped&) {
                    stop = true;
                }
            }
        } catch (...) {
            std::lock_guard<std::mutex> lock(mutex);
            if (!error)
                error = std::current_exception();
            stop = true;
        }
        std::lock_guard<std::mutex> lock(mutex);
        --running;
        wake.notify_all();
    };
    std::vector<std::thread> threads;
    const int first = poll ? 0 : 1;  // without poll, this thread is worker 0
    for (int w = first; w < workers; ++w)
        threads.emplace_back(work, w);
    if (poll) {
        std::unique_lock<std::mutex> lock(mutex);
        while (running > 0) {
            wake.wait_for(lock, std::chrono::milliseconds(100));
            if (running > 0) {
                lock.unlock();
                poll(done);
                lock.lock();
            }
        }
    } else {
        work(0);
    }
    for (auto& t : threads)
        t.join();
    if (error)
        std::rethrow_exception(error);
    return done;
}

}  // namespace filmgrain
