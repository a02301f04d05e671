#pragma once
// The natural choice's terms and scales (docs/method.md section 7b; src/edit/natural.hpp computes them).
#include <cstdint>
#include <limits>
#include <vector>

#include "src/body/skeleton_body.hpp"
#include "src/sweep/problem.hpp"

namespace amhv {

inline constexpr double kNaturalGazeHalfAngleDeg = 30.0;
inline constexpr double kNaturalDepthScale = 0.01;     // metres
inline constexpr double kNaturalSlidingScale = 0.02;   // metres
inline constexpr double kIntimateDistance = 0.45;      // metres (Hall's intimate zone)
inline constexpr double kNaturalCrowdingScale = 0.10;  // metres
// A head whose body moves on the floor at least this fast (m/s, the slow end of walking; standing
// sway stays under 0.2) may look along its path instead of at the other: locomotor gaze.
inline constexpr double kWalkingSpeed = 0.5;
// The floor velocity of a head is taken over this time either side of a frame (seconds).
inline constexpr double kWalkingWindow = 1.0 / 15.0;
// A strike's limbs (reach): the least horizontal length (metres) of a limb, root to end, for its
// direction to count; a limb held straight up or down has none.
inline constexpr double kReachMinLength = 0.05;
// A strike's ends off each other's limb line (reach_offset_m): half an adult's palm breadth (ANSUR II
// hand breadth 7.8-8.9 cm), metres: a palm further off its line meets the other with its edge.
inline constexpr double kReachOffsetScale = 0.04;
// A strike's ends at the impact (impact_gap_m): what lies between an end joint and the surface it
// strikes with, metres. A hand: half its thickness across the knuckles (the bodies' kHandThickness,
// 3 cm: a palm or the back of the hand meets the other). A foot: half its breadth (ANSUR II foot breadth
// 9.1-10.1 cm, women's and men's means: the instep or the side meets the other).
inline constexpr double kImpactHandDepth = 0.5 * kHandThickness;
inline constexpr double kImpactFootDepth = 0.048;
// At most this many of the key's normalised frames are scored (evenly spaced, ends included).
inline constexpr int kNaturalFrames = 8;
// At most this many points of B's interest part per frame; fewer for large groups, so that a
// group's depth lookups stay under kNaturalLookups (at least kNaturalMinPoints points per frame).
inline constexpr int kNaturalPoints = 64;
inline constexpr int kNaturalMinPoints = 4;
inline constexpr double kNaturalLookups = 1e8;

struct NaturalTerms {
    static constexpr double kNone = std::numeric_limits<double>::quiet_NaN();
    double gaze = kNone;       // 1 - cos, mean
    double depth_m = kNone;    // metres
    double sliding_m = kNone;  // metres
    double crowding = kNone;   // already scaled and squared
    double reach = kNone;      // 1 - cos, at the contact frame
    double reach_offset_m = kNone;  // metres, at the contact frame
    double impact_gap_m = kNone;      // metres: the ends' surfaces apart along their closing at the impact
    double impact_closing_m = kNone;  // metres: how far the ends closed over the key frame into the impact
    // Sum over the terms that apply of (term / scale)^2 (crowding as it is).
    double cost() const;
};

// One key segment's natural scores as result.json reports them: the chosen member's and the
// runner-up's (the best-scoring member other than the chosen one).
struct NaturalReport {
    int key = 0;
    double weight = 0;
    NaturalTerms chosen, runner_up;
    bool has_runner_up = false;
    Solution runner_up_pose;
    // The scene's [truth], on the lattice (nearest x, y and angle step; B not raised), when it has one.
    bool has_truth = false;
    NaturalTerms truth;
    // The scores of members 0, stride, 2 stride, ... (in the group's order), for the page.
    std::uint64_t stride = 1;
    std::vector<float> sampled;
};

}  // namespace amhv
