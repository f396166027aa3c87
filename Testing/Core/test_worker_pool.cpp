// SPDX-License-Identifier: MIT
#include "csgv/base/WorkerPool.h"

#include <gtest/gtest.h>

#include <atomic>
#include <stdexcept>
#include <vector>

namespace {

TEST(WorkerPool, EveryIndexOnceOnAValidWorker) {
    csgv::WorkerPool pool(3);
    ASSERT_EQ(pool.size(), 3u);
    for (uint64_t n : {0ull, 1ull, 2ull, 7ull, 1000ull}) { // jobs of every size, one pool
        std::vector<std::atomic<int>> hits(n);
        std::atomic<unsigned> badWorker{0};
        pool.parallelFor(n, [&](uint64_t i, unsigned worker) {
            hits[i].fetch_add(1);
            if (worker >= pool.size()) badWorker.fetch_add(1);
        });
        for (uint64_t i = 0; i < n; ++i) ASSERT_EQ(hits[i].load(), 1) << "n " << n << " index " << i;
        EXPECT_EQ(badWorker.load(), 0u);
    }
}

TEST(WorkerPool, WorkersShareTheJob) {
    csgv::WorkerPool pool(2);
    std::atomic<int> seen[2] = {{0}, {0}};
    // Items that each wait for the other worker to have started one: done only if both work.
    pool.parallelFor(2, [&](uint64_t, unsigned worker) {
        seen[worker].fetch_add(1);
        while (seen[0].load() == 0 || seen[1].load() == 0) {
        }
    });
    EXPECT_EQ(seen[0].load(), 1);
    EXPECT_EQ(seen[1].load(), 1);
}

TEST(WorkerPool, FirstExceptionReachesTheCallerAndThePoolGoesOn) {
    csgv::WorkerPool pool(2);
    std::atomic<int> ran{0};
    EXPECT_THROW(pool.parallelFor(50, [&](uint64_t i, unsigned) {
        ran.fetch_add(1);
        if (i == 10) throw std::runtime_error("item 10");
    }), std::runtime_error);
    EXPECT_EQ(ran.load(), 50); // the other items still ran
    std::atomic<int> again{0};
    pool.parallelFor(20, [&](uint64_t, unsigned) { again.fetch_add(1); });
    EXPECT_EQ(again.load(), 20);
}

TEST(WorkerPool, OneWorkerRunsOnTheCaller) {
    csgv::WorkerPool pool(1);
    EXPECT_EQ(pool.size(), 1u);
    uint64_t sum = 0; // not atomic: only the caller may touch it
    pool.parallelFor(100, [&](uint64_t i, unsigned worker) {
        EXPECT_EQ(worker, 0u);
        sum += i;
    });
    EXPECT_EQ(sum, 4950u);
}

} // namespace
