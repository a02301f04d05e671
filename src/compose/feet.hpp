#pragma once
// Foot contacts in a spliced take (Kovar, Schreiner and Gleicher 2002, "Footskate cleanup", in
// its simplest form): per run of frames in which a foot is planted, its ankle is held at one
// place, the mean of where the run puts it, by turning the thigh and the shank in the leg's own
// bend plane (two-bone inverse kinematics); the foot keeps its orientation. The correction fades in
// and out over kEaseSeconds either side of the run.
#include "src/compose/features.hpp"
#include "src/compose/splice.hpp"

namespace amhv::compose {

void keep_feet_planted(const Library& library, const KeyJoints& key, Spliced& spliced);

// Two-bone inverse kinematics: the knee position that puts the ankle at `target` (as near as the
// bones reach), keeping the knee on the side of the line hip-target where `knee` lies.
Vec3 knee_for(const Vec3& hip, const Vec3& knee, const Vec3& ankle, const Vec3& target);

}  // namespace amhv::compose
