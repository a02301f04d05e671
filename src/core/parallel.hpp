#pragma once
// Host work split over all cores, for the loops the host runs while the device waits (planning,
// cutting slice runs, formatting output). Helper threads are started once and wait asleep between
// loops, so none spins on the cores afterwards: on a CPU Vulkan driver (lavapipe) the device's own
// threads need them. (OpenMP's idle workers spin after each loop and slowed the sweep's dispatches
// by up to half; starting threads for every loop cost about 45 us a loop.)
#include <cstddef>
#include <functional>

namespace amhv {

// Calls work(i) for every i in [0, count), in any order, on up to `threads` threads (0: one per
// core); the calling thread takes part. Items are handed out one at a time, so uneven items
// balance. Once a call throws, no further items are handed out; after every thread has stopped, the
// exception of the lowest item that threw is rethrown here (the same one on every run).
void parallel_for(std::size_t count, const std::function<void(std::size_t)>& work, unsigned threads = 0);

// The threads parallel_for uses by default: one per core (at least 1).
unsigned core_count();

// memcpy(to, from, bytes) in pieces of 4 MiB on parallel_for's threads: for large copies out of
// mapped device buffers into fresh host memory, whose first touch (the kernel clearing its pages)
// costs as much as the copy.
void copy_on_threads(void* to, const void* from, std::size_t bytes);

}  // namespace amhv
