#pragma once
// The edited scene's timeline (docs/method.md section 2): each object's frames split into transitional
// and key segments, every pair normalised to its shorter length, one after the other.
#include <array>
#include <vector>

#include "src/scene/scene.hpp"

namespace amhv {

struct TimelineSegment {
    int key = 0;                  // 1-based key segment index; 0 for a transitional segment
    std::array<int, 2> a{}, b{};  // source frame numbers, inclusive; first > last when the side is empty
    int first = 0, length = 0;    // output frames [first, first + length)
};

struct Timeline {
    std::vector<TimelineSegment> segments;  // transitional 0, key 1, transitional 1, ..., key I, transitional I
    std::vector<int> frame_a, frame_b;      // source frame number of each output frame
    std::vector<int> segment;               // index into `segments` of each output frame
    int length() const { return int(frame_a.size()); }
};

// The timeline of `scene` over each object's frames [frame_first, frame_last]. A transitional pair
// where one side has no frames has no output frames.
Timeline make_timeline(const Scene& scene);

}  // namespace amhv
