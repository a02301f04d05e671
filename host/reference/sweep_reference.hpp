#pragma once
// The plain CPU reference of the placement sweep: every constraint of docs/method.md section 5 evaluated
// straight from its definition, voxel by voxel, with the shared integer pull mapping
// (sweep/pose_map.hpp). Slow and obviously correct; the Vulkan path must give identical outcomes.
#include "src/sweep/problem.hpp"

namespace amhv {

class ReferenceSweeper : public Sweeper {
public:
    std::string name() const override { return "cpu-reference"; }
    SweepResult sweep(const SweepProblem& problem) override;
    // Only the poses of angles [first_angle, first_angle + angle_count); the others stay FailsContact.
    // Benchmarks use it to time the reference on a sample of angles.
    SweepResult sweep_angles(const SweepProblem& problem, int first_angle, int angle_count);
};

}  // namespace amhv
