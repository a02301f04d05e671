#include "src/edit/timeline.hpp"

#include "src/core/normalise.hpp"

namespace amhv {

namespace {

// A stage where A keeps its timing: where B has no frames between two key segments (or before the
// first, after the last), it holds the nearest frame it has, so no frame of A is dropped.
std::array<int, 2> held_when_empty(const Scene& scene, std::array<int, 2> b) {
    if (!scene.a_sets_time || b[1] >= b[0]) return b;
    const int held = b[0] > scene.b.frame_last ? scene.b.frame_last : b[0] > scene.b.frame_first ? b[0] - 1 : scene.b.frame_first;
    return {held, held};
}

}  // namespace

Timeline make_timeline(const Scene& scene) {
    Timeline t;
    auto add = [&t, &scene](int key, std::array<int, 2> a, std::array<int, 2> b) {
        b = held_when_empty(scene, b);
        TimelineSegment s{key, a, b, t.length(), 0};
        const int length_a = a[1] - a[0] + 1, length_b = b[1] - b[0] + 1;
        if (length_a > 0 && length_b > 0) {
            const NormalisedPair pair = scene.a_sets_time ? normalise_to_a(length_a, length_b) : normalise_pair(length_a, length_b);
            s.length = pair.length;
            for (int m = 0; m < pair.length; ++m) {
                t.frame_a.push_back(a[0] + pair.frames_a[std::size_t(m)]);
                t.frame_b.push_back(b[0] + pair.frames_b[std::size_t(m)]);
                t.segment.push_back(int(t.segments.size()));
            }
        }
        t.segments.push_back(s);
    };
    int next_a = scene.a.frame_first, next_b = scene.b.frame_first;
    for (const KeySegment& k : scene.segments) {
        add(0, {next_a, k.a[0] - 1}, {next_b, k.b[0] - 1});
        add(k.index, k.a, k.b);
        next_a = k.a[1] + 1;
        next_b = k.b[1] + 1;
    }
    add(0, {next_a, scene.a.frame_last}, {next_b, scene.b.frame_last});
    return t;
}

}  // namespace amhv
