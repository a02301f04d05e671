#pragma once
// Scale-out (docs/design.md, "Scale-out"): a scene's sweep cut into N shards that run anywhere
// (a Slurm job array, GNU parallel, a render farm's command list), then merged into exactly the
// folder `amhv sweep` writes on one machine.
//   plan_shards:   the work (every key segment's angles, in order) cut into N contiguous shards of
//                  about equal estimated cost; the same cut for the plan, every shard and merge;
//   sweep_shard:   `amhv sweep --shard K/N`, one shard folder;
//   read_shard_set, merge_shards: `amhv merge`, which checks that the folders are every shard of
//                  one plan of one scene, once, and writes the sweep's files from their outcomes;
//   write_plan:    `amhv plan`, commands.txt and slurm.sbatch.
#include <chrono>
#include <filesystem>
#include <string>
#include <vector>

#include "src/pipeline/sweep_stage.hpp"
#include "src/results/shard_files.hpp"

namespace amhv::pipeline {

using ShardWork = std::vector<results::ShardPiece>;

// Estimated cost of one angle of `segment` (relative): its normalised frames times B's heights,
// twice that with visibility (the paper scene's visibility segment sweeps about twice as long).
std::uint64_t angle_cost(const Scene& scene, const KeySegment& segment);

// The scene's work in `count` shards (index 0 is shard 1). Throws when count is not 1..angles.
std::vector<ShardWork> plan_shards(const Scene& scene, int count);

// A fingerprint of what the scene reads beyond its TOML: the CRC-32 and size of every input file
// (takes, labels, tracks) and the names, sizes and times of the files in every mesh-sequence folder.
// Shards and merge compare it, so that a take changed between them is refused, not merged.
std::string inputs_fingerprint(const Scene& scene);

struct ShardIndex {
    int index = 0, count = 0;  // K of N, K from 1
};
// "K/N"; an empty text or part takes K from SLURM_ARRAY_TASK_ID (less SLURM_ARRAY_TASK_MIN - 1)
// and N from SLURM_ARRAY_TASK_COUNT. Throws naming --shard when neither gives a shard.
ShardIndex parse_shard(const std::string& text);

// `amhv sweep --shard K/N` into `out` (a staging folder): the shard's pieces and shard.json.
results::ShardManifest sweep_shard(const Scene& scene, Backends& backends, const std::filesystem::path& out, ShardIndex shard, bool timings,
                                   std::chrono::steady_clock::time_point start);

// Shard folders checked to be every shard of one plan of one scene and program, once each, in
// shard order.
struct ShardSet {
    std::vector<std::filesystem::path> folders;
    std::vector<results::ShardManifest> shards;
};
// Reads the folders' manifests and checks everything that needs no scene: one program, one scene,
// one N, each K once and none missing. Throws amhv::Error naming the folder.
ShardSet read_shard_set(const std::vector<std::filesystem::path>& folders);
// Checks the set against the scene it names (its hash, the plan of its work) before any volume is built.
void check_shard_set(const ShardSet& set, const Scene& scene);

// `amhv merge` into `out`: for each key segment, its volumes (with `voxeliser`), the shards'
// outcomes, and the same files and result.json that `amhv sweep` writes.
SweepStage merge_shards(const Scene& scene, const ShardSet& set, Voxeliser& voxeliser, const std::filesystem::path& out,
                        const SweepStageOptions& options, std::chrono::steady_clock::time_point start);

struct PlanOptions {
    int shards = 0;
    std::string backend = "vulkan";
    int cpus_per_task = 2;
    bool timings = true;
    std::filesystem::path program;  // the amhv binary the commands run
};
// `amhv plan` into `staging`, for the folder `target` (absolute): plan.json, commands.txt (one
// shard command per line), slurm.sbatch (the job array, the merge after it, the edit after that),
// and the empty shards/ and logs/ folders they write into.
void write_plan(const Scene& scene, const PlanOptions& options, const std::filesystem::path& staging, const std::filesystem::path& target);

}  // namespace amhv::pipeline
