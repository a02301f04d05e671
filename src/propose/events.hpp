#pragma once
// Moments where a take's hand can meet another person's (docs/method.md section 13), found from
// its hips and hands alone (a skeleton's joints, or a labelled mesh sequence's torso and wrists):
//   a slap (0&0 (b): the hand arrives fast and stops at once: an impact),
//   a hold (0&0 (a): the person stands, a hand free to shake or take another's).
// Each is a window of the take's frames with the hand, the kind and how strong the cue is.
#include <string>
#include <vector>

#include "src/body/skeleton_body.hpp"
#include "src/core/geometry.hpp"
#include "src/io/bvh.hpp"
#include "src/io/mesh_sequence.hpp"

namespace amhv::propose {

// Scales of the cues (docs/method.md section 13), SI units:
//   speeds and decelerations are central differences over kSpanSeconds, so takes at 30 and 120 fps
//   measure alike;
inline constexpr double kSpanSeconds = 1.0 / 30.0;
//   a slap arrives at kSlapSpeed or faster (a reaching hand moves at about 1 m/s; the shipped
//   high five's hands at 2.5-3 m/s) and loses speed at kImpactDeceleration or more around one
//   frame (an arm's swing turns back at under 10 m/s^2: a 0.3 m swing at 1 Hz peaks at 12 m/s^2
//   only at its ends, where its speed is near 0), the strongest within kImpactSeconds;
inline constexpr double kSlapSpeed = 1.5, kImpactDeceleration = 12.0, kImpactSeconds = 0.1;
//   the slap's window holds its arrival and rebound: kSlapHalfSeconds either side of the impact;
inline constexpr double kSlapHalfSeconds = 0.15;
//   a hold: the person stands (the root moves slower than kStandSpeed over kStandSeconds; walking
//   is 1-1.5 m/s) for at least kMinHoldSeconds: either hand may hold the other's there (a hand
//   taken low, by the hip, is held as well as one held out), so that the pairing decides by the
//   two hands' coupled motion (proposals.hpp) and the sweep.
inline constexpr double kStandSpeed = 0.3, kStandSeconds = 0.2, kMinHoldSeconds = 0.3;

enum class Hand { Left = 0, Right = 1 };
const char* hand_part(Hand hand);  // "left_hand" / "right_hand": the BVH body's part

struct ContactEvent {
    Hand hand = Hand::Right;
    char variant = 'b';     // 'b' slap, 'a' hold
    int first = 0, last = 0;  // frames of the take (its own numbering at the scene's rate), inclusive
    int moment = 0;         // the impact (a slap) or the first frame of the hold
    double strength = 0;    // slap: deceleration, m/s^2; hold: seconds held
    std::string why;        // one line: the cue's numbers
};

// The hand joints' positions (scene axes, metres) and the hips' per frame of a BVH take.
struct HandTrack {
    double fps = 0;
    int first = 0;  // frame number of element 0
    std::vector<Vec3> hips, hand[2];
    int frames() const { return int(hips.size()); }
};
HandTrack hand_track(const BvhMotion& motion, const UnitsAndAxes& units, int first, int last, const std::string& source);
// The same from any rig whose joints have roles (a character's: its Hips, LeftHand and RightHand),
// sampled at `fps`.
HandTrack hand_track(const JointFrames& joints, const UnitsAndAxes& units, double fps, int first, int last);

// Every slap and hold of the track, by hand, in frame order.
std::vector<ContactEvent> contact_events(const HandTrack& track);

}  // namespace amhv::propose
