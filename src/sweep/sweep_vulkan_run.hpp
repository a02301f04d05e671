#pragma once
// One call of VulkanSweeper::sweep, as named steps over shared state (internal to the sweeper).
//
//   plan      (sweep_vulkan_plan.cpp)   which overlap tests decide each stage, their column volumes
//                                       and overlap maps, the angle tables, the batch size;
//   pose tests (sweep_vulkan_poses.cpp) tests pose by pose in waves, with block pre-tests first;
//   maps      (sweep_vulkan_maps.cpp)   tests for every offset of an angle at once from slice runs;
//   batches   (sweep_vulkan.cpp)        contact, dictionary, fidelity and visibility per batch of
//                                       angles, and the outcome of every pose.
#include <algorithm>
#include <array>
#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "src/gpu/compute.hpp"
#include "src/sweep/column_volume.hpp"
#include "src/sweep/problem.hpp"
#include "src/sweep/slice_runs.hpp"
#include "src/sweep/sweep_vulkan.hpp"

namespace amhv::gpu::sweep_detail {

struct OverlapParams {
    std::uint32_t item_base, item_count;
    std::int32_t static_x0, static_y0, static_nx, static_ny;
    std::int32_t moving_x0, moving_y0, moving_nx, moving_ny;
    std::int32_t slots, zwords, frames, mode;
    std::int32_t columns_per_item, rows_per_item, items_x;
    std::int32_t chunk_first, chunks_in_wave;
    std::int32_t range_i0, range_j0, range_ni, range_nj;
    std::int32_t angle_first, explicit_poses, flag_words, flag_offset;
    std::int32_t word_first, word_last;
    std::int32_t frames_per_item, spatial_items;
};
static_assert(sizeof(OverlapParams) <= 128, "push constants beyond the guaranteed 128 bytes");

struct MapParams {
    std::uint32_t item_base, item_count;
    std::int32_t heights;  // the run's heights: a pulled run at slice z and height h meets the fixed runs at z + h
    std::int32_t chunks, runs_per_chunk;
    std::int32_t zbits, slot_count;
    std::int32_t range_i0, range_j0, range_ni, range_nj, row_words;
    std::int32_t map_per_slot;
    std::int32_t fixed_x0, fixed_y0, pulled_x0;
    std::uint32_t texel_words;
};
static_assert(sizeof(MapParams) <= 128, "push constants beyond the guaranteed 128 bytes");

// A pulled run as the map kernel reads it: y relative to the fixed volume's y0 (16 bits, signed)
// | the height it is paired at << 16, x packed relative to the batch's pulled_x0, and the rows j
// (first | last << 16) it is paired on.
struct PulledRun {
    std::uint32_t y_heights;
    std::uint32_t x;
    std::int32_t key;
    std::uint32_t rows;
};
static_assert(sizeof(PulledRun) == 16);

struct GpuAngle {
    std::int64_t trig[2];
    std::int32_t bounds[4];
};
static_assert(sizeof(GpuAngle) == 32);

// MODE_PER_FRAME_ALL stops an item at the first frame without overlap (every frame is needed).
constexpr std::int32_t kModeAny = 0, kModePerFrameAll = 1, kModePerFrame = 2;

// A column volume; uploaded when a pose-by-pose test first reads it (overlap maps read slice runs
// instead), and its angle table (used when it is the moving side) on demand.
struct GpuVolume {
    ColumnVolume columns;
    std::unique_ptr<Buffer> bits, rows, angles;
    std::unique_ptr<Buffer> frame_boxes, angle_frame_boxes;  // PER_FRAME tests only
};

enum class Want { Overlap, NoOverlap, Frames };

struct OverlapTest {
    GpuVolume* fixed;   // A's side: its columns are visited
    GpuVolume* moving;  // B's side: pulled under A's columns
    int frames;         // 0: unions only
    Want want;
    int needed = 0;     // Frames: the overlap must show on at least this many frames
    std::int32_t mode() const { return want != Want::Frames ? kModeAny : needed >= frames ? kModePerFrameAll : kModePerFrame; }
    // Frames: misses that decide the test (a pose with more fails).
    int misses_allowed() const { return frames - needed; }
    // The z words where both volumes have bits (first > last: the test cannot find an overlap).
    int word_first() const { return std::max(fixed->columns.word_first, moving->columns.word_first); }
    int word_last() const { return std::min(fixed->columns.word_last, moving->columns.word_last); }
    int words() const { return std::max(0, word_last() - word_first() + 1); }
    int flag_words() const { return want == Want::Frames ? (frames + 31) / 32 : 1; }
};

// One angle's pulled runs in a map test, kept between batches so their buffers are reused. A map
// cuts each row of A's lattice just before its first pass (first_pass_of_row), so the runs come in
// parts, one per cut, each ordered by map pass and key within a pass.
struct AngleScratch {
    std::vector<SliceRun> by_pass;        // every part's runs, part after part
    std::vector<std::size_t> pass_first;  // per part and pass: its first run in by_pass (passes + 1 entries a part)
    int rows_through = -1;                // the rows whose first pass is at most this one are cut
    int longest = 0;                      // voxels in the longest run kept
    std::size_t cut = 0;                  // runs cut, kept or not (what the cost model prices)
    std::vector<PulledRun> pruned;        // one pass's runs that reach poses in play
    // The runs of map pass `pass` (of `passes`), one span per part.
    void runs_of_pass(int pass, int passes, std::vector<std::span<const SliceRun>>& spans) const;
};

// A fixed volume's slice runs for some slots, and their uploads: the map kernel reads them as
// texels, (y, x_first | x_last << 16) relative to the volume's origin, and each key's first run
// and count.
struct FixedSide {
    FixedRuns runs;
    std::unique_ptr<Buffer> packed, keys;
    // Per count of heights above one: the runs of lowered_union(volume, heights), which one prune
    // of B's runs reads for every height of a run (a run reaches a pose at some height exactly
    // when it reaches it in these). Their boxes and hulls only: the runs themselves are dropped.
    std::map<int, FixedRuns> reach_by_heights;
};

// One overlap test decided for every offset of an angle at once (shaders/sweep_map.comp). Slot s
// of the fixed volume pairs with slot s of the moving one: slot 0 for unions, 1..frames for frames.
struct MapTest {
    const ColumnVolume* fixed;
    const ColumnVolume* moving;
    std::vector<int> slots;
    Want want;  // Overlap: in some slot pair; NoOverlap: in none; Frames: in at least `needed`
    FixedSide* fixed_side = nullptr;  // the fixed volume's runs for `slots` (HeightShare)
    const FixedRuns* reach = nullptr;  // what pruning reads: runs(), or with several heights their lowered union
    SparseColumns moving_words;  // the moving volume's slots, as the host cuts them into pulled runs
    std::int32_t pulled_x0 = 0;  // the first column pulled runs can start at (their packed x is relative to it)
    int z_phase = 0;             // MapPasses::z_phase of its pulled runs (densest_shared_slice)
    std::vector<AngleScratch> angles;  // per angle of the batch: its pulled runs (SweepRun::cut_angles)
    int needed = 0;
    int maps_per_angle() const { return want == Want::Frames ? int(slots.size()) : 1; }
    const FixedRuns& runs() const { return fixed_side->runs; }
    const FixedRuns& reach_runs() const { return *reach; }
};

// What every height of a sweep shares: A's side, which never moves (only B is raised), built by
// the first height's run in a z frame that covers every height. Its column volumes by what they
// hold (with their uploads), their copies OR-pooled for the block pre-test, and the slice runs
// of each volume and set of slots that overlap maps read.
struct HeightShare {
    std::map<std::string, std::unique_ptr<GpuVolume>> fixed;
    std::map<const GpuVolume*, std::unique_ptr<GpuVolume>> block_pooled;
    std::map<std::pair<const ColumnVolume*, std::vector<int>>, std::unique_ptr<FixedSide>> fixed_sides;
    // Whether `columns` are one of the shared volumes' (the caches above are keyed by address, so
    // a run's own volume must never be a key: a later run's could take its address).
    bool holds(const ColumnVolume* columns) const {
        return std::any_of(fixed.begin(), fixed.end(), [&](const auto& entry) { return &entry.second->columns == columns; });
    }
    // Fills an empty entry of `fixed` or `block_pooled` with `columns`, counting it in `built`.
    static GpuVolume* keep(std::unique_ptr<GpuVolume>& entry, ColumnVolume columns, std::uint64_t& built) {
        entry = std::make_unique<GpuVolume>();
        entry->columns = std::move(columns);
        ++built;
        return entry.get();
    }
};

// Work blocks of one pose test: columns x rows of the fixed volume per invocation, and for
// PER_FRAME tests the frames each invocation covers.
struct Blocks {
    int columns, rows, items_x, items_per_pose;
    int frames_per_item = 0, spatial_items = 1;
};

using Pose = std::array<std::int32_t, 4>;  // angle, i, j, height (of the run's heights; pose tests: 0)
// Per view (angle and height of a batch): the box of the poses in play, first and last row
// j - j_first, then first and last column i - i_first (first > last: none).
using Band = std::array<std::int32_t, 4>;
using Rows = std::vector<Band>;

// Grows a band to hold the pose at row j, column i.
inline void widen(Band& band, std::int32_t j, std::int32_t i) {
    band = {std::min(band[0], j), std::max(band[1], j), std::min(band[2], i), std::max(band[3], i)};
}

// Widens `band` by the first and last set flag of row j (`row`: its flags, one per column) among
// columns i0..i1; a row with none leaves it as it is.
inline void widen_by_flags(Band& band, const std::uint8_t* row, std::int32_t j, std::int32_t i0, std::int32_t i1) {
    const std::uint8_t *begin = row + i0, *end = row + i1 + 1;
    const std::uint8_t* first = std::find_if(begin, end, [](std::uint8_t f) { return f != 0; });
    if (first == end) return;
    const std::uint8_t* last = end - 1;
    while (*last == 0) --last;
    widen(band, j, std::int32_t(first - row));
    widen(band, j, std::int32_t(last - row));
}

using Meets = std::vector<std::vector<std::uint8_t>>;   // per test and pose: whether the pose meets the test's criterion

// Whether pose p meets every test.
inline bool passes_all(const Meets& meets, std::size_t p) {
    return std::all_of(meets.begin(), meets.end(), [p](const auto& m) { return m[p] != 0; });
}

// The cost model's scale (SweeperOptions::pose_test_pairs prices a pose test of this many loop
// steps; lavapipe, measured on the paper scene at 10 mm and 5 mm), and what cutting one pulled
// run on the host costs in run pairs.
constexpr double kPoseTestIterations = 160000;
constexpr std::uint64_t kCutPairs = 4;

// Loop steps of one pose test of `test` (estimated): the fixed columns it can visit, those under
// the moving volume's box turned any way, times the words and frames each column test reads.
double pose_test_iterations(const OverlapTest& test);

// What a block pre-test proves for every pose of its block: a pooled "no overlap" makes an
// Overlap or EveryFrame test fail and a NoOverlap test pass; a pooled overlap proves nothing.
enum class Verdict : std::uint8_t { Fail, Pass, Undecided };

// The poses in play of one angle of a batch at any of its run's heights (per pose of the angle;
// null: every pose of the box) and their box.
struct AngleInPlay {
    const std::uint8_t* open;
    Band rows;
};

// Scratch of the pulled-run pruning, reused by one thread.
struct PulledPruner {
    std::vector<std::uint32_t> prefix;  // (height + 1) x (width + 1) counts of poses in play
};

// With several heights: per height of one angle, its poses in play counted (`open` false: every
// pose of its box is) and their box. The prune pairs a run at each height where the fixed runs at
// its lifted key, moved by the run, reach a pose in play, on the rows where they do.
struct HeightsInPlay {
    std::vector<PulledPruner> counts;
    std::vector<Band> rows;
    bool open = false;
};

// The poses in play of the box `rows` counted into `pruner` (2D prefix sums of `open`, one row of
// `width` poses per j; sweep_vulkan_pulled.cpp).
void count_poses_in_play(PulledPruner& pruner, const std::uint8_t* open, const Band& rows, int width, int height);
// At least the pairs the pruned runs of `runs` (of angle `angle_in_batch`) visit: the fixed runs
// their keys hold.
std::uint64_t pairs_at_most(const MapTest& test, int angle_in_batch, std::span<const SliceRun> runs);

// The kernels and settings a run borrows from its VulkanSweeper.
struct SweepTools {
    Context& context;
    const SweeperOptions& options;
    Kernel& overlap;
    Kernel& map;
    SweepStats& stats;
    const std::function<void(int, int)>& progress;
};

class SweepRun {
public:
    // The poses of `heights` heights: B raised by `level_first` voxels and by each level above it
    // up to `heights`; A's side comes from `share` (and goes there when it is not yet). Several
    // heights need overlap maps for every stage (SweepRun::heights_in_one): B's runs are cut and
    // pruned once per angle for all of them, and each map pairs them with A's runs at every lift.
    SweepRun(const SweepProblem& problem, SweepTools tools, HeightShare& share, int level_first, int heights = 1);
    // Whether a sweep with `options` may put several heights in one run: every stage then goes
    // by maps (pose tests take one height).
    static bool heights_in_one(const SweeperOptions& options) { return options.maps && options.pose_test_pairs > 0 && options.heights_per_run > 1; }
    static constexpr int kMaxHeights = 16;  // a pulled run holds a bit per height
    // The outcomes of those heights (a result whose range is those levels).
    SweepResult run();

private:
    // ---- plan (sweep_vulkan_plan.cpp) ----
    GpuVolume* add(ColumnVolume columns);
    // A's volume `name` from the share, built by `build` where it is not there yet.
    GpuVolume* shared_fixed(const std::string& name, const std::function<ColumnVolume()>& build);
    // Each map test's fixed runs from the share (cut on all cores where not there yet), and the
    // moving volume's words.
    void cut_map_volumes(const std::vector<MapTest*>& tests);
    // The pose tests of each stage: contact, dictionary, fidelity, visibility.
    void plan_stages();
    // The overlap maps that replace (required) or may replace (optional) each stage's pose tests.
    void plan_maps();
    // Uploads a map test's fixed runs (cut by plan_maps).
    void prepare_map(MapTest& test);
    // Per moving volume: every angle's rotation and mapped bounds; per-frame boxes for PER_FRAME tests.
    void upload_angle_tables();
    // How many angles one batch holds (flag buffer, 32-bit item counts, map bytes).
    void size_batches();
    template <typename Visit>
    void for_each_test(const Visit& visit) {
        for (const auto& stage : stages_)
            for (const OverlapTest& test : stage) visit(test);
    }

    // ---- pose tests (sweep_vulkan_poses.cpp) ----
    Blocks blocks_of(const OverlapTest& test) const;
    // The stage's tests with each fixed volume OR-pooled over a block of offsets (made on first use).
    const std::vector<OverlapTest>& block_stage(int stage);
    Pose implicit_pose(int angle_first, std::uint64_t p) const;
    Band box_of_flags(const std::uint8_t* flags) const;
    std::size_t outcome_index(const Pose& p) const;
    // Runs every test of `stage` on `pose_list` (or, when null, on `implicit_count` poses of the
    // range from angle `angle_first`): per test and pose, whether the pose meets the criterion.
    Meets run_stage(const std::vector<OverlapTest>& stage, const std::vector<Pose>* pose_list, std::uint64_t implicit_count,
                    int angle_first);
    // One test of run_stage, in waves; fills `found` (flag words per pose).
    void run_test_waves(const OverlapTest& test, const std::vector<Pose>* pose_list, std::uint64_t count, int angle_first,
                        std::vector<std::uint32_t>& found);
    std::uint64_t poses_per_dispatch(int chunks, int words) const;
    const std::uint32_t* dispatch_wave_slice(const OverlapTest& test, const Blocks& b, const std::vector<Pose>* pose_list, int angle_first,
                                             bool implicit, int chunk_first, int chunks, std::span<const std::uint64_t> slice);
    bool wave_decides(const OverlapTest& test, const std::uint32_t* w, int frames_done) const;
    std::vector<Verdict> block_verdicts(int stage, const std::vector<Pose>& bases);
    // Stage 1..3 for `candidates` of a batch: blocks first, then pose by pose where undecided.
    std::vector<std::uint8_t> decide(int stage, const std::vector<Pose>& candidates, int angle_first, int batch_angles);

    // ---- maps (sweep_vulkan_maps.cpp) ----
    bool cut_pulled_runs(PulledPruner& pruner, const MapTest& test, int angle, int angle_in_batch, const Band& rows, int passes,
                         const std::uint8_t* open, std::array<int, 2> row_passes, AngleScratch& scratch) const;
    std::uint64_t prune_pulled_runs(PulledPruner& pruner, const MapTest& test, const Band& rows, int angle_in_batch,
                                    std::span<const std::span<const SliceRun>> runs, const std::uint8_t* open, std::vector<PulledRun>& out,
                                    bool counted = false, const HeightsInPlay* heights = nullptr) const;
    // Angle a's views joined (`open`: per pose of the batch, or null; `rows`: per view), in
    // `joined` where there are several heights.
    AngleInPlay angle_in_play(int a, const std::uint8_t* open, const Rows& rows, std::vector<std::uint8_t>& joined) const;
    // Angle a's heights, each with its poses in play counted (`open`: per pose of the batch, or null).
    void count_heights_in_play(int a, const std::uint8_t* open, const Rows& rows, HeightsInPlay& heights) const;
    // Cuts the rows of the first map pass of every angle of the batch into test.angles, on all
    // cores (every row of angle `whole_angle`); with `open` (per pose of the batch), only the runs
    // that reach a pose in play.
    void cut_angles(MapTest& test, int angle_first, int batch_angles, const Rows& rows, const std::vector<std::uint8_t>* open,
                    int whole_angle = -1) const;
    // The angle of the batch whose runs stand for every angle in the cost model: the first with poses in play.
    static int model_sample(const Rows& rows);
    int map_passes() const;
    // Decides `test` for every pose of the batch (implicit order) with an overlap map (`runs_cut`:
    // test.angles holds the batch's runs of the first pass already, cut against the candidates).
    std::vector<std::uint8_t> run_map(MapTest& test, int stage, int angle_first, int batch_angles, const Rows& rows,
                                      const std::vector<std::uint8_t>* candidates, bool runs_cut = false);
    void dispatch_map_pass(MapTest& test, std::size_t run_count, int longest, std::uint64_t map_bytes);
    // Submits the sequence and waits for it, counting the wait as the device's time.
    void submit_and_wait();
    void close_decided_poses(const MapTest& test, int batch_angles, bool open_known, std::vector<std::uint8_t>& open, Rows& open_rows) const;
    std::vector<std::uint8_t> read_map(const MapTest& test, int batch_angles) const;
    bool maps_pay_off(int stage, std::size_t pose_count, int batch_angles, const Rows& rows, const std::vector<std::uint8_t>& candidates) const;

    // ---- batches (sweep_vulkan.cpp) ----
    void sweep_batch(int angle_first, int batch_angles);
    // Adds the time since the last lap to `stage`'s wall time.
    void lap(int stage);
    std::vector<Pose> contact_and_dictionary_by_maps(int angle_first, int batch_angles);
    std::vector<Pose> contact_pose_by_pose(int angle_first, int batch_angles);
    std::vector<Pose> later_stage(int stage, std::vector<Pose> survivors, int angle_first, int batch_angles);
    std::vector<std::size_t> view_starts(const std::vector<Pose>& poses, int angle_first, int batch_angles) const;
    // A batch holds a view per angle and height, angle after angle, each per_angle_ poses.
    int views(int batch_angles) const { return batch_angles * heights_; }
    // Pose p's index among its batch's poses (views in order, then row, then column).
    std::size_t batch_index(const Pose& p, int angle_first) const {
        return (std::size_t(p[0] - angle_first) * std::size_t(heights_) + std::size_t(p[3])) * per_angle_ +
               std::size_t(p[2] - range_.j_first) * std::size_t(width_) + std::size_t(p[1] - range_.i_first);
    }
    // The outcomes of a view's poses (row by row).
    PoseOutcome* view_outcomes(int angle_first, int view) {
        const std::size_t angle = std::size_t(angle_first + view / heights_), level = std::size_t(view % heights_);
        return result_.outcomes.data() + (level * std::size_t(range_.angles) + angle) * per_angle_;
    }
    void keep_passed(const std::vector<std::uint8_t>& meets, int batch_angles, std::vector<std::uint8_t>& candidates, Rows& rows) const;

    const SweepProblem& problem_;
    SweepTools tools_;
    HeightShare& share_;
    const int frames_, last_;
    const InteractionType type_;
    const PoseRange range_;  // the problem's, cut to the run's levels
    const int heights_;      // levels in the run
    const int width_, height_, block_;
    const std::uint64_t per_angle_;
    ZFrame z_, z_b_;  // B's volumes are raised by the first level: they see the z frame as z_b_
    std::array<std::int64_t, 2> root_a_{}, root_b_{};
    std::vector<posemap::Trig> trig_;

    std::vector<std::unique_ptr<GpuVolume>> volumes_;
    GpuVolume* interest_a_ = nullptr;
    GpuVolume* interest_b_ = nullptr;
    std::vector<std::vector<OverlapTest>> stages_{4};
    std::vector<std::vector<MapTest>> required_maps_{4}, optional_maps_{4};
    std::vector<std::vector<OverlapTest>> block_stages_{4};
    std::array<bool, 4> blocks_made_{};

    int angles_per_batch_ = 1, row_words_ = 0;
    std::array<double, 4> pose_iterations_{};  // per stage: pose_test_iterations of its tests, summed
    int blocks_x_ = 0, blocks_y_ = 0;
    SweepResult result_;
    std::chrono::steady_clock::time_point clock_;
    Sequence sequence_;
    MirroredBuffer poses_, pulled_, flags_, map_words_;
    // Scratch of the overlap maps, reused batch after batch (fresh buffers cost page faults).
    std::vector<std::uint8_t> open_scratch_;
    std::vector<std::uint8_t> candidates_scratch_;  // later_stage's poses in play, per pose of the batch
    Buffer no_poses_;
};

}  // namespace amhv::gpu::sweep_detail
