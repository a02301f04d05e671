#pragma once
// Key segments proposed (`amhv propose`, docs/method.md section 13): pairs of A's and B's contact
// moments (events.hpp) with B's frames shifted so that the two moments meet, each decided by a
// coarse sweep of the key segment it makes and ranked by the natural score of its best member.
#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "src/propose/events.hpp"
#include "src/scene/scene.hpp"
#include "src/scene/segment.hpp"
#include "src/sweep/problem.hpp"
#include "src/voxelise/voxelise.hpp"

namespace amhv::propose {

// The coarse sweep's sampling (the scene's when coarser): 4 cm / 8 degrees, a hand's width and the
// turn that moves a hand 0.07 m at arm's length, enough to find a contact of two hands.
inline constexpr double kCoarseVoxel = 0.04, kCoarseAngleDeg = 8.0;
// Holds: B's shifts tried per pair of hands, the best of the coupled motion's local minima (see
// coupled_motion), at most kShiftsPerPair.
inline constexpr int kShiftsPerPair = 2;
// The proposals refined at the scene's own sampling, best first.
inline constexpr int kRefined = 3;
// A handshake's shake: the joined hands pump up and down together. A stroke is a run of frames
// where the two hands' mean height moves one way; it pumps when its vertical speed peaks at
// kPumpSpeed or more (m/s; a 2 cm stroke at 3 Hz peaks at 0.19 m/s, where held hands at rest
// drift slower), and a shake is at least kPumpStrokes such strokes in a row, up and down, from the
// first frame where the hands move (kStillSpeed or faster: a quarter of a pump) to the last.
inline constexpr double kPumpSpeed = 0.2, kStillSpeed = kPumpSpeed / 4;
inline constexpr int kPumpStrokes = 2;
// The near-peripheral field (+-45 degrees from the gaze), where people see a partner's hand.
inline constexpr double kProposalViewDeg = 45.0;

// One pair of moments: A's frames, B's frames, the hands and the type.
struct Candidate {
    std::array<int, 2> a{}, b{};  // inclusive frame numbers of A and B
    Hand hand_a = Hand::Right, hand_b = Hand::Right;
    char variant = 'b';           // 0&0 (a) or (b)
    double coupling_m = -1;       // holds: RMS of the hands' relative motion at the best turn (metres)
    std::string why;              // A's and B's cues
    int shift() const { return b[0] - a[0]; }
};

// The hands' relative motion when B's frame f + shift meets A's frame f over A's frames a0..a1:
// the RMS about its mean of (A's hand - B's hand turned by theta), at the turn theta that makes it
// least (closed form, a turn about z), metres. Held hands move together: it is small at the shift
// where they are held.
struct Coupling {
    double rms_m = 0, theta_rad = 0;
};
Coupling coupled_motion(const HandTrack& a, Hand hand_a, const HandTrack& b, Hand hand_b, int a0, int a1, int shift);

// The shake of held hands over A's frames a0..a1 (B's frame f + shift meets A's f): the longest run
// of pumping strokes (the earliest of equal ones) of the two hands' mean height, vertical speeds as
// the events' (central differences over kSpanSeconds); nothing when no kPumpStrokes strokes pump in
// a row. Heights are the scene's z, which no placement changes.
struct Shake {
    std::array<int, 2> a{};  // A's frames, inclusive
    int strokes = 0;
    double slowest_mps = 0;  // the weakest stroke's peak vertical speed
};
std::optional<Shake> joined_shake(const HandTrack& a, Hand hand_a, const HandTrack& b, Hand hand_b, int a0, int a1, int shift);

// Every candidate from the two tracks' events: each slap of A with each of B (B shifted so that the
// impacts meet); each pair of A's and B's holds and hands, at the kShiftsPerPair shifts of least
// coupled motion over the frames both hold (at least kMinHoldSeconds of them), trimmed to the held
// hands' shake when they shake (the handshake proper; a hold without a shake keeps every frame
// both stand).
std::vector<Candidate> candidates(const HandTrack& a, const std::vector<ContactEvent>& events_a, const HandTrack& b,
                                  const std::vector<ContactEvent>& events_b);

// The key segment a candidate makes (index `index`): its type on the two hands, fidelity on the rest
// of the bodies but the two arms, mutual visibility within kProposalViewDeg.
KeySegment candidate_segment(const Candidate& c, int index);

}  // namespace amhv::propose
