#pragma once
// Wall-clock seconds for the per-stage timings the commands report.
#include <chrono>

namespace amhv {

inline double seconds_since(std::chrono::steady_clock::time_point start) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace amhv
