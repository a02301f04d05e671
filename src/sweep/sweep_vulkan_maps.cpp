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

}  // namespace


// Every map, every-frame maps too (close_decided_poses), goes in the same passes.
int SweepRun::map_passes() const { return std::clamp(tools_.options.map_passes, 1, 16); }

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
    // Kept between maps and batches (the same size batch after batch: no clearing), filled on all
    // cores; without candidates it holds nothing until the first pass closes poses.
    std::vector<std::uint8_t>& open = open_scratch_;
    bool open_known = candidates != nullptr;
    if (candidates) {
        open.resize(candidates->size());
        copy_on_threads(open.data(), candidates->data(), std::size_t(views(batch_angles)) * per_angle_);
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
