// Pulled runs of the Vulkan sweep's overlap maps: B's runs, turned and moved for an angle, cut to
// the columns that can reach A's runs and pruned to the rows where a pose in play can take a bit
// (the poses in play counted by 2D prefix sums). sweep_vulkan_maps.cpp records the passes that
// pair them with A's runs (shaders/sweep_map.comp).
#include <algorithm>
#include <array>
#include <limits>

#include "src/core/error.hpp"
#include "src/sweep/sweep_vulkan_run.hpp"

namespace amhv::gpu::sweep_detail {

namespace {

// Poses in play in columns i0..i1 and rows j0..j1 (the prefix sums of count_poses_in_play).
std::uint32_t count_in_play(const PulledPruner& pruner, std::size_t stride, int i0, int i1, int j0, int j1) {
    const auto at = [&](int j, int i) { return pruner.prefix[std::size_t(j) * stride + std::size_t(i)]; };
    return at(j1 + 1, i1 + 1) - at(j0, i1 + 1) - at(j1 + 1, i0) + at(j0, i0);
}

// The rows j of the pose map where one pulled run can set a bit of a pose in play: those whose
// fixed row's hull (FixedRuns::row_hulls), moved by the run, holds one. A box of 2^L rows is tested
// at once with the hull of its fixed rows (window_hulls), and split only where it holds a pose in
// play, so a band that the run reaches nowhere costs one test per 64 rows, not one per row.
class RunReach {
public:
    RunReach(const PulledPruner& pruner, std::size_t stride, const Band& rows, const FixedRuns& fixed, std::size_t fixed_key,
             std::ptrdiff_t hull_of_row_0, std::int32_t i_first_of_run, std::int32_t i_last_of_run)
        : pruner_(pruner), stride_(stride), rows_(rows), i_first_(i_first_of_run), i_last_(i_last_of_run) {
        hull_of_row_0_ = std::ptrdiff_t(fixed.row_hull_first[fixed_key]) + hull_of_row_0;
        levels_[0] = fixed.row_hulls.data();
        for (int level = 1; level < FixedRuns::kHullLevels; ++level) levels_[std::size_t(level)] = fixed.window_hulls[std::size_t(level - 1)].data();
    }

    // The first and the last reached row of j0..j1 (-1: none).
    int first(int j0, int j1) const {
        for (int j = j0; j <= j1;) {
            const int level = level_fitting(j1 - j + 1);
            if (const int found = first_in(j, level); found >= 0) return found;
            j += 1 << level;
        }
        return -1;
    }
    int last(int j0, int j1) const {
        for (int j = j1; j >= j0;) {
            const int level = level_fitting(j - j0 + 1);
            if (const int found = last_in(j - (1 << level) + 1, level); found >= 0) return found;
            j -= 1 << level;
        }
        return -1;
    }

private:
    static int level_fitting(int rows) { return std::min(FixedRuns::kHullLevels - 1, int(std::bit_width(std::uint32_t(rows))) - 1); }

    // Whether rows j .. j + 2^level - 1 hold a pose in play within the run's reach.
    bool reaches(int j, int level) const {
        const auto& hull = levels_[std::size_t(level)][hull_of_row_0_ + j];
        if (hull[0] > hull[1]) return false;
        const int i0 = std::max(rows_[2], hull[0] - i_last_), i1 = std::min(rows_[3], hull[1] - i_first_);
        return i0 <= i1 && count_in_play(pruner_, stride_, i0, i1, j, j + (1 << level) - 1) != 0;
    }
    int first_in(int j, int level) const {
        if (!reaches(j, level)) return -1;
        if (level == 0) return j;
        const int found = first_in(j, level - 1);
        return found >= 0 ? found : first_in(j + (1 << (level - 1)), level - 1);
    }
    int last_in(int j, int level) const {
        if (!reaches(j, level)) return -1;
        if (level == 0) return j;
        const int found = last_in(j + (1 << (level - 1)), level - 1);
        return found >= 0 ? found : last_in(j, level - 1);
    }

    const PulledPruner& pruner_;
    std::size_t stride_;
    const Band& rows_;
    std::int32_t i_first_, i_last_;
    std::ptrdiff_t hull_of_row_0_ = 0;
    std::array<const std::array<std::int32_t, 2>*, FixedRuns::kHullLevels> levels_{};
};

// A pulled run's key minus this is its fixed run's key: pulled keys start at each angle's block.
std::int32_t key_base_of(const MapTest& test, int angle_in_batch) {
    return std::int32_t(angle_in_batch) * test.runs().zbits * std::int32_t(test.slots.size());
}

// The box of poses (within `rows`, relative to the range's first offsets `i_first`, `j_first`)
// that some run of `runs` can reach: the union of their keys' boxes moved by the runs
// (RunsInPlay::band tests nothing outside a run's own). Empty: first > last.
Band reach_of(const MapTest& test, int angle_in_batch, std::span<const std::span<const SliceRun>> parts, const Band& rows, std::int32_t i_first,
              std::int32_t j_first) {
    const std::int32_t key_base = key_base_of(test, angle_in_batch);
    Band reach{std::numeric_limits<std::int32_t>::max(), std::numeric_limits<std::int32_t>::min(), std::numeric_limits<std::int32_t>::max(),
               std::numeric_limits<std::int32_t>::min()};
    for (const std::span<const SliceRun> runs : parts)
        for (const SliceRun& run : runs) {
            const auto& box = test.reach_runs().key_boxes[std::size_t(run.key - key_base)];
            if (box[0] > box[1]) continue;
            reach = {std::min(reach[0], box[2] - run.y), std::max(reach[1], box[3] - run.y), std::min(reach[2], box[0] - run.x_last),
                     std::max(reach[3], box[1] - run.x_first)};
        }
    if (reach[0] > reach[1]) return {1, 0, 1, 0};
    return {std::max(rows[0], reach[0] - j_first), std::min(rows[1], reach[1] - j_first), std::max(rows[2], reach[2] - i_first),
            std::min(rows[3], reach[3] - i_first)};
}

// The rows j of the pose map where a pulled run of one angle can set a bit of a pose in play
// (`open`: false, every pose of the box `rows` is): those where the fixed runs at its key lie and,
// with poses in play, the band from the first to the last row whose fixed runs' hull, moved by
// the run, holds one (a pair can only set bits inside it). A box test (2D prefix sums of the poses
// in play) first drops most runs cheaply.
class RunsInPlay : public RunFilter {
public:
    RunsInPlay(const PulledPruner& pruner, const FixedRuns& fixed, const Band& rows, bool open, std::int32_t key_base, std::int32_t i_first,
               std::int32_t j_first, int width)
        : pruner_(pruner), fixed_(fixed), rows_(rows), open_(open), key_base_(key_base), i_first_(i_first), j_first_(j_first),
          stride_(std::size_t(width) + 1) {}

    // The band [j0, j1] of rows (relative to j_first) the run reaches, or nothing; with
    // `box_only`, the band of its key's box when that box, moved by the run, holds a pose in play
    // (a cheap test that drops most runs; the passes' pruning narrows the rest). Only rows within
    // `within` are looked at (a band known to hold every row the run reaches).
    // Inlined: it runs once per run cut and per run pruned (called where it is not, it cost 4% of
    // a 5 mm sweep's samples).
    [[gnu::always_inline]] std::optional<std::array<int, 2>> band(const SliceRun& run, bool box_only = false,
                                           std::array<int, 2> within = {std::numeric_limits<int>::min(), std::numeric_limits<int>::max()}) const {
        const std::int32_t fixed_key = run.key - key_base_;
        const auto& box = fixed_.key_boxes[std::size_t(fixed_key)];
        if (box[0] > box[1]) return std::nullopt;
        // A pair with fixed run (y_a, [xa0, xa1]) sets row j = y_a - y - j_first, offsets xa0 - x_last .. xa1 - x_first.
        int j0 = std::max({rows_[0], within[0], box[2] - run.y - j_first_}), j1 = std::min({rows_[1], within[1], box[3] - run.y - j_first_});
        if (j0 > j1) return std::nullopt;
        if (!open_) return std::array<int, 2>{j0, j1};
        const int i0 = std::max(rows_[2], box[0] - run.x_last - i_first_), i1 = std::min(rows_[3], box[1] - run.x_first - i_first_);
        if (i0 > i1 || count_in_play(pruner_, stride_, i0, i1, j0, j1) == 0) return std::nullopt;
        if (box_only) return std::array<int, 2>{j0, j1};
        // Only the band's ends matter: the first and the last row the run reaches.
        const RunReach reach(pruner_, stride_, rows_, fixed_, std::size_t(fixed_key), std::ptrdiff_t(run.y) + j_first_ - box[2],
                             run.x_first + i_first_, run.x_last + i_first_);
        j0 = reach.first(j0, j1);
        if (j0 < 0) return std::nullopt;
        j1 = reach.last(j0, j1);
        return std::array<int, 2>{j0, j1};
    }
    bool keep(const SliceRun& run) const override { return band(run, true).has_value(); }

private:
    const PulledPruner& pruner_;
    const FixedRuns& fixed_;
    const Band& rows_;
    bool open_;
    std::int32_t key_base_, i_first_, j_first_;
    std::size_t stride_;
};

// The fixed runs of key `fixed_key` on rows y0..y1: the pairs one pulled run visits there.
std::uint64_t pairs_on_rows(const FixedRuns& fixed, std::int32_t fixed_key, std::int32_t y0, std::int32_t y1) {
    const auto [key_first, key_count] = fixed.by_key[std::size_t(fixed_key)];
    const auto key_begin = fixed.runs.begin() + key_first, key_end = key_begin + key_count;
    const auto from = std::lower_bound(key_begin, key_end, y0, [](const SliceRun& r, std::int32_t y) { return r.y < y; });
    const auto to = std::upper_bound(from, key_end, y1, [](std::int32_t y, const SliceRun& r) { return y < r.y; });
    return std::uint64_t(to - from);
}

// A pruned run as the kernel reads it, paired at height h on rows j0..j1.
PulledRun pulled_run(const MapTest& test, const SliceRun& run, int h, int j0, int j1) {
    const std::int64_t y = std::int64_t(run.y) - test.fixed->y0;
    if (y < -32768 || y > 32767)
        fail("key segment", "B reaches {} rows from A's volume, more than the sweep handles (32,767); use a larger voxel", y);
    const std::uint32_t x = std::uint32_t(run.x_first - test.pulled_x0) | std::uint32_t(run.x_last - test.pulled_x0) << 16;
    return {(std::uint32_t(y) & 0xffffu) | std::uint32_t(h) << 16, x, run.key, std::uint32_t(j0) | std::uint32_t(j1) << 16};
}

// prune_pulled_runs on one part's runs of a pass. With one height, `in_play` gives each run's
// band. With several, `in_play` (A lowered over the heights, against the poses in play at any)
// drops the runs that reach none, and each height's own test (`at_height`: A's runs at the key
// lifted by h, against that height's poses in play) gives the band at each height it reaches:
// a run goes to the kernel once per such height (`out_by_height`), with the pairs counted there.
void prune_part(const MapTest& test, const RunsInPlay& in_play, std::span<const RunsInPlay> at_height, std::int32_t key_base, std::int32_t j_first,
                std::span<const SliceRun> runs, std::uint64_t& pairs, std::span<std::vector<PulledRun>* const> out_by_height) {
    const std::int32_t zbits = test.runs().zbits;
    for (const SliceRun& run : runs) {
        const auto band = in_play.band(run);
        if (!band) continue;
        const std::int32_t fixed_key = run.key - key_base;
        if (at_height.empty()) {
            pairs += pairs_on_rows(test.runs(), fixed_key, run.y + j_first + (*band)[0], run.y + j_first + (*band)[1]);
            out_by_height[0]->push_back(pulled_run(test, run, 0, (*band)[0], (*band)[1]));
            continue;
        }
        // A lifted key's runs lie within the lowered union's, and a height's poses in play within
        // those at any height: the run reaches rows of `band` only.
        for (int h = 0; h < int(at_height.size()) && fixed_key % zbits + h < zbits; ++h) {
            const auto reached = at_height[std::size_t(h)].band(run, false, *band);
            if (!reached) continue;
            const auto [j0, j1] = *reached;
            pairs += pairs_on_rows(test.runs(), fixed_key + h, run.y + j_first + j0, run.y + j_first + j1);
            out_by_height[std::size_t(h)]->push_back(pulled_run(test, run, h, j0, j1));
        }
    }
}

}  // namespace

// Counts of the poses in play in the box `rows` (2D prefix sums of `open`, one row of `width` poses
// per j), so that a box of offsets within it is tested for poses in play in constant time. Only
// the box's prefix rows and columns are filled: every query is clamped to the box.
void count_poses_in_play(PulledPruner& pruner, const std::uint8_t* open, const Band& rows, int width, int height) {
    const std::size_t stride = std::size_t(width) + 1;
    pruner.prefix.resize(stride * (std::size_t(height) + 1));
    const int i_first = rows[2], i_last = rows[3];
    std::fill_n(pruner.prefix.begin() + std::ptrdiff_t(std::size_t(rows[0]) * stride + std::size_t(i_first)), i_last - i_first + 2, 0u);
    for (int j = rows[0]; j <= rows[1]; ++j) {
        const std::uint8_t* row_open = open + std::size_t(j) * std::size_t(width);
        const std::uint32_t* above = pruner.prefix.data() + std::size_t(j) * stride;
        std::uint32_t* below = pruner.prefix.data() + (std::size_t(j) + 1) * stride;
        std::uint32_t row_count = 0;
        below[i_first] = 0;
        for (int i = i_first; i <= i_last; ++i) {
            row_count += row_open[i];
            below[i + 1] = above[i + 1] + row_count;
        }
    }
}

// The fixed runs a pulled run's key holds, summed over `runs` (of angle `angle_in_batch`): at
// least the pairs their pruned runs visit, since a pruned run pairs only with rows of its key.
std::uint64_t pairs_at_most(const MapTest& test, int angle_in_batch, std::span<const SliceRun> runs) {
    const std::int32_t key_base = key_base_of(test, angle_in_batch);
    std::uint64_t pairs = 0;
    for (const SliceRun& run : runs) pairs += std::uint64_t(test.runs().by_key[std::size_t(run.key - key_base)][1]);
    return pairs;
}

void AngleScratch::runs_of_pass(int pass, int passes, std::vector<std::span<const SliceRun>>& spans) const {
    spans.clear();
    const std::size_t stride = std::size_t(passes) + 1;
    for (std::size_t part = 0; part + stride <= pass_first.size(); part += stride) {
        const std::size_t first = pass_first[part + std::size_t(pass)], end = pass_first[part + std::size_t(pass) + 1];
        if (first < end) spans.emplace_back(by_pass.data() + first, end - first);
    }
}

// Cuts the rows of one angle whose first map pass lies in `row_passes` into a new part of
// `scratch` (the first pass's rows start it afresh), each slot's and word's runs cut to the columns
// that can reach that slot of the fixed volume from the box of the poses in play, and, where only
// some poses are in play (`open`: per pose of the angle; null: all), only the runs that reach one
// of them (RunsInPlay): the passes' pruning would drop the others. Returns whether it left the
// prefix sums of the poses in play over `rows` in `pruner` (with `open`, where it cut).
bool SweepRun::cut_pulled_runs(PulledPruner& pruner, const MapTest& test, int angle, int angle_in_batch, const Band& rows, int passes,
                               const std::uint8_t* open, std::array<int, 2> row_passes, AngleScratch& scratch) const {
    if (row_passes[0] == 0) {
        scratch.by_pass.clear();
        scratch.pass_first.clear();
        scratch.longest = 0;
        scratch.cut = 0;
    }
    scratch.rows_through = row_passes[1];
    if (rows[0] > rows[1] || rows[2] > rows[3] || test.runs().runs.empty()) return false;
    const WordClips clips =
        word_clips(test.reach_runs(), range_.i_first + rows[2], range_.i_first + rows[3], range_.j_first + rows[0], range_.j_first + rows[1]);
    if (open) count_poses_in_play(pruner, open, rows, width_, height_);
    const RunsInPlay in_play(pruner, test.reach_runs(), rows, true, key_base_of(test, angle_in_batch), range_.i_first, range_.j_first, width_);
    std::vector<std::size_t> pass_first;
    std::size_t cut = 0;
    const PulledCut how{MapPasses{passes, test.z_phase}, row_passes[0], row_passes[1], &pass_first, open ? &in_play : nullptr, &cut};
    scratch.longest = std::max(scratch.longest, append_pulled_runs(test.moving_words, trig_[std::size_t(angle)], root_a_, root_b_, angle_in_batch,
                                                                   clips, scratch.by_pass, how));
    scratch.pass_first.insert(scratch.pass_first.end(), pass_first.begin(), pass_first.end());
    scratch.cut += cut;
    return open != nullptr;
}

// Gives each of an angle's pulled runs (of one map pass) the rows j it must be paired on: those
// where the fixed runs at its key lie and, where only some poses are in play (`open`: per pose
// of the angle, in outcome order; null: all), the band from the first to the last row whose
// fixed runs' hull, moved by the run, holds a pose in play (a pair can only set bits inside it).
// Runs that reach none are dropped. The map is then exact on the poses in play, the only ones
// read of it (fidelity, for one, reaches few: most pairs of body runs meet far from any pose in
// play). A box test (2D prefix sums of the poses in play) first drops most runs cheaply.
// Returns the pairs of runs the kernel will visit.
std::uint64_t SweepRun::prune_pulled_runs(PulledPruner& pruner, const MapTest& test, const Band& rows, int angle_in_batch,
                                          std::span<const std::span<const SliceRun>> parts, const std::uint8_t* open,
                                          std::vector<PulledRun>& out, bool counted, const HeightsInPlay* heights) const {
    std::uint64_t pairs = 0;
    if (rows[0] > rows[1] || parts.empty()) return pairs;
    if (open && !counted) {
        // Every test below stays within some run's reach: the poses in play are counted there only.
        const Band reach = reach_of(test, angle_in_batch, parts, rows, range_.i_first, range_.j_first);
        if (reach[0] > reach[1] || reach[2] > reach[3]) return pairs;
        count_poses_in_play(pruner, open, reach, width_, height_);
    }
    const std::int32_t key_base = key_base_of(test, angle_in_batch);
    const RunsInPlay in_play(pruner, test.reach_runs(), rows, open != nullptr, key_base, range_.i_first, range_.j_first, width_);
    // Each height's runs together, in key order: neighbouring items of the kernel walk the same keys.
    thread_local std::vector<RunsInPlay> at_height;
    thread_local std::vector<std::vector<PulledRun>> by_height;
    thread_local std::vector<std::vector<PulledRun>*> targets;
    at_height.clear();
    targets.assign(1, &out);
    if (heights) {
        by_height.resize(std::size_t(heights_));
        targets.clear();
        for (int h = 0; h < heights_; ++h) {
            at_height.emplace_back(heights->counts[std::size_t(h)], test.runs(), heights->rows[std::size_t(h)], heights->open, key_base - h,
                                   range_.i_first, range_.j_first, width_);
            by_height[std::size_t(h)].clear();
            targets.push_back(&by_height[std::size_t(h)]);
        }
    }
    for (const std::span<const SliceRun> runs : parts) prune_part(test, in_play, at_height, key_base, range_.j_first, runs, pairs, targets);
    if (heights)
        for (const auto& runs : by_height) out.insert(out.end(), runs.begin(), runs.end());
    return pairs;
}

AngleInPlay SweepRun::angle_in_play(int a, const std::uint8_t* open, const Rows& rows, std::vector<std::uint8_t>& joined) const {
    if (heights_ == 1) return {open ? open + std::size_t(a) * per_angle_ : nullptr, rows[std::size_t(a)]};
    Band box{height_, -1, width_, -1};
    for (int h = 0; h < heights_; ++h) {
        const Band& view = rows[std::size_t(a * heights_ + h)];
        if (view[0] > view[1] || view[2] > view[3]) continue;
        box = {std::min(box[0], view[0]), std::max(box[1], view[1]), std::min(box[2], view[2]), std::max(box[3], view[3])};
    }
    if (!open || box[0] > box[1]) return {open ? joined.data() : nullptr, box};
    joined.resize(per_angle_);
    // Only the box is read (every query of the pruning is clamped to it).
    for (int j = box[0]; j <= box[1]; ++j)
        std::fill_n(joined.data() + std::size_t(j) * std::size_t(width_) + std::size_t(box[2]), box[3] - box[2] + 1, std::uint8_t(0));
    for (int h = 0; h < heights_; ++h) {
        const std::size_t v = std::size_t(a * heights_ + h);
        const Band& view = rows[v];
        for (int j = view[0]; j <= view[1]; ++j) {
            const std::size_t row = std::size_t(j) * std::size_t(width_);
            const std::uint8_t* from = open + v * per_angle_ + row;
            std::uint8_t* to = joined.data() + row;
            for (int i = view[2]; i <= view[3]; ++i) to[i] |= from[i];
        }
    }
    return {joined.data(), box};
}

void SweepRun::count_heights_in_play(int a, const std::uint8_t* open, const Rows& rows, HeightsInPlay& heights) const {
    heights.counts.resize(std::size_t(heights_));
    heights.rows.resize(std::size_t(heights_));
    heights.open = open != nullptr;
    for (int h = 0; h < heights_; ++h) {
        const std::size_t v = std::size_t(a * heights_ + h);
        const Band& band = rows[v];
        heights.rows[std::size_t(h)] = band;
        if (open && band[0] <= band[1] && band[2] <= band[3])
            count_poses_in_play(heights.counts[std::size_t(h)], open + v * per_angle_, band, width_, height_);
    }
}

}  // namespace amhv::gpu::sweep_detail
