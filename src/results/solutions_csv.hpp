#pragma once
// segment_N/solutions.csv (docs/method.md section 6): the solution group of one key segment, one
// row per solution in (theta, y, x) order: x,y,theta_deg,L,thetaA_deg,thetaB_deg. Degrees are the
// file's; in memory a solution carries its lattice indices (i, j, k).
#include <filesystem>
#include <vector>

#include "src/core/angles.hpp"
#include "src/sweep/problem.hpp"

namespace amhv {

void write_solutions_csv(const std::filesystem::path& path, const std::vector<Solution>& solutions);

// Reads a file written by write_solutions_csv for a sweep of edge `voxel` on `lattice`: every row's
// numbers, and its lattice pose (i, j, k) recovered at the file's edge. Throws amhv::Error naming
// the file and line of a malformed row.
std::vector<Solution> read_solutions_csv(const std::filesystem::path& path, double voxel, const angles::AngleLattice& lattice);

}  // namespace amhv
