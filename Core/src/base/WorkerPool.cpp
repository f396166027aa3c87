// SPDX-License-Identifier: MIT
#include "csgv/base/WorkerPool.h"

#include <omp.h>

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace csgv {

struct WorkerPool::Impl {
    std::mutex mutex;
    std::condition_variable wake, done;
    std::vector<std::thread> threads;
    const std::function<void(uint64_t, unsigned)>* fn = nullptr;
    std::atomic<uint64_t> next{0};
    uint64_t count = 0;
    uint64_t generation = 0; // a new job for the workers each time it grows
    unsigned busy = 0;       // workers still on the current job
    bool stop = false;
    std::exception_ptr error;

    /// Takes items of the current job until none is left.
    void work(unsigned worker) {
        for (uint64_t i = next.fetch_add(1); i < count; i = next.fetch_add(1)) {
            try {
                (*fn)(i, worker);
            } catch (...) {
                std::lock_guard<std::mutex> lock(mutex);
                if (!error) error = std::current_exception();
            }
        }
    }

    void run(unsigned worker) {
        uint64_t seen = 0;
        std::unique_lock<std::mutex> lock(mutex);
        for (;;) {
            wake.wait(lock, [&] { return stop || generation != seen; });
            if (stop) return;
            seen = generation;
            lock.unlock();
            work(worker);
            lock.lock();
            if (--busy == 0) done.notify_one();
        }
    }
};

WorkerPool::WorkerPool(unsigned threads) : m_impl(new Impl) {
    const unsigned n = threads > 0 ? threads : unsigned(std::max(1, omp_get_max_threads()));
    for (unsigned w = 1; w < n; ++w) m_impl->threads.emplace_back([this, w] { m_impl->run(w); });
}

WorkerPool::~WorkerPool() {
    {
        std::lock_guard<std::mutex> lock(m_impl->mutex);
        m_impl->stop = true;
    }
    m_impl->wake.notify_all();
    for (std::thread& t : m_impl->threads) t.join();
}

unsigned WorkerPool::size() const { return unsigned(m_impl->threads.size()) + 1; }

void WorkerPool::parallelFor(uint64_t n, const std::function<void(uint64_t, unsigned)>& fn) {
    Impl& im = *m_impl;
    if (n == 0) return;
    im.fn = &fn;
    im.count = n;
    im.next = 0;
    im.error = nullptr;
    const bool alone = n == 1 || im.threads.empty();
    if (!alone) {
        std::lock_guard<std::mutex> lock(im.mutex);
        im.busy = unsigned(im.threads.size());
        ++im.generation;
    }
    if (!alone) im.wake.notify_all();
    im.work(0);
    if (!alone) {
        std::unique_lock<std::mutex> lock(im.mutex);
        im.done.wait(lock, [&] { return im.busy == 0; });
    }
    im.fn = nullptr;
    if (im.error) std::rethrow_exception(im.error);
}

} // namespace csgv
