#pragma once
// Slice runs: a column volume cut into horizontal runs, the layout of the overlap-map stage of the
// sweep (shaders/sweep_map.comp). A run is a maximal stretch of set voxels along x at one z, one y
// and one slot. Two volumes overlap under pose offset (i, j) exactly when some run of the fixed
// volume (y_a, [xa0, xa1]) and some run of the pulled moving volume (y_b, [xb0, xb1]) at the same
// z and slot pair satisfy j = y_a - y_b and xa0 - xb1 <= i <= xa1 - xb0: one pair of runs settles a
// whole interval of offsets, so a map of every offset costs one step per pair of runs instead of
// one test per pose.
#include <array>
#include <cstdint>
#include <limits>
#include <vector>

#include "src/sweep/column_volume.hpp"
#include "src/sweep/pose_map.hpp"

namespace amhv {

struct SliceRun {
    std::int32_t y = 0, x_first = 0, x_last = 0;  // global lattice
    // Fixed runs: slot_index * zbits + z. Pulled runs: (angle_in_batch * slot count + slot_index) * zbits + z.
    std::int32_t key = 0;
};
static_assert(sizeof(SliceRun) == 16);

// The runs of the fixed volume, grouped by key = slot_index * zbits + z, where slot_index indexes
// `slots` (slot numbers of the column volume) and z is the bit in the shared z frame.
struct FixedRuns {
    int zbits = 0;
    std::vector<SliceRun> runs;                         // sorted by (key, y, x_first)
    std::vector<std::array<std::int32_t, 2>> by_key;    // per key: first run, run count
    int longest = 0;                                    // voxels in the longest run
    int most_per_key = 0;                               // runs in the fullest key
    // Per key: the box of its runs (x_first, x_last, y_first, y_last; global; empty: first > last).
    std::vector<std::array<std::int32_t, 4>> key_boxes;
    // Per key and row of its box: the row's first x_first and last x_last (empty row: first >
    // last), from row_hull_first[key] on.
    std::vector<std::array<std::int32_t, 2>> row_hulls;
    std::vector<std::uint32_t> row_hull_first;
    // Per level L = 1 .. kHullLevels - 1 (window_hulls[L - 1]), indexed as row_hulls: the hull of
    // the key's rows r .. r + 2^L - 1 (fewer at the end of its box), so that one test of a box of
    // poses covers 2^L rows.
    static constexpr int kHullLevels = 7;
    std::vector<std::vector<std::array<std::int32_t, 2>>> window_hulls;
    // Per slot index and z word (key / 32): the box of the runs of its 32 keys ([x_first, y_first,
    // x_last, y_last], global; empty: first > last), what word_clips cuts pulled runs to.
    std::vector<std::array<std::int32_t, 4>> word_boxes;
};

FixedRuns fixed_runs(const ColumnVolume& volume, const std::vector<int>& slots);

// The non-zero words of `slots` of a moving volume, column by column: what cutting pulled runs
// reads. A frame fills a small part of the segment's columns, so most of its words are zero.
struct SparseColumns {
    const ColumnVolume* volume = nullptr;
    std::vector<int> slots;
    std::vector<std::uint32_t> first;  // per local column y * nx + x: its first entry (one more at the end)
    struct Entry {
        std::uint32_t bits;
        std::int32_t word;  // slot_index * zwords + word
    };
    std::vector<Entry> entries;
};

SparseColumns sparse_columns(const ColumnVolume& moving, const std::vector<int>& slots);

// Per slot index and z word (slot_index * zwords + word), a box of A columns ([x_first, y_first,
// x_last, y_last], global A lattice).
using WordClips = std::vector<std::array<std::int32_t, 4>>;

// The overlap-map pass of the runs at z slice `z` and row `y` out of `passes`: coarse to fine in
// both, cells whose z and y have more trailing zeros go first. With 5 passes: the cells where z
// and y are both multiples of 16, then of 8, 4, 2, and the rest. Each pass spans the whole volume,
// so early passes find most overlaps with few pairs: a pose in contact usually overlaps over
// several slices and rows, and one cell of them settles it. (Over z alone, a part a few slices
// thick, such as a sword held level, put nearly all its pairs in one pass.)
int map_pass_of(int z, int y, int passes);

// The map passes pulled runs are sorted into: `count` passes of map_pass_of, with z counted from
// `z_phase` (a run at slice z goes to map_pass_of(z - z_phase, y, count)). The sweep puts the
// slice where both volumes are densest first: the first pass then holds few runs and still
// settles most poses in contact. Counted from z = 0, a sword 4 slices thick at 10 mm fell
// wholly in the third pass with four times the rows, and contact made 3.7 times the run pairs.
struct MapPasses {
    int count = 1;
    int z_phase = 0;
};

// The slice z (of the fixed runs' z frame) where the fixed runs and the moving volume's words
// hold the most voxels together (the largest product of the two counts; the moving side counted
// on every 16th column, which is enough to rank slices): the z_phase of their map's passes.
int densest_shared_slice(const FixedRuns& fixed, const SparseColumns& moving);

// Which cut runs are kept, decided as each run is cut (while it is in cache): most runs of a
// later stage's map reach no pose in play, and storing, sorting and rereading them cost more than
// the test.
class RunFilter {
public:
    virtual bool keep(const SliceRun& run) const = 0;

protected:
    ~RunFilter() = default;
};

// How append_pulled_runs sorts, filters and hands back the runs it cuts.
struct PulledCut {
    MapPasses passes;  // the runs are sorted by map pass, then key, then y, then x
    // Only the rows y whose first map pass (first_pass_of_row) lies in [first_row_pass,
    // last_row_pass]: a map cuts each row just before its first pass, with the poses still in play
    // then (a coarse pass settles most poses, and a row's runs reach only those left).
    int first_row_pass = 0, last_row_pass = std::numeric_limits<int>::max();
    std::vector<std::size_t>* pass_first = nullptr;  // where given: the index in `out` of each pass's first run, and one more
    const RunFilter* keep = nullptr;                 // keeps only the runs it keeps (null: all)
    std::size_t* cut = nullptr;                      // where given: how many runs were cut before `keep` chose
};

// The first map pass (of `passes`) that holds runs of row y: its runs at the slice z_phase, where
// every z bit counts as a multiple of the largest power of two.
int first_pass_of_row(int y, int passes);

// Appends the runs of the moving volume pulled under A's lattice at pose (0, 0, angle) (the
// mapping of pose_map.hpp), for its slots, with keys for `angle_in_batch`, each slot's and z
// word's runs cut to its box in `clips`, as `how` says. Returns the longest run appended.
int append_pulled_runs(const SparseColumns& moving, const posemap::Trig& trig, const std::array<std::int64_t, 2>& root_a,
                       const std::array<std::int64_t, 2>& root_b, int angle_in_batch, const WordClips& clips,
                       std::vector<SliceRun>& out, const PulledCut& how = {});

// Per slot index and z word of `fixed`'s runs, the pulled columns that can meet that word's runs
// at an offset (i, j) with i in [i_first, i_last] and j in [j_first, j_last]: column g meets fixed
// column g + (i, j), so g lies in the word's box (FixedRuns::word_boxes) shifted by minus those
// offsets. Runs cut to these boxes give the same map on those offsets; a word's box holds only
// the runs of its 32 slices, so a body's clips are far narrower than the box of all its slices.
WordClips word_clips(const FixedRuns& fixed, int i_first, int i_last, int j_first, int j_last);

}  // namespace amhv
