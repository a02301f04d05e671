#include "sweep/slice_runs.hpp"

#include <algorithm>
#include <bit>
#include <limits>

#include "core/error.hpp"

namespace amhv {

namespace {

// Collects the runs of one row, column by column in increasing x: one open run per z.
class RowRuns {
public:
    explicit RowRuns(int zbits) : first_(std::size_t(zbits), kNone), last_(std::size_t(zbits), kNone) {}

    void add(std::int32_t x, int word, std::uint32_t bits) {
        while (bits != 0u) {
            const int z = word * 32 + std::countr_zero(bits);
            bits &= bits - 1u;
            auto& first = first_[std::size_t(z)];
            auto& last = last_[std::size_t(z)];
            if (first == kNone) {
                open_.push_back(z);
            } else if (last != x - 1) {
                emit(z);
            } else {
                last = x;
                continue;
            }
            first = last = x;
        }
    }

    // Closes the row: every open run goes out.
    void end_row() {
        for (int z : open_) {
            emit(z);
            first_[std::size_t(z)] = last_[std::size_t(z)] = kNone;
        }
        open_.clear();
    }

    // Where the row's runs go, with their y and key base.
    void start_row(std::int32_t y, std::int32_t key_base, std::vector<SliceRun>& out, int& longest) {
        y_ = y;
        key_base_ = key_base;
        out_ = &out;
        longest_ = &longest;
    }

private:
    static constexpr std::int32_t kNone = std::numeric_limits<std::int32_t>::min();
    void emit(int z) {
        const std::int32_t first = first_[std::size_t(z)], last = last_[std::size_t(z)];
        out_->push_back({y_, first, last, key_base_ + z});
        *longest_ = std::max(*longest_, int(last - first + 1));
    }
    std::vector<std::int32_t> first_, last_;
    std::vector<int> open_;
    std::int32_t y_ = 0, key_base_ = 0;
    std::vector<SliceRun>* out_ = nullptr;
    int* longest_ = nullptr;
};

void check_lattice(std::int64_t x0, std::int64_t y0, int nx, int ny) {
    constexpr std::int64_t limit = std::numeric_limits<std::int32_t>::max() / 4;
    if (std::abs(x0) > limit || std::abs(y0) > limit || nx > limit || ny > limit)
        fail("sweep", "internal: lattice indices beyond what slice runs store");
}

}  // namespace

FixedRuns fixed_runs(const ColumnVolume& volume, const std::vector<int>& slots) {
    check_lattice(volume.x0, volume.y0, volume.nx, volume.ny);
    FixedRuns result;
    result.zbits = 32 * volume.zwords;
    RowRuns row(result.zbits);
    for (std::size_t s = 0; s < slots.size(); ++s) {
        const int slot = slots[s];
        if (slot < 0 || slot >= volume.slots) fail("sweep", "internal: slot {} of a volume with {} slots", slot, volume.slots);
        const auto& box = volume.slot_boxes[std::size_t(slot)];
        const std::int32_t key_base = std::int32_t(s) * result.zbits;
        for (int y = box[1]; y <= box[3]; ++y) {
            const std::int32_t gy = std::int32_t(volume.y0 + y);
            row.start_row(gy, key_base, result.runs, result.longest);
            for (int x = box[0]; x <= box[2]; ++x) {
                const std::uint32_t* words = volume.column(x, y) + std::size_t(slot) * std::size_t(volume.zwords);
                for (int w = 0; w < volume.zwords; ++w)
                    if (words[w] != 0u) row.add(std::int32_t(volume.x0 + x), w, words[w]);
            }
            row.end_row();
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
    return result;
}

int append_pulled_runs(const ColumnVolume& moving, const std::vector<int>& slots, const posemap::Trig& trig,
                       const std::array<std::int64_t, 2>& root_a, const std::array<std::int64_t, 2>& root_b, int angle_in_batch,
                       const std::array<std::int32_t, 4>& clip, std::vector<SliceRun>& out) {
    check_lattice(moving.x0, moving.y0, moving.nx, moving.ny);
    const int zbits = 32 * moving.zwords;
    int longest = 0;
    RowRuns row(zbits);
    for (std::size_t s = 0; s < slots.size(); ++s) {
        const int slot = slots[s];
        if (slot < 0 || slot >= moving.slots) fail("sweep", "internal: slot {} of a volume with {} slots", slot, moving.slots);
        auto box = mapped_bounds(moving, moving.slot_boxes[std::size_t(slot)], trig, root_a, root_b);
        box = {std::max(box[0], clip[0]), std::max(box[1], clip[1]), std::min(box[2], clip[2]), std::min(box[3], clip[3])};
        const std::int32_t key_base = (std::int32_t(angle_in_batch) * std::int32_t(slots.size()) + std::int32_t(s)) * zbits;
        for (std::int32_t gy = box[1]; gy <= box[3]; ++gy) {
            row.start_row(gy, key_base, out, longest);
            for (std::int32_t gx = box[0]; gx <= box[2]; ++gx) {
                const auto source = posemap::source_column(gx, gy, trig, root_a[0], root_a[1], root_b[0], root_b[1]);
                const std::int64_t bx = source.x - moving.x0, by = source.y - moving.y0;
                if (bx < 0 || by < 0 || bx >= moving.nx || by >= moving.ny) continue;
                const std::uint32_t* words = moving.column(int(bx), int(by)) + std::size_t(slot) * std::size_t(moving.zwords);
                for (int w = 0; w < moving.zwords; ++w)
                    if (words[w] != 0u) row.add(gx, w, words[w]);
            }
            row.end_row();
        }
    }
    return longest;
}

std::array<std::int32_t, 4> pulled_clip(const ColumnVolume& fixed, int i_first, int i_last, int j_first, int j_last) {
    if (fixed.empty() || i_first > i_last || j_first > j_last) return {1, 1, 0, 0};
    return {std::int32_t(fixed.x0 + fixed.x_first - i_last), std::int32_t(fixed.y0 + fixed.y_first - j_last),
            std::int32_t(fixed.x0 + fixed.x_last - i_first), std::int32_t(fixed.y0 + fixed.y_last - j_first)};
}

}  // namespace amhv
