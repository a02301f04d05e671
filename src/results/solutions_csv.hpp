#pragma once
// segment_N/solutions.csv (docs/method.md section 6): the solution group of one key segment, one
// row per solution in (z, theta, y, x) order: x,y,z,theta_deg,L,thetaA_deg,thetaB_deg (z, B's
// raise, is 0 without z_range). Degrees are the file's; in memory a solution carries its lattice
// indices (i, j, k, l).
#include <filesystem>
#include <vector>

#include "src/core/angles.hpp"
#include "src/sweep/problem.hpp"

namespace amhv {

inline constexpr const char* kSolutionsHeader = "x,y,z,theta_deg,L,thetaA_deg,thetaB_deg";

void write_solutions_csv(const std::filesystem::path& path, const std::vector<Solution>& solutions);

// Reads a file written by write_solutions_csv for a sweep of edge `voxel` on `lattice`: every row's
// numbers, and its lattice pose (i, j, k, l) recovered at the file's edge. Throws amhv::Error naming
// the file and line of a malformed row.
std::vector<Solution> read_solutions_csv(const std::filesystem::path& path, double voxel, const angles::AngleLattice& lattice);

}  // namespace amhv
