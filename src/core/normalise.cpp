#include "src/core/normalise.hpp"

#include <algorithm>
#include <cstdint>

#include "src/core/error.hpp"

namespace amhv {

std::vector<int> resample_indices(int source_length, int target_length) {
    if (source_length <= 0 || target_length <= 0)
        throw Error(fmt::format("cannot resample {} frames to {} frames: both must be positive", source_length, target_length));
    std::vector<int> indices(static_cast<std::size_t>(target_length));
    for (int m = 0; m < target_length; ++m)
        indices[std::size_t(m)] = int(std::int64_t(m) * source_length / target_length);  // exact integer floor
    return indices;
}

NormalisedPair normalise_pair(int length_a, int length_b) {
    NormalisedPair pair;
    pair.length = std::min(length_a, length_b);
    pair.frames_a = resample_indices(length_a, pair.length);
    pair.frames_b = resample_indices(length_b, pair.length);
    return pair;
}

NormalisedPair normalise_to_a(int length_a, int length_b) {
    NormalisedPair pair;
    pair.length = length_a;
    pair.frames_a = resample_indices(length_a, length_a);
    pair.frames_b = resample_indices(length_b, length_a);
    return pair;
}

}  // namespace amhv
