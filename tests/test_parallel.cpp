// The host's parallel loop (core/parallel.hpp): every item runs exactly once whatever the thread
// count, the first exception comes back to the caller after every thread has stopped, and an
// empty loop runs nothing; copy_on_threads copies every byte and no more.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "src/core/parallel.hpp"

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

TEST(ParallelFor, CopyOnThreadsCopiesEveryByteAndNoMore) {
    // Sizes around the 4 MiB pieces: none, less than one, exactly two, and a ragged last piece.
    for (std::size_t bytes : {std::size_t(0), std::size_t(13), std::size_t(8) << 20, (std::size_t(12) << 20) + 17}) {
        std::vector<unsigned char> from(bytes), to(bytes + 64, 0xAB);
        for (std::size_t i = 0; i < bytes; ++i) from[i] = static_cast<unsigned char>((i * 2654435761u) >> 13);
        copy_on_threads(to.data(), from.data(), bytes);
        EXPECT_TRUE(std::equal(from.begin(), from.end(), to.begin())) << bytes;
        EXPECT_TRUE(std::all_of(to.begin() + std::ptrdiff_t(bytes), to.end(), [](unsigned char c) { return c == 0xAB; })) << bytes;
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

// Of several failing items, the lowest one's exception is the one reported, whichever threw first.
TEST(ParallelFor, TheLowestFailingItemIsReported) {
    for (unsigned threads : {2u, 4u}) {
        try {
            parallel_for(
                64,
                [&](std::size_t i) {
                    if (i == 17) {
                        std::this_thread::sleep_for(std::chrono::milliseconds(50));  // throws after the items above it
                        throw std::runtime_error("item 17");
                    }
                    if (i > 17) throw std::runtime_error("item " + std::to_string(i));
                },
                threads);
            ADD_FAILURE() << "no exception with " << threads << " threads";
        } catch (const std::runtime_error& e) {
            EXPECT_STREQ(e.what(), "item 17") << threads;
        }
    }
}

// The helper threads serve one loop at a time: a loop inside a loop, and loops started from several
// threads at once, run on threads of their own, every item once.
TEST(ParallelFor, NestedAndConcurrentLoopsRunEveryItemOnce) {
    std::vector<std::atomic<int>> runs(64 * 50);
    parallel_for(64, [&](std::size_t outer) { parallel_for(50, [&](std::size_t inner) { ++runs[outer * 50 + inner]; }, 2); }, 2);
    for (std::size_t i = 0; i < runs.size(); ++i) ASSERT_EQ(runs[i].load(), 1) << "nested item " << i;
    std::vector<std::atomic<int>> concurrent(4 * 2000);
    {
        std::vector<std::jthread> callers;
        for (std::size_t caller = 0; caller < 4; ++caller)
            callers.emplace_back([&, caller] {
                for (int round = 0; round < 20; ++round)
                    parallel_for(100, [&](std::size_t i) { ++concurrent[caller * 2000 + std::size_t(round) * 100 + i]; }, 2);
            });
    }
    for (std::size_t i = 0; i < concurrent.size(); ++i) ASSERT_EQ(concurrent[i].load(), 1) << "concurrent item " << i;
}

}  // namespace
}  // namespace amhv
