// `amhv plan`: the shard commands for any engine (commands.txt) and for Slurm (slurm.sbatch).
#include <filesystem>

#include <fmt/format.h>

#include "src/io/files.hpp"
#include "src/pipeline/shard_stage.hpp"
#include "src/results/group_vdb.hpp"

namespace amhv::pipeline {

namespace fs = std::filesystem;

namespace {

// One word for sh and bash, whatever it holds.
std::string shell_quote(const std::string& text) {
    std::string out = "'";
    for (char c : text) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
    return out + "'";
}

std::string timings_flag(const PlanOptions& options) { return options.timings ? "" : " --no-timings"; }

std::string commands_text(const Scene& scene, const PlanOptions& options, const fs::path& target) {
    std::string text;
    for (int k = 1; k <= options.shards; ++k)
        text += fmt::format("{} sweep {} --shard {}/{} --backend {}{} --out {}\n", shell_quote(options.program.string()), shell_quote(scene.file.string()), k,
                            options.shards, options.backend, timings_flag(options), shell_quote((target / "shards" / std::to_string(k)).string()));
    return text;
}

// One script for every step, so that one file is the whole job: run outside an array task (by
// bash, or by sbatch as a small job) it submits the array of shards, the merge after it and the
// edit after the merge; sbatch runs it again as each of those jobs with the step as argument.
std::string sbatch_text(const Scene& scene, const PlanOptions& options, const fs::path& target) {
    const std::string flags = fmt::format("--backend {}{}", options.backend, timings_flag(options));
    return fmt::format(R"sh(#!/bin/bash
# amhv plan: {scene} in {n} shards ({program}).
#   bash slurm.sbatch   (or: sbatch slurm.sbatch) submits a job array of the {n} shards, then
#                       `amhv merge` once all succeeded (afterok), then `amhv edit --from-sweep`
#                       once the merge succeeded. Job ids are printed; logs go to logs/.
# Outputs: shards/K (one folder per shard), sweep/ (merged, as `amhv sweep` writes it), edit/.
#SBATCH --job-name=amhv-submit
#SBATCH --output={plan}/logs/submit.out
set -euo pipefail
AMHV={amhv}
SCENE={scene_q}
PLAN={plan_q}
SELF="$PLAN/slurm.sbatch"
step="${{1:-submit}}"

case "$step" in
shard)  # a task of the array: amhv sweep takes K and N from SLURM_ARRAY_TASK_ID and _COUNT
  exec "$AMHV" sweep "$SCENE" --shard {flags} --out "$PLAN/shards/$SLURM_ARRAY_TASK_ID" ;;
merge)
  shards=()
  for k in $(seq 1 {n}); do shards+=("$PLAN/shards/$k"); done
  exec "$AMHV" merge "${{shards[@]}}" {flags} --out "$PLAN/sweep" ;;
edit)
  exec "$AMHV" edit "$SCENE" --from-sweep "$PLAN/sweep" {flags} --out "$PLAN/edit" ;;
submit)
  submit() {{ local id; id=$(sbatch --parsable "$@"); echo "${{id%%;*}}"; }}
  shards=$(submit --array=1-{n} --job-name=amhv-shard --cpus-per-task={cpus} --output="$PLAN/logs/shard_%a.out" "$SELF" shard)
  merge=$(submit --dependency=afterok:"$shards" --kill-on-invalid-dep=yes --job-name=amhv-merge --cpus-per-task={cpus} \
            --output="$PLAN/logs/merge.out" "$SELF" merge)
  edit=$(submit --dependency=afterok:"$merge" --kill-on-invalid-dep=yes --job-name=amhv-edit --cpus-per-task={cpus} \
            --output="$PLAN/logs/edit.out" "$SELF" edit)
  echo "amhv plan: submitted shards=$shards merge=$merge edit=$edit" ;;
*)
  echo "slurm.sbatch: unknown step '$step' (submit, shard, merge or edit)" >&2
  exit 2 ;;
esac
)sh",
                       fmt::arg("scene", scene.file.string()), fmt::arg("n", options.shards), fmt::arg("program", std::string("amhv ") + AMHV_VERSION),
                       fmt::arg("plan", target.string()), fmt::arg("amhv", shell_quote(options.program.string())),
                       fmt::arg("scene_q", shell_quote(scene.file.string())), fmt::arg("plan_q", shell_quote(target.string())),
                       fmt::arg("flags", flags), fmt::arg("cpus", options.cpus_per_task));
}

results::Json plan_json(const Scene& scene, const std::vector<ShardWork>& plan) {
    results::Json shards = results::Json::array();
    for (std::size_t s = 0; s < plan.size(); ++s) {
        results::Json pieces = results::Json::array();
        std::uint64_t cost = 0;
        for (const results::ShardPiece& p : plan[s]) {
            pieces.push_back({{"segment", p.segment}, {"angles", {p.first_angle, p.first_angle + p.angle_count - 1}}});
            cost += angle_cost(scene, scene.segments[std::size_t(p.segment - 1)]) * std::uint64_t(p.angle_count);
        }
        shards.push_back({{"index", s + 1}, {"estimated_cost", cost}, {"pieces", pieces}});
    }
    return {{"kind", "amhv plan"}, {"program", std::string("amhv ") + AMHV_VERSION}, {"scene", scene.file.string()},
            {"scene_hash", results::scene_hash(scene)}, {"shards", shards}};
}

}  // namespace

void write_plan(const Scene& scene, const PlanOptions& options, const fs::path& staging, const fs::path& target) {
    const std::vector<ShardWork> plan = plan_shards(scene, options.shards);
    results::write_json_file(staging / "plan.json", plan_json(scene, plan));
    write_file(staging / "commands.txt", commands_text(scene, options, target));
    write_file(staging / "slurm.sbatch", sbatch_text(scene, options, target));
    fs::permissions(staging / "slurm.sbatch", fs::perms::owner_exec | fs::perms::group_exec | fs::perms::others_exec, fs::perm_options::add);
    fs::create_directories(staging / "shards");
    fs::create_directories(staging / "logs");
}

}  // namespace amhv::pipeline
