#pragma once
// Joints by role: skeletons name their joints differently (CMU 18/19: LeftArm, LeftForeArm,
// LeftHand; CMU 20/21: LeftShoulder, LeftElbow, LeftWrist, lhand; CMU's LeftShoulder is the other's
// LeftCollar). The body builder speaks one vocabulary, the CMU 18/19 one; this finds each joint's
// role from the skeleton's structure, anchored at a few joints every naming scheme recognisably
// names (the head, the elbows, the knees), and gives each joint the name of its role there.
#include <string>
#include <vector>

#include "src/io/bvh.hpp"

namespace amhv {

// Per joint of `motion`, the name of its role in the CMU 18/19 vocabulary:
//   spine, from the root to the head: Hips, [LowerBack], [Spine], Spine1, Neck, [Neck1...], Head;
//   each arm, from the spine: [clavicles: LeftShoulder], LeftArm (upper arm), LeftForeArm (from
//   the elbow), LeftHand (from the wrist), then LeftHandIndex1 / LThumb below it;
//   each leg, from the root: [LHipJoint], LeftUpLeg (thigh), LeftLeg (from the knee), LeftFoot,
//   LeftToeBase below it;
// props (a joint whose name holds "Sword" or "Prop") and end sites keep their names ("<role>_end"
// for end sites). A joint a skeleton names as the vocabulary does keeps its name. Throws
// amhv::Error naming the file and the role when one cannot be found (no head; an arm without an
// elbow; a leg without a knee; a limb whose side the names do not tell).
std::vector<std::string> role_names(const BvhMotion& motion);

// The roles a scene may give a character's joints by name (`joints = { NAME = ROLE }`): the spine's,
// each side's arm and leg chain (Left.../Right...).
const std::vector<std::string>& role_vocabulary();

}  // namespace amhv
