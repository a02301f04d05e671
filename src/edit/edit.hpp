#pragma once
// From the key segments' solution groups to the edited scene (docs/method.md sections 7, 8 and 10):
// per-frame roots and facings, one solution per key segment by dynamic programming, the
// transitional root paths by path optimisation, and the rigid transform of every output frame.
#include <array>
#include <cstdint>
#include <optional>
#include <vector>

#include <Eigen/Core>

#include "src/voxelise/voxelise.hpp"
#include "src/edit/natural_terms.hpp"
#include "src/edit/timeline.hpp"
#include "host/choose/chain_dp.hpp"
#include "src/scene/segment.hpp"
#include "src/sweep/problem.hpp"
#include "src/sweep/solution_group.hpp"

namespace amhv {

// One key segment's sweep as the edit needs it: run now, or read back from a sweep folder.
struct KeySweep {
    int index = 0;                    // 1-based key segment
    Vec3 root_a = Vec3::Zero(), root_b = Vec3::Zero();  // C^A, C^B in the capture frames
    PoseDescriber describe;  // the sampling and A's and B's facings F: a member's descriptors
    SolutionGroup group;     // the solution group, in the sweep's (z, theta, y, x) order
    std::uint64_t poses_tested = 0;
    std::array<std::uint64_t, 4> rejected{};  // contact, dictionary, fidelity, visibility
};

// One object at one output frame: capture -> scene is p -> R(yaw) p + translation (z kept).
struct ObjectFrameEdit {
    int source = 0;  // frame number in the object's sequence
    Eigen::Vector2d root = Eigen::Vector2d::Zero();         // C_k: centroid of the frame's voxels, capture frame
    double facing = 0;                                      // F_k, capture frame, radians (unwrapped along the output)
    Eigen::Vector2d original_root = Eigen::Vector2d::Zero();  // C_k where the editor's placement puts it
    double original_facing = 0;
    Eigen::Vector2d edited_root = Eigen::Vector2d::Zero();  // C-bar_k in the scene
    double edited_facing = 0;
    double yaw = 0;
    Eigen::Vector2d translation = Eigen::Vector2d::Zero();
    // Vertical shift into the scene: B's chosen z (z_range) in a key segment, blended linearly
    // across a transition between the key segments around it; 0 for A.
    double lift = 0;
    // Every field equal (the edit's check reuses a segment placed as before: src/edit/edit.cpp).
    bool operator==(const ObjectFrameEdit&) const = default;
};

struct KeyEdit {
    int index = 0;
    bool captured = false;   // --allow-empty: an empty group, B kept at its captured placement
    Solution chosen;         // B's pose relative to A (docs/method.md section 6)
    int solution = -1;       // row of the solution group (-1 when captured)
    double a_rotation_rad = 0;  // delta_i
    Eigen::Vector2d a_translation = Eigen::Vector2d::Zero();  // t_i (t_1 = 0)
    double yaw_a = 0, yaw_b = 0;  // the rigid moves of the segment (capture -> scene rotations)
    Eigen::Vector2d root_a = Eigen::Vector2d::Zero(), root_b = Eigen::Vector2d::Zero();  // edited C-bar^A_i, C-bar^B_i
};

struct PathReport {
    int timeline_segment = 0;  // index into Timeline::segments
    int object = 0;            // 0 = A, 1 = B
    int frames = 0;            // free frames optimised
    double root_cost = 0, facing_cost = 0;  // the objective at the optimum
    double max_shift_m = 0;    // largest |C-bar_k - C_k| (original placement) over the segment
};

// How far apart two bodies may be for their gap to be measured (beyond it: "far").
inline constexpr double kGapReach = 0.3;

// One output frame's check (src/edit/frame_check.hpp): both whole bodies as solids at the scene's voxel.
struct FrameCheck {
    int frame = 0;                // output frame
    std::uint64_t overlap = 0;    // voxels inside both bodies
    std::optional<double> gap_m;  // 0 when they overlap; else the smallest distance between the two
                                  // solids' voxel centres less one voxel; empty beyond kGapReach
    Eigen::Vector2d apart = Eigen::Vector2d::UnitX();  // on the floor, from A's root towards B's
    double depth_m = 0;           // the overlap's extent along `apart` (0 without overlap)
};

// One transitional segment's check, before and after the separation (docs/method.md section 8a).
struct TransitionCheck {
    int timeline_segment = 0;
    int frames = 0;
    int overlapping_before = 0, overlapping = 0;        // frames with overlap
    std::uint64_t max_overlap_before = 0, max_overlap = 0;  // voxels
    int rounds = 0;                                     // re-solves with separation targets
    double smoothness_before = 0, smoothness = 0;       // the paper's path objective, both objects, roots and facings
};

struct EditOptions {
    bool allow_empty = false;  // keep B's captured placement where a group is empty
    bool allow_transition_overlap = false;  // check and report, but keep the paper's paths
    // A multi-party stage (docs/method.md section 11): A (the objects placed so far) keeps every frame
    // where it is; its path is not bent (the DP's w_A should be infinite and its rotations {0}).
    bool fixed_a = false;
    // The natural scores kept for the page: every member up to this many, else every n-th by rank
    // (NaturalReport::sampled), as the page plots the group.
    std::uint64_t natural_sampled = 20000;
};

// Tolerance that still touches (src/edit/touch_up.hpp), per key segment with a contact tolerance.
struct TouchUp {
    int key = 0;             // 1-based key segment
    bool touches = false;    // the pose now chosen meets without the tolerance
    double moved_m = 0;      // how far the choice moved on the floor
    PoseIndex from, to;      // the DP's choice and the one kept
    std::string note;        // why it could not touch, when it could not
};

struct EditResult {
    Timeline timeline;
    std::array<std::vector<ObjectFrameEdit>, 2> frames;  // A, B per output frame
    std::vector<KeyEdit> keys;
    ChainChoice choice;  // solution index per key segment (captured placements included as their own state)
    std::vector<PathReport> paths;
    std::vector<FrameCheck> frame_checks;        // every output frame, in order
    std::vector<TransitionCheck> transition_checks;
    double voxel = 0.01;  // the edge the frames were checked at
    // Choices of the key poses tried (docs/method.md section 8a): 1 unless a transition could not
    // be freed and the DP chose again without the key poses around it.
    int choices_tried = 1;
    std::vector<NaturalReport> natural;  // per key segment, when weights.natural > 0
    std::vector<TouchUp> touch_ups;      // per key segment with a contact tolerance
    double natural_seconds = 0;
    double roots_seconds = 0, dp_seconds = 0, path_seconds = 0, check_seconds = 0;
};

// The most choices of the key poses an edit tries before it names the transition it cannot free,
// and how far around a failing key pose (same rotations) the next choices stay away from it.
inline constexpr int kMaxKeyChoices = 6;
inline constexpr double kRuleOutRadius = 0.15;

// Object `object`'s (0 = A, 1 = B) mesh at output frame k, moved into the scene (the frame's
// rigid transform and lift).
TriangleMesh placed_mesh(const EditResult& edit, int k, int object, ObjectSource& source);
// One object's mesh at one output frame `e`, moved into the scene.
TriangleMesh placed_mesh(const ObjectFrameEdit& e, ObjectSource& source);

// Roots (centroid of the voxels of edge `voxel`) of the given frames of `object`, by `voxeliser`.
std::vector<Eigen::Vector2d> frame_roots(ObjectSource& object, const std::vector<int>& numbers, double voxel, Voxeliser& voxeliser);

// The whole edit after the sweep. `sweeps` has one entry per key segment of `scene`, in order.
// Throws amhv::Error naming the segment when a group is empty (unless options.allow_empty).
EditResult edit_scene(const Scene& scene, const std::vector<KeySweep>& sweeps, ObjectSource& a, ObjectSource& b, Voxeliser& voxeliser,
                      const EditOptions& options);

// The root as the sweep's pose mapping uses it (1/4096 voxel fixed point), in metres.
Vec3 sweep_root(const Vec3& root, double voxel);

}  // namespace amhv
