#include "src/sweep/slice_runs.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <limits>
#include <memory>

#include "src/core/error.hpp"

namespace amhv {

namespace {

class RunBuckets;

// Cuts one row into maximal runs from whole words, column by column in increasing x (runs of one
// key come out in increasing x): a run starts where a bit is set and was clear in the previous
// column, and ends where it was set and is clear now, so the work is per run end rather than per
// set voxel.
class RowRuns {
public:
    explicit RowRuns(std::size_t words) : previous_(words, 0u), current_(words, 0u), first_(words * 32, 0) {}
    std::size_t words() const { return previous_.size(); }

    void start_row(std::int32_t y, std::int32_t key_base, std::vector<SliceRun>& out, int& longest);
    // Counts each emitted run into its bucket as it goes (a pass over the runs saved).
    void count_into(RunBuckets* buckets) { buckets_ = buckets; }
    // Emits only the runs `keep` keeps (null: all); counts every run cut.
    void filter_by(const RunFilter* keep) {
        keep_ = keep;
        cut_ = 0;
    }
    std::size_t cut() const { return cut_; }
    // Column x's non-zero words (each word index at most once); columns not added are empty.
    void add(std::int32_t word, std::uint32_t bits) {
        current_[std::size_t(word)] = bits;
        current_words_.push_back(word);
    }
    // Ends column x: compares it with the column before.
    void end_column(std::int32_t x) {
        if (current_words_.empty() && previous_words_.empty()) return;  // most columns: nothing starts or ends
        for (const std::int32_t w : current_words_)
            for (std::uint32_t starts = current_[std::size_t(w)] & ~previous_[std::size_t(w)]; starts != 0u; starts &= starts - 1u)
                first_[std::size_t(w) * 32 + std::size_t(std::countr_zero(starts))] = x;
        for (const std::int32_t w : previous_words_) {
            for (std::uint32_t ends = previous_[std::size_t(w)] & ~current_[std::size_t(w)]; ends != 0u; ends &= ends - 1u)
                emit(w * 32 + std::countr_zero(ends), x - 1);
            previous_[std::size_t(w)] = 0u;
        }
        // The cleared previous words become the next column's blank current words.
        std::swap(previous_, current_);
        std::swap(previous_words_, current_words_);
        current_words_.clear();
    }
    // Closes the row after its last column x_last: every open run goes out.
    void end_row(std::int32_t x_last) { end_column(x_last + 1); }

private:
    void emit(std::int32_t bit, std::int32_t x_last);
    std::vector<std::uint32_t> previous_, current_;
    std::vector<std::int32_t> previous_words_, current_words_;
    std::vector<std::int32_t> first_;
    std::int32_t y_ = 0, key_base_ = 0;
    std::vector<SliceRun>* out_ = nullptr;
    int* longest_ = nullptr;
    RunBuckets* buckets_ = nullptr;
    const RunFilter* keep_ = nullptr;
    std::size_t cut_ = 0;
};

void check_lattice(std::int64_t x0, std::int64_t y0, int nx, int ny) {
    constexpr std::int64_t limit = std::numeric_limits<std::int32_t>::max() / 4;
    if (std::abs(x0) > limit || std::abs(y0) > limit || nx > limit || ny > limit)
        fail("sweep", "internal: lattice indices beyond what slice runs store");
}

// floor(a / b) and ceil(a / b), b != 0, for any signs.
std::int64_t floor_div(std::int64_t a, std::int64_t b) {
    const std::int64_t q = a / b;
    return a % b != 0 && (a < 0) != (b < 0) ? q - 1 : q;
}
std::int64_t ceil_div(std::int64_t a, std::int64_t b) {
    const std::int64_t q = a / b;
    return a % b != 0 && (a < 0) == (b < 0) ? q + 1 : q;
}

// The steps k (value + k * delta, as a row of the pull mapping steps) at which the value lies in
// [low, high]: [first, last], empty when first > last.
std::array<std::int64_t, 2> steps_within(std::int64_t value, std::int64_t delta, std::int64_t low, std::int64_t high) {
    if (delta == 0) return low <= value && value <= high ? std::array<std::int64_t, 2>{0, std::numeric_limits<std::int64_t>::max()}
                                                         : std::array<std::int64_t, 2>{1, 0};
    if (delta > 0) return {ceil_div(low - value, delta), floor_div(high - value, delta)};
    return {ceil_div(high - value, delta), floor_div(low - value, delta)};
}

// Where the pull mapping of one A row lands in a box of B's columns: the first and last A column
// (gx_first, gx_last within the row's [gx_first, gx_last]) and the step at the first. Columns
// outside are empty, so the row is walked only over that stretch (most of a rotated volume's
// bounding box lies outside it). Exact: the mapping is linear along the row, in integers.
struct RowStretch {
    std::int32_t first = 1, last = 0;
    posemap::Step at;
};
RowStretch stretch_in_box(std::int32_t gy, std::int32_t gx_first, std::int32_t gx_last, const posemap::Trig& trig, const std::array<std::int64_t, 2>& root_a,
                          const std::array<std::int64_t, 2>& root_b, const std::array<std::int64_t, 4>& source_box) {
    constexpr std::int64_t unit = std::int64_t(1) << (posemap::kPositionBits + posemap::kTrigBits);  // one column
    RowStretch stretch;
    stretch.at = posemap::source_step(gx_first, gy, trig, root_a[0], root_a[1], root_b[0], root_b[1]);
    const auto in_x = steps_within(stretch.at.px, stretch.at.dpx, source_box[0] * unit, (source_box[2] + 1) * unit - 1);
    const auto in_y = steps_within(stretch.at.py, stretch.at.dpy, source_box[1] * unit, (source_box[3] + 1) * unit - 1);
    const std::int64_t first = std::max({std::int64_t(0), in_x[0], in_y[0]});
    const std::int64_t last = std::min({std::int64_t(gx_last) - gx_first, in_x[1], in_y[1]});
    if (first > last) return stretch;
    stretch.first = gx_first + std::int32_t(first);
    stretch.last = gx_first + std::int32_t(last);
    stretch.at.px += first * stretch.at.dpx;
    stretch.at.py += first * stretch.at.dpy;
    return stretch;
}

// The pass of a run with key `key` (z = key % zbits): zbits is a multiple of 32, so the last five
// bits of z - z_phase are those of key - z_phase, and they alone settle it unless all five are
// zero and more than six passes are asked for (a division per run was a tenth of the time of
// ordering runs by pass).
int map_pass_of_run(std::int32_t key, int zbits, int y, const MapPasses& passes) {
    const std::uint32_t low = std::uint32_t(key - passes.z_phase) & 31u;
    const int z = low != 0u || passes.count <= 6 ? int(low) : key % zbits - passes.z_phase;
    return map_pass_of(z, y, passes.count);
}

// The counting sort of pulled runs into (map pass, key) order: `first` gets each bucket's count
// (at its index + 1) as runs are emitted, then each bucket's first place, then each run's place.
class RunBuckets {
public:
    RunBuckets(std::vector<std::uint32_t>& first, const MapPasses& passes, int zbits, std::size_t key_count, std::int32_t key_base)
        : first_(first), passes_(passes), zbits_(zbits), key_count_(key_count), key_base_(key_base) {
        first_.assign(std::size_t(passes.count) * key_count + 1, 0u);
    }
    std::size_t buckets() const { return first_.size() - 1; }
    // The bucket of a run with key `key` on row y.
    std::size_t of(std::int32_t key, std::int32_t y) const {
        const std::size_t in_angle = std::size_t(key - key_base_);
        return passes_.count == 1 ? in_angle : std::size_t(map_pass_of_run(key, zbits_, y, passes_)) * key_count_ + in_angle;
    }
    void start_row(std::int32_t y) { y_ = y; }
    void count(std::int32_t key) { ++first_[of(key, y_) + 1]; }
    // After the counts: each bucket's first place (relative to the output's base).
    void accumulate() {
        for (std::size_t b = 0; b < buckets(); ++b) first_[b + 1] += first_[b];
    }
    std::uint32_t first_of_pass(int pass) const { return first_[std::size_t(pass) * key_count_]; }
    std::uint32_t place(const SliceRun& run) { return first_[of(run.key, run.y)]++; }

private:
    std::vector<std::uint32_t>& first_;
    MapPasses passes_;
    int zbits_;
    std::size_t key_count_;
    std::int32_t key_base_, y_ = 0;
};

void RowRuns::start_row(std::int32_t y, std::int32_t key_base, std::vector<SliceRun>& out, int& longest) {
    y_ = y;
    key_base_ = key_base;
    out_ = &out;
    longest_ = &longest;
    if (buckets_) buckets_->start_row(y);
}

void RowRuns::emit(std::int32_t bit, std::int32_t x_last) {
    const std::int32_t x_first = first_[std::size_t(bit)];
    const SliceRun run{y_, x_first, x_last, key_base_ + bit};
    ++cut_;
    if (keep_ && !keep_->keep(run)) return;
    out_->push_back(run);
    if (buckets_) buckets_->count(run.key);
    *longest_ = std::max(*longest_, int(x_last - x_first + 1));
}

// Fills FixedRuns::window_hulls from row_hulls: each level joins two windows of the level below.
void add_window_hulls(FixedRuns& result) {
    using Hull = std::array<std::int32_t, 2>;
    const auto join = [](const Hull& a, const Hull& b) {
        if (a[0] > a[1]) return b;
        if (b[0] > b[1]) return a;
        return Hull{std::min(a[0], b[0]), std::max(a[1], b[1])};
    };
    result.window_hulls.assign(FixedRuns::kHullLevels - 1, {});
    const std::vector<Hull>* below = &result.row_hulls;
    for (int level = 1; level < FixedRuns::kHullLevels; ++level) {
        std::vector<Hull>& windows = result.window_hulls[std::size_t(level - 1)];
        windows.resize(result.row_hulls.size());
        const std::size_t half = std::size_t(1) << (level - 1);
        for (std::size_t k = 0; k < result.by_key.size(); ++k) {
            const std::size_t first = result.row_hull_first[k];
            const std::size_t end = k + 1 < result.by_key.size() ? result.row_hull_first[k + 1] : result.row_hulls.size();
            for (std::size_t r = first; r < end; ++r) windows[r] = r + half < end ? join((*below)[r], (*below)[r + half]) : (*below)[r];
        }
        below = &windows;
    }
}

// Walks one row of A's lattice over its stretch, reading the sparse words of the B column under
// each A column into RowRuns. The B columns along a rotated row are scattered in memory, so the
// column index kIndexAhead columns ahead and the words kWordsAhead ahead are prefetched.
class RowCut {
public:
    // `clips`: per slot index and word, the A columns its words are kept in (null: all).
    RowCut(const SparseColumns& sparse, const WordClips* clips) : sparse_(sparse), moving_(*sparse.volume), clips_(clips) {}

    void walk(std::int32_t gy, const RowStretch& stretch, RowRuns& row) const {
        posemap::Step at = stretch.at, index_ahead = ahead(at, kIndexAhead), words_ahead = ahead(at, kWordsAhead);
        for (std::int32_t gx = stretch.first; gx <= stretch.last; ++gx) {
            if (const std::int64_t c = column_of(index_ahead); c >= 0) __builtin_prefetch(sparse_.first.data() + c);
            if (const std::int64_t c = column_of(words_ahead); c >= 0) __builtin_prefetch(sparse_.entries.data() + sparse_.first[std::size_t(c)]);
            if (const std::int64_t c = column_of(at); c >= 0) add_column(std::size_t(c), gx, gy, row);
            row.end_column(gx);
            at.advance(), index_ahead.advance(), words_ahead.advance();
        }
        row.end_row(stretch.last);
    }

private:
    static constexpr int kIndexAhead = 16, kWordsAhead = 8;

    static posemap::Step ahead(posemap::Step step, int columns) {
        step.px += columns * step.dpx;
        step.py += columns * step.dpy;
        return step;
    }
    // The local index of B's column under `at` (-1: outside B's volume).
    std::int64_t column_of(const posemap::Step& at) const {
        const posemap::Column source = at.column();
        const std::int64_t bx = source.x - moving_.x0, by = source.y - moving_.y0;
        if (bx < 0 || by < 0 || bx >= moving_.nx || by >= moving_.ny) return -1;
        return by * moving_.nx + bx;
    }
    void add_column(std::size_t c, std::int32_t gx, std::int32_t gy, RowRuns& row) const {
        for (std::uint32_t e = sparse_.first[c]; e < sparse_.first[c + 1]; ++e) {
            const SparseColumns::Entry& entry = sparse_.entries[e];
            if (clips_) {
                const auto& clip = (*clips_)[std::size_t(entry.word)];
                if (gx < clip[0] || gx > clip[2] || gy < clip[1] || gy > clip[3]) continue;
            }
            row.add(entry.word, entry.bits);
        }
    }

    const SparseColumns& sparse_;
    const ColumnVolume& moving_;
    const WordClips* clips_;
};

}  // namespace

int map_pass_of(int z, int y, int passes) {
    const int last = passes - 1;
    return last - std::min({std::countr_zero(std::uint32_t(z)), std::countr_zero(std::uint32_t(y)), last});
}

int first_pass_of_row(int y, int passes) { return map_pass_of(0, y, passes); }

FixedRuns fixed_runs(const ColumnVolume& volume, const std::vector<int>& slots) {
    check_lattice(volume.x0, volume.y0, volume.nx, volume.ny);
    FixedRuns result;
    result.zbits = 32 * volume.zwords;
    RowRuns row{std::size_t(volume.zwords)};
    for (std::size_t s = 0; s < slots.size(); ++s) {
        const int slot = slots[s];
        if (slot < 0 || slot >= volume.slots) fail("sweep", "internal: slot {} of a volume with {} slots", slot, volume.slots);
        const auto& box = volume.slot_boxes[std::size_t(slot)];
        const std::int32_t key_base = std::int32_t(s) * result.zbits;
        for (int y = box[1]; y <= box[3]; ++y) {
            row.start_row(std::int32_t(volume.y0 + y), key_base, result.runs, result.longest);
            for (int x = box[0]; x <= box[2]; ++x) {
                const std::uint32_t* words = volume.column(x, y) + std::size_t(slot) * std::size_t(volume.zwords);
                for (int w = 0; w < volume.zwords; ++w)
                    if (words[w] != 0u) row.add(w, words[w]);
                row.end_column(std::int32_t(volume.x0 + x));
            }
            row.end_row(std::int32_t(volume.x0 + box[2]));
        }
    }
    // Rows were visited in increasing y and each key's runs of a row come out in increasing x, so a
    // stable sort by key keeps (y, x) order within a key.
    std::stable_sort(result.runs.begin(), result.runs.end(), [](const SliceRun& a, const SliceRun& b) { return a.key < b.key; });
    result.by_key.assign(slots.size() * std::size_t(result.zbits), {0, 0});
    for (std::size_t r = 0; r < result.runs.size(); ++r) {
        auto& entry = result.by_key[std::size_t(result.runs[r].key)];
        if (entry[1] == 0) entry[0] = std::int32_t(r);
        ++entry[1];
        result.most_per_key = std::max(result.most_per_key, int(entry[1]));
    }
    // Per key: the box of its runs and, per row of the box, the hull of the row's runs.
    result.key_boxes.assign(result.by_key.size(), {1, 0, 1, 0});
    result.row_hull_first.assign(result.by_key.size(), 0);
    for (std::size_t k = 0; k < result.by_key.size(); ++k) {
        result.row_hull_first[k] = std::uint32_t(result.row_hulls.size());
        const auto [first, count] = result.by_key[k];
        if (count == 0) continue;
        const std::int32_t y_first = result.runs[std::size_t(first)].y, y_last = result.runs[std::size_t(first + count - 1)].y;
        auto& box = result.key_boxes[k];
        box = {std::numeric_limits<std::int32_t>::max(), std::numeric_limits<std::int32_t>::min(), y_first, y_last};
        result.row_hulls.resize(result.row_hulls.size() + std::size_t(y_last - y_first + 1), {1, 0});
        for (std::int32_t r = first; r < first + count; ++r) {
            const SliceRun& run = result.runs[std::size_t(r)];
            box[0] = std::min(box[0], run.x_first), box[1] = std::max(box[1], run.x_last);
            auto& hull = result.row_hulls[result.row_hull_first[k] + std::size_t(run.y - y_first)];
            hull = hull[0] > hull[1] ? std::array<std::int32_t, 2>{run.x_first, run.x_last}
                                     : std::array<std::int32_t, 2>{std::min(hull[0], run.x_first), std::max(hull[1], run.x_last)};
        }
    }
    add_window_hulls(result);
    result.word_boxes.assign(result.by_key.size() / 32, {1, 1, 0, 0});
    for (std::size_t k = 0; k < result.key_boxes.size(); ++k) {
        const auto& key = result.key_boxes[k];
        if (key[0] > key[1]) continue;
        auto& word = result.word_boxes[k / 32];
        word = word[0] > word[2] ? std::array<std::int32_t, 4>{key[0], key[2], key[1], key[3]}
                                 : std::array<std::int32_t, 4>{std::min(word[0], key[0]), std::min(word[1], key[2]), std::max(word[2], key[1]),
                                                               std::max(word[3], key[3])};
    }
    return result;
}

int densest_shared_slice(const FixedRuns& fixed, const SparseColumns& moving) {
    constexpr std::size_t kColumnStride = 16;
    const std::size_t zbits = std::size_t(fixed.zbits);
    if (zbits == 0 || moving.volume == nullptr || 32 * std::size_t(moving.volume->zwords) != zbits) return 0;
    std::vector<double> fixed_voxels(zbits, 0.0), moving_voxels(zbits, 0.0);
    for (const SliceRun& run : fixed.runs) fixed_voxels[std::size_t(run.key) % zbits] += double(run.x_last - run.x_first + 1);
    const std::size_t zwords = std::size_t(moving.volume->zwords);
    for (std::size_t c = 0; c + 1 < moving.first.size(); c += kColumnStride)
        for (std::uint32_t e = moving.first[c]; e < moving.first[c + 1]; ++e) {
            const SparseColumns::Entry& entry = moving.entries[e];
            const std::size_t base = 32 * (std::size_t(entry.word) % zwords);
            for (std::uint32_t bits = entry.bits; bits != 0u; bits &= bits - 1u) moving_voxels[base + std::size_t(std::countr_zero(bits))] += 1.0;
        }
    std::size_t best = 0;
    for (std::size_t z = 1; z < zbits; ++z)
        if (fixed_voxels[z] * moving_voxels[z] > fixed_voxels[best] * moving_voxels[best]) best = z;
    return int(best);
}

SparseColumns sparse_columns(const ColumnVolume& moving, const std::vector<int>& slots) {
    check_lattice(moving.x0, moving.y0, moving.nx, moving.ny);
    for (const int slot : slots)
        if (slot < 0 || slot >= moving.slots) fail("sweep", "internal: slot {} of a volume with {} slots", slot, moving.slots);
    SparseColumns sparse;
    sparse.volume = &moving;
    sparse.slots = slots;
    const std::size_t columns = std::size_t(moving.nx) * std::size_t(moving.ny);
    sparse.first.reserve(columns + 1);
    for (std::size_t c = 0; c < columns; ++c) {
        sparse.first.push_back(std::uint32_t(sparse.entries.size()));
        const std::uint32_t* column = moving.bits.data() + c * moving.column_words();
        for (std::size_t s = 0; s < slots.size(); ++s)
            for (int w = 0; w < moving.zwords; ++w) {
                const std::uint32_t bits = column[std::size_t(slots[s]) * std::size_t(moving.zwords) + std::size_t(w)];
                if (bits != 0u) sparse.entries.push_back({bits, std::int32_t(s) * moving.zwords + w});
            }
        if (sparse.entries.size() > std::numeric_limits<std::uint32_t>::max()) fail("sweep", "internal: a moving volume with more than 2^32 words");
    }
    sparse.first.push_back(std::uint32_t(sparse.entries.size()));
    return sparse;
}

int append_pulled_runs(const SparseColumns& sparse, const posemap::Trig& trig, const std::array<std::int64_t, 2>& root_a,
                       const std::array<std::int64_t, 2>& root_b, int angle_in_batch, const WordClips& clips,
                       std::vector<SliceRun>& out, const PulledCut& how) {
    const ColumnVolume& moving = *sparse.volume;
    const MapPasses passes = how.passes;
    const int zbits = 32 * moving.zwords;
    const std::size_t key_count = sparse.slots.size() * std::size_t(zbits);
    const std::int32_t key_base = std::int32_t(angle_in_batch) * std::int32_t(key_count);
    if (clips.size() != sparse.slots.size() * std::size_t(moving.zwords))
        fail("sweep", "internal: {} clips for {} slots of {} words", clips.size(), sparse.slots.size(), moving.zwords);
    // Each slot's clip, the union of its words': its columns lie within.
    const auto slot_clip = [&](std::size_t s) {
        std::array<std::int32_t, 4> box{1, 1, 0, 0};
        for (int w = 0; w < moving.zwords; ++w) {
            const auto& c = clips[s * std::size_t(moving.zwords) + std::size_t(w)];
            if (c[0] > c[2] || c[1] > c[3]) continue;
            box = box[0] > box[2] ? c : std::array<std::int32_t, 4>{std::min(box[0], c[0]), std::min(box[1], c[1]), std::max(box[2], c[2]), std::max(box[3], c[3])};
        }
        return box;
    };
    if (passes.count < 1) fail("sweep", "internal: {} map passes", passes.count);
    // One pass over the union of the slots' mapped boxes within their clips: each A column is
    // mapped once and reads the non-zero words of every slot from its B column. Outside a slot's
    // own box its words are zero, and outside its clip they are skipped, so the runs are those of
    // slot-by-slot passes.
    std::array<std::int32_t, 4> box{std::numeric_limits<std::int32_t>::max(), std::numeric_limits<std::int32_t>::max(),
                                    std::numeric_limits<std::int32_t>::min(), std::numeric_limits<std::int32_t>::min()};
    bool clipped = false;  // whether some slot's clip is narrower than the box
    for (std::size_t s = 0; s < sparse.slots.size(); ++s) {
        auto b = mapped_bounds(moving, moving.slot_boxes[std::size_t(sparse.slots[s])], trig, root_a, root_b);
        const auto c = slot_clip(s);
        b = {std::max(b[0], c[0]), std::max(b[1], c[1]), std::min(b[2], c[2]), std::min(b[3], c[3])};
        if (b[0] > b[2] || b[1] > b[3]) continue;
        box = {std::min(box[0], b[0]), std::min(box[1], b[1]), std::max(box[2], b[2]), std::max(box[3], b[3])};
    }
    // (An empty clip, {1, 1, 0, 0}, holds no box that has columns, so it counts.)
    for (const auto& c : clips) clipped |= c[0] > box[0] || c[1] > box[1] || c[2] < box[2] || c[3] < box[3];
    // The slots' occupied columns in B's global lattice: every non-zero word lies in their box.
    std::array<std::int64_t, 4> source_box{std::numeric_limits<std::int64_t>::max(), std::numeric_limits<std::int64_t>::max(),
                                           std::numeric_limits<std::int64_t>::min(), std::numeric_limits<std::int64_t>::min()};
    for (const int slot : sparse.slots) {
        const auto& b = moving.slot_boxes[std::size_t(slot)];
        if (b[0] > b[2] || b[1] > b[3]) continue;
        source_box = {std::min(source_box[0], moving.x0 + b[0]), std::min(source_box[1], moving.y0 + b[1]),
                      std::max(source_box[2], moving.x0 + b[2]), std::max(source_box[3], moving.y0 + b[3])};
    }
    int longest = 0;
    // Runs in visiting order (row by row), counted into (pass, key) buckets as they come, then
    // placed in bucket order: within a key they stay in (y, x) order, as a stable sort by key would
    // leave them. The scratch stays with the thread: this runs once per angle and test, and fresh
    // buffers cost more in page faults than the cut.
    thread_local std::vector<SliceRun> visited;
    thread_local std::unique_ptr<RowRuns> row_runs;
    thread_local std::vector<std::uint32_t> first;
    visited.clear();
    if (!row_runs || row_runs->words() != key_count / 32) row_runs = std::make_unique<RowRuns>(key_count / 32);
    RunBuckets buckets(first, passes, zbits, key_count, key_base);
    RowRuns& row = *row_runs;
    row.count_into(&buckets);
    row.filter_by(how.keep);
    const RowCut cut(sparse, clipped ? &clips : nullptr);
    const bool every_row = how.first_row_pass <= 0 && how.last_row_pass >= passes.count - 1;
    for (std::int32_t gy = box[1]; gy <= box[3] && source_box[0] <= source_box[2]; ++gy) {
        if (!every_row) {
            const int first_pass = first_pass_of_row(gy, passes.count);
            if (first_pass < how.first_row_pass || first_pass > how.last_row_pass) continue;
        }
        const RowStretch stretch = stretch_in_box(gy, box[0], box[2], trig, root_a, root_b, source_box);
        if (stretch.first > stretch.last) continue;
        row.start_row(gy, key_base, visited, longest);
        cut.walk(gy, stretch, row);
    }
    row.count_into(nullptr);
    if (how.cut) *how.cut = row.cut();
    row.filter_by(nullptr);
    buckets.accumulate();
    const std::size_t base = out.size();
    if (how.pass_first) {
        how.pass_first->resize(std::size_t(passes.count) + 1);
        for (int p = 0; p <= passes.count; ++p) (*how.pass_first)[std::size_t(p)] = base + buckets.first_of_pass(p);
    }
    out.resize(base + visited.size());
    for (const SliceRun& run : visited) out[base + buckets.place(run)] = run;
    return longest;
}

WordClips word_clips(const FixedRuns& fixed, int i_first, int i_last, int j_first, int j_last) {
    WordClips clips;
    clips.reserve(fixed.word_boxes.size());
    for (const auto& box : fixed.word_boxes) {
        if (box[0] > box[2] || box[1] > box[3] || i_first > i_last || j_first > j_last) {
            clips.push_back({1, 1, 0, 0});
            continue;
        }
        clips.push_back({box[0] - i_last, box[1] - j_last, box[2] - i_first, box[3] - j_first});
    }
    return clips;
}

}  // namespace amhv
