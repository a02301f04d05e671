// The placement sweep: the Vulkan path against the plain CPU reference (identical outcome for every
// pose), and both against solution sets known in closed form.
#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <numeric>
#include <random>
#include <tuple>

#include <gtest/gtest.h>

#include "src/body/shapes.hpp"
#include "src/core/error.hpp"
#include "src/core/parallel.hpp"
#include "src/sweep/sweep_vulkan.hpp"
#include "host/reference/pose_probe.hpp"
#include "host/reference/sweep_reference.hpp"
#include "host/reference/voxelise_reference.hpp"
#include "src/sweep/column_volume.hpp"
#include "src/sweep/objects.hpp"
#include "src/results/group_vdb.hpp"
#include "src/sweep/slice_runs.hpp"
#include "src/sweep/solution_group.hpp"
#include "support.hpp"

namespace amhv {
namespace {

// A performer: per frame a body (any closed parts) and a separate interest part.
struct Performer {
    std::vector<MeshFrame> body, part;
};

SweepObject object_from(const std::string& name, const Performer& p, double voxel, ObjectParts parts = {},
                        Eigen::Vector2d facing = Eigen::Vector2d::UnitX()) {
    std::vector<ObjectFrame> frames(p.body.size());
    for (std::size_t f = 0; f < frames.size(); ++f) {
        frames[f].whole = {&p.body[f]};
        if (!p.part.empty()) frames[f].interest = {&p.part[f]};
    }
    ReferenceVoxeliser voxeliser;
    SweepObject object = build_sweep_object(name, frames, parts, voxel, voxeliser);
    object.facing = facing;
    return object;
}

SweepProblem problem_of(SweepObject a, SweepObject b, const std::string& type, double voxel, double angle_step) {
    SweepProblem problem;
    problem.a = std::move(a);
    problem.b = std::move(b);
    problem.type = parse_interaction_type(type, "test");
    problem.voxel = voxel;
    problem.angle_step_deg = angle_step;
    problem.range = automatic_range(problem.a, problem.b, voxel, int(std::lround(360.0 / angle_step)));
    return problem;
}

struct BothResults {
    SweepResult reference, gpu;
};

BothResults sweep_both(const SweepProblem& problem, gpu::SweeperOptions options = {}) {
    ReferenceSweeper reference;
    gpu::VulkanSweeper vulkan(test::context(), options);
    BothResults both{reference.sweep(problem), vulkan.sweep(problem)};
    test::expect_no_validation_messages();
    return both;
}

void expect_identical(const BothResults& both) {
    ASSERT_EQ(both.reference.outcomes.size(), both.gpu.outcomes.size());
    std::size_t differing = 0, first = 0;
    for (std::size_t i = 0; i < both.gpu.outcomes.size(); ++i)
        if (both.reference.outcomes[i] != both.gpu.outcomes[i] && differing++ == 0) first = i;
    EXPECT_EQ(differing, 0u) << "first differing pose " << first << ": reference " << int(both.reference.outcomes[first]) << ", vulkan "
                             << int(both.gpu.outcomes[first]);
    EXPECT_EQ(both.reference.rejected, both.gpu.rejected);
    EXPECT_EQ(both.reference.solutions, both.gpu.solutions);
}

MeshFrame frame_of(TriangleMesh mesh, int f) { return {std::move(mesh), "frame " + std::to_string(f)}; }

// A random performer: a body that drifts and an arm whose hand (the interest part) moves, over
// `frames` frames; `hand_heights` varies the hand's starting height too.
Performer random_performer(std::mt19937& random, int frames, bool hand_heights) {
    std::uniform_real_distribution<double> u(-1, 1);
    Performer p;
    Vec3 body0(u(random) * 0.2, u(random) * 0.2, 0.9), body_v(u(random) * 0.15, u(random) * 0.15, 0);
    Vec3 hand0 = hand_heights ? Vec3(u(random) * 0.2 + 0.35, u(random) * 0.2, 1.2 + 0.1 * u(random)) : Vec3(u(random) * 0.2 + 0.35, u(random) * 0.2, 1.2);
    Vec3 hand_v(u(random) * 0.4, u(random) * 0.4, u(random) * 0.2);
    for (int f = 0; f < frames; ++f) {
        double s = double(f) / (frames - 1);
        Vec3 c = body0 + s * body_v, hand = hand0 + s * hand_v;
        TriangleMesh body = shapes::capsule(c - Vec3(0, 0, 0.5), c + Vec3(0, 0, 0.5), 0.16, 3, 10);
        body.append(shapes::capsule(c + Vec3(0, 0, 0.3), hand, 0.05, 2, 8));  // the arm
        p.body.push_back(frame_of(body, f));
        p.part.push_back(frame_of(shapes::sphere(hand, 0.07 + 0.03 * std::abs(u(random)), 6, 10), f));
    }
    return p;
}

// Visibility on: each object's cone from 60 cm above its root along its facing, 25 degrees, over a
// region of 3.2 x 3.2 x 2 m around it.
void add_view_cones(SweepProblem& problem, double voxel) {
    problem.visibility = true;
    for (auto* obj : {&problem.a, &problem.b}) {
        Box3 region;
        region.min = obj->root - Vec3(1.6, 1.6, 1.0);
        region.max = obj->root + Vec3(1.6, 1.6, 1.0);
        ViewCone cone{obj->root + Vec3(0, 0, 0.6), Vec3(obj->facing.x(), obj->facing.y(), -0.2).normalized(), 25, 0};
        obj->view_cone = view_cone_volume(cone, region, voxel);
    }
}

// Two static spheres of radius r, contact by 0&0 (b): solutions are the offsets with |s| < 2r, at
// every angle, up to the voxelisation (one voxel either side).
TEST(Sweep, StaticSpheresTouchWithinTwoRadii) {
    const double h = 0.02, r = 0.15;
    Performer a, b;
    for (int f = 0; f < 4; ++f) {
        a.body.push_back(frame_of(shapes::sphere(Vec3(0.3, -0.2, 1.0), r), f));
        b.body.push_back(frame_of(shapes::sphere(Vec3(-2.0, 4.0, 1.0), r), f));
    }
    ObjectParts whole{.interest = PartRule::Whole};
    auto problem = problem_of(object_from("A", a, h, whole), object_from("B", b, h, whole), "0&0b", h, 30);
    auto both = sweep_both(problem);
    expect_identical(both);
    ASSERT_GT(both.gpu.solutions, 0u);
    solution_group(both.gpu).for_each([&](const PoseIndex& p) { EXPECT_LT(describe(problem, p.i, p.j, p.k, p.l).distance, 2 * r + 2 * h); });
    const PoseRange& range = both.gpu.range;
    for (int k = 0; k < range.angles; ++k)
        for (int j = range.j_first; j <= range.j_last; ++j)
            for (int i = range.i_first; i <= range.i_last; ++i)
                if (std::hypot(i * h, j * h) < 2 * r - 2 * h) {
                    EXPECT_EQ(both.gpu.at(i, j, k), PoseOutcome::Solution) << i << " " << j << " " << k;
                }
}

// A punch (+ & 0): A's fist moves +x from x = -0.3 to 0 and stops; B is a static ball. With B on
// the x axis in front of the fist's final position the contact is on A's end surface (a solution);
// behind it B meets the fist's path, which is not the end surface (rejected by the dictionary).
TEST(Sweep, PunchMeetsOnlyTheEndSurface) {
    const double h = 0.02, r = 0.08;
    const int frames = 8;
    Performer a, b;
    for (int f = 0; f < frames; ++f) {
        double x = -0.3 + 0.3 * f / (frames - 1);
        a.body.push_back(frame_of(shapes::box(Vec3(-0.9, -0.15, 0.0), Vec3(-0.5, 0.15, 1.8)), f));
        a.part.push_back(frame_of(shapes::sphere(Vec3(x, 0, 1.4), r), f));
        b.body.push_back(frame_of(shapes::sphere(Vec3(0, 0, 1.4), r), f));
    }
    ObjectParts whole{.interest = PartRule::Whole};
    SweepObject A = object_from("A", a, h), B = object_from("B", b, h, whole);
    auto problem = problem_of(A, B, "+&0", h, 90);
    auto both = sweep_both(problem);
    expect_identical(both);
    // Offsets are relative to A's root (its body and fist together); find the fist's end on the axis.
    const double fist_end_x = 0.0 - problem.a.root.x(), axis_y = 0.0 - problem.a.root.y();
    const int j = int(std::lround(axis_y / h));
    for (int k = 0; k < 4; ++k) {
        // B's ball centred 1.5 r in front of the fist's final centre: touches the end surface only.
        int i_front = int(std::lround((fist_end_x + 1.5 * r) / h));
        EXPECT_EQ(both.gpu.at(i_front, j, k), PoseOutcome::Solution) << "angle " << k;
        // B's ball in the middle of the path: contact off the end surface.
        int i_path = int(std::lround((fist_end_x - 0.15) / h));
        EXPECT_EQ(both.gpu.at(i_path, j, k), PoseOutcome::FailsDictionary) << "angle " << k;
    }
}

// Random performers and every interaction type, with and without visibility: identical outcomes.
TEST(Sweep, RandomScenesMatchReference) {
    std::mt19937 random(20261121);
    std::uniform_real_distribution<double> u(-1, 1);
    const char* types[] = {"+&-", "-&+", "+&+", "-&-", "+&0", "0&+", "-&0", "0&-", "0&0a", "0&0b", "0&0c"};
    std::uint64_t total_solutions = 0, total_dictionary = 0, total_fidelity = 0, total_visibility = 0;
    std::uint64_t poses_entering = 0, poses_tested_one_by_one = 0;
    for (int scene = 0; scene < 22; ++scene) {
        const double h = 0.03;
        const int frames = 5 + scene % 7;
        Performer a = random_performer(random, frames, false), b = random_performer(random, frames, false);
        Eigen::Vector2d fa(u(random), u(random)), fb(u(random), u(random));
        SweepObject A = object_from("A", a, h, {}, fa.normalized()), B = object_from("B", b, h, {}, fb.normalized());
        auto problem = problem_of(A, B, types[scene % 11], h, 30);
        problem.tolerance = scene % 3 == 2 ? 1 : 0;
        if (scene % 2 == 1) add_view_cones(problem, h);
        auto both = sweep_both(problem);
        SCOPED_TRACE("scene " + std::to_string(scene) + " type " + types[scene % 11]);
        expect_identical(both);
        // Overlap maps (the default) decide contact without a single pose test; every other stage
        // can go by maps too (in one pass over the z slices or several), or pose by pose, whatever
        // the cost model says.
        for (const auto& [pose_test_pairs, map_passes] : {std::pair{0.0, 5}, std::pair{1e12, 5}, std::pair{1e12, 1}, std::pair{1e12, 3}}) {
            gpu::VulkanSweeper mapped(test::context(), {.pose_test_pairs = pose_test_pairs, .map_passes = map_passes});
            EXPECT_EQ(mapped.sweep(problem).outcomes, both.reference.outcomes) << pose_test_pairs << " " << map_passes;
            test::expect_no_validation_messages();
            const auto& stats = mapped.last_stats();
            EXPECT_EQ(stats.pose_tests_per_stage[0], 0u);
            EXPECT_GT(stats.pulled_runs_per_stage[0], 0u);
            if (pose_test_pairs > 0) {
                EXPECT_EQ(stats.pose_tests_per_stage[1] + stats.pose_tests_per_stage[2] + stats.pose_tests_per_stage[3], 0u);
                if (stats.poses_per_stage[2] > 0) {
                    EXPECT_GT(stats.maps_per_stage[2], 0u);
                }
            }
        }
        // Pose by pose, the block pre-test is exact at any block size, and off (1) it is the plain
        // per-pose sweep.
        for (int block : {1, 3}) {
            gpu::VulkanSweeper sweeper(test::context(), {.block = block, .maps = false});
            EXPECT_EQ(sweeper.sweep(problem).outcomes, both.reference.outcomes) << "block " << block;
            test::expect_no_validation_messages();
        }
        gpu::VulkanSweeper blocked(test::context(), {.maps = false});
        blocked.sweep(problem);
        for (int stage = 0; stage < 4; ++stage) {
            poses_entering += blocked.last_stats().poses_per_stage[std::size_t(stage)];
            poses_tested_one_by_one += blocked.last_stats().pose_tests_per_stage[std::size_t(stage)];
        }
        total_solutions += both.gpu.solutions;
        total_dictionary += both.gpu.rejected[1];
        total_fidelity += both.gpu.rejected[2];
        total_visibility += both.gpu.rejected[3];
    }
    // The scenes exercise every stage.
    EXPECT_GT(total_solutions, 0u);
    EXPECT_GT(total_dictionary, 0u);
    EXPECT_GT(total_fidelity, 0u);
    EXPECT_GT(total_visibility, 0u);
    // Blocks decide most poses: fewer than half are tested one by one.
    EXPECT_LT(2 * poses_tested_one_by_one, poses_entering) << poses_tested_one_by_one << " of " << poses_entering;
}

// The discrete-GPU memory path (kernel inputs uploaded to device-local memory through a staging
// buffer, results copied back, per-batch inputs copied in) gives the reference's outcomes too, by
// maps in one pass or several and pose by pose with and without blocks, with no validation message
// (synchronisation validation included). On lavapipe it runs only because the test asks for it.
TEST(Sweep, StagedTransfersMatchReference) {
    gpu::Context& staged = test::staged_context();
    ASSERT_TRUE(staged.staged_transfers());
    const std::uint32_t word = 0x5eed;
    EXPECT_EQ(gpu::upload_for_kernels(staged, &word, 4)->memory(), gpu::Buffer::Memory::Device);
    std::mt19937 random(20261126);
    std::uniform_real_distribution<double> u(-1, 1);
    const char* types[] = {"+&+", "0&0b", "+&0", "-&-", "0&0a", "0&+"};
    std::uint64_t solutions = 0, visibility = 0, fidelity = 0;
    for (int scene = 0; scene < 6; ++scene) {
        const double h = 0.03;
        Performer a = random_performer(random, 6 + scene, false), b = random_performer(random, 6 + scene, false);
        Eigen::Vector2d fa(u(random), u(random)), fb(u(random), u(random));
        auto problem = problem_of(object_from("A", a, h, {}, fa.normalized()), object_from("B", b, h, {}, fb.normalized()), types[scene], h, 30);
        if (scene % 2 == 1) add_view_cones(problem, h);
        const SweepResult reference = ReferenceSweeper().sweep(problem);
        SCOPED_TRACE("scene " + std::to_string(scene) + " type " + types[scene]);
        for (const gpu::SweeperOptions& options : {gpu::SweeperOptions{}, gpu::SweeperOptions{.pose_test_pairs = 1e12, .map_passes = 3},
                                                   gpu::SweeperOptions{.block = 1, .maps = false}, gpu::SweeperOptions{.block = 3, .maps = false}}) {
            gpu::VulkanSweeper sweeper(staged, options);
            EXPECT_EQ(sweeper.sweep(problem).outcomes, reference.outcomes) << "maps " << options.maps << " block " << options.block;
        }
        EXPECT_TRUE(staged.validation_messages().empty()) << staged.validation_messages().front();
        solutions += reference.solutions;
        fidelity += reference.rejected[2];
        visibility += reference.rejected[3];
    }
    EXPECT_GT(solutions, 0u);
    EXPECT_GT(fidelity, 0u);
    EXPECT_GT(visibility, 0u);
}

// Multi-party (docs/method.md section 11): A's side holds a third object O beside A (the other
// placed objects), which B's whole body must never meet at the same frame. Random scenes give
// identical outcomes on both backends, by maps and pose by pose, and the clearance rejects poses
// that the pair alone accepts, never the other way round.
TEST(Sweep, ClearanceOfTheOtherPlacedObjectsMatchesReference) {
    std::mt19937 random(20261126);
    std::uniform_real_distribution<double> u(-1, 1);
    const char* types[] = {"0&0b", "+&0", "0&0a", "-&-"};
    std::uint64_t rejected_by_clearance = 0;
    for (int scene = 0; scene < 8; ++scene) {
        const double h = 0.03;
        const int frames = 5 + scene % 5;
        Performer a = random_performer(random, frames, false), b = random_performer(random, frames, false);
        Performer other = random_performer(random, frames, false);
        const Vec3 beside(0.45 + 0.2 * u(random), 0.4 * u(random), 0);
        for (MeshFrame& f : other.body)
            for (Vec3& v : f.mesh.vertices) v += beside;
        std::vector<ObjectFrame> group(std::size_t(frames), ObjectFrame{});
        std::vector<const MeshFrame*> others;
        for (std::size_t f = 0; f < group.size(); ++f) {
            group[f].whole = {&a.body[f], &other.body[f]};
            group[f].interest = {&a.part[f]};
            others.push_back(&other.body[f]);
        }
        ReferenceVoxeliser voxeliser;
        SweepObject A = build_sweep_object("A+O", group, {}, h, voxeliser);
        A.facing = Eigen::Vector2d(u(random), u(random)).normalized();
        A.clearance = voxelise(prepare_voxelisation(others, A.whole.grid()), voxeliser);
        SweepObject B = object_from("B", b, h, {}, Eigen::Vector2d(u(random), u(random)).normalized());
        const SweepProblem problem = problem_of(A, B, types[scene % 4], h, 30);
        SCOPED_TRACE("scene " + std::to_string(scene) + " type " + types[scene % 4]);
        const BothResults both = sweep_both(problem);
        expect_identical(both);
        for (const gpu::SweeperOptions& options : {gpu::SweeperOptions{.pose_test_pairs = 1e12}, gpu::SweeperOptions{.pose_test_pairs = 0.0},
                                                   gpu::SweeperOptions{.block = 1, .maps = false}, gpu::SweeperOptions{.maps = false}}) {
            gpu::VulkanSweeper sweeper(test::context(), options);
            EXPECT_EQ(sweeper.sweep(problem).outcomes, both.reference.outcomes) << options.pose_test_pairs << " " << options.maps;
            test::expect_no_validation_messages();
        }
        SweepProblem pair_alone = problem;
        pair_alone.a.clearance = Amhv();
        const SweepResult without = ReferenceSweeper().sweep(pair_alone);
        for (std::size_t p = 0; p < without.outcomes.size(); ++p) {
            if (both.reference.outcomes[p] == PoseOutcome::Solution) {
                EXPECT_EQ(without.outcomes[p], PoseOutcome::Solution) << p;
            }
        }
        rejected_by_clearance += without.solutions - both.reference.solutions;
    }
    EXPECT_GT(rejected_by_clearance, 0u);
}

// Random per-frame view cones for both objects: eyes that drift and gazes that turn.
void add_frame_cones(SweepProblem& problem, std::mt19937& random) {
    std::uniform_real_distribution<double> u(-1, 1);
    for (auto* obj : {&problem.a, &problem.b}) {
        Box3 region;
        region.min = obj->root - Vec3(1.6, 1.6, 1.0);
        region.max = obj->root + Vec3(1.6, 1.6, 1.0);
        std::vector<ViewCone> cones;
        const double turn = u(random) * 2.5, start = std::atan2(obj->facing.y(), obj->facing.x());
        for (int t = 0; t < problem.frames(); ++t) {
            const double a = start + turn * t / std::max(1, problem.frames() - 1);
            cones.push_back({obj->root + Vec3(0.05 * t * u(random), 0, 0.6), Vec3(std::cos(a), std::sin(a), -0.2).normalized(), 25, 0});
        }
        obj->view_cone = view_cone_volumes(cones, region, problem.voxel);
    }
}

// The keys for real captures (docs/method.md section 5a): 0&0 (a) on a fraction of the frames,
// per-frame visibility on a fraction of the frames, and B raised or lowered within a z range give
// identical outcomes on both backends, by maps and pose by pose.
TEST(Sweep, RealCaptureKeysMatchReference) {
    std::mt19937 random(20261125);
    std::uniform_real_distribution<double> u(-1, 1);
    const char* types[] = {"0&0a", "0&0b", "+&-", "0&0c", "+&0", "0&0a", "-&-", "0&+"};
    std::uint64_t solutions = 0, visibility_rejections = 0, raised_solutions = 0;
    for (int scene = 0; scene < 16; ++scene) {
        const double h = 0.03;
        const int frames = 6 + scene % 5;
        Performer a = random_performer(random, frames, true), b = random_performer(random, frames, true);
        Eigen::Vector2d fa(u(random), u(random)), fb(u(random), u(random));
        auto problem = problem_of(object_from("A", a, h, {}, fa.normalized()), object_from("B", b, h, {}, fb.normalized()), types[scene % 8], h, 30);
        problem.contact_frames = scene % 2 == 0 ? frames - 1 - scene % 3 : 0;
        problem.range.z_first = -(scene % 3);
        problem.range.z_last = scene % 4;
        if (scene % 4 != 3) {
            problem.visibility = true;
            problem.visibility_frames = 1 + scene % frames;
            add_frame_cones(problem, random);
        }
        SCOPED_TRACE("scene " + std::to_string(scene) + " type " + types[scene % 8]);
        auto both = sweep_both(problem);
        expect_identical(both);
        for (const auto& options : {gpu::SweeperOptions{.pose_test_pairs = 1e12}, gpu::SweeperOptions{.block = 3, .maps = false}}) {
            gpu::VulkanSweeper sweeper(test::context(), options);
            EXPECT_EQ(sweeper.sweep(problem).outcomes, both.reference.outcomes) << "maps " << options.maps << " block " << options.block;
            test::expect_no_validation_messages();
        }
        solutions += both.gpu.solutions;
        visibility_rejections += both.gpu.rejected[3];
        const SolutionGroup group = solution_group(both.gpu);
        group.for_each([&](const PoseIndex& p) { raised_solutions += p.l != 0; });
        // The group as a volume (segment_N/group.vdb) reads back as exactly the set the sweep decided.
        {
            ASSERT_EQ(group.size(), both.gpu.solutions);
            results::GroupLattice lattice{h, 30, 12, 1, problem.range.z_first, problem.range.z_last, "test"};
            test::TempDir dir;
            results::write_group_vdb(dir.path() / "group.vdb", group, lattice);
            EXPECT_TRUE(results::read_group_vdb(dir.path() / "group.vdb", lattice) == group);
            lattice.scene_hash = "other";
            EXPECT_THROW(results::read_group_vdb(dir.path() / "group.vdb", lattice), Error);
        }
        // The probe's verdict is the sweep's, on random poses and on every solution.
        const PoseProber prober(problem);
        const PoseRange& r = problem.range;
        std::uniform_int_distribution<int> pick_i(r.i_first, r.i_last), pick_j(r.j_first, r.j_last), pick_k(0, r.angles - 1),
            pick_l(r.z_first, r.z_last);
        for (int n = 0; n < 30; ++n) {
            const int i = pick_i(random), j = pick_j(random), k = pick_k(random), l = pick_l(random);
            EXPECT_EQ(prober.probe(i, j, k, l, false).outcome, both.reference.at(i, j, k, l)) << i << " " << j << " " << k << " " << l;
        }
        if (!group.empty()) {
            const PoseIndex s = group.at(group.size() / 2);
            const PoseProbe probe = prober.probe(s.i, s.j, s.k, s.l, true);
            EXPECT_EQ(probe.outcome, PoseOutcome::Solution);
            EXPECT_TRUE(probe.failed_frames().empty());
            if (problem.type.variant == 'b') {
                EXPECT_TRUE(std::any_of(probe.gap_m.begin(), probe.gap_m.end(), [](double g) { return g == 0; }));
            }
        }
    }
    EXPECT_GT(solutions, 0u);
    EXPECT_GT(visibility_rejections, 0u);
    EXPECT_GT(raised_solutions, 0u);
}

// Every height of a z range shares A's side (HeightShare): A's volumes are built once, in a z frame
// that covers every height, by maps and pose by pose, with the heights in one run, in runs of 4 and
// 2, and one by one; each height's outcomes are those of a sweep of that height alone (its own,
// narrower frame) and the reference's. Heights in one run cut and prune B's runs once for all.
TEST(Sweep, HeightsShareTheFixedSide) {
    std::mt19937 random(1);
    const double h = 0.03;
    const int frames = 9;
    Performer a = random_performer(random, frames, true), b = random_performer(random, frames, true);
    auto problem = problem_of(object_from("A", a, h), object_from("B", b, h, {}, -Eigen::Vector2d::UnitX()), "0&0a", h, 30);
    problem.contact_frames = 3;
    problem.visibility = true;
    problem.visibility_frames = 2;
    add_frame_cones(problem, random);
    problem.range.z_first = -2;
    problem.range.z_last = 3;
    const auto both = sweep_both(problem);
    expect_identical(both);
    EXPECT_GT(both.gpu.solutions, 0u);
    EXPECT_GT(both.gpu.rejected[3], 0u);
    std::map<int, std::uint64_t> runs_cut;  // per heights_per_run
    for (const auto& options : {gpu::SweeperOptions{.pose_test_pairs = 1e12}, gpu::SweeperOptions{.pose_test_pairs = 1e12, .heights_per_run = 4},
                                gpu::SweeperOptions{.pose_test_pairs = 1e12, .heights_per_run = 1}, gpu::SweeperOptions{.block = 3, .maps = false}}) {
        gpu::VulkanSweeper sweeper(test::context(), options);
        EXPECT_EQ(sweeper.sweep(problem).outcomes, both.reference.outcomes) << "maps " << options.maps << " heights " << options.heights_per_run;
        const std::uint64_t built = sweeper.last_stats().fixed_volumes_built;
        const auto& cut = sweeper.last_stats().runs_cut_per_stage;
        if (options.maps) runs_cut[options.heights_per_run] = std::accumulate(cut.begin(), cut.end(), std::uint64_t(0));
        SweepProblem one = problem;
        std::uint64_t most_for_one = 0;
        for (int level = problem.range.z_first; level <= problem.range.z_last; ++level) {
            one.range.z_first = one.range.z_last = level;
            const SweepResult alone = sweeper.sweep(one);
            most_for_one = std::max(most_for_one, sweeper.last_stats().fixed_volumes_built);
            ASSERT_EQ(alone.outcomes.size(), problem.range.per_level());
            const std::size_t first = std::size_t(level - problem.range.z_first) * problem.range.per_level();
            EXPECT_TRUE(std::equal(alone.outcomes.begin(), alone.outcomes.end(), both.gpu.outcomes.begin() + std::ptrdiff_t(first))) << level;
        }
        EXPECT_GT(built, 0u);
        EXPECT_EQ(built, most_for_one) << "A's volumes built once for the six heights, as for one";
        test::expect_no_validation_messages();
    }
    EXPECT_LT(runs_cut[16], runs_cut[4]);
    EXPECT_LT(runs_cut[4], runs_cut[1]);
}

// A solid block of poses is stored as tiles (a few bytes) and reads back pose for pose.
TEST(Sweep, GroupVdbStoresSolidBlocksAsTilesAndReadsThemBack) {
    SolutionGroup group;
    std::vector<PoseIndex> poses;
    for (int l = -1; l <= 1; ++l)
        for (int k = 0; k < 40; ++k)
            for (int j = -20; j < 20; ++j)
                for (int i = 3; i < 43; ++i)
                    if (l != 1 || (i + j + k) % 7 == 0) group.add({i, j, k, l}), poses.push_back({i, j, k, l});
    const results::GroupLattice lattice{0.01, 2, 180, 3, -1, 1, "block"};
    test::TempDir dir;
    results::write_group_vdb(dir.path() / "group.vdb", group, lattice);
    EXPECT_LT(std::filesystem::file_size(dir.path() / "group.vdb"), 2 * group.size());  // the CSV takes about 60 bytes a pose
    EXPECT_EQ(results::read_group_lattice(dir.path() / "group.vdb").scene_hash, "block");
    const SolutionGroup back = results::read_group_vdb(dir.path() / "group.vdb", lattice);
    ASSERT_EQ(back.size(), poses.size());
    std::uint64_t n = 0;
    back.for_each([&](const PoseIndex& p) { ASSERT_EQ(p, poses[n++]); });
}

// The group's runs: members in the sweep's order, member n by rank, membership, and refusal of a
// pose out of order (a set, never a list with repeats).
TEST(Sweep, SolutionGroupHoldsRunsInTheSweepsOrder) {
    std::mt19937 random(33);
    std::vector<PoseIndex> poses;
    SolutionGroup group;
    for (int l = -1; l <= 1; ++l)
        for (int k = 0; k < 6; ++k)
            for (int j = -4; j <= 4; ++j)
                for (int i = -10; i <= 10; ++i)
                    if (random() % 3 != 0) group.add({i, j, k, l}), poses.push_back({i, j, k, l});
    ASSERT_EQ(group.size(), poses.size());
    EXPECT_LT(group.runs().size(), poses.size() / 2);  // runs merge neighbours along x
    for (std::size_t n = 0; n < poses.size(); n += 7) EXPECT_EQ(group.at(n), poses[n]) << n;
    std::vector<PoseIndex> listed;
    group.for_range(5, 300, [&](const PoseIndex& p) { listed.push_back(p); });
    EXPECT_TRUE(std::equal(listed.begin(), listed.end(), poses.begin() + 5, poses.begin() + 300));
    EXPECT_EQ(listed.size(), 295u);
    for (int n = 0; n < 500; ++n) {
        const PoseIndex p{int(random() % 23) - 11, int(random() % 11) - 5, int(random() % 7), int(random() % 3) - 1};
        const auto found = std::find(poses.begin(), poses.end(), p);
        EXPECT_EQ(group.contains(p), found != poses.end());
        EXPECT_EQ(group.index_of(p), found != poses.end() ? std::uint64_t(found - poses.begin()) : group.size());
    }
    EXPECT_TRUE(group.any_raised());
    EXPECT_THROW(group.add(poses.front()), Error);
    EXPECT_THROW(group.add(poses.back()), Error);
    EXPECT_THROW(group.at(group.size()), Error);
}

// The probe's per-frame gap compares only the two sets' boundary points: against every pair, on
// solid blocks (mostly interior points), scattered points, and overlapping sets.
TEST(Sweep, ProbeGapMatchesEveryPair) {
    std::mt19937 random(61);
    using detail::LatticePoint;
    auto block = [&](std::int64_t x, std::int64_t y, std::int64_t z, int n) {
        std::vector<LatticePoint> out;
        for (int a = 0; a < n; ++a)
            for (int b = 0; b < n; ++b)
                for (int c = 0; c < n; ++c)
                    if (random() % 5 != 0 || (a > 0 && a < n - 1)) out.push_back({x + a, y + b, z + c});
        return out;
    };
    for (int trial = 0; trial < 40; ++trial) {
        const int spread = 4 + trial;
        std::vector<LatticePoint> a = block(0, 0, 0, 6 + trial % 5);
        std::vector<LatticePoint> b = block(int(random() % spread) - 2, int(random() % spread) - 3, int(random() % spread) - 1, 3 + trial % 7);
        std::int64_t brute = std::numeric_limits<std::int64_t>::max();
        for (const auto& q : a)
            for (const auto& r : b) brute = std::min(brute, (q[0] - r[0]) * (q[0] - r[0]) + (q[1] - r[1]) * (q[1] - r[1]) + (q[2] - r[2]) * (q[2] - r[2]));
        EXPECT_EQ(detail::smallest_squared_gap(a, b), brute) << trial;
    }
    std::vector<LatticePoint> none, one{{1, 2, 3}};
    EXPECT_EQ(detail::smallest_squared_gap(none, one), std::numeric_limits<std::int64_t>::max());
}

// The probe's depths on two flat hands (boxes 10 cm high and wide) that meet end to end: B moved k
// voxels into A makes k more layers of shared voxels, so the depth grows by exactly k voxels, read
// as the interest parts' merge when the hands are the interest parts and as another pair's
// interpenetration when they are not; apart, both read 0.
TEST(Sweep, ProbeDepthGrowsByTheVoxelsMovedIntoTheOther) {
    const double h = 0.01;
    auto performer = [&](double side, bool hands_are_interest) {
        Performer p;
        for (int f = 0; f < 2; ++f) {
            TriangleMesh body = shapes::box(Vec3(side * 0.40, -0.15, 0.6).cwiseMin(Vec3(side * 0.12, 0.15, 1.4)),
                                            Vec3(side * 0.40, -0.15, 0.6).cwiseMax(Vec3(side * 0.12, 0.15, 1.4)));
            const TriangleMesh hand = shapes::box(Vec3(side * 0.12, -0.05, 1.0).cwiseMin(Vec3(-side * 0.0049, 0.05, 1.1)),
                                                  Vec3(side * 0.12, -0.05, 1.0).cwiseMax(Vec3(-side * 0.0049, 0.05, 1.1)));
            body.append(hand);
            const TriangleMesh part = hands_are_interest ? hand : shapes::sphere(Vec3(side * 0.26, 0, 1.45), 0.04, 6, 10);
            if (!hands_are_interest) body.append(part);
            p.body.push_back(frame_of(body, f));
            p.part.push_back(frame_of(part, f));
        }
        return p;
    };
    int first = 0;  // found with the hands as interest parts (their gap), kept for the other pass
    for (const bool interest : {true, false}) {
        const Performer a = performer(-1, interest), b = performer(1, interest);
        const SweepProblem problem = problem_of(object_from("A", a, h), object_from("B", b, h), "0&0b", h, 90);
        const PoseProber prober(problem);
        const Eigen::Vector2d s = (problem.b.root - problem.a.root).head<2>() / h;
        const int i0 = int(std::lround(s.x())), j0 = int(std::lround(s.y()));
        auto deepest = [](const std::vector<double>& d) { return *std::max_element(d.begin(), d.end()); };
        // The first pose, moving B into A, where the hands share a voxel: one layer, depth 0.
        auto touches = [&](int i) {
            const std::vector<double> gap = prober.probe(i, j0, 0, 0).gap_m;
            return *std::min_element(gap.begin(), gap.end()) == 0;
        };
        if (interest)
            for (first = i0 + 3; first > i0 - 6 && !touches(first);) --first;
        ASSERT_GT(first, i0 - 6);
        const PoseProbe apart = prober.probe(first + 2, j0, 0, 0);
        EXPECT_EQ(deepest(apart.contact_depth_m) + deepest(apart.other_depth_m), 0.0) << interest;
        for (int k = 0; k <= 3; ++k) {
            const PoseProbe in = prober.probe(first - k, j0, 0, 0);
            const auto& depth = interest ? in.contact_depth_m : in.other_depth_m;
            const auto& none = interest ? in.other_depth_m : in.contact_depth_m;
            EXPECT_NEAR(deepest(depth), k * h, 1e-9) << interest << " " << k;
            EXPECT_EQ(deepest(none), 0.0) << interest << " " << k;
        }
    }
}

// Real hands part: two hands that touch for 7 frames and are 5 cm apart for the last 3. At the
// true pose 0&0 (a) rejects them; 7 of 10 contact frames or a 7 cm contact tolerance accept them,
// and 8 frames or a 2 cm tolerance still do not. B's hand is 3 cm lower: z_range finds it raised.
TEST(Sweep, HandsThatPartPassWithContactFramesOrTolerance) {
    const double h = 0.01;
    const int frames = 10;
    Performer a, b;
    for (int f = 0; f < frames; ++f) {
        const double apart = f < 7 ? 0.0 : 0.045;  // the hands overlap by 4 cm, then are 5 cm apart
        a.body.push_back(frame_of(shapes::capsule(Vec3(-0.45, 0, 0.4), Vec3(-0.45, 0, 1.4), 0.15, 3, 12), f));
        a.part.push_back(frame_of(shapes::sphere(Vec3(-0.03 - apart, 0, 1.2), 0.05, 8, 12), f));
        b.body.push_back(frame_of(shapes::capsule(Vec3(0.45, 0, 0.37), Vec3(0.45, 0, 1.37), 0.15, 3, 12), f));
        b.part.push_back(frame_of(shapes::sphere(Vec3(0.03 + apart, 0, 1.17), 0.05, 8, 12), f));
    }
    auto outcome_at_truth = [&](double tolerance, int contact_frames, int z_last) {
        ObjectParts parts_a;
        parts_a.grow_interest = tolerance;
        auto problem = problem_of(object_from("A", a, h, parts_a), object_from("B", b, h), "0&0a", h, 90);
        problem.contact_frames = contact_frames;
        problem.range.z_last = z_last;
        // B's capture frame on A's: the offset between the roots.
        const Eigen::Vector2d s = (problem.b.root - problem.a.root).head<2>() / h;
        const int i = int(std::lround(s.x())), j = int(std::lround(s.y()));
        problem.range.i_first = problem.range.i_last = i;
        problem.range.j_first = problem.range.j_last = j;
        auto both = sweep_both(problem);
        expect_identical(both);
        return std::array<PoseOutcome, 2>{both.gpu.at(i, j, 0, 0), both.gpu.at(i, j, 0, z_last)};
    };
    EXPECT_EQ(outcome_at_truth(0, 0, 0)[0], PoseOutcome::FailsDictionary);
    EXPECT_EQ(outcome_at_truth(0, 7, 0)[0], PoseOutcome::Solution);
    EXPECT_EQ(outcome_at_truth(0, 8, 0)[0], PoseOutcome::FailsDictionary);
    EXPECT_EQ(outcome_at_truth(0.07, 0, 0)[0], PoseOutcome::Solution);
    EXPECT_EQ(outcome_at_truth(0.02, 0, 0)[0], PoseOutcome::FailsDictionary);
    // Raised by 3 voxels the hands meet square; with contact on 7 frames both heights pass.
    EXPECT_EQ(outcome_at_truth(0, 7, 3)[1], PoseOutcome::Solution);
}

// The swept-body test lets a performer who looks away most of the time "see" the other: B stands
// looking along +x; A stands in front of B for 2 frames, then behind B for 8. B's cone holds A's
// swept body, so the paper's test passes; per frame B sees A on 2 of 10 frames, so 0.8 of the
// frames fails and 0.2 passes.
TEST(Sweep, PerFrameVisibilityRejectsAPerformerLookingAway) {
    const double h = 0.02;
    const int frames = 10;
    Performer a, b;
    std::vector<ViewCone> cones_a, cones_b;
    for (int f = 0; f < frames; ++f) {
        const double x = f < 2 ? 1.0 : -1.0;
        a.body.push_back(frame_of(shapes::capsule(Vec3(x, 0, 0.4), Vec3(x, 0, 1.4), 0.15, 3, 12), f));
        a.part.push_back(frame_of(shapes::sphere(Vec3(x, 0.3, 1.2), 0.05, 6, 10), f));
        b.body.push_back(frame_of(shapes::capsule(Vec3(0, 0, 0.4), Vec3(0, 0, 1.4), 0.15, 3, 12), f));
        b.part.push_back(frame_of(shapes::sphere(Vec3(x, 0.3, 1.2), 0.05, 6, 10), f));  // B's part meets A's: contact
        cones_a.push_back({Vec3(x, 0, 1.5), Vec3(-x, 0, -0.1).normalized(), 30, 0});
        cones_b.push_back({Vec3(0, 0, 1.5), Vec3(1, 0, -0.1).normalized(), 30, 0});
    }
    ObjectParts none{.fidelity = PartRule::Box, .fidelity_box = Box3{Vec3::Constant(50), Vec3::Constant(51)}};
    auto problem = problem_of(object_from("A", a, h, none), object_from("B", b, h, none), "0&0a", h, 90);
    const Eigen::Vector2d s = (problem.b.root - problem.a.root).head<2>() / h;
    problem.range.i_first = problem.range.i_last = int(std::lround(s.x()));
    problem.range.j_first = problem.range.j_last = int(std::lround(s.y()));
    Box3 region{Vec3(-3, -3, -0.5), Vec3(3, 3, 2.5)};
    problem.visibility = true;
    problem.a.view_cone = view_cone_volume(cones_a.front(), region, h);
    problem.b.view_cone = view_cone_volume(cones_b.front(), region, h);
    auto swept = sweep_both(problem);
    expect_identical(swept);
    EXPECT_EQ(swept.gpu.outcomes[0], PoseOutcome::Solution);
    problem.a.view_cone = view_cone_volumes(cones_a, region, h);
    problem.b.view_cone = view_cone_volumes(cones_b, region, h);
    for (const auto& [needed, expected] : {std::pair{8, PoseOutcome::FailsVisibility}, std::pair{2, PoseOutcome::Solution}}) {
        problem.visibility_frames = needed;
        auto per_frame = sweep_both(problem);
        expect_identical(per_frame);
        EXPECT_EQ(per_frame.gpu.outcomes[0], expected) << needed;
    }
}

// Work split into many small items (a tiny loop budget) must not change a single outcome, and the
// default split must handle a large fidelity volume over many frames (which one invocation per pose
// would take far past lavapipe's loop cap).
TEST(Sweep, WorkSplittingMatchesReference) {
    const double h = 0.02;
    const int frames = 40;
    Performer a, b;
    for (int f = 0; f < frames; ++f) {
        double s = double(f) / (frames - 1);
        Vec3 ca(0, 0, 0.9), cb(0.1 * s, 0.05, 0.9);
        TriangleMesh body_a = shapes::capsule(ca - Vec3(0, 0, 0.6), ca + Vec3(0, 0, 0.6), 0.25, 3, 12);
        body_a.append(shapes::box(Vec3(-0.6, -0.6, 0.0), Vec3(0.6, 0.6, 0.05)));  // a wide base: many columns
        a.body.push_back(frame_of(body_a, f));
        a.part.push_back(frame_of(shapes::sphere(Vec3(0.45, 0, 1.2 + 0.1 * s), 0.08), f));
        b.body.push_back(frame_of(shapes::capsule(cb - Vec3(0, 0, 0.6), cb + Vec3(0, 0, 0.6), 0.2, 3, 12), f));
        b.part.push_back(frame_of(shapes::sphere(Vec3(0.4 - 0.1 * s, 0, 1.25), 0.08), f));
    }
    SweepObject A = object_from("A", a, h), B = object_from("B", b, h);
    for (const char* type : {"0&0b", "0&0a", "0&0c"}) {
        SCOPED_TRACE(type);
        auto problem = problem_of(A, B, type, h, 45);
        // Per pose the fidelity test alone visits about 60 x 60 columns x 3 words x 41 slots.
        auto both = sweep_both(problem);
        expect_identical(both);
        // Tiny items, pose by pose and by maps (fixed runs split into many chunks, maps in many
        // batches of angles, pose-by-pose waves in many dispatches).
        for (bool maps : {false, true}) {
            gpu::VulkanSweeper tiny(test::context(), {.max_poses_per_batch = 5000,
                                                      .angles_per_core_round = 1,
                                                      .max_poses_per_dispatch = 777,
                                                      .loop_budget = 200,
                                                      .block = 2,
                                                      .maps = maps,
                                                      .pose_test_pairs = 1e12,
                                                      .max_map_bytes = 1 << 18});
            SweepResult split = tiny.sweep(problem);
            test::expect_no_validation_messages();
            EXPECT_EQ(split.outcomes, both.reference.outcomes) << "maps " << maps;
        }
        // Batches of 16 angles, as on a 16-core machine, past max_poses_per_batch; pose by pose in
        // slices of one dispatch each.
        gpu::VulkanSweeper rounds(test::context(), {.max_poses_per_batch = 5000, .angles_per_core_round = 16, .max_poses_per_dispatch = 4096,
                                                    .pose_test_pairs = 0});
        EXPECT_EQ(rounds.sweep(problem).outcomes, both.reference.outcomes);
        test::expect_no_validation_messages();
        // With a round per core, a batch holds balanced_rounds rounds over the cores, or as many whole
        // rounds as max_balanced_poses holds (one at least).
        const std::uint64_t per_angle = problem.range.size() / std::uint64_t(problem.range.angles), cores = core_count();
        for (const auto& [rounds_wanted, poses, angles_per_batch] : {std::tuple{2, std::uint64_t(1) << 40, 2 * cores},
                                                                     std::tuple{4, 3 * cores * per_angle, 3 * cores},
                                                                     std::tuple{4, per_angle, cores}}) {
            gpu::VulkanSweeper balanced(test::context(),
                                        {.max_poses_per_batch = per_angle, .balanced_rounds = rounds_wanted, .max_balanced_poses = poses});
            EXPECT_EQ(balanced.sweep(problem).outcomes, both.reference.outcomes);
            const std::uint64_t angles = std::uint64_t(problem.range.angles);
            EXPECT_EQ(balanced.last_stats().batches, (angles + angles_per_batch - 1) / angles_per_batch) << rounds_wanted << " rounds";
        }
        if (std::string(type) == "0&0b") {
            EXPECT_GT(both.gpu.rejected[2], 0u);
            EXPECT_GT(both.gpu.solutions, 0u);
            // Per-frame visibility (40 cones a side over the wide base) and a grown part at this
            // size, whole and in tiny items: a pose's per-frame cone test visits far more than the
            // loop cap allows one invocation.
            ObjectParts grown;
            grown.grow_interest = 0.04;
            auto seen = problem_of(object_from("A", a, h, grown), B, type, h, 45);
            const std::array<double, 2> near_x{-0.2, 0.4}, near_y{-0.3, 0.3};
            narrow_range(seen.range, h, &near_x, &near_y);
            // A looks ahead for 30 frames (40 degrees), then straight up (10); B looks back at A all along (80).
            seen.visibility = true;
            seen.visibility_frames = 30;
            Box3 region{Vec3(-2.5, -2.5, -0.5), Vec3(2.5, 2.5, 2.5)};
            std::vector<ViewCone> ahead, back;
            for (int f = 0; f < frames; ++f) {
                ahead.push_back({seen.a.root + Vec3(0, 0, 0.5), f < 30 ? Vec3(1, 0, 0) : Vec3(0, 0, 1), f < 30 ? 40.0 : 10.0, 0});
                back.push_back({seen.b.root + Vec3(0, 0, 0.5), Vec3(-1, 0, 0), 80, 0});
            }
            seen.a.view_cone = view_cone_volumes(ahead, region, h);
            seen.b.view_cone = view_cone_volumes(back, region, h);
            auto per_frame = sweep_both(seen);
            expect_identical(per_frame);
            EXPECT_GT(per_frame.gpu.solutions, 0u);
            gpu::VulkanSweeper tiny(test::context(), {.loop_budget = 200, .block = 2, .maps = false});
            EXPECT_EQ(tiny.sweep(seen).outcomes, per_frame.reference.outcomes);
            test::expect_no_validation_messages();
            // By maps: A's cone against B's body, then B's cone against A's body on the poses the
            // first map passed (SweepRun::keep_passed), each over every frame.
            for (int passes : {5, 1}) {
                gpu::VulkanSweeper mapped(test::context(), {.pose_test_pairs = 1e12, .map_passes = passes});
                EXPECT_EQ(mapped.sweep(seen).outcomes, per_frame.reference.outcomes) << passes;
                const auto& stats = mapped.last_stats();
                EXPECT_GT(stats.maps_per_stage[3], 0u);
                EXPECT_EQ(stats.maps_per_stage[3] % 2, 0u) << "both cones' maps in every batch";
            }
            seen.visibility_frames = 31;  // A looks ahead on 30 frames only
            auto too_many = sweep_both(seen);
            expect_identical(too_many);
            EXPECT_EQ(too_many.gpu.solutions, 0u);
            EXPECT_EQ(too_many.gpu.rejected[3], per_frame.gpu.solutions + per_frame.gpu.rejected[3]);
        }
        if (std::string(type) == "0&0a") {
            EXPECT_GT(both.gpu.rejected[1], 0u);
            // The keys for real captures at this size too: 30 of 40 frames, B one voxel up or down.
            problem.contact_frames = 30;
            problem.range.z_first = -1;
            problem.range.z_last = 1;
            auto loose = sweep_both(problem);
            expect_identical(loose);
            EXPECT_GT(loose.gpu.solutions, both.gpu.solutions);
            gpu::VulkanSweeper tiny(test::context(), {.loop_budget = 200, .block = 2, .maps = false});
            EXPECT_EQ(tiny.sweep(problem).outcomes, loose.reference.outcomes);
            // The three heights by maps in tiny items, and with the maps' bytes of a batch too few
            // for one angle's maps at every height (the heights then go in smaller runs).
            for (const std::uint64_t map_bytes : {std::uint64_t(64) << 20, std::uint64_t(1) << 18}) {
                gpu::VulkanSweeper mapped(test::context(), {.max_poses_per_batch = 5000, .angles_per_core_round = 1, .loop_budget = 200,
                                                            .pose_test_pairs = 1e12, .max_map_bytes = map_bytes});
                EXPECT_EQ(mapped.sweep(problem).outcomes, loose.reference.outcomes) << map_bytes;
                test::expect_no_validation_messages();
            }
        }
    }
}

// contact_tolerance grows the part by a ball measured between voxel centres: every voxel within
// the radius of an occupied one at the same frame, by brute force over pairs.
TEST(Sweep, GrownPartIsEveryVoxelWithinTheRadius) {
    std::mt19937 random(3);
    VoxelGrid grid;
    grid.voxel = 0.01;
    grid.origin = Vec3(0.2, -0.1, 0.5);
    grid.dims = {17, 13, 11};
    Amhv part(grid, 35);
    for (int n = 0; n < 40; ++n) part.set(random() % grid.voxel_count(), int(random() % 35));
    for (double radius : {0.0, 0.01, 0.015, 0.03}) {
        const Amhv grown = grow_part(part, radius);
        std::size_t differing = 0;
        for (int z = 0; z < grid.dims[2]; ++z)
            for (int y = 0; y < grid.dims[1]; ++y)
                for (int x = 0; x < grid.dims[0]; ++x)
                    for (int t = 0; t < 35; ++t) {
                        bool expected = false;
                        for (std::size_t u = 0; u < grid.voxel_count() && !expected; ++u)
                            expected = part.occupied(u, t) && (grid.centre(x, y, z) - grid.centre(int(u % 17), int(u / 17 % 13), int(u / (17 * 13)))).norm() <= radius + 1e-9;
                        differing += grown.occupied(grid.index(x, y, z), t) != expected;
                    }
        EXPECT_EQ(differing, 0u) << radius;
    }
}

// The overlap-map kernel walks the fixed runs of one z in chunks. Here A is a comb of 400 thin
// bars along y at one height, 400 runs on every row: a pulled run of B walks every run on the 201
// rows of the range at its z, about 80,000 runs, past lavapipe's silent loop cap (about 65,535
// steps) for one invocation. Walked in one piece (one chunk per key) it loses 720 poses; the
// default budget splits it. One angle keeps the voxel-by-voxel reference quick.
TEST(Sweep, MapChunksCoverManyRunsPerSlice) {
    const double h = 0.01, pitch = 0.025, side = 0.012;
    TriangleMesh comb;
    for (int col = 0; col < 400; ++col) {
        const Vec3 corner(col * pitch + 0.004, 0.004, 1.004);
        comb.append(shapes::box(corner, corner + Vec3(side, 2.1, side)));  // every row B can reach
    }
    Performer a, b;
    for (int f = 0; f < 2; ++f) {
        a.body.push_back(frame_of(comb, f));
        b.body.push_back(frame_of(shapes::box(Vec3(-0.996, -0.996, 1.004), Vec3(-0.988, -0.988, 1.016)), f));  // one voxel wide
    }
    ObjectParts whole{.interest = PartRule::Whole};
    auto problem = problem_of(object_from("A", a, h, whole), object_from("B", b, h, whole), "0&0b", h, 360);
    const std::array<double, 2> x_range{1.0, 1.1}, y_range{-1.0, 1.0};  // offsets of the roots: about all of A's rows
    narrow_range(problem.range, h, &x_range, &y_range);
    ASSERT_EQ(problem.range.height(), 201);
    const ZFrame z = z_frame_covering({&problem.a.whole.grid(), &problem.b.whole.grid()});
    ASSERT_GT(fixed_runs(columns_of(problem.a.interest, z, false), {0}).most_per_key, 70000);
    auto both = sweep_both(problem);
    expect_identical(both);
    EXPECT_GT(both.gpu.solutions, 0u);
    EXPECT_GT(both.gpu.rejected[0], 0u);
}

// The view cone is cut per column analytically; it must hold exactly the voxels whose centres a
// plain test puts inside, for cones looking level, up, down and straight down, narrow and at the
// full 90 degrees, with and without a range, with the eye inside and outside the region.
TEST(Sweep, ViewConeVolumeIsEveryCentreInsideTheCone) {
    std::mt19937 random(77);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    const double h = 0.02;
    Box3 region;
    region.min = Vec3(-1.0, -0.8, 0.0);
    region.max = Vec3(1.2, 0.9, 1.9);
    std::vector<ViewCone> cones{
        {Vec3(0.0, 0.0, 1.6), Vec3(1, 0, 0), 30, 0},         {Vec3(0.0, 0.0, 1.6), Vec3(0, 0, -1), 25, 0},
        {Vec3(0.0, 0.0, 1.6), Vec3(0, 0, 1), 90, 0},          {Vec3(-1.5, 0.2, 1.0), Vec3(1, 0.1, -0.3).normalized(), 10, 2.0},
        {Vec3(0.3, -0.2, 0.9), Vec3(0, 1, 0), 60, 0.7},      {Vec3(0.0, 0.0, 1.6), Vec3(1, 0, -1).normalized(), 45, 0}};
    for (int i = 0; i < 20; ++i)
        cones.push_back({Vec3(1.5 * u(random), 1.5 * u(random), 1.0 + u(random)), Vec3(u(random), u(random), u(random)).normalized(),
                         5 + 42.5 * (1 + u(random)), i % 2 ? 0.0 : 0.5 + 1.5 * (1 + u(random))});
    for (std::size_t k = 0; k < cones.size(); ++k) {
        const ViewCone& cone = cones[k];
        const ConeVolume cone_volume = view_cone_volume(cone, region, h);
        const Amhv volume = cone_volume.to_amhv();
        const VoxelGrid& g = volume.grid();
        // The sweep's columns come straight from the spans: the same bits as from the dense volume.
        const ZFrame z_frame = z_frame_covering({&g});
        EXPECT_EQ(columns_of(cone_volume, z_frame).bits, columns_of(volume, z_frame, false).bits) << "cone " << k;
        const double cos_half = std::cos(cone.half_angle_deg * std::numbers::pi / 180.0);
        std::size_t differing = 0, inside = 0;
        for (int z = 0; z < g.dims[2]; ++z)
            for (int y = 0; y < g.dims[1]; ++y)
                for (int x = 0; x < g.dims[0]; ++x) {
                    Vec3 d = g.centre(x, y, z) - cone.eye;
                    double along = d.dot(cone.gaze), length = d.norm();
                    bool expected = length > 0 && along >= cos_half * length && (cone.range <= 0 || length <= cone.range);
                    inside += expected;
                    differing += volume.any(g.index(x, y, z)) != expected;
                }
        EXPECT_EQ(differing, 0u) << "cone " << k;
        if (k < 6) {
            EXPECT_GT(inside, 1000u) << "cone " << k;
        }
    }
}

// A column volume of nx x ny columns at global (x0, y0), all words clear.
ColumnVolume blank_columns(std::int64_t x0, std::int64_t y0, int nx, int ny, int slots, int zwords) {
    ColumnVolume volume;
    volume.x0 = x0;
    volume.y0 = y0;
    volume.nx = nx;
    volume.ny = ny;
    volume.slots = slots;
    volume.zwords = zwords;
    volume.bits.assign(std::size_t(nx) * std::size_t(ny) * volume.column_words(), 0u);
    return volume;
}

// Pooling over a block of offsets: every column of the result is the OR of the block's columns.
TEST(Sweep, DilatedColumnsAreTheOrOverTheBlock) {
    std::mt19937 random(7);
    ColumnVolume volume = blank_columns(-5, 17, 13, 11, 3, 2);
    for (auto& word : volume.bits)
        if (random() % 5 == 0) word = std::uint32_t(random()) & std::uint32_t(random());
    volume.finish();
    for (int block : {1, 2, 4, 8}) {
        const ColumnVolume d = dilated_columns(volume, block);
        ASSERT_EQ(d.x0, volume.x0 - (block - 1));
        ASSERT_EQ(d.nx, volume.nx + block - 1);
        ASSERT_EQ(d.ny, volume.ny + block - 1);
        for (int y = 0; y < d.ny; ++y)
            for (int x = 0; x < d.nx; ++x)
                for (std::size_t w = 0; w < volume.column_words(); ++w) {
                    std::uint32_t expected = 0;
                    for (int dy = 0; dy < block; ++dy)
                        for (int dx = 0; dx < block; ++dx) {
                            // Global column d.x0 + x + dx of the original.
                            const std::int64_t ox = d.x0 + x + dx - volume.x0, oy = d.y0 + y + dy - volume.y0;
                            if (ox >= 0 && oy >= 0 && ox < volume.nx && oy < volume.ny) expected |= volume.column(int(ox), int(oy))[w];
                        }
                    ASSERT_EQ(d.column(x, y)[w], expected) << block << " " << x << " " << y << " " << w;
                }
    }
}

// A's volume lowered over a run's heights: bit z of every slot is the OR of bits z .. z + lifts - 1,
// across word boundaries and for lifts past a word (slot 0, the union, holds every frame's bits).
TEST(Sweep, LoweredUnionIsTheOrOverTheLifts) {
    std::mt19937 random(11);
    ColumnVolume volume = blank_columns(3, -4, 9, 7, 3, 3);
    for (int y = 0; y < volume.ny; ++y)
        for (int x = 0; x < volume.nx; ++x) {
            if (random() % 3 == 0) continue;
            std::uint32_t* column = volume.column(x, y);
            for (int w = 0; w < volume.zwords; ++w) {
                for (int slot = 1; slot < volume.slots; ++slot) {
                    const std::uint32_t bits = std::uint32_t(random()) & std::uint32_t(random()) & std::uint32_t(random());
                    column[std::size_t(slot) * std::size_t(volume.zwords) + std::size_t(w)] = bits;
                }
                column[w] = column[std::size_t(volume.zwords) + std::size_t(w)] | column[2 * std::size_t(volume.zwords) + std::size_t(w)];
            }
        }
    volume.finish();
    const auto bit = [](const ColumnVolume& v, int x, int y, int slot, int z) {
        return z < 32 * v.zwords && ((v.column(x, y)[std::size_t(slot) * std::size_t(v.zwords) + std::size_t(z / 32)] >> (z % 32)) & 1u) != 0;
    };
    for (int lifts : {1, 2, 3, 11, 16, 33, 40}) {
        const ColumnVolume lowered = lowered_union(volume, lifts);
        ASSERT_EQ(lowered.nx, volume.nx);
        ASSERT_EQ(lowered.zwords, volume.zwords);
        for (int y = 0; y < volume.ny; ++y)
            for (int x = 0; x < volume.nx; ++x)
                for (int slot = 0; slot < volume.slots; ++slot)
                    for (int z = 0; z < 32 * volume.zwords; ++z) {
                        bool expected = false;
                        for (int h = 0; h < lifts; ++h) expected = expected || bit(volume, x, y, slot, z + h);
                        ASSERT_EQ(bit(lowered, x, y, slot, z), expected) << lifts << " " << x << " " << y << " " << slot << " " << z;
                    }
        EXPECT_EQ(lowered.word_last, volume.word_last);
    }
}

// Pulled runs are cut from whole words of a sparse copy of the moving volume, mapping each A column
// once for all slots by stepping the pull mapping along the row. They must be exactly the maximal
// runs of the pulled voxels, found here voxel by voxel with source_column, in (key, y, x) order.
TEST(Sweep, PulledRunsAreTheMaximalRunsOfThePulledVoxels) {
    std::mt19937 random(11);
    ColumnVolume volume = blank_columns(-31, 12, 40, 33, 4, 2);
    // Blobs of columns sharing words, so runs span many columns, plus scattered noise.
    for (int y = 0; y < volume.ny; ++y)
        for (int x = 0; x < volume.nx; ++x)
            for (std::size_t w = 0; w < volume.column_words(); ++w) {
                std::uint32_t& word = volume.column(x, y)[w];
                if ((x / 7 + y / 5 + int(w)) % 3 == 0) word = 0x0ff0f00fu << (w % 3);
                if (random() % 9 == 0) word ^= std::uint32_t(random());
                // Slot 3 only in a box inside the volume: rows are walked only where they map into it.
                if (w / std::size_t(volume.zwords) == 3 && (x < 10 || x > 25 || y < 8 || y > 20)) word = 0;
            }
    volume.finish();
    const std::array<std::int64_t, 2> root_a{posemap::quantise_root(3.3), posemap::quantise_root(-7.6)};
    const std::array<std::int64_t, 2> root_b{posemap::quantise_root(-10.2), posemap::quantise_root(28.9)};
    for (const std::vector<int>& slots : {std::vector<int>{0}, std::vector<int>{1, 2, 3}, std::vector<int>{3, 1}, std::vector<int>{3}}) {
        const SparseColumns sparse = sparse_columns(volume, slots);
        for (const double degrees : {0.0, 17.0, 90.0, 133.0, 251.5}) {
            const posemap::Trig trig = posemap::quantise_rotation(degrees * std::numbers::pi / 180.0);
            // A clip per slot and word (the first as wide as them all, a slot's high word narrower
            // than its low), so runs end where their slot's and word's clip does.
            WordClips clips;
            for (std::size_t s = 0; s < slots.size(); ++s)
                for (std::int32_t w = 0; w < volume.zwords; ++w)
                    clips.push_back({-40 + 9 * std::int32_t(s) + 3 * w, -30 + 4 * std::int32_t(s) + 2 * w, 35 - 6 * std::int32_t(s) - 4 * w,
                                     40 - 5 * std::int32_t(s) - w});
            const int angle_in_batch = 2;
            std::vector<SliceRun> runs{{7, 7, 7, 7}};  // appended after what is there
            const int longest = append_pulled_runs(sparse, trig, root_a, root_b, angle_in_batch, clips, runs);
            // Voxel by voxel: keys of set bits per A column of the clip, then runs along x.
            const int zbits = 32 * volume.zwords;
            const std::int32_t key_base = angle_in_batch * std::int32_t(slots.size()) * zbits;
            std::vector<SliceRun> expected{{7, 7, 7, 7}};
            int expected_longest = 0;
            for (std::int32_t key = key_base; key < key_base + std::int32_t(slots.size()) * zbits; ++key) {
                const int slot = slots[std::size_t((key - key_base) / zbits)], z = (key - key_base) % zbits;
                const auto& clip = clips[std::size_t((key - key_base) / 32)];  // slot index * zwords + word
                for (std::int32_t gy = clip[1]; gy <= clip[3]; ++gy) {
                    auto set = [&](std::int32_t gx) {
                        const posemap::Column c = posemap::source_column(gx, gy, trig, root_a[0], root_a[1], root_b[0], root_b[1]);
                        const std::int64_t bx = c.x - volume.x0, by = c.y - volume.y0;
                        if (bx < 0 || by < 0 || bx >= volume.nx || by >= volume.ny) return false;
                        return ((volume.column(int(bx), int(by))[std::size_t(slot * volume.zwords + z / 32)] >> (z % 32)) & 1u) != 0u;
                    };
                    for (std::int32_t gx = clip[0]; gx <= clip[2]; ++gx) {
                        if (!set(gx)) continue;
                        std::int32_t end = gx;
                        while (end + 1 <= clip[2] && set(end + 1)) ++end;
                        expected.push_back({gy, gx, end, key});
                        expected_longest = std::max(expected_longest, int(end - gx + 1));
                        gx = end;
                    }
                }
            }
            ASSERT_GT(expected.size(), 50u) << degrees;
            ASSERT_EQ(runs.size(), expected.size()) << degrees;
            for (std::size_t r = 0; r < runs.size(); ++r) {
                ASSERT_EQ(runs[r].key, expected[r].key) << degrees << " run " << r;
                ASSERT_EQ(runs[r].y, expected[r].y) << degrees << " run " << r;
                ASSERT_EQ(runs[r].x_first, expected[r].x_first) << degrees << " run " << r;
                ASSERT_EQ(runs[r].x_last, expected[r].x_last) << degrees << " run " << r;
            }
            EXPECT_EQ(longest, expected_longest) << degrees;
            // Ordered by map pass: the same runs grouped stably by pass, with each pass's first.
            // Nine passes need z itself where a key's last five bits are zero; z counts from the
            // phase (past 32 the phase's low bits alone would give other passes).
            for (const MapPasses passes : {MapPasses{5, 0}, MapPasses{9, 0}, MapPasses{5, 13}, MapPasses{9, 37}}) {
                std::vector<SliceRun> by_pass{{7, 7, 7, 7}};
                std::vector<std::size_t> pass_first;
                append_pulled_runs(sparse, trig, root_a, root_b, angle_in_batch, clips, by_pass, PulledCut{passes, 0, passes.count - 1, &pass_first});
                ASSERT_EQ(pass_first.size(), std::size_t(passes.count) + 1);
                std::size_t at = 1;
                for (int pass = 0; pass < passes.count; ++pass) {
                    ASSERT_EQ(pass_first[std::size_t(pass)], at) << degrees << " pass " << pass;
                    for (std::size_t r = 1; r < runs.size(); ++r) {
                        if (map_pass_of((runs[r].key - key_base) % zbits - passes.z_phase, runs[r].y, passes.count) != pass) continue;
                        ASSERT_LT(at, by_pass.size());
                        ASSERT_EQ(by_pass[at].key, runs[r].key) << degrees << " pass " << pass;
                        ASSERT_EQ(by_pass[at].y, runs[r].y) << degrees << " pass " << pass;
                        ASSERT_EQ(by_pass[at].x_first, runs[r].x_first) << degrees << " pass " << pass;
                        ++at;
                    }
                }
                EXPECT_EQ(pass_first.back(), at);
                EXPECT_EQ(by_pass.size(), at);
                // Cut row pass by row pass (as a map cuts each row just before its first pass),
                // each pass gets the same runs from the parts, none from a part cut after it.
                std::vector<SliceRun> parts;
                std::vector<std::size_t> part_first;
                for (int row_pass = 0; row_pass < passes.count; ++row_pass) {
                    std::vector<std::size_t> first;
                    append_pulled_runs(sparse, trig, root_a, root_b, angle_in_batch, clips, parts, PulledCut{passes, row_pass, row_pass, &first});
                    part_first.insert(part_first.end(), first.begin(), first.end());
                }
                ASSERT_EQ(parts.size(), by_pass.size() - 1) << degrees;
                const auto order = [](const SliceRun& a, const SliceRun& b) {
                    return std::tie(a.key, a.y, a.x_first, a.x_last) < std::tie(b.key, b.y, b.x_first, b.x_last);
                };
                const std::size_t stride = std::size_t(passes.count) + 1;
                for (int pass = 0; pass < passes.count; ++pass) {
                    std::vector<SliceRun> whole(by_pass.begin() + std::ptrdiff_t(pass_first[std::size_t(pass)]),
                                                by_pass.begin() + std::ptrdiff_t(pass_first[std::size_t(pass) + 1]));
                    std::vector<SliceRun> joined;
                    for (int row_pass = 0; row_pass < passes.count; ++row_pass) {
                        const std::size_t first = part_first[std::size_t(row_pass) * stride + std::size_t(pass)];
                        const std::size_t end = part_first[std::size_t(row_pass) * stride + std::size_t(pass) + 1];
                        if (row_pass > pass) {
                            EXPECT_EQ(first, end) << degrees << " pass " << pass << " part " << row_pass;
                        }
                        for (std::size_t r = first; r < end; ++r) {
                            EXPECT_EQ(first_pass_of_row(parts[r].y, passes.count), row_pass) << degrees << " pass " << pass;
                            joined.push_back(parts[r]);
                        }
                    }
                    std::sort(whole.begin(), whole.end(), order);
                    std::sort(joined.begin(), joined.end(), order);
                    ASSERT_EQ(joined.size(), whole.size()) << degrees << " pass " << pass;
                    for (std::size_t r = 0; r < whole.size(); ++r) ASSERT_FALSE(order(whole[r], joined[r]) || order(joined[r], whole[r])) << degrees;
                }
            }
        }
    }
}

// A sparse copy holds, column by column, every non-zero word of the asked slots (and only those),
// whatever part of the volume each slot's box covers.
TEST(Sweep, SparseColumnsHoldEveryNonZeroWordOfTheSlots) {
    std::mt19937 random(29);
    ColumnVolume volume = blank_columns(3, -8, 37, 29, 4, 2);
    for (int y = 0; y < volume.ny; ++y)
        for (int x = 0; x < volume.nx; ++x)
            for (std::size_t w = 0; w < volume.column_words(); ++w) {
                const int slot = int(w) / volume.zwords;
                // Each slot in its own box (slot 2 empty), words sparse within it.
                const bool inside = slot == 0 || (slot == 1 && x >= 5 && x <= 20 && y >= 3 && y <= 11) || (slot == 3 && x >= 14 && y >= 17);
                if (inside && random() % 3 == 0) volume.column(x, y)[w] = std::uint32_t(random()) | 1u;
            }
    volume.finish();
    for (const std::vector<int>& slots : {std::vector<int>{0, 1, 2, 3}, std::vector<int>{1}, std::vector<int>{3, 1}, std::vector<int>{2}}) {
        const SparseColumns sparse = sparse_columns(volume, slots);
        ASSERT_EQ(sparse.first.size(), std::size_t(volume.nx) * std::size_t(volume.ny) + 1);
        std::vector<SparseColumns::Entry> expected;
        for (std::size_t c = 0; c + 1 < sparse.first.size(); ++c) {
            ASSERT_EQ(sparse.first[c], expected.size()) << "column " << c;
            const std::uint32_t* column = volume.bits.data() + c * volume.column_words();
            for (std::size_t s = 0; s < slots.size(); ++s)
                for (int w = 0; w < volume.zwords; ++w)
                    if (const std::uint32_t bits = column[std::size_t(slots[s] * volume.zwords + w)]; bits != 0u)
                        expected.push_back({bits, std::int32_t(s) * volume.zwords + w});
        }
        EXPECT_EQ(sparse.first.back(), expected.size());
        ASSERT_EQ(sparse.entries.size(), expected.size());
        for (std::size_t e = 0; e < expected.size(); ++e) {
            EXPECT_EQ(sparse.entries[e].bits, expected[e].bits) << e;
            EXPECT_EQ(sparse.entries[e].word, expected[e].word) << e;
        }
    }
}

// The map passes start at the slice where both volumes hold the most voxels together: here slice
// 40 (the fixed side half full, the moving side full) beats slice 7 (full, a quarter full) and
// slice 50 (full on the fixed side only).
TEST(Sweep, MapPassesStartAtTheDensestSharedSlice) {
    ColumnVolume fixed = blank_columns(0, 0, 48, 40, 1, 2), moving = blank_columns(-6, 3, 48, 40, 1, 2);
    const auto set = [](ColumnVolume& volume, int z, int rows) {
        for (int y = 0; y < rows; ++y)
            for (int x = 0; x < volume.nx; ++x) volume.column(x, y)[std::size_t(z / 32)] |= 1u << (z % 32);
    };
    set(fixed, 7, 40), set(fixed, 40, 20), set(fixed, 50, 40);
    set(moving, 7, 10), set(moving, 40, 40), set(moving, 3, 40);
    fixed.finish();
    moving.finish();
    EXPECT_EQ(densest_shared_slice(fixed_runs(fixed, {0}), sparse_columns(moving, {0})), 40);
    // Nothing shared: the passes count from z = 0, as before.
    ColumnVolume apart = blank_columns(0, 0, 48, 40, 1, 2);
    set(apart, 60, 40);
    apart.finish();
    EXPECT_EQ(densest_shared_slice(fixed_runs(fixed, {0}), sparse_columns(apart, {0})), 0);
}

// Pulled runs cut to each slot's and z word's clip (word_clips) make the same overlap map on the
// clips' range of offsets as uncut runs, with fewer pulled voxels where the fixed volume's words
// lie in different places (here: its low word on the left, its high word on the right).
TEST(Sweep, WordClipsGiveTheSameMapOnTheirRange) {
    std::mt19937 random(41);
    ColumnVolume fixed = blank_columns(-20, 5, 50, 36, 3, 2), moving = blank_columns(-45, -12, 44, 40, 3, 2);
    // Each slot's low word a blob on the left, its high word one on the right; sparse bits in B.
    for (std::size_t w = 0; w < fixed.column_words(); ++w)
        for (int y = 0; y < 3; ++y)
            for (int x = 0; x < 3; ++x) fixed.column(w % 2 == 0 ? 2 + x : 40 + x, w % 2 == 0 ? 3 + y : 25 + y)[w] = 0x00200400u;
    for (std::uint32_t& word : moving.bits)
        if (random() % 24 == 0) word = 0x00200400u & std::uint32_t(random());
    fixed.finish();
    moving.finish();
    const std::vector<int> slots{0, 2};
    const FixedRuns runs = fixed_runs(fixed, slots);
    const SparseColumns sparse = sparse_columns(moving, slots);
    const int i_first = -9, i_last = 14, j_first = -6, j_last = 11, width = i_last - i_first + 1, height = j_last - j_first + 1;
    const std::array<std::int64_t, 2> root_a{posemap::quantise_root(1.4), posemap::quantise_root(20.2)};
    const std::array<std::int64_t, 2> root_b{posemap::quantise_root(-24.7), posemap::quantise_root(6.1)};
    // The map on the range from pairs of runs at the same key, and how many voxels the runs hold.
    const auto map_of = [&](const std::vector<SliceRun>& pulled) {
        std::vector<std::uint8_t> map(std::size_t(width) * std::size_t(height), 0);
        for (const SliceRun& b : pulled) {
            const auto [first, count] = runs.by_key[std::size_t(b.key)];
            for (std::int32_t r = first; r < first + count; ++r) {
                const SliceRun& a = runs.runs[std::size_t(r)];
                const int j = a.y - b.y;
                if (j < j_first || j > j_last) continue;
                for (int i = std::max(i_first, a.x_first - b.x_last); i <= std::min(i_last, a.x_last - b.x_first); ++i)
                    map[std::size_t(j - j_first) * std::size_t(width) + std::size_t(i - i_first)] = 1;
            }
        }
        return map;
    };
    const auto voxels = [](const std::vector<SliceRun>& pulled) {
        std::size_t n = 0;
        for (const SliceRun& r : pulled) n += std::size_t(r.x_last - r.x_first + 1);
        return n;
    };
    const WordClips everywhere(slots.size() * 2, {-1000, -1000, 1000, 1000});
    const WordClips words = word_clips(runs, i_first, i_last, j_first, j_last);
    ASSERT_EQ(words.size(), slots.size() * 2);
    for (const double degrees : {0.0, 31.0, 144.5, 270.0}) {
        const posemap::Trig trig = posemap::quantise_rotation(degrees * std::numbers::pi / 180.0);
        std::vector<SliceRun> all, clipped;
        append_pulled_runs(sparse, trig, root_a, root_b, 0, everywhere, all);
        append_pulled_runs(sparse, trig, root_a, root_b, 0, words, clipped);
        const std::vector<std::uint8_t> expected = map_of(all);
        EXPECT_EQ(map_of(clipped), expected) << degrees;
        const auto set = std::size_t(std::count(expected.begin(), expected.end(), 1));
        EXPECT_GT(set, 10u) << degrees;
        EXPECT_LT(set, expected.size()) << degrees;
        EXPECT_LT(voxels(clipped), voxels(all) * 3 / 4) << degrees;
    }
}

// Fixed runs carry, per key, the box of its runs, each row's hull (first x_first to last x_last),
// and per level L the hull of 2^L rows from each row on (cut short at the key's last row): the
// pruning of pulled runs tests 2^L rows of poses at once with them.
TEST(Sweep, FixedRunsKnowEachRowsAndEachWindowsHull) {
    std::mt19937 random(23);
    ColumnVolume volume = blank_columns(-5, 40, 61, 90, 3, 2);
    for (int y = 0; y < volume.ny; ++y)
        for (int x = 0; x < volume.nx; ++x)
            for (std::size_t w = 0; w < volume.column_words(); ++w)
                if ((x / 9 + y / 13 + int(w)) % 4 == 0 || random() % 11 == 0) volume.column(x, y)[w] = std::uint32_t(random()) & std::uint32_t(random());
    volume.finish();
    const std::vector<int> slots{2, 0};
    const FixedRuns runs = fixed_runs(volume, slots);
    using Hull = std::array<std::int32_t, 2>;
    const auto join = [](Hull a, const Hull& b) {
        if (b[0] > b[1]) return a;
        if (a[0] > a[1]) return b;
        return Hull{std::min(a[0], b[0]), std::max(a[1], b[1])};
    };
    ASSERT_EQ(runs.window_hulls.size(), std::size_t(FixedRuns::kHullLevels - 1));
    std::size_t keys_with_runs = 0, long_keys = 0;
    for (std::size_t key = 0; key < runs.by_key.size(); ++key) {
        const auto [first, count] = runs.by_key[key];
        if (count == 0) {
            EXPECT_GT(runs.key_boxes[key][0], runs.key_boxes[key][1]);
            continue;
        }
        ++keys_with_runs;
        const auto& box = runs.key_boxes[key];
        std::vector<Hull> rows(std::size_t(box[3] - box[2] + 1), Hull{1, 0});
        for (std::int32_t r = first; r < first + count; ++r) {
            const SliceRun& run = runs.runs[std::size_t(r)];
            ASSERT_GE(run.y, box[2]);
            ASSERT_LE(run.y, box[3]);
            rows[std::size_t(run.y - box[2])] = join(rows[std::size_t(run.y - box[2])], {run.x_first, run.x_last});
        }
        long_keys += rows.size() > 64;
        for (std::size_t r = 0; r < rows.size(); ++r) {
            const std::size_t at = runs.row_hull_first[key] + r;
            EXPECT_EQ(runs.row_hulls[at], rows[r]) << key << " row " << r;
            for (int level = 1; level < FixedRuns::kHullLevels; ++level) {
                Hull window{1, 0};
                for (std::size_t k = r; k < std::min(rows.size(), r + (std::size_t(1) << level)); ++k) window = join(window, rows[k]);
                const Hull& kept = runs.window_hulls[std::size_t(level - 1)][at];
                if (window[0] > window[1]) EXPECT_GT(kept[0], kept[1]) << key << " row " << r << " level " << level;
                else EXPECT_EQ(kept, window) << key << " row " << r << " level " << level;
            }
        }
    }
    EXPECT_GT(keys_with_runs, 100u);
    EXPECT_GT(long_keys, 10u);  // windows cut short at the end of a key's box, and spanning rows without runs
}

// Descriptors (docs/method.md section 6): B straight ahead of A, facing A, is L = |s|, thetaA = thetaB = 0.
TEST(Sweep, DescriptorsOfAFaceToFacePose) {
    SweepProblem problem;
    problem.voxel = 0.01;
    problem.angle_step_deg = 2;
    problem.a.facing = Eigen::Vector2d::UnitX();
    problem.b.facing = Eigen::Vector2d::UnitX();
    Solution s = describe(problem, 100, 0, 90);  // B at (1, 0), turned by 180 degrees
    EXPECT_NEAR(s.distance, 1.0, 1e-12);
    EXPECT_NEAR(s.theta_deg, 180.0, 1e-12);
    EXPECT_NEAR(s.theta_a_deg, 0.0, 1e-9);
    EXPECT_NEAR(std::abs(s.theta_b_deg), 0.0, 1e-9);
    Solution side = describe(problem, 0, 100, 0);  // B at (0, 1), facing +x like A
    EXPECT_NEAR(side.theta_a_deg, 90.0, 1e-9);
    EXPECT_NEAR(side.theta_b_deg, -90.0, 1e-9);
}

TEST(Sweep, InteractionTypesParse) {
    EXPECT_EQ(parse_interaction_type("+ & -", "t").name(), "+&-");
    EXPECT_EQ(parse_interaction_type("0&0 (a)", "t").name(), "0&0a");
    EXPECT_EQ(parse_interaction_type("0&0-c", "t").name(), "0&0c");
    EXPECT_EQ(parse_interaction_type("0&+", "t").name(), "0&+");
    EXPECT_THROW(parse_interaction_type("0&0", "t"), Error);
    EXPECT_THROW(parse_interaction_type("+&-a", "t"), Error);
    EXPECT_THROW(parse_interaction_type("hug", "t"), Error);
}

// The outcome tallies (16 poses at a time, byte counters emptied every 255 blocks) are those of a
// pose-by-pose count, over chunks of every length and runs long enough to wrap a byte counter.
TEST(Sweep, OutcomeCountsAreThoseOfEveryPose) {
    std::mt19937 random(41);
    for (const std::size_t n : {std::size_t(0), std::size_t(7), std::size_t(16 * 255 + 5), std::size_t(5'000'003)}) {
        SweepResult result;
        result.outcomes.resize(n);
        std::array<std::uint64_t, 5> expected{};
        for (std::size_t p = 0; p < n;) {
            // Long runs of one outcome, as a sweep leaves them.
            const auto outcome = PoseOutcome(random() % 5);
            const std::size_t run = std::min<std::size_t>(n - p, 1 + random() % 9000);
            std::fill_n(result.outcomes.begin() + std::ptrdiff_t(p), run, outcome);
            expected[std::size_t(outcome)] += run;
            p += run;
        }
        result.count();
        for (std::size_t o = 0; o < 4; ++o) EXPECT_EQ(result.rejected[o], expected[o]) << n << " outcome " << o;
        EXPECT_EQ(result.solutions, expected[4]) << n;
    }
}

}  // namespace
}  // namespace amhv
