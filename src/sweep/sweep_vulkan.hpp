#pragma once
// The placement sweep in compute shaders (docs/method.md sections 4-5). The host turns the volumes into
// column bitsets (sweep/column_volume.hpp) once, then runs the constraints as stages of overlap
// tests (shaders/sweep_overlap.comp) over batches of poses: contact on every pose of the range,
// then the dictionary on the poses in contact, fidelity on those, visibility on those. Each stage
// first decides whole blocks of offsets with OR-pooled volumes where it can, then tests the rest
// pose by pose. It only reads back one flag word per pose (or block) and test. With overlap maps
// (the default), contact and the dictionary are instead decided for every offset of an angle at
// once from slice runs (sweep/slice_runs.hpp, shaders/sweep_map.comp), and only fidelity and
// visibility, which few poses reach, go pose by pose.
#include <array>
#include <cstdint>

#include "src/gpu/compute.hpp"
#include "src/sweep/problem.hpp"

namespace amhv::gpu {

struct SweeperOptions {
    std::uint64_t max_poses_per_batch = std::uint64_t(1) << 22;
    // A batch's angles are a multiple of this many (0: one per core), past max_poses_per_batch
    // where the maps' bytes allow: the host cuts and prunes each angle's runs on a core of its
    // own, and a batch of fewer angles than cores leaves cores idle (the 5 mm paper scene's
    // batches of 2 angles left 14 of a 16-core GPU machine's cores idle).
    int angles_per_core_round = 0;
    // With one round per core (angles_per_core_round 0), a batch holds at least this many rounds
    // where its poses stay within max_balanced_poses: each core then takes several angles of the
    // batch, one after another, and angles of uneven work even out, where one angle per core
    // leaves every core waiting for the slowest in each pass (on a 16-core H200 machine, batches of
    // 128 angles instead of 16 took key segment 2 of the 5 mm paper scene from 4.3-5.0 s to 2.9 s,
    // with 0.5 GB more memory: about 6 bytes of host memory per pose of a batch, 0.8 GB at most),
    // and a pass's fixed costs (a submit, a wait) are paid once for more angles.
    int balanced_rounds = 8;
    std::uint64_t max_balanced_poses = std::uint64_t(1) << 27;
    // Poses one pose-by-pose dispatch takes at most (0: as many as 32-bit item indices and the
    // device's storage buffers allow); a wave over more goes in slices.
    std::uint64_t max_poses_per_dispatch = 0;
    // Loop iterations one invocation may run (lavapipe silently stops loops after about 65,535).
    std::uint32_t loop_budget = 32768;
    // Offsets per side of the exact block pre-test (1: off). Each stage first tests one pose per
    // block of block x block offsets against the fixed volumes OR-pooled over the block; a block
    // whose pooled test proves "no overlap" is decided for all its poses at once.
    int block = 8;
    // Contact and the interaction dictionary by overlap maps (shaders/sweep_map.comp): every offset
    // of an angle at once, from pairs of slice runs, instead of pose by pose. Off: pose by pose.
    bool maps = true;
    // Cost model for fidelity, visibility and the labelled dictionary tests: a pose test of
    // 160,000 loop steps costs about as much as this many run pairs of a map. A pose test's steps
    // are estimated from its volumes (so the price grows with the resolution) and a map's pairs
    // from one angle with every pose in play (its passes then visit several times fewer);
    // calibrated on lavapipe, 2 cores, with the paper scene at 10 mm and 5 mm, where no batch is
    // cheaper pose by pose. 0: always pose by pose; very large: always maps.
    double pose_test_pairs = 50000;
    // Bytes of overlap maps one batch of angles may hold.
    std::uint64_t max_map_bytes = std::uint64_t(64) << 20;
    // Passes over the z slices and rows of an overlap map, coarse to fine (with 5: the runs whose
    // z and y are both multiples of 16 first, then of 8, 4, 2, the rest last): poses decided by a
    // pass leave play and later passes skip the runs that reach only decided poses (1: one pass;
    // at most 16).
    int map_passes = 5;
    // Heights of B (z_range) one run sweeps together (1: one run per height). B's runs are then cut
    // and pruned once per angle for all of them, and each map pass pairs them with A's runs at
    // every height in one dispatch; a batch then holds fewer angles (its maps are per height).
    // Needs maps on and pose_test_pairs above 0 (every stage goes by maps).
    int heights_per_run = 16;
};

struct SweepStats {
    std::uint64_t work_items = 0;  // invocations over all stages
    std::uint64_t submits = 0;
    std::uint64_t batches = 0;  // batches of angles (SweeperOptions: max_poses_per_batch, balanced_rounds)
    std::array<std::uint64_t, 4> poses_per_stage{};  // poses entering contact, dictionary, fidelity, visibility
    std::array<double, 4> seconds_per_stage{};        // wall time of each stage, host work included
    double device_wait_seconds = 0;                   // of those, waiting for submits to finish
    std::array<std::uint64_t, 4> blocks_per_stage{};  // block pre-tests run
    std::array<std::uint64_t, 4> pose_tests_per_stage{};  // poses the block pre-test left undecided
    std::array<std::uint64_t, 4> maps_per_stage{};         // overlap maps computed (per batch and test)
    std::array<std::uint64_t, 4> pulled_runs_per_stage{};  // slice runs of B mapped by overlap maps (once per height)
    std::array<std::uint64_t, 4> runs_cut_per_stage{};     // slice runs of B the host cut for them, kept or not
    std::array<std::uint64_t, 4> run_pairs_per_stage{};    // pairs of fixed and pulled runs the maps visited
    std::uint64_t fixed_volumes_built = 0;  // A's column volumes, built once for every height (HeightShare)
};

class VulkanSweeper : public Sweeper {
public:
    explicit VulkanSweeper(Context& context, SweeperOptions options = {});
    std::string name() const override;
    SweepResult sweep(const SweepProblem& problem) override;
    const SweepStats& last_stats() const { return stats_; }
    std::vector<double> stage_seconds() const override {
        return {stats_.seconds_per_stage.begin(), stats_.seconds_per_stage.end()};
    }
    double device_wait_seconds() const override { return stats_.device_wait_seconds; }

    static constexpr std::uint32_t kWorkgroup = 64;
    static constexpr int kMaxFrameWords = 16;  // PER_FRAME tests handle up to 512 frames

private:
    // `kernels`: sweep_overlap.comp, then sweep_map.comp, built (make_kernels).
    VulkanSweeper(Context& context, SweeperOptions options, std::vector<Kernel> kernels);
    // How many heights of `problem` one SweepRun sweeps together.
    int heights_per_run(const SweepProblem& problem) const;

    Context& context_;
    SweeperOptions options_;
    Kernel overlap_;
    Kernel map_;
    SweepStats stats_;
};

}  // namespace amhv::gpu
