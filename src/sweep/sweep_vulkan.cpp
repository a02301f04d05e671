// VulkanSweeper: one sweep is a SweepRun (sweep_vulkan_run.hpp); this file holds its batches:
// contact and the dictionary on every pose of a batch of angles, then fidelity and visibility on
// the poses that are left, and the outcome of every pose.
#include "src/sweep/sweep_vulkan.hpp"

#include <algorithm>
#include <chrono>

#include "src/core/error.hpp"
#include "src/core/parallel.hpp"
#include "src/sweep/sweep_vulkan_run.hpp"
#include "shaders/sweep_map.spv.h"
#include "shaders/sweep_overlap.spv.h"

namespace amhv::gpu {

using namespace sweep_detail;

VulkanSweeper::VulkanSweeper(Context& context, SweeperOptions options)
    : VulkanSweeper(context, options,
                    make_kernels(context, {{sweep_overlap_spv, std::vector<Binding>(8, Binding::Storage), sizeof(OverlapParams),
                                            {kWorkgroup, std::uint32_t(kMaxFrameWords)}},
                                           {sweep_map_spv,
                                            {Binding::Texels64, Binding::Storage, Binding::Storage, Binding::Storage, Binding::Texels32},
                                            sizeof(MapParams),
                                            {kWorkgroup}}})) {}

VulkanSweeper::VulkanSweeper(Context& context, SweeperOptions options, std::vector<Kernel> kernels)
    : context_(context), options_(options), overlap_(std::move(kernels.at(0))), map_(std::move(kernels.at(1))) {}

std::string VulkanSweeper::name() const { return "vulkan:" + context_.selected().name; }

// One SweepRun per group of heights of B (z_range), each over every angle; their outcomes follow
// each other.
SweepResult VulkanSweeper::sweep(const SweepProblem& problem) {
    validate(problem);
    stats_ = {};
    const PoseRange& r = problem.range;
    const int group = heights_per_run(problem);
    if (group == r.depth()) {  // one run: its outcomes are the result (no second copy)
        HeightShare share;
        SweepResult result =
            SweepRun(problem, SweepTools{context_, options_, overlap_, map_, stats_, progress}, share, r.z_first, group).run();
        result.range = r;
        return result;
    }
    SweepResult result;
    result.range = r;
    result.outcomes.resize(r.size());  // FailsContact (zero), on pages untouched until written
    HeightShare share;
    for (int level = r.z_first; level <= r.z_last; level += group) {
        const int heights = std::min(group, r.z_last - level + 1);
        const int swept = problem.angle_end() - problem.first_angle, done_before = (level - r.z_first) * swept;
        std::function<void(int, int)> run_progress;
        if (progress) run_progress = [&](int done, int) { progress(done_before + done * heights, swept * r.depth()); };
        SweepRun run(problem, SweepTools{context_, options_, overlap_, map_, stats_, run_progress}, share, level, heights);
        const SweepResult run_result = run.run();
        std::copy(run_result.outcomes.begin(), run_result.outcomes.end(),
                  result.outcomes.begin() + std::ptrdiff_t(std::size_t(level - r.z_first) * r.per_level()));
    }
    result.count();
    return result;
}

// Heights in one run: as many as the options allow and an angle's maps at every height fit a
// batch (a test has at most one map per frame; those of one angle cannot be split).
int VulkanSweeper::heights_per_run(const SweepProblem& problem) const {
    if (!SweepRun::heights_in_one(options_)) return 1;
    const PoseRange& r = problem.range;
    const std::uint64_t row_bytes = std::uint64_t((std::max(1, r.width()) + 31) / 32) * 4;
    const std::uint64_t per_height = std::uint64_t(std::max(1, problem.frames())) * std::uint64_t(std::max(1, r.height())) * row_bytes;
    const std::uint64_t max_bytes = std::min<std::uint64_t>(options_.max_map_bytes, context_.selected().max_storage_buffer_range);
    const std::uint64_t fitting = std::max<std::uint64_t>(1, max_bytes / per_height);
    return int(std::min<std::uint64_t>({std::uint64_t(r.depth()), std::uint64_t(std::max(1, options_.heights_per_run)),
                                        std::uint64_t(SweepRun::kMaxHeights), fitting}));
}

namespace sweep_detail {

SweepResult SweepRun::run() {
    result_.range = range_;
    static_assert(PoseOutcome::FailsContact == PoseOutcome{}, "outcomes start as zero pages");
    result_.outcomes.resize(range_.size());  // FailsContact, on pages untouched until written
    if (range_.size() == 0) {
        result_.count();
        return result_;
    }
    size_batches();
    // Only the problem's angles (all but in a shard); the others stay FailsContact.
    const int first = problem_.first_angle, end = problem_.angle_end();
    for (int angle_first = first; angle_first < end; angle_first += angles_per_batch_) {
        sweep_batch(angle_first, std::min(angles_per_batch_, end - angle_first));
        ++tools_.stats.batches;
        if (tools_.progress) tools_.progress(std::min(angle_first + angles_per_batch_, end) - first, end - first);
    }
    result_.count();
    return std::move(result_);
}

void SweepRun::submit_and_wait() {
    const auto start = std::chrono::steady_clock::now();
    sequence_.submit_and_wait();
    tools_.stats.device_wait_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

void SweepRun::lap(int stage) {
    const auto now = std::chrono::steady_clock::now();
    tools_.stats.seconds_per_stage[std::size_t(stage)] += std::chrono::duration<double>(now - clock_).count();
    clock_ = now;
}

// One batch of angles through every stage; each stage's wall time, host work included, goes to
// its entry of SweepStats::seconds_per_stage.
void SweepRun::sweep_batch(int angle_first, int batch_angles) {
    tools_.stats.poses_per_stage[0] += per_angle_ * std::uint64_t(views(batch_angles));
    clock_ = std::chrono::steady_clock::now();
    std::vector<Pose> survivors =
        tools_.options.maps ? contact_and_dictionary_by_maps(angle_first, batch_angles) : contact_pose_by_pose(angle_first, batch_angles);
    for (int stage = 1; stage < 4; ++stage) {
        if (!tools_.options.maps || stage > 1) tools_.stats.poses_per_stage[std::size_t(stage)] += survivors.size();
        // With maps, the lateral pairs' dictionary is decided by the required maps already.
        if (!(tools_.options.maps && stage == 1 && type_.lateral_pair())) survivors = later_stage(stage, std::move(survivors), angle_first, batch_angles);
        lap(stage);
    }
    const std::vector<std::size_t> starts = view_starts(survivors, angle_first, batch_angles);
    parallel_for(std::size_t(views(batch_angles)), [&](std::size_t v) {
        for (std::size_t p = starts[v]; p < starts[v + 1]; ++p) result_.outcomes[outcome_index(survivors[p])] = PoseOutcome::Solution;
    });
}

// Where each view's poses start in `poses` (sorted by view, as every stage keeps them), and the
// end: per-view work on them runs on all cores, each view writing only its own poses' entries.
std::vector<std::size_t> SweepRun::view_starts(const std::vector<Pose>& poses, int angle_first, int batch_angles) const {
    const int count = views(batch_angles);
    const auto view_of = [&](const Pose& q) { return (q[0] - angle_first) * heights_ + q[3]; };
    // By binary search: a walk over every pose was, on a 16-core host, serial time in every stage.
    std::vector<std::size_t> starts(std::size_t(count) + 1, poses.size());
    for (int v = 0; v < count; ++v)
        starts[std::size_t(v)] = std::size_t(std::partition_point(poses.begin(), poses.end(), [&](const Pose& q) { return view_of(q) < v; }) -
                                             poses.begin());
    // Each view's stretch must begin and end with that view (and the batch's poses lie in it).
    const auto in_batch = [&](const Pose& q) { return q[0] >= angle_first && q[3] >= 0 && q[3] < heights_ && view_of(q) < count; };
    bool in_order = poses.empty() || (in_batch(poses.front()) && in_batch(poses.back()));
    for (int v = 0; v < count && in_order; ++v) {
        const std::size_t first = starts[std::size_t(v)], end = starts[std::size_t(v) + 1];
        in_order = first == end || (view_of(poses[first]) == v && view_of(poses[end - 1]) == v);
    }
    if (!in_order) fail("sweep", "internal: a batch's poses are not in view order");
    return starts;
}

// The box of the set flags of one angle's poses (row by row, `width_` to a row; empty: first > last).
Band SweepRun::box_of_flags(const std::uint8_t* flags) const {
    Band box{height_, -1, width_, -1};
    for (int j = 0; j < height_; ++j) widen_by_flags(box, flags + std::size_t(j) * std::size_t(width_), j, 0, width_ - 1);
    return box;
}

// Contact by its map on every pose of the batch, then the required dictionary maps on the poses
// in contact. Returns the poses that pass both; the rest get their outcome.
std::vector<Pose> SweepRun::contact_and_dictionary_by_maps(int angle_first, int batch_angles) {
    const std::size_t view_count = std::size_t(views(batch_angles));
    const Rows all_rows(view_count, {0, height_ - 1, 0, width_ - 1});
    const auto contact = run_map(required_maps_[0].front(), 0, angle_first, batch_angles, all_rows, nullptr);
    lap(0);  // the dictionary maps count as the dictionary's time
    Rows contact_rows(view_count);
    parallel_for(view_count, [&](std::size_t v) { contact_rows[v] = box_of_flags(contact.data() + v * per_angle_); });
    Meets dictionary;
    for (MapTest& test : required_maps_[1]) dictionary.push_back(run_map(test, 1, angle_first, batch_angles, contact_rows, &contact));
    // Row by row, so a pose's offsets come without dividing its index; views on all cores: first
    // each view's outcomes and survivor count, then its survivors in place (view order).
    const auto for_each_contact = [&](std::size_t v, const auto& visit) {
        const Band& band = contact_rows[v];
        for (int j = band[0]; j <= band[1]; ++j) {
            const std::size_t row = std::size_t(j) * std::size_t(width_);
            for (int i = band[2]; i <= band[3]; ++i)
                if (contact[v * per_angle_ + row + std::size_t(i)]) visit(row + std::size_t(i), i, j);
        }
    };
    std::vector<std::size_t> kept(view_count + 1, 0);
    std::vector<std::uint64_t> in_contact(view_count, 0);
    parallel_for(view_count, [&](std::size_t v) {
        PoseOutcome* outcomes = view_outcomes(angle_first, int(v));
        std::uint64_t contacts = 0, passed = 0;  // local: neighbouring views' counters share a cache line
        for_each_contact(v, [&](std::size_t pose, int, int) {
            ++contacts;
            if (passes_all(dictionary, v * per_angle_ + pose)) ++passed;
            else outcomes[pose] = PoseOutcome::FailsDictionary;
        });
        in_contact[v] = contacts;
        kept[v + 1] = passed;
    });
    for (std::size_t v = 0; v < view_count; ++v) {
        kept[v + 1] += kept[v];
        tools_.stats.poses_per_stage[1] += in_contact[v];
    }
    std::vector<Pose> survivors(kept.back());
    parallel_for(view_count, [&](std::size_t v) {
        const PoseOutcome* outcomes = view_outcomes(angle_first, int(v));
        const int angle = angle_first + int(v) / heights_, level = int(v) % heights_;
        std::size_t next = kept[v];
        for_each_contact(v, [&](std::size_t pose, int i, int j) {
            if (outcomes[pose] != PoseOutcome::FailsDictionary) survivors[next++] = {angle, range_.i_first + i, range_.j_first + j, level};
        });
    });
    return survivors;
}

// Contact on every pose of the batch: by block where blocks are on, then pose by pose.
std::vector<Pose> SweepRun::contact_pose_by_pose(int angle_first, int batch_angles) {
    std::vector<Pose> survivors;
    if (block_ > 1) {
        std::vector<Pose> bases;
        for (int k = angle_first; k < angle_first + batch_angles; ++k)
            for (int bj = 0; bj < blocks_y_; ++bj)
                for (int bi = 0; bi < blocks_x_; ++bi) bases.push_back({k, range_.i_first + bi * block_, range_.j_first + bj * block_, 0});
        const std::vector<Verdict> verdicts = block_verdicts(0, bases);
        std::vector<Pose> candidates;
        for (std::size_t b = 0; b < bases.size(); ++b) {
            if (verdicts[b] == Verdict::Fail) continue;
            for (int j = bases[b][2]; j < std::min(bases[b][2] + block_, range_.j_last + 1); ++j)
                for (int i = bases[b][1]; i < std::min(bases[b][1] + block_, range_.i_last + 1); ++i) candidates.push_back({bases[b][0], i, j, 0});
        }
        tools_.stats.pose_tests_per_stage[0] += candidates.size();
        const auto meets = run_stage(stages_[0], &candidates, 0, 0);
        for (std::size_t p = 0; p < candidates.size(); ++p)
            if (passes_all(meets, p)) survivors.push_back(candidates[p]);
    } else {
        const std::uint64_t batch_poses = per_angle_ * std::uint64_t(batch_angles);
        tools_.stats.pose_tests_per_stage[0] += batch_poses;
        const auto meets = run_stage(stages_[0], nullptr, batch_poses, angle_first);
        for (std::uint64_t p = 0; p < batch_poses; ++p)
            if (passes_all(meets, p)) survivors.push_back(implicit_pose(angle_first, p));
    }
    lap(0);
    return survivors;
}

// Clears the candidates (per pose of the batch) that `meets` fails and shrinks each view's box
// to those left; views on all cores.
void SweepRun::keep_passed(const std::vector<std::uint8_t>& meets, int batch_angles, std::vector<std::uint8_t>& candidates, Rows& rows) const {
    parallel_for(std::size_t(views(batch_angles)), [&](std::size_t v) {
        Band& band = rows[v];
        Band still{height_, -1, width_, -1};
        for (int j = band[0]; j <= band[1]; ++j) {
            const std::size_t row = v * per_angle_ + std::size_t(j) * std::size_t(width_);
            for (int i = band[2]; i <= band[3]; ++i) candidates[row + std::size_t(i)] &= meets[row + std::size_t(i)];
            widen_by_flags(still, candidates.data() + row, j, band[2], band[3]);
        }
        band = still;
    });
}

// Stage 1..3 on the survivors of the stage before, by maps where the cost model says they pay off,
// else pose by pose. Returns the poses that pass; the rest get this stage's outcome.
std::vector<Pose> SweepRun::later_stage(int stage, std::vector<Pose> survivors, int angle_first, int batch_angles) {
    const std::size_t view_count = std::size_t(views(batch_angles));
    const std::uint64_t batch_poses = per_angle_ * view_count;
    const std::vector<std::size_t> starts = view_starts(survivors, angle_first, batch_angles);
    // Per view, on all cores: each writes its own band and its own poses' entries.
    const auto for_each_view = [&](const std::function<void(std::size_t v, std::size_t first, std::size_t end)>& work) {
        parallel_for(view_count, [&](std::size_t v) { work(v, starts[v], starts[v + 1]); });
    };
    std::vector<std::uint8_t> passes;
    Rows rows(view_count, {height_, -1, width_, -1});
    // Kept between stages and batches, each angle clearing its own: a fresh zeroed list was a
    // serial clear of every pose of the batch in every stage.
    std::vector<std::uint8_t>& candidates = candidates_scratch_;
    candidates.resize(batch_poses);
    for_each_view([&](std::size_t v, std::size_t first, std::size_t end) {
        std::fill_n(candidates.data() + v * per_angle_, per_angle_, std::uint8_t(0));
        Band band = rows[v];  // local: neighbouring views' bands share a cache line
        for (std::size_t p = first; p < end; ++p) {
            const Pose& q = survivors[p];
            widen(band, q[2] - range_.j_first, q[1] - range_.i_first);
            candidates[batch_index(q, angle_first)] = 1;
        }
        rows[v] = band;
    });
    // Every angle's first map pass is cut (on all cores), and the cost model's sample angle whole,
    // before the model reads it: the maps then use them as they are and cut each angle's other rows
    // just before their first pass. (Cutting the sample alone, on one core, cost as much as the
    // maps at 5 mm; the other angles' later rows, cut up front, were mostly runs that only poses
    // decided by the first passes could have used.)
    std::vector<MapTest>& maps = optional_maps_[std::size_t(stage)];
    const bool may_map = !maps.empty() && !survivors.empty();
    // With several heights every stage goes by maps (a pose test takes one height), and no angle
    // is cut whole for the cost model.
    if (may_map)
        for (MapTest& test : maps) cut_angles(test, angle_first, batch_angles, rows, &candidates, heights_ > 1 ? -1 : model_sample(rows));
    if (may_map && (heights_ > 1 || maps_pay_off(stage, survivors.size(), batch_angles, rows, candidates))) {
        Meets meets;
        for (std::size_t m = 0; m < maps.size(); ++m) {
            // A pose that fails one test of the stage fails the stage: each later map needs only
            // the poses the ones before passed. Its first pass, cut up front, then prunes against
            // those, and its later passes are cut within their box. (Cutting the first pass again
            // against them paid nothing: the runs it would drop, the pruning drops.)
            if (m > 0) keep_passed(meets.back(), batch_angles, candidates, rows);
            meets.push_back(run_map(maps[m], stage, angle_first, batch_angles, rows, &candidates, true));
        }
        passes.resize(survivors.size());
        // The maps hold the batch's poses view by view.
        for_each_view([&](std::size_t, std::size_t first, std::size_t end) {
            for (std::size_t p = first; p < end; ++p) passes[p] = passes_all(meets, batch_index(survivors[p], angle_first));
        });
    } else if (heights_ > 1) {
        if (!survivors.empty() && !stages_[std::size_t(stage)].empty()) fail("sweep", "internal: a stage without maps in a run of several heights");
        passes.assign(survivors.size(), 1);
    } else {
        passes = decide(stage, survivors, angle_first, batch_angles);
    }
    // Each view's failures get this stage's outcome, then its passes move down in place (view order).
    std::vector<std::size_t> kept(view_count + 1, 0);
    for_each_view([&](std::size_t v, std::size_t first, std::size_t end) {
        std::size_t passed = 0;
        for (std::size_t p = first; p < end; ++p) {
            if (passes[p]) ++passed;
            else result_.outcomes[outcome_index(survivors[p])] = PoseOutcome(stage);
        }
        kept[v + 1] = passed;
    });
    for (std::size_t v = 0; v < view_count; ++v) kept[v + 1] += kept[v];
    // The passes of every view at once, each into its own stretch (view order).
    std::vector<Pose> passed(kept.back());
    for_each_view([&](std::size_t v, std::size_t first, std::size_t end) {
        std::size_t next = kept[v];
        for (std::size_t p = first; p < end; ++p)
            if (passes[p]) passed[next++] = survivors[p];
    });
    return passed;
}

}  // namespace sweep_detail

}  // namespace amhv::gpu
