#pragma once
// Exact squared Euclidean distance transform of a 3D grid (Felzenszwalb and Huttenlocher,
// "Distance transforms of sampled functions", 2012), in voxels.
#include <array>
#include <vector>

namespace amhv {

// `f` holds 0 at the sites and a large value elsewhere ([z][y][x], x fastest); on return, the
// squared distance (in voxels squared) from each voxel's centre to the nearest site's.
void squared_distance_transform(std::vector<double>& f, const std::array<int, 3>& dims);

}  // namespace amhv
