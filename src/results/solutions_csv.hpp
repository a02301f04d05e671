#pragma once
// segment_N/solutions.csv (docs/method.md section 6): the solution group of one key segment, one
// row per solution in (z, theta, y, x) order: x,y,z,theta_deg,L,thetaA_deg,thetaB_deg (z, B's
// raise, is 0 without z_range). Written on request (--csv, `amhv solutions --csv`); the group's own
// store is group.vdb.
#include <filesystem>
#include <vector>

#include "src/core/angles.hpp"
#include "src/sweep/solution_group.hpp"

namespace amhv {

inline constexpr const char* kSolutionsHeader = "x,y,z,theta_deg,L,thetaA_deg,thetaB_deg";

// Writes `group` in its order, each member with its descriptors (`describe`).
void write_solutions_csv(const std::filesystem::path& path, const SolutionGroup& group, const PoseDescriber& describe);

}  // namespace amhv
