#pragma once
// A closed body mesh built around a skeleton's bones: one capsule per bone with a radius that
// looks like a person, so the non-zero winding voxelisation sees one solid body.
#include <functional>
#include <memory>

#include "src/core/geometry.hpp"
#include "src/io/bvh.hpp"
#include "src/io/mesh_sequence.hpp"

namespace amhv {

// Radius in metres of the capsule around the bone from `parent` to `child` (CMU joint names;
// other skeletons fall back to matching words such as "Head", "Hand", "Leg").
double bone_radius(const std::string& parent, const std::string& child);

// Wrist to fingertip, and wrist to thumb tip, of an adult hand (metres): hand chains that end
// short of these (marker sets stop at the knuckles) are extended to them.
inline constexpr double kHandLength = 0.18;
inline constexpr double kThumbLength = 0.11;
// A capsule body's hand is a mitten: kMittenRadius around the finger bones makes it about as broad
// as a palm (8-9 cm), and therefore thicker than a real hand, kHandThickness across the knuckles
// (the natural choice's depth term allows for the difference: src/edit/natural.cpp).
inline constexpr double kMittenRadius = 0.04;
inline constexpr double kHandThickness = 0.03;
// A forearm narrows from the elbow (bone_radius) to the wrist: an adult wrist is 15-18 cm around
// (ANSUR II, 2012: means 17.5 cm for men, 15.2 cm for women), a radius of 2.6 cm at their mean.
inline constexpr double kWristRadius = 0.026;

struct SkinnedFit;
struct SkeletonBodyOptions {
    UnitsAndAxes units{0.0564444, UpAxis::Y};  // CMU defaults
    int segments = 12;                          // around each capsule
    int cap_rings = 4;
    // Set: the skinned human fitted to the take (src/body/skinned_body.hpp) instead of capsules.
    std::shared_ptr<const SkinnedFit> skinned;
};

// The body part (head, torso, left_upper_arm, left_forearm, left_hand, ..., right_foot,
// left_shoulder, right_shoulder) of the bone
// that starts at joint `parent`. A joint whose name contains "Sword" or "Prop" starts a hand-held
// prop (part "sword" or "prop"): mocap exports rigid props as extra joints under a hand.
std::string body_part(const std::string& parent);
// The same for the skinned human, whose mesh is split by skin weight: the collar bones'
// vertices stay in its torso (a shoulder region cut from the torso would not close as a surface).
std::string skinned_body_part(const std::string& parent);
const std::vector<std::string>& body_part_names();
// The parts a skeleton's bones give (body_part_names' order, props last), for the capsule body or
// the skinned one.
std::vector<std::string> body_part_names(const BvhMotion& motion, bool skinned = false);

struct BodyPart {
    std::string name;
    TriangleMesh mesh;  // closed: a union of capsules
};
// The body at BVH frame `frame` split by body part, in metres, z up.
std::vector<BodyPart> skeleton_body_parts(const BvhMotion& motion, int frame, const SkeletonBodyOptions& options);

// Per BVH frame: eye position (between the eyes) and gaze direction (from the head's rotation,
// calibrated against the facing given by hips and shoulders), metres, z up.
struct TrackSample {
    Vec3 eye = Vec3::Zero();
    Vec3 gaze = Vec3::UnitX();
};
std::vector<TrackSample> skeleton_track(const BvhMotion& motion, const SkeletonBodyOptions& options);

// The same from any skeleton whose joints have roles (a BVH take, a character's rig): per joint its
// role (skeleton_roles' vocabulary) and parent, and per frame every joint's global transform in the
// file's units and axes.
struct JointFrames {
    std::string source;
    std::vector<std::string> roles;
    std::vector<int> parent;
    int frame_count = 0;
    int first_frame = 0;  // frames before it (a T-pose) do not calibrate the head
    std::function<std::vector<Eigen::Affine3d>(int)> globals;
};
std::vector<TrackSample> joints_track(const JointFrames& joints, const UnitsAndAxes& units);

// The body at BVH frame `frame`, in metres, z up.
TriangleMesh skeleton_body(const BvhMotion& motion, int frame, const SkeletonBodyOptions& options);

// Body meshes for BVH frames range.first..range.last.
MeshSequence skeleton_body_sequence(const BvhMotion& motion, const FrameRange& range, const SkeletonBodyOptions& options);

}  // namespace amhv
