#include "src/edit/edit.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <numbers>
#include <numeric>

#include <Eigen/Geometry>

#include "src/core/angles.hpp"
#include "src/core/clock.hpp"
#include "src/core/error.hpp"
#include "src/core/parallel.hpp"
#include "src/edit/frame_check.hpp"
#include "src/edit/natural.hpp"
#include "src/edit/touch_up.hpp"
#include "host/choose/chain_alternatives.hpp"
#include "host/paths/path_opt.hpp"
#include "src/sweep/pose_map.hpp"

namespace amhv {

namespace {

using angles::nearest_turn;
using angles::radians;

Eigen::Vector2d rotate(double angle, const Eigen::Vector2d& v) { return Eigen::Rotation2Dd(angle) * v; }
Eigen::Vector2d xy(const Vec3& v) { return {v.x(), v.y()}; }

// Per output frame: the facing from the track's gaze on the floor, else the constant facing, else +x;
// unwrapped along the output so consecutive frames never jump by a full turn.
std::vector<double> frame_facings(const ObjectSource& object, const std::vector<int>& numbers) {
    std::vector<double> out;
    const double constant = radians(object.spec().facing_deg.value_or(0.0));
    for (int number : numbers) {
        double f = out.empty() ? constant : out.back();  // no track sample, or looking straight down: keep the last facing
        if (auto sample = object.track(number)) {
            const Eigen::Vector2d g(sample->gaze.x(), sample->gaze.y());
            if (g.norm() > 1e-6) f = std::atan2(g.y(), g.x());
        }
        out.push_back(out.empty() ? f : nearest_turn(f, out.back()));
    }
    return out;
}

}  // namespace

Vec3 sweep_root(const Vec3& root, double voxel) {
    const double scale = double(std::int64_t(1) << posemap::kPositionBits);
    Vec3 out;
    for (int a = 0; a < 3; ++a) out[a] = double(posemap::quantise_root(root[a] / voxel)) / scale * voxel;
    return out;
}

TriangleMesh placed_mesh(const ObjectFrameEdit& e, ObjectSource& source) {
    TriangleMesh mesh;
    for (const BodyPart& part : source.frame_parts(e.source)) mesh.append(part.mesh);
    return moved_into_scene(std::move(mesh), e.yaw, e.translation, e.lift);
}

TriangleMesh placed_mesh(const EditResult& edit, int k, int object, ObjectSource& source) {
    return placed_mesh(edit.frames[std::size_t(object)][std::size_t(k)], source);
}

// Per frame f (bit f of the volume's one word): its voxels' count and the sums of their x and y
// indices. Integers, so the layers' shares on the cores add up to the same sums in any order.
struct IndexSums {
    std::int64_t x = 0, y = 0, count = 0;
};

std::vector<IndexSums> sum_frame_indices(const Amhv& volume, std::size_t count) {
    const VoxelGrid& grid = volume.grid();
    const std::size_t nx = std::size_t(grid.dims[0]), ny = std::size_t(grid.dims[1]), layers = std::size_t(grid.dims[2]);
    const std::size_t parts = std::min<std::size_t>(layers, 4 * core_count());
    std::vector<std::array<IndexSums, 32>> partial(parts);
    parallel_for(parts, [&](std::size_t p) {
        std::array<IndexSums, 32>& sums = partial[p];
        for (std::size_t z = p * layers / parts; z < (p + 1) * layers / parts; ++z)
            for (std::size_t y = 0; y < ny; ++y) {
                const std::uint32_t* row = volume.plane(0) + (z * ny + y) * nx;
                for (std::size_t x = 0; x < nx; ++x) {
                    // A body fills a small part of its grid: eight empty voxels at once.
                    if ((x & 7) == 0 && x + 8 <= nx && eight_words_zero(row + x)) {
                        x += 7;
                        continue;
                    }
                    for (std::uint32_t bits = row[x]; bits; bits &= bits - 1) {
                        IndexSums& s = sums[std::size_t(std::countr_zero(bits))];
                        s.x += std::int64_t(x), s.y += std::int64_t(y), ++s.count;
                    }
                }
            }
    });
    std::vector<IndexSums> total(count);
    for (const auto& sums : partial)
        for (std::size_t f = 0; f < count; ++f) total[f].x += sums[f].x, total[f].y += sums[f].y, total[f].count += sums[f].count;
    return total;
}

std::vector<Eigen::Vector2d> frame_roots(ObjectSource& object, const std::vector<int>& numbers, double voxel, Voxeliser& voxeliser) {
    // A frame's root is the mean of its voxels' centres on the grid covering that frame alone: a
    // property of the frame, whatever frames it is computed with. Frames go 32 at a time (one word
    // of the mask), stacked in a grid the size of the largest frame's (prepare_voxelisation_stacked),
    // not one covering the 32 frames' walk (at 5 mm about a fifth smaller: one frame with its arms
    // out spans most of that walk).
    std::vector<Eigen::Vector2d> roots(numbers.size());
    const Voxeliser::ScratchHold hold(voxeliser);
    for (std::size_t first = 0; first < numbers.size(); first += 32) {
        const std::size_t count = std::min<std::size_t>(32, numbers.size() - first);
        std::vector<MeshFrame> merged(count);
        std::vector<const MeshFrame*> pointers;
        std::vector<VoxelGrid> grids;
        for (std::size_t f = 0; f < count; ++f) {
            const int number = numbers[first + f];
            for (const BodyPart& part : object.frame_parts(number)) merged[f].mesh.append(part.mesh);
            merged[f].source = fmt::format("object {} frame {}", object.spec().name, number);
            grids.push_back(grid_covering(merged[f].mesh.bounds(), voxel, merged[f].source));
            pointers.push_back(&merged[f]);
        }
        const Amhv volume = voxelise(prepare_voxelisation_stacked(pointers, grids), voxeliser);
        const std::vector<IndexSums> sums = sum_frame_indices(volume, count);
        for (std::size_t f = 0; f < count; ++f) {
            const IndexSums& s = sums[f];
            if (s.count == 0) fail(merged[f].source, "occupies no voxel of {} m: the root is undefined", voxel);
            // The mean of the voxels' lattice indices, then its voxel's centre.
            const std::array<std::int64_t, 3> lattice = grids[f].lattice_origin();
            const double n = double(s.count);
            roots[first + f] = Eigen::Vector2d((double(lattice[0] * s.count + s.x) / n + 0.5) * voxel,
                                               (double(lattice[1] * s.count + s.y) / n + 0.5) * voxel);
        }
    }
    return roots;
}

namespace {

// Per-frame roots and facings of every output frame of both objects, each source frame voxelised
// once (docs/method.md section 8), and where the editor's placements put them.
void frame_roots_and_facings(const Scene& scene, ObjectSource* sources[2], Voxeliser& voxeliser, EditResult& r) {
    const Timeline& timeline = r.timeline;
    const int length = timeline.length();
    const SceneObject* specs[2] = {&scene.a, &scene.b};
    for (int o = 0; o < 2; ++o) {
        const std::vector<int>& numbers = o == 0 ? timeline.frame_a : timeline.frame_b;
        std::vector<int> unique = numbers;
        std::sort(unique.begin(), unique.end());
        unique.erase(std::unique(unique.begin(), unique.end()), unique.end());
        const std::vector<Eigen::Vector2d> roots = frame_roots(*sources[o], unique, scene.sampling.voxel, voxeliser);
        const std::vector<double> facings = frame_facings(*sources[o], numbers);
        const Placement& place = specs[o]->placement;
        const double psi = radians(place.yaw_deg);
        auto& frames = r.frames[std::size_t(o)];
        frames.resize(std::size_t(length));
        for (int k = 0; k < length; ++k) {
            ObjectFrameEdit& f = frames[std::size_t(k)];
            f.source = numbers[std::size_t(k)];
            f.root = roots[std::size_t(std::lower_bound(unique.begin(), unique.end(), f.source) - unique.begin())];
            f.facing = facings[std::size_t(k)];
            f.original_root = rotate(psi, f.root) + Eigen::Vector2d(place.x, place.y);
            f.original_facing = f.facing + psi;
        }
    }
}

ChainWeights chain_weights(const Scene& scene) {
    ChainWeights weights;
    weights.voxel = scene.sampling.voxel;
    weights.w_a = scene.weights.w_a;
    weights.w_b = scene.weights.w_b;
    weights.lambda = scene.weights.lambda;
    weights.mu = scene.weights.mu;
    weights.yaw_a = radians(scene.a.placement.yaw_deg);
    weights.yaw_b = radians(scene.b.placement.yaw_deg);
    weights.a_rotations_rad.clear();
    for (double d : scene.weights.a_rotations_deg) weights.a_rotations_rad.push_back(radians(d));
    return weights;
}

// The group's members as chain solutions, in the group's order, a chunk per core: each writes
// its own fresh pages (at 5 mm the solutions are a gigabyte; filled on one core, the kernel's
// clearing of those pages was half the DP's time).
void fill_solutions(const KeySweep& s, ChainSolutions& out) {
    constexpr std::uint64_t kChunk = std::uint64_t(1) << 20;
    const std::uint64_t n = s.group.size();
    parallel_for(std::size_t((n + kChunk - 1) / kChunk), [&](std::size_t chunk) {
        std::uint64_t at = chunk * kChunk;
        // theta of angle index k, once per run of equal k (the group's order is (z, theta, y, x)).
        int angle = std::numeric_limits<int>::min();
        double theta = 0;
        s.group.for_range(at, std::min(n, at + kChunk), [&](const PoseIndex& p) {
            if (p.k != angle) angle = p.k, theta = radians(s.describe.theta_deg(p.k));
            out[at++] = {p.i, p.j, theta};
        });
    });
}

// The DP's chain (docs/method.md section 7): each key segment's solutions as states, with the
// pose where the editor's placements put B as the prior. An empty group stops the edit, or with
// --allow-empty becomes the one state of B's captured placement on the lattice (`captured`, its
// angle index in `captured_k`).
std::vector<ChainSegment> make_chain(const Scene& scene, const std::vector<KeySweep>& sweeps, const EditOptions& options,
                                     std::vector<std::vector<double>>& natural, std::vector<bool>& captured, std::vector<int>& captured_k) {
    const double h = scene.sampling.voxel;
    const double psi_a = radians(scene.a.placement.yaw_deg), psi_b = radians(scene.b.placement.yaw_deg);
    const Eigen::Vector2d place_a(scene.a.placement.x, scene.a.placement.y), place_b(scene.b.placement.x, scene.b.placement.y);
    const double step = radians(scene.sampling.angle_step_deg);
    std::vector<ChainSegment> chain(sweeps.size());
    captured.assign(sweeps.size(), false);
    captured_k.assign(sweeps.size(), 0);
    for (std::size_t i = 0; i < sweeps.size(); ++i) {
        const KeySweep& s = sweeps[i];
        const KeySegment& key = scene.segments[i];
        ChainSegment& c = chain[i];
        c.root_a = xy(sweep_root(s.root_a, h));
        c.root_b = xy(sweep_root(s.root_b, h));
        // Where the editor's placements put B relative to A, in A's capture axes.
        c.prior_offset = rotate(-psi_a, (rotate(psi_b, c.root_b) + place_b) - (rotate(psi_a, c.root_a) + place_a));
        c.prior_theta_rad = psi_b - psi_a;
        c.solutions.resize(s.group.size());
        fill_solutions(s, c.solutions);
        // The editor's placements leave B's height as captured (z = 0): with z_range the prior
        // gains mu z^2, so that among equal poses the one least raised or lowered wins.
        // The natural choice (section 7b) adds natural_weight() times each member's score.
        const bool scored = i < natural.size() && !natural[i].empty();
        const double natural_scale = natural_weight(scene, key);
        // One key segment chosen by the natural score: B's capture-frame yaw is the editor's
        // arbitrary placement, not a datum, and with no pairwise term the objective minimised over
        // that yaw loses B's facing term exactly (docs/method.md section 7).
        if (sweeps.size() == 1 && scored && !key.intent.prefers()) c.facing_b_weight = 0;
        if (scored && !key.intent.prefers() && !s.group.any_raised()) {
            // Only the natural score: the chain takes the scores themselves, weighted in place.
            c.extra_unary = std::move(natural[i]);
            for (double& u : c.extra_unary) u *= natural_scale;
        } else if (key.intent.prefers() || s.group.any_raised() || scored) {
            c.extra_unary.reserve(s.group.size());
            std::size_t n = 0;
            s.group.for_each([&](const PoseIndex& p) {
                const Solution sol = s.describe(p);
                const double score = scored ? natural_scale * natural[i][n++] : 0.0;
                c.extra_unary.push_back(intent_cost(key.intent, sol) + scene.weights.mu * sol.z * sol.z + score);
            });
        }
        if (scored) std::vector<double>().swap(natural[i]);  // in the unary terms now
        if (!c.solutions.empty()) continue;
        if (!options.allow_empty)
            throw Error(fmt::format("{}: key segment {} ({}) has no solution among {} poses (rejected by {}); "
                                    "change its type, parts or visibility, or pass --allow-empty to keep {}'s captured placement there",
                                    scene.file.string(), key.index, key.type.name(), s.poses_tested, rejection_counts(s.rejected), scene.b.name));
        // The captured placement, on the sweep's lattice (within h/2 and half an angle step).
        captured[i] = true;
        const int k = int(std::lround(c.prior_theta_rad / step));
        captured_k[i] = k;
        c.solutions.push_back({int(std::lround(c.prior_offset.x() / h)), int(std::lround(c.prior_offset.y() / h)), k * step});
    }
    return chain;
}

// The rigid move of each key segment pair from the DP's choice, and every key frame's transform:
// capture -> scene is R(yaw) (p - C_i) + C-bar_i.
void place_key_segments(const Scene& scene, const std::vector<KeySweep>& sweeps, const std::vector<ChainSegment>& chain,
                        const std::vector<bool>& captured, const std::vector<int>& captured_k, const ChainWeights& weights,
                        EditResult& r) {
    const double h = scene.sampling.voxel;
    const double psi_a = weights.yaw_a, psi_b = weights.yaw_b;
    const Eigen::Vector2d place_a(scene.a.placement.x, scene.a.placement.y);
    const std::vector<Eigen::Vector2d> steps = a_translation_steps(chain, weights, r.choice);
    Eigen::Vector2d t = Eigen::Vector2d::Zero();
    for (std::size_t i = 0; i < chain.size(); ++i) {
        const int j = r.choice.solution[i];
        const ChainSolution& sol = chain[i].solutions[std::size_t(j)];
        KeyEdit k;
        k.index = scene.segments[i].index;
        k.captured = captured[i];
        k.solution = captured[i] ? -1 : j;
        k.a_rotation_rad = weights.a_rotations_rad[std::size_t(r.choice.rotation[i])];
        if (i > 0) t += steps[i - 1];
        k.a_translation = t;
        const double previous_a = i == 0 ? psi_a : r.keys.back().yaw_a, previous_b = i == 0 ? psi_b : r.keys.back().yaw_b;
        k.yaw_a = nearest_turn(psi_a + k.a_rotation_rad, previous_a);
        k.yaw_b = nearest_turn(psi_a + k.a_rotation_rad + sol.theta_rad, previous_b);
        const Eigen::Vector2d offset(sol.i * h, sol.j * h);
        k.root_a = rotate(psi_a, chain[i].root_a) + place_a + t;
        k.root_b = k.root_a + rotate(psi_a + k.a_rotation_rad, offset);
        // The descriptors of the state used (for a captured placement, of its lattice pose).
        k.chosen.i = sol.i;
        k.chosen.j = sol.j;
        k.chosen.x = offset.x();
        k.chosen.y = offset.y();
        k.chosen.theta_deg = angles::degrees(sol.theta_rad);
        k.chosen.k = captured_k[i];
        if (!captured[i]) k.chosen = sweeps[i].describe(sweeps[i].group.at(std::uint64_t(j)));
        r.keys.push_back(k);
        const TimelineSegment& seg = *std::find_if(r.timeline.segments.begin(), r.timeline.segments.end(),
                                                   [&](const TimelineSegment& s) { return s.key == k.index; });
        for (int o = 0; o < 2; ++o) {
            const double yaw = o == 0 ? k.yaw_a : k.yaw_b;
            const Eigen::Vector2d translation = (o == 0 ? k.root_a : k.root_b) - rotate(yaw, o == 0 ? chain[i].root_a : chain[i].root_b);
            for (int m = seg.first; m < seg.first + seg.length; ++m) {
                ObjectFrameEdit& f = r.frames[std::size_t(o)][std::size_t(m)];
                f.yaw = yaw;
                f.translation = translation;
                f.lift = o == 1 ? k.chosen.z : 0.0;
                f.edited_root = rotate(yaw, f.root) + translation;
                f.edited_facing = f.facing + yaw;
            }
        }
    }
}

// One object's path through one transitional segment (docs/method.md section 8), between the
// edited ends of the key segments around it (one free end before the first and after the last).
PathReport optimise_transition(const TimelineSegment& seg, int segment_index, int o, const PathWeights& pw, EditResult& r,
                               const std::map<int, Eigen::Vector2d>& targets = {}) {
    const int length = r.timeline.length();
    const bool before = seg.first > 0, after = seg.first + seg.length < length;
    const int first = seg.first - (before ? 1 : 0), last = seg.first + seg.length - 1 + (after ? 1 : 0);
    auto& frames = r.frames[std::size_t(o)];
    PathProblem p;
    for (int m = first; m <= last; ++m) {
        p.roots.push_back(frames[std::size_t(m)].original_root);
        p.facings.push_back(frames[std::size_t(m)].original_facing);
    }
    if (before) p.first = PathEnd{frames[std::size_t(first)].edited_root, frames[std::size_t(first)].edited_facing};
    if (after) p.last = PathEnd{frames[std::size_t(last)].edited_root, frames[std::size_t(last)].edited_facing};
    // The turn the edit gives the object, blended between the key segments' turns.
    auto turn_at = [&](int m) { return frames[std::size_t(m)].edited_facing - frames[std::size_t(m)].original_facing; };
    const double turn_first = before ? turn_at(first) : turn_at(last), turn_last = after ? turn_at(last) : turn_first;
    for (int m = first; m <= last; ++m)
        p.turns.push_back(turn_first + (turn_last - turn_first) * (last > first ? double(m - first) / (last - first) : 0.0));
    // B's height, blended the same way (the ends hold the key segment's).
    const double lift_first = before ? frames[std::size_t(first)].lift : frames[std::size_t(last)].lift;
    const double lift_last = after ? frames[std::size_t(last)].lift : lift_first;
    for (int m = seg.first; m < seg.first + seg.length; ++m)
        frames[std::size_t(m)].lift = lift_first + (lift_last - lift_first) * (last > first ? double(m - first) / (last - first) : 0.0);
    for (const auto& [m, point] : targets) p.targets.push_back({m - first, point});
    const PathSolution sol = optimise_path(p, pw);
    PathReport report{segment_index, o, seg.length, sol.root_cost, sol.facing_cost, 0};
    for (int m = seg.first; m < seg.first + seg.length; ++m) {
        ObjectFrameEdit& f = frames[std::size_t(m)];
        f.edited_root = sol.roots[std::size_t(m - first)];
        f.edited_facing = sol.facings[std::size_t(m - first)];
        f.yaw = f.edited_facing - f.facing;
        f.translation = f.edited_root - rotate(f.yaw, f.root);
        report.max_shift_m = std::max(report.max_shift_m, (f.edited_root - f.original_root).norm());
    }
    return report;
}

// A fixed A through a transitional segment: every frame where the editor's placement puts it.
void keep_in_place(const TimelineSegment& seg, double yaw, EditResult& r) {
    for (int m = seg.first; m < seg.first + seg.length; ++m) {
        ObjectFrameEdit& f = r.frames[0][std::size_t(m)];
        f.edited_root = f.original_root;
        f.edited_facing = f.original_facing;
        f.yaw = yaw;
        f.translation = f.original_root - rotate(yaw, f.root);
    }
}

// Separation gives up when kStallRounds rounds in a row free no frame and lower the largest
// overlap below its best (the pushes are not freeing the transition: choosing the key poses again
// costs less and bends the paths less than pushing the performers metres apart), and after
// kSeparationRounds in all. A few rounds without progress are normal while a push accumulates: the
// overlap of a frame being pushed wavers by a few voxels for up to 4 rounds on the paper scene at
// 5 mm before it frees (docs/method.md section 8a).
constexpr int kSeparationRounds = 24, kStallRounds = 6;

// Frame numbers as "39-86, 127" for messages.
std::string frame_ranges(const std::vector<int>& frames) {
    std::string out;
    for (std::size_t i = 0; i < frames.size();) {
        std::size_t j = i;
        while (j + 1 < frames.size() && frames[j + 1] == frames[j] + 1) ++j;
        out += fmt::format("{}{}", out.empty() ? "" : ", ", i == j ? fmt::format("{}", frames[i]) : fmt::format("{}-{}", frames[i], frames[j]));
        i = j + 1;
    }
    return out;
}

// The output frames of one timeline segment.
std::vector<int> segment_frames(const TimelineSegment& seg) {
    std::vector<int> frames(std::size_t(seg.length));
    std::iota(frames.begin(), frames.end(), seg.first);
    return frames;
}

struct SeparationContext {
    const Scene& scene;
    ObjectSource* sources[2];
    Voxeliser& voxeliser;
    PathWeights weights;
};

// One transitional segment kept free of overlap (docs/method.md section 8a): where the check finds
// the two bodies inside each other, each root gets a target pushed apart along the line between the
// roots by the overlap's depth and one voxel (shared as the DP shares A's translations: A moves
// w_B / (w_A + w_B) of it), the paths are solved again with those targets, and the frames checked
// again, until none overlaps.
TransitionCheck separate_transition(const SeparationContext& c, int s, const EditOptions& options, EditResult& r, std::vector<FrameCheck>& checks) {
    const TimelineSegment seg = r.timeline.segments[std::size_t(s)];
    const double h = c.scene.sampling.voxel;
    const std::vector<int> frames = segment_frames(seg);
    TransitionCheck t;
    t.timeline_segment = s;
    t.frames = seg.length;
    auto tally = [&](int& overlapping, std::uint64_t& largest) {
        overlapping = 0, largest = 0;
        for (const FrameCheck& f : checks) overlapping += f.overlap > 0, largest = std::max(largest, f.overlap);
    };
    auto smoothness = [&] {
        double sum = 0;
        for (const PathReport& p : r.paths)
            if (p.timeline_segment == s) sum += p.root_cost + p.facing_cost;
        return sum;
    };
    // A check that finds an overlap is followed by another round, or the transition is stuck: its
    // gaps are never reported (with overlap allowed, the first check is the one reported).
    const Gaps gaps = options.allow_transition_overlap ? Gaps::Every : Gaps::UntilAnOverlap;
    checks = check_frames(r, frames, *c.sources[0], *c.sources[1], h, c.voxeliser, gaps);
    tally(t.overlapping_before, t.max_overlap_before);
    t.smoothness_before = t.smoothness = smoothness();
    // Progress: fewer overlapping frames, or as many with a smaller largest overlap.
    std::pair<int, std::uint64_t> best{t.overlapping_before, t.max_overlap_before};
    int stalled = 0;
    const double w_a = c.scene.weights.w_a, w_b = c.scene.weights.w_b;
    const double share_a = std::isinf(w_a) ? 0.0 : w_b / (w_a + w_b);
    std::array<std::map<int, Eigen::Vector2d>, 2> targets;
    for (; t.rounds < kSeparationRounds && stalled < kStallRounds && !options.allow_transition_overlap; ++t.rounds) {
        bool any = false;
        for (const FrameCheck& f : checks) {
            if (f.overlap == 0) continue;
            any = true;
            const Eigen::Vector2d push = f.apart * (f.depth_m + h);
            targets[0][f.frame] = r.frames[0][std::size_t(f.frame)].edited_root - share_a * push;
            targets[1][f.frame] = r.frames[1][std::size_t(f.frame)].edited_root + (1 - share_a) * push;
        }
        if (!any) break;
        for (PathReport& p : r.paths)
            if (p.timeline_segment == s) p = optimise_transition(seg, s, p.object, c.weights, r, targets[std::size_t(p.object)]);
        checks = check_frames(r, frames, *c.sources[0], *c.sources[1], h, c.voxeliser, gaps);
        std::pair<int, std::uint64_t> now;
        tally(now.first, now.second);
        if (now < best) best = now, stalled = 0;
        else ++stalled;
    }
    tally(t.overlapping, t.max_overlap);
    t.smoothness = smoothness();
    return t;
}

// A transition separation could not free, for the error that names it.
struct StuckTransition {
    int timeline_segment = -1;
    std::string message;
};

std::string stuck_message(const Scene& scene, const TransitionCheck& t, const std::vector<FrameCheck>& checks, const TimelineSegment& seg) {
    std::vector<int> bad;
    for (const FrameCheck& f : checks)
        if (f.overlap > 0) bad.push_back(f.frame);
    return fmt::format("{}: transition {} (output frames {}) keeps the performers inside each other at frames {} ({} voxels at most) after {} rounds "
                       "of separation",
                       scene.file.string(), t.timeline_segment / 2, frame_ranges(segment_frames(seg)), frame_ranges(bad), t.max_overlap, t.rounds);
}

// What a segment's check depends on and what it gave, kept from one choice of the key poses to
// the next (docs/method.md section 8a): a segment whose frames, and the frames either side of it
// (a transition's ends), are placed as before checks and separates as before, so the next choice
// reuses its outcome instead of checking it again. The check is a function of those frames alone
// (the bodies and the voxel are fixed), so the outcome is the same bytes either way.
struct CheckedSegment {
    std::array<std::vector<ObjectFrameEdit>, 2> placed;  // r.frames over [first - 1, last + 1], as placed
    std::array<std::vector<ObjectFrameEdit>, 2> result;  // the same frames after separation
    std::vector<PathReport> paths;                       // the segment's paths after separation
    std::optional<TransitionCheck> transition;
    std::vector<FrameCheck> checks;
};
using CheckCache = std::map<int, CheckedSegment>;

// r.frames over segment `seg` and the frame either side of it (where there is one).
std::array<std::vector<ObjectFrameEdit>, 2> frames_around(const TimelineSegment& seg, const EditResult& r) {
    const int first = std::max(0, seg.first - 1), last = std::min(r.timeline.length() - 1, seg.first + seg.length);
    std::array<std::vector<ObjectFrameEdit>, 2> out;
    for (int o = 0; o < 2; ++o) out[std::size_t(o)].assign(r.frames[std::size_t(o)].begin() + first, r.frames[std::size_t(o)].begin() + last + 1);
    return out;
}

// Segment `s` as `cached` left it: its frames, paths and transition check (the caller adds its
// frame checks).
void reuse(const CheckedSegment& cached, int s, EditResult& r) {
    const TimelineSegment& seg = r.timeline.segments[std::size_t(s)];
    const int first = std::max(0, seg.first - 1);
    for (int o = 0; o < 2; ++o) std::copy(cached.result[std::size_t(o)].begin(), cached.result[std::size_t(o)].end(), r.frames[std::size_t(o)].begin() + first);
    std::size_t next = 0;
    for (PathReport& p : r.paths)
        if (p.timeline_segment == s) p = cached.paths[next++];
    if (cached.transition) r.transition_checks.push_back(*cached.transition);
}

// Every output frame checked (frame_checks); every transitional segment separated where it
// overlaps. Stops at the first transition that stays overlapping (unless overlap is allowed).
// Segments placed as in an earlier choice reuse that choice's outcome (`cache`).
std::optional<StuckTransition> check_and_separate(const SeparationContext& c, const EditOptions& options, EditResult& r, CheckCache& cache) {
    std::vector<FrameCheck> all;
    for (std::size_t s = 0; s < r.timeline.segments.size(); ++s) {
        const TimelineSegment& seg = r.timeline.segments[s];
        if (seg.length == 0) continue;
        std::array<std::vector<ObjectFrameEdit>, 2> placed = frames_around(seg, r);
        if (const auto hit = cache.find(int(s)); hit != cache.end() && hit->second.placed == placed) {
            reuse(hit->second, int(s), r);
            all.insert(all.end(), hit->second.checks.begin(), hit->second.checks.end());
            continue;
        }
        CheckedSegment entry;
        entry.placed = std::move(placed);
        if (seg.key == 0) {
            r.transition_checks.push_back(separate_transition(c, int(s), options, r, entry.checks));
            if (r.transition_checks.back().overlapping > 0 && !options.allow_transition_overlap)
                return StuckTransition{int(s), stuck_message(c.scene, r.transition_checks.back(), entry.checks, seg)};
            entry.transition = r.transition_checks.back();
            for (const PathReport& p : r.paths)
                if (p.timeline_segment == int(s)) entry.paths.push_back(p);
        } else {
            entry.checks = check_frames(r, segment_frames(seg), *c.sources[0], *c.sources[1], c.scene.sampling.voxel, c.voxeliser);
        }
        entry.result = frames_around(seg, r);
        all.insert(all.end(), entry.checks.begin(), entry.checks.end());
        cache[int(s)] = std::move(entry);
    }
    std::sort(all.begin(), all.end(), [](const FrameCheck& x, const FrameCheck& y) { return x.frame < y.frame; });
    r.frame_checks = std::move(all);
    return std::nullopt;
}

// The key segments (chain indices) at the two ends of timeline segment `s`: one before the first
// key segment or after the last, else two.
std::vector<std::size_t> keys_around(const Scene& scene, const Timeline& timeline, int s) {
    std::vector<std::size_t> keys;
    for (int n : {s - 1, s + 1}) {
        if (n < 0 || n >= int(timeline.segments.size()) || timeline.segments[std::size_t(n)].key == 0) continue;
        for (std::size_t i = 0; i < scene.segments.size(); ++i)
            if (scene.segments[i].index == timeline.segments[std::size_t(n)].key) keys.push_back(i);
    }
    return keys;
}

PathWeights path_weights(const Scene& scene) {
    PathWeights pw;
    pw.delta = scene.weights.delta;
    pw.lambda = scene.weights.lambda;
    pw.alpha = scene.weights.alpha;
    pw.v_c = scene.weights.v_c;
    pw.r_c = scene.weights.r_c;
    return pw;
}

// Places the key segments by `choice`, solves every transitional path and checks every frame,
// separating where transitions overlap (docs/method.md sections 7, 8 and 8a).
std::optional<StuckTransition> realise_choice(const Scene& scene, const std::vector<KeySweep>& sweeps, const std::vector<ChainSegment>& chain,
                                              const std::vector<bool>& captured, const std::vector<int>& captured_k, const ChainWeights& weights,
                                              const SeparationContext& c, const EditOptions& options, EditResult& r, CheckCache& cache) {
    r.keys.clear();
    r.paths.clear();
    r.transition_checks.clear();
    r.frame_checks.clear();
    auto t0 = std::chrono::steady_clock::now();
    place_key_segments(scene, sweeps, chain, captured, captured_k, weights, r);
    for (std::size_t s = 0; s < r.timeline.segments.size(); ++s) {  // transitional segments, each object on its own
        const TimelineSegment seg = r.timeline.segments[s];
        if (seg.key != 0 || seg.length == 0) continue;
        if (options.fixed_a) keep_in_place(seg, weights.yaw_a, r);
        for (int o = options.fixed_a ? 1 : 0; o < 2; ++o) r.paths.push_back(optimise_transition(seg, int(s), o, c.weights, r));
    }
    r.path_seconds += seconds_since(t0);
    t0 = std::chrono::steady_clock::now();
    std::optional<StuckTransition> stuck = check_and_separate(c, options, r, cache);
    r.check_seconds += seconds_since(t0);
    return stuck;
}

// The scene's [truth] as a pose of the sweep's lattice (nearest x, y and angle step, not raised).
PoseIndex truth_pose(const Scene& scene, const KeySweep& s) {
    const Placement& t = *scene.truth;
    const double h = scene.sampling.voxel, step = scene.sampling.angle_step_deg;
    const Eigen::Vector2d offset = truth_offset(t, s.root_a, s.root_b);
    const int angles = scene.sampling.angles();
    const int k = ((int(std::lround(t.yaw_deg / step)) % angles) + angles) % angles;
    return {int(std::lround(offset.x() / h)), int(std::lround(offset.y() / h)), k, 0};
}

// Every key segment's natural scores (docs/method.md section 7b), when weights.natural > 0: the
// members' costs for the DP, and the chosen and runner-up members' terms for result.json.
struct NaturalChoice {
    struct Key {
        std::unique_ptr<NaturalScorer> scorer;
        std::array<std::uint64_t, 2> best;  // the two best members (the group's size: none)
        NaturalReport report;               // key, weight and the page's sample; the rest after the DP
    };
    std::vector<Key> keys;
    // Every member's score per key segment, until the chain takes them (make_chain frees them).
    std::vector<std::vector<double>> costs;
    double seconds = 0;

    NaturalChoice(const Scene& scene, const std::vector<KeySweep>& sweeps, const EditResult& r, ObjectSource& a, ObjectSource& b,
                  Voxeliser& voxeliser, std::uint64_t page_members) {
        if (!(scene.weights.natural > 0)) return;
        const auto t0 = std::chrono::steady_clock::now();
        for (std::size_t i = 0; i < sweeps.size(); ++i) {
            const KeySegment& key = scene.segments[i];
            Key& k = keys.emplace_back();
            k.scorer = std::make_unique<NaturalScorer>(key, sweeps[i], natural_frames(r, key.index, scene.a.fps), a, b, voxeliser,
                                                       scene.sampling.angles());
            const std::vector<double>& c = costs.emplace_back(k.scorer->costs(sweeps[i].group));
            k.best = {c.size(), c.size()};
            for (std::uint64_t m = 0; m < c.size(); ++m) {
                if (k.best[0] == c.size() || c[m] < c[k.best[0]]) k.best = {m, k.best[0]};
                else if (k.best[1] == c.size() || c[m] < c[k.best[1]]) k.best[1] = m;
            }
            k.report.key = key.index;
            k.report.weight = natural_weight(scene, key);
            k.report.stride = sample_stride(c.size(), page_members);
            for (std::uint64_t m = 0; m < c.size(); m += k.report.stride) k.report.sampled.push_back(float(c[m]));
        }
        seconds = seconds_since(t0);
    }

    void report(const Scene& scene, const std::vector<KeySweep>& sweeps, EditResult& r) const {
        r.natural_seconds = seconds;
        r.natural.clear();
        for (std::size_t i = 0; i < keys.size(); ++i) {
            const Key& key = keys[i];
            NaturalReport n = key.report;
            const KeyEdit& k = r.keys[i];
            if (!k.captured) n.chosen = key.scorer->terms(sweeps[i].group.at(std::uint64_t(k.solution)));
            const std::uint64_t runner = key.best[0] != std::uint64_t(k.solution) || k.captured ? key.best[0] : key.best[1];
            if (runner < sweeps[i].group.size()) {
                const PoseIndex p = sweeps[i].group.at(runner);
                n.has_runner_up = true;
                n.runner_up = key.scorer->terms(p);
                n.runner_up_pose = sweeps[i].describe(p);
            }
            if (scene.truth) {
                n.has_truth = true;
                n.truth = key.scorer->terms(truth_pose(scene, sweeps[i]));
            }
            r.natural.push_back(std::move(n));
        }
    }
};

}  // namespace

EditResult edit_scene(const Scene& scene, const std::vector<KeySweep>& sweeps, ObjectSource& a, ObjectSource& b, Voxeliser& voxeliser,
                      const EditOptions& options) {
    EditResult r;
    r.timeline = make_timeline(scene);
    if (sweeps.size() != scene.segments.size())
        throw Error(fmt::format("{}: the edit needs the sweep of all {} key segments, got {}", scene.file.string(), scene.segments.size(), sweeps.size()));
    ObjectSource* sources[2] = {&a, &b};

    auto t0 = std::chrono::steady_clock::now();
    frame_roots_and_facings(scene, sources, voxeliser, r);
    r.roots_seconds = seconds_since(t0);

    NaturalChoice natural(scene, sweeps, r, a, b, voxeliser, options.natural_sampled);
    // One solution per key segment (docs/method.md section 7); again without the key poses around a
    // transition that cannot be freed (section 8a), up to kMaxKeyChoices choices.
    t0 = std::chrono::steady_clock::now();
    const ChainWeights weights = chain_weights(scene);
    std::vector<bool> captured;
    std::vector<int> captured_k;
    const std::vector<ChainSegment> chain = make_chain(scene, sweeps, options, natural.costs, captured, captured_k);
    ChainAlternatives alternatives(chain, weights);
    r.dp_seconds = seconds_since(t0);
    r.voxel = scene.sampling.voxel;
    const SeparationContext context{scene, {&a, &b}, voxeliser, path_weights(scene)};
    std::string first_stuck;
    ExactKeys exact;
    CheckCache checked;
    for (r.choices_tried = 1;; ++r.choices_tried) {
        t0 = std::chrono::steady_clock::now();
        std::optional<ChainChoice> choice = alternatives.next();
        r.dp_seconds += seconds_since(t0);
        if (!choice)
            throw Error(fmt::format("{}, and no other choice of the key poses around it is left ({} tried); change the key segments around it, "
                                    "or pass --allow-transition-overlap",
                                    first_stuck, r.choices_tried - 1));
        r.choice = std::move(*choice);
        r.touch_ups = touch_up_choice(scene, sweeps, a, b, voxeliser, captured, exact, r.choice);
        const std::optional<StuckTransition> stuck = realise_choice(scene, sweeps, chain, captured, captured_k, weights, context, options, r, checked);
        if (!stuck) {
            natural.report(scene, sweeps, r);
            return r;
        }
        if (first_stuck.empty()) first_stuck = stuck->message;
        if (r.choices_tried == kMaxKeyChoices)
            throw Error(fmt::format("{}, and so did the next {} choices of the key poses without the ones around it; change the key segments "
                                    "around it, or pass --allow-transition-overlap",
                                    first_stuck, kMaxKeyChoices - 1));
        t0 = std::chrono::steady_clock::now();
        alternatives.rule_out(keys_around(scene, r.timeline, stuck->timeline_segment), kRuleOutRadius);
        r.dp_seconds += seconds_since(t0);
    }
}

}  // namespace amhv
