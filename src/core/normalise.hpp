#pragma once
// Temporal normalisation (docs/method.md section 2, eq. 12-13).
#include <vector>

namespace amhv {

// Source frame of each of `target_length` frames resampled from `source_length` frames:
// n = floor(m * source_length / target_length). Works both ways (shortening and stretching).
std::vector<int> resample_indices(int source_length, int target_length);

// A segment pair normalised to tau = min(length_a, length_b): the longer one is resampled.
struct NormalisedPair {
    int length = 0;
    std::vector<int> frames_a;  // source frame (segment-relative) of each normalised frame
    std::vector<int> frames_b;
};
NormalisedPair normalise_pair(int length_a, int length_b);
// A multi-party stage (docs/method.md section 11): the placed side keeps its timing, so the pair
// takes A's length and B is resampled to it (stretched or shortened).
NormalisedPair normalise_to_a(int length_a, int length_b);

}  // namespace amhv
