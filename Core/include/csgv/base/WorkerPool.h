// SPDX-License-Identifier: MIT
/// @file WorkerPool.h
/// @brief Threads for work that repeats every frame. Between jobs they sleep: OpenMP's idle workers
/// spin for milliseconds after each parallel region, taking a core from whatever runs next (on a
/// two-core machine, half of a CPU Vulkan device's shader threads).
#ifndef CSGV_BASE_WORKERPOOL_H
#define CSGV_BASE_WORKERPOOL_H

#include <cstdint>
#include <functional>
#include <memory>

namespace csgv {

class WorkerPool {
public:
    /// `threads` workers in all, the calling thread included (0: omp_get_max_threads(), which
    /// follows OMP_NUM_THREADS).
    explicit WorkerPool(unsigned threads = 0);
    ~WorkerPool();
    WorkerPool(const WorkerPool&) = delete;
    WorkerPool& operator=(const WorkerPool&) = delete;

    /// Workers in all, the caller included: the range of `worker` below.
    unsigned size() const;

    /// Calls fn(i, worker) for every i in [0, n), indices handed out one at a time, and returns
    /// when all are done. The caller works too; with one item or one worker it works alone. Not
    /// reentrant. The first exception thrown by fn is rethrown here (later items still run).
    void parallelFor(uint64_t n, const std::function<void(uint64_t i, unsigned worker)>& fn);

private:
    struct Impl;
    std::unique_ptr<Impl> m_impl;
};

} // namespace csgv

#endif
