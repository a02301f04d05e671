// `amhv merge` and `amhv plan`: the scale-out commands (`amhv sweep --shard` is in command_sweep.cpp).
#include <chrono>
#include <iostream>
#include <memory>

#include "src/cli/backend.hpp"
#include "src/cli/commands.hpp"
#include "src/core/error.hpp"
#include "src/io/output_dir.hpp"
#include "src/pipeline/shard_stage.hpp"
#include "src/scene/scene.hpp"

namespace amhv::cli {

namespace fs = std::filesystem;

namespace {

struct MergeArguments {
    std::vector<std::string> shards;
    std::string out, backend = "vulkan", scene;
    int device = -1;
    bool require_solutions = false, maps = true, timings = true, csv = false;
};

void run_merge(const MergeArguments& args) {
    const auto start = std::chrono::steady_clock::now();
    const std::vector<fs::path> folders(args.shards.begin(), args.shards.end());
    const pipeline::ShardSet set = pipeline::read_shard_set(folders);
    // The shards name their scene; where this machine mounts it elsewhere, --scene (same hash).
    const Scene scene = load_two_object_scene(args.scene.empty() ? set.shards.front().scene : args.scene, "merge");
    pipeline::check_shard_set(set, scene);
    std::vector<fs::path> inputs = scene_inputs(scene);
    inputs.insert(inputs.end(), folders.begin(), folders.end());
    Backend backend(args.backend, args.device);  // builds the volumes again (identical on either backend)
    StagedOutput out(args.out, inputs);
    const pipeline::SweepStage stage = pipeline::merge_shards(scene, set, backend.voxeliser(), out.dir(), {0, args.maps, args.timings, args.csv}, start);
    out.commit();
    std::cout << fmt::format("wrote {}/ (result.json, segment_N/group.vdb{}{}) from {} shards\n", out.target().string(),
                             args.csv ? ", segment_N/solutions.csv" : "", args.maps ? ", segment_N/feasibility/" : "", set.shards.size());
    for (const KeySweep& k : stage.sweeps)
        if (args.require_solutions && k.group.empty()) throw Error(fmt::format("--require-solutions: key segment {} has no solution", k.index));
}

struct PlanArguments {
    std::string scene, out;
    pipeline::PlanOptions options;
};

void run_plan(PlanArguments args) {
    const Scene scene = load_two_object_scene(args.scene, "plan");
    pipeline::plan_shards(scene, args.options.shards);  // refuses an impossible N before writing
    args.options.program = fs::canonical("/proc/self/exe");
    StagedOutput out(args.out, scene_inputs(scene));
    const fs::path target = fs::absolute(args.out).lexically_normal();
    pipeline::write_plan(scene, args.options, out.dir(), target);
    out.commit();
    std::cout << fmt::format(
        "wrote {}/ (plan.json, commands.txt, slurm.sbatch: {} shards)\n"
        "  one machine or GNU parallel: parallel < {}/commands.txt, then amhv merge {}/shards/* --out {}/sweep\n"
        "  Slurm: bash {}/slurm.sbatch (the shards as a job array, then merge, then edit)\n",
        out.target().string(), args.options.shards, out.target().string(), out.target().string(), out.target().string(), out.target().string());
}

}  // namespace

void add_shard_commands(CLI::App& app) {
    auto merge_args = std::make_shared<MergeArguments>();
    auto* merge = app.add_subcommand("merge", "Merge the shard folders of `amhv sweep --shard` into the folder `amhv sweep` writes on one machine");
    merge->add_option("shards", merge_args->shards, "Every shard folder of one plan (K/N for K = 1..N)")->required();
    merge->add_option("--out", merge_args->out, "Output folder (replaced as a whole when the run succeeds)")->required();
    merge->add_option("--scene", merge_args->scene, "The scene file, where it is not at the path the shards name (it must be the same scene)");
    add_backend_options(*merge, merge_args->backend, merge_args->device);
    merge->add_flag("--require-solutions", merge_args->require_solutions, "Exit non-zero when a key segment has no solution");
    merge->add_flag("!--no-maps", merge_args->maps, "Skip the feasibility maps");
    merge->add_flag("--csv", merge_args->csv, "Also write each solution group as segment_N/solutions.csv");
    merge->add_flag("!--no-timings", merge_args->timings, "Leave timings out of result.json (byte-identical reruns)");
    merge->callback([merge_args] { run_merge(*merge_args); });

    auto plan_args = std::make_shared<PlanArguments>();
    auto* plan = app.add_subcommand("plan", "Cut a scene's sweep into shards: commands.txt for any engine, slurm.sbatch for a Slurm cluster");
    plan->add_option("scene", plan_args->scene, "Scene file (TOML)")->required();
    plan->add_option("--shards", plan_args->options.shards, "Number of shards N")->required()->check(CLI::PositiveNumber);
    plan->add_option("--out", plan_args->out, "Plan folder: the shards, the merged sweep and the edit go inside it")->required();
    plan->add_option("--backend", plan_args->options.backend, "Backend of every step: vulkan or cpu")
        ->check(CLI::IsMember({"vulkan", "cpu"}))
        ->capture_default_str();
    plan->add_option("--cpus-per-task", plan_args->options.cpus_per_task, "Slurm CPUs per job")->check(CLI::PositiveNumber)->capture_default_str();
    plan->add_flag("!--no-timings", plan_args->options.timings, "Every step leaves timings out (byte-identical reruns)");
    plan->callback([plan_args] { run_plan(*plan_args); });
}

}  // namespace amhv::cli
