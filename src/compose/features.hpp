#pragma once
// What recognition and splicing compare: the joints' positions in the scene's axes (z up, metres),
// the body's heading, and per frame a motion feature vector in the root's frame.
#include <array>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "src/core/geometry.hpp"
#include "src/io/bvh.hpp"
#include "src/io/mesh_sequence.hpp"

namespace amhv::compose {

// The joints the features and the foot contacts use, by role.
struct KeyJoints {
    int hips = -1, head = -1;
    std::array<int, 2> hand{-1, -1}, elbow{-1, -1}, foot{-1, -1}, knee{-1, -1}, hip{-1, -1};  // left, right
    std::vector<int> all() const;        // the joints a feature holds: head, hands, elbows, knees, feet
    std::vector<int> with_hips() const;  // all(), then the hips: the joints splice distances compare
};
KeyJoints key_joints(const std::vector<std::string>& roles, const std::string& source);

// Every frame of a take: joint positions (scene axes, metres) and the heading, the horizontal
// direction the hips face (perpendicular to the line from the right hip joint to the left one),
// averaged over kHeadingSpan, as an angle about z.
struct PoseTrack {
    std::vector<std::vector<Vec3>> joints;  // [frame][joint]
    std::vector<double> heading;            // radians
};
PoseTrack pose_track(const BvhMotion& motion, const UnitsAndAxes& units, const KeyJoints& key);

// The horizontal direction the hips face, from the two hip joints' positions (z up).
double heading_of(const Vec3& left_hip, const Vec3& right_hip);

// Scales of the motion features (docs/method.md section 12):
//   velocities enter as the distance they cover in kVelocityTime (0.2 s, a fifth of a walking
//   step cycle), the root's turning as the distance a point kTurnRadius (0.3 m, half a shoulder
//   span beyond the spine) from the root covers then; velocities are central differences over
//   kVelocitySpan (0.1 s) so that 30 and 120 fps takes give the same numbers.
inline constexpr double kVelocityTime = 0.2, kTurnRadius = 0.3, kVelocitySpan = 0.1;
// The heading is the hips' mean direction over a step cycle (1 s), not their swing within it.
inline constexpr double kHeadingSpan = 1.0;
// Lengths are in leg lengths (thigh plus shank) times this nominal adult leg, metres.
inline constexpr double kLegLength = 0.85;

// Per frame in [first, last]: the key joints' positions in the root's frame (origin under the
// hips on the floor plane, x along the heading; heights kept), their velocities in that frame,
// and the root's horizontal velocity and turning rate, all in metres, weighted so that the
// squared distance between two features is the mean over the joints plus the root's terms.
std::vector<Eigen::VectorXd> motion_features(const PoseTrack& track, const KeyJoints& key, double fps, int first, int last);

// The same feature seen in a mirror across the body's sagittal plane: left and right joints
// swapped, the sideways components (the root frame's y) and the turning negated. An action done
// to the left is the action done to the right (docs/method.md section 12).
Eigen::VectorXd mirrored_feature(const Eigen::VectorXd& feature);

}  // namespace amhv::compose
