// Overlap maps of the Vulkan sweep (shaders/sweep_map.comp): one test decided for every offset of
// an angle at once from pairs of slice runs, in passes over the z slices and rows, coarse to fine,
// and only where poses are in play.
#include <algorithm>
#include <array>
#include <bit>
#include <cstring>
#include <limits>
#include <optional>

#include "src/core/error.hpp"
#include "src/core/parallel.hpp"
#include "src/sweep/sweep_vulkan_run.hpp"

namespace amhv::gpu::sweep_detail {

namespace {
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

static_assert(std::endian::native == std::endian::little, "flags are spread through 64-bit words in memory order");

// Per byte value, the 8 flag bytes (in memory order) that are 1 where its bits are set: a map
// word becomes 32 pose flags with four lookups instead of 32 shifts.
constexpr std::array<std::uint64_t, 256> kFlagsOfByte = [] {
    std::array<std::uint64_t, 256> table{};
    for (std::size_t value = 0; value < table.size(); ++value)
        for (int bit = 0; bit < 8; ++bit)
            if ((value >> bit) & 1u) table[value] |= std::uint64_t(1) << (8 * bit);
    return table;
}();
constexpr std::uint64_t kAllFlags = 0x0101010101010101ull;

// flags[0..31] = bit i of `bits` (XOR 1 where `flip`).
void write_flags(std::uint32_t bits, bool flip, std::uint8_t* flags) {
    for (int part = 0; part < 4; ++part) {
        const std::uint64_t eight = kFlagsOfByte[(bits >> (8 * part)) & 0xffu] ^ (flip ? kAllFlags : 0u);
        std::memcpy(flags + 8 * part, &eight, sizeof eight);
    }
}

// flags[0..31] &= bit i of `keep`.
void keep_flags(std::uint32_t keep, std::uint8_t* flags) {
    for (int part = 0; part < 4; ++part) {
        std::uint64_t eight;
        std::memcpy(&eight, flags + 8 * part, sizeof eight);
        eight &= kFlagsOfByte[(keep >> (8 * part)) & 0xffu];
        std::memcpy(flags + 8 * part, &eight, sizeof eight);
    }
}

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

// The fixed runs a pulled run's key holds, summed over `runs` (of angle `angle_in_batch`): at
// least the pairs their pruned runs visit, since a pruned run pairs only with rows of its key.
std::uint64_t pairs_at_most(const MapTest& test, int angle_in_batch, std::span<const SliceRun> runs) {
    const std::int32_t key_base = key_base_of(test, angle_in_batch);
    std::uint64_t pairs = 0;
    for (const SliceRun& run : runs) pairs += std::uint64_t(test.runs().by_key[std::size_t(run.key - key_base)][1]);
    return pairs;
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

// Every map, every-frame maps too (close_decided_poses), goes in the same passes.
int SweepRun::map_passes() const { return std::clamp(tools_.options.map_passes, 1, 16); }

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

void SweepRun::cut_angles(MapTest& test, int angle_first, int batch_angles, const Rows& rows, const std::vector<std::uint8_t>* open,
                          int whole_angle) const {
    if (test.angles.size() < std::size_t(batch_angles)) test.angles.resize(std::size_t(batch_angles));
    const int passes = map_passes();
    parallel_for(std::size_t(batch_angles), [&](std::size_t a) {
        thread_local PulledPruner pruner;
        thread_local std::vector<std::uint8_t> joined;
        const std::array<int, 2> row_passes{0, int(a) == whole_angle ? passes - 1 : 0};
        const AngleInPlay in_play = angle_in_play(int(a), open ? open->data() : nullptr, rows, joined);
        cut_pulled_runs(pruner, test, angle_first + int(a), int(a), in_play.rows, passes, in_play.open, row_passes, test.angles[a]);
    });
}

int SweepRun::model_sample(const Rows& rows) {
    for (std::size_t a = 0; a < rows.size(); ++a)
        if (rows[a][0] <= rows[a][1]) return int(a);
    return 0;
}

// Computes the map on the box `rows[a]` of each angle a of the batch and, where `candidates` is
// given (per pose of the batch), exactly only on those poses. The map goes in passes over the z
// slices and rows, coarse to fine (pass_of): a pose that a pass decides (an overlap found) leaves
// play, so later passes skip the runs that reach only decided poses. For contact the coarse cells
// find most overlaps, and the rest of the runs reach little that is new.
std::vector<std::uint8_t> SweepRun::run_map(MapTest& test, int stage, int angle_first, int batch_angles, const Rows& rows,
                                            const std::vector<std::uint8_t>* candidates, bool runs_cut) {
    // Pulled runs' x is packed in 16 bits relative to pulled_x0.
    const std::int64_t x_span = std::int64_t(test.fixed->x_last - test.fixed->x_first) + width_;
    if (x_span > 0xffff) fail("key segment", "pulled runs span {} columns, more than the sweep handles (65,535); use a larger voxel", x_span);
    const int passes = map_passes();
    // The poses in play not decided yet; without candidates, every pose once the first pass is in.
    // Host work per angle (or view), on all cores while the device waits.
    auto for_each_angle = [&](const auto& work) { parallel_for(std::size_t(batch_angles), [&](std::size_t a) { work(int(a)); }); };
    // Kept between maps and batches (the same size batch after batch: no clearing), filled per
    // view on all cores; without candidates it holds nothing until the first pass closes poses.
    std::vector<std::uint8_t>& open = open_scratch_;
    bool open_known = candidates != nullptr;
    if (candidates) {
        open.resize(candidates->size());
        parallel_for(std::size_t(views(batch_angles)), [&](std::size_t v) {
            std::copy_n(candidates->data() + v * per_angle_, per_angle_, open.data() + v * per_angle_);
        });
    }
    Rows open_rows = rows;  // per view: the box of the poses in play
    if (!runs_cut) cut_angles(test, angle_first, batch_angles, rows, nullptr);
    const int maps = test.maps_per_angle();
    const std::uint64_t map_bytes =
        std::uint64_t(views(batch_angles)) * std::uint64_t(maps) * std::uint64_t(height_) * std::uint64_t(row_words_) * 4;
    map_words_.ensure(tools_.context, map_bytes);
    sequence_.fill(map_words_.device(), map_bytes, 0u);
    // The clear must land before the runs OR their intervals in.
    sequence_.barrier();
    ++tools_.stats.maps_per_stage[std::size_t(stage)];
    for (int pass = 0; pass < passes; ++pass) {
        std::vector<std::uint64_t> pairs_of(static_cast<std::size_t>(batch_angles), 0);
        for_each_angle([&](int a) {
            thread_local PulledPruner pruner;
            thread_local std::vector<std::span<const SliceRun>> parts;
            thread_local std::vector<std::uint8_t> joined;
            thread_local HeightsInPlay heights;
            AngleScratch& scratch = test.angles[std::size_t(a)];
            // One cut and one prune for every height of the angle: against the poses in play at any.
            const AngleInPlay in_play = angle_in_play(a, open_known ? open.data() : nullptr, open_rows, joined);
            const std::uint8_t* angle_open = in_play.open;
            if (heights_ > 1) count_heights_in_play(a, open_known ? open.data() : nullptr, open_rows, heights);
            // This pass's rows are cut now, within the box of the poses still in play. Where the
            // first pass's were cut against the candidates (the later stages: few poses in play),
            // so are they, against those still open; contact's and the dictionary's poses in play
            // are dense, and a filter there costs what the copies it saves do.
            bool counted = false;  // the cut's prefix sums of the poses in play are the prune's
            if (scratch.rows_through < pass)
                counted = cut_pulled_runs(pruner, test, angle_first + a, a, in_play.rows, passes, runs_cut ? angle_open : nullptr, {pass, pass},
                                          scratch);
            scratch.pruned.clear();
            scratch.runs_of_pass(pass, passes, parts);
            pairs_of[std::size_t(a)] =
                prune_pulled_runs(pruner, test, in_play.rows, a, parts, angle_open, scratch.pruned, counted, heights_ > 1 ? &heights : nullptr);
        });
        std::size_t total_runs = 0;
        int longest = 0;
        for (int a = 0; a < batch_angles; ++a) {
            longest = std::max(longest, test.angles[std::size_t(a)].longest);
            total_runs += test.angles[std::size_t(a)].pruned.size();
            tools_.stats.run_pairs_per_stage[std::size_t(stage)] += pairs_of[std::size_t(a)];
        }
        tools_.stats.pulled_runs_per_stage[std::size_t(stage)] += total_runs;
        // Each angle's runs come sorted by key and keys grow with the angle, so joining them in
        // angle order sorts the batch: neighbouring invocations with the same key walk the same
        // fixed runs (uniform loops and loads across a subgroup).
        if (total_runs > 0) {
            // On one thread: a pass's pruned runs are few (thousands to hundreds of thousands, a
            // few MB at most), less than a round over the cores costs on a 16-core host.
            pulled_.ensure(tools_.context, total_runs * sizeof(PulledRun));
            PulledRun* staged = pulled_.host<PulledRun>().data();
            for (int a = 0; a < batch_angles; ++a) {
                const auto& pruned = test.angles[std::size_t(a)].pruned;
                staged = std::copy(pruned.begin(), pruned.end(), staged);
            }
        }
        pulled_.copy_to_device(sequence_, total_runs * sizeof(PulledRun));
        dispatch_map_pass(test, total_runs, longest, map_bytes);
        if (pass + 1 < passes) {
            close_decided_poses(test, batch_angles, open_known, open, open_rows);
            open_known = true;
        }
    }
    for (int a = 0; a < batch_angles; ++a) tools_.stats.runs_cut_per_stage[std::size_t(stage)] += test.angles[std::size_t(a)].cut;
    return read_map(test, batch_angles);
}

// ORs one pass's pulled runs (staged in `pulled_`) into the maps (`map_bytes` of them) and waits for them.
void SweepRun::dispatch_map_pass(MapTest& test, std::size_t run_count, int longest, std::uint64_t map_bytes) {
    std::optional<BoundBuffers> set;  // lives until the submit below has finished
    if (run_count > 0) {
        const std::uint32_t budget = tools_.options.loop_budget;
        // Loop steps: the binary search, then per fixed run its test and the words its interval spans.
        const std::uint64_t search = 34, per_run = std::uint64_t(test.runs().longest + longest) / 32 + 4;
        if (search + per_run > budget)
            fail("key segment", "a run of {} voxels is longer than one invocation may handle; use a larger voxel", test.runs().longest + longest);
        const int runs_per_chunk = int((budget - search) / per_run);
        const int chunks = std::max(1, (test.runs().most_per_key + runs_per_chunk - 1) / runs_per_chunk);
        const std::uint64_t items = std::uint64_t(run_count) * std::uint64_t(chunks);
        if (items > std::uint64_t(std::numeric_limits<std::uint32_t>::max()))
            fail("sweep", "{} overlap-map work items in one batch are more than one dispatch takes; narrow the x/y range", items);
        set.emplace(tools_.map.bind(
            {test.fixed_side->packed.get(), test.fixed_side->keys.get(), &pulled_.device(), &map_words_.device(), &map_words_.device()}));
        // The words the maps' texel view covers (Kernel::bind cuts it to the device's limit).
        const std::uint32_t texel_words = std::uint32_t(std::min<std::uint64_t>(map_words_.device().size() / 4, tools_.context.selected().max_texel_buffer_elements));
        const MapParams params{0, 0, heights_, chunks, runs_per_chunk, test.runs().zbits, std::int32_t(test.slots.size()),
                               range_.i_first, range_.j_first, width_, height_, row_words_,
                               test.want == Want::Frames ? 1 : 0, std::int32_t(test.fixed->x0), std::int32_t(test.fixed->y0),
                               test.pulled_x0, texel_words};
        tools_.stats.work_items += items;
        sequence_.dispatch(tools_.map, *set, params, std::uint32_t(items));
    }
    // The host reads the maps after the fence.
    map_words_.copy_to_host(sequence_, map_bytes);
    sequence_.barrier_to_host();
    submit_and_wait();
    ++tools_.stats.submits;
}

namespace {

// Bit i set where at least `needed` of the `maps` words (`stride` apart from `first`) have bit i.
// The 32 counts go eight to a 64-bit word, one byte each, a map word added with four lookups of
// kFlagsOfByte (up to 255 maps; more are counted bit by bit).
std::uint32_t frames_at_least(const std::uint32_t* first, int maps, std::size_t stride, int needed) {
    std::uint32_t out = 0;
    if (maps > 255) {
        for (int i = 0; i < 32; ++i) {
            int count = 0;
            for (int m = 0; m < maps && count < needed; ++m) count += (first[std::size_t(m) * stride] >> i) & 1u;
            if (count >= needed) out |= 1u << i;
        }
        return out;
    }
    std::array<std::uint64_t, 4> counts{};
    for (int m = 0; m < maps; ++m) {
        const std::uint32_t word = first[std::size_t(m) * stride];
        for (int part = 0; part < 4; ++part) counts[std::size_t(part)] += kFlagsOfByte[(word >> (8 * part)) & 0xffu];
    }
    for (int i = 0; i < 32; ++i)
        if (int((counts[std::size_t(i / 8)] >> (8 * (i % 8))) & 0xffu) >= needed) out |= 1u << i;
    return out;
}

// Bit i set where the poses of map word `first` (of an angle's `maps` maps, `stride` apart) show
// the overlap the test looks for: in one map, its bit; in every-frame maps, in at least `needed`
// of them (ANDed when all are needed).
std::uint32_t overlap_found(const MapTest& test, const std::uint32_t* first, int maps, std::size_t stride) {
    if (test.want == Want::Frames && test.needed < maps) return frames_at_least(first, maps, stride, test.needed);
    std::uint32_t bits = first[0];
    for (int m = 1; m < maps; ++m) bits &= first[std::size_t(m) * stride];
    return bits;
}

}  // namespace

// After a pass: poses where the overlap the test looks for is found are decided (it can only grow
// with the passes left: an overlap test passes, a "must not meet" test fails, an every-frame test
// has its frames); the box in play shrinks to the poses still open. Angles on all cores. Where
// `open` is not known yet, every pose was open.
void SweepRun::close_decided_poses(const MapTest& test, int batch_angles, bool open_known, std::vector<std::uint8_t>& open,
                                   Rows& open_rows) const {
    const std::uint32_t* words = map_words_.host<std::uint32_t>().data();
    const int maps = test.maps_per_angle();
    const std::size_t stride = std::size_t(height_) * std::size_t(row_words_);
    const std::size_t view_count = std::size_t(views(batch_angles));
    if (!open_known) open.resize(per_angle_ * view_count);
    parallel_for(view_count, [&](std::size_t v) {
        if (!open_known) std::fill_n(open.data() + v * per_angle_, per_angle_, std::uint8_t(1));
        Band& band = open_rows[v];
        Band still{height_, -1, width_, -1};
        for (int j = band[0]; j <= band[1]; ++j) {
            std::uint8_t* row_open = open.data() + v * per_angle_ + std::size_t(j) * std::size_t(width_);
            const std::uint32_t* row = words + (v * std::size_t(maps) * std::size_t(height_) + std::size_t(j)) * std::size_t(row_words_);
            // Word by word (whole words in a loop the compiler vectorises); outside the band the
            // row holds no pose in play, so clearing there changes nothing.
            for (int w = band[2] >> 5; w <= band[3] >> 5; ++w) {
                const std::uint32_t missed = ~(maps == 1 ? row[w] : overlap_found(test, row + w, maps, stride));
                std::uint8_t* word_open = row_open + w * 32;
                if (w * 32 + 32 <= width_) {
                    keep_flags(missed, word_open);
                } else {
                    for (int b = 0; b < width_ - w * 32; ++b) word_open[b] &= std::uint8_t((missed >> b) & 1u);
                }
            }
            widen_by_flags(still, row_open, j, band[2], band[3]);
        }
        band = still;
    });
}

// Per pose of the batch, whether it meets the test: Frames, set in at least `needed` of the slots'
// maps (in every one when all are needed); otherwise the one map's bit says it.
std::vector<std::uint8_t> SweepRun::read_map(const MapTest& test, int batch_angles) const {
    const int maps = test.maps_per_angle();
    const std::uint32_t* words = map_words_.host<std::uint32_t>().data();
    const std::size_t view_count = std::size_t(views(batch_angles));
    std::vector<std::uint8_t> meets(per_angle_ * view_count);
    const std::uint8_t when_set = test.want == Want::NoOverlap ? 0 : 1;
    parallel_for(view_count, [&](std::size_t v) {
        for (int j = 0; j < height_; ++j) {
            std::uint8_t* out = meets.data() + v * per_angle_ + std::size_t(j) * std::size_t(width_);
            const std::uint32_t* row = words + (v * std::size_t(maps) * std::size_t(height_) + std::size_t(j)) * std::size_t(row_words_);
            for (int w = 0; w < row_words_; ++w) {
                const std::uint32_t bits = overlap_found(test, row + w, maps, std::size_t(height_) * std::size_t(row_words_));
                if (w * 32 + 32 <= width_) {
                    write_flags(bits, when_set == 0, out + w * 32);
                } else {
                    for (int i = w * 32; i < width_; ++i) out[i] = ((bits >> (i & 31)) & 1u) ? when_set : std::uint8_t(1 - when_set);
                }
            }
        }
    });
    return meets;
}

// The cost model: a stage's optional maps pay off when its poses, tested one by one, would cost
// more than the run pairs of its maps and the host's cutting of their runs (estimated from one
// angle of the batch).
bool SweepRun::maps_pay_off(int stage, std::size_t pose_count, int batch_angles, const Rows& rows, const std::vector<std::uint8_t>& candidates) const {
    if (optional_maps_[std::size_t(stage)].empty() || pose_count == 0) return false;
    // The first angle with poses in play stands for every angle with some (cut whole by cut_angles).
    const int sample = model_sample(rows);
    int angles_in_play = 0;
    for (int a = 0; a < batch_angles; ++a) angles_in_play += rows[std::size_t(a)][0] <= rows[std::size_t(a)][1] ? 1 : 0;
    // A pose test's cost grows with the columns and words it visits (8x from 10 mm to 5 mm); the
    // option prices one of kPoseTestIterations loop steps.
    const double pose_cost = double(pose_count) * tools_.options.pose_test_pairs * pose_iterations_[std::size_t(stage)] / kPoseTestIterations;
    const auto maps_cost = [&](std::uint64_t pairs, std::uint64_t cut) { return double(pairs + cut * kCutPairs) * double(angles_in_play); };
    std::uint64_t bound = 0, cut = 0;
    for (const MapTest& test : optional_maps_[std::size_t(stage)]) {
        const AngleScratch& scratch = test.angles[std::size_t(sample)];
        cut += scratch.cut;
        bound += pairs_at_most(test, sample, scratch.by_pass);
    }
    // The pairs the maps visit are at most the bound: when that already pays off, so do they (the
    // exact count, which prunes the sample's runs on one core, is needed only near the balance).
    if (pose_cost > maps_cost(bound, cut)) return true;
    std::uint64_t pairs = 0;
    thread_local PulledPruner pruner;
    thread_local std::vector<PulledRun> pruned;
    for (const MapTest& test : optional_maps_[std::size_t(stage)]) {
        pruned.clear();
        const std::span<const SliceRun> all(test.angles[std::size_t(sample)].by_pass);
        pairs += prune_pulled_runs(pruner, test, rows[std::size_t(sample)], sample, std::span(&all, 1),
                                   candidates.data() + std::size_t(sample) * per_angle_, pruned);
    }
    return pose_cost > maps_cost(pairs, cut);
}

}  // namespace amhv::gpu::sweep_detail
