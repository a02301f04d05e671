// The host's parallel loop (core/parallel.hpp): every item runs exactly once whatever the thread
// count, the first exception comes back to the caller after every thread has stopped, and an
// empty loop runs nothing.
#include <atomic>
#include <chrono>
#include <stdexcept>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "core/parallel.hpp"

namespace amhv {
namespace {

TEST(ParallelFor, EveryItemRunsOnce) {
    for (unsigned threads : {0u, 1u, 2u, 7u}) {
        for (std::size_t count : {std::size_t(0), std::size_t(1), std::size_t(5), std::size_t(1000)}) {
            std::vector<std::atomic<int>> runs(count);
            parallel_for(count, [&](std::size_t i) { ++runs[i]; }, threads);
            for (std::size_t i = 0; i < count; ++i) EXPECT_EQ(runs[i].load(), 1) << "threads " << threads << " count " << count << " item " << i;
        }
    }
}

TEST(ParallelFor, AnExceptionReachesTheCaller) {
    for (unsigned threads : {1u, 2u, 4u}) {
        std::atomic<int> started{0};
        try {
            parallel_for(
                200,
                [&](std::size_t i) {
                    ++started;
                    if (i == 17) throw std::runtime_error("item 17");
                    std::this_thread::sleep_for(std::chrono::milliseconds(1));  // items long enough to see the stop
                },
                threads);
            ADD_FAILURE() << "no exception with " << threads << " threads";
        } catch (const std::runtime_error& e) {
            EXPECT_STREQ(e.what(), "item 17");
        }
        // Items after the failure stop being handed out (those already taken finish).
        EXPECT_LT(started.load(), 200) << threads;
        EXPECT_GE(started.load(), 18) << threads;
    }
}

}  // namespace
}  // namespace amhv
