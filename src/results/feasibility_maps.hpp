#pragma once
// The feasibility maps of a sweep (docs/method.md section 10): one FLOAT EXR per sampled angle
// plus a PNG montage of all angles, for image viewers.
#include <array>
#include <cstdint>
#include <filesystem>

#include "src/sweep/problem.hpp"

namespace amhv {

// `folder`/angle_KKK.exr: pixel (x, y) of angle k; channel `passed` = how many of contact,
// dictionary, fidelity, visibility the pose passed in that order (4 = solution), R G B = its colour.
// `folder`/montage.png: every angle's map, tiled in angle order. Returns the number of files.
int write_feasibility_maps(const std::filesystem::path& folder, const SweepProblem& problem, const SweepResult& result);

// The colour of an outcome in the maps (sRGB 0..255).
std::array<std::uint8_t, 3> outcome_colour(PoseOutcome outcome);

}  // namespace amhv
