#pragma once
// MHV slices as OpenEXR (docs/method.md section 10) for any EXR viewer. Each slice image has FLOAT
// channels R, G, B (a preview coloured by t_end, black where empty), t_start, t_end (NaN where
// empty), frames (occupied-frame count) and label (+1 end surface, -1 start surface, 0 lateral,
// NaN where empty). Header attributes (strings) give the voxel size, origin, axes and slice.
#include <filesystem>
#include <string>

#include "src/core/amhv.hpp"

namespace amhv {

struct ExrSliceOptions {
    char axis = 'z';        // slicing axis: x, y or z
    bool multipart = false; // one file with one part per slice instead of one file per slice
};

// Writes into `folder` (created); returns the number of slices written.
int write_exr_slices(const Amhv& volume, const std::filesystem::path& folder, const ExrSliceOptions& options);

// The preview colour for a normalised time in [0, 1] (blue early, red late, like the paper's Fig. 3).
std::array<float, 3> time_colour(double t);

}  // namespace amhv
