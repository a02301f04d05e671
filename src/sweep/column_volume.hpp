#pragma once
// Column bitsets: the layout the accelerated sweep tests overlaps in. A volume is cut into vertical
// columns on the global lattice; each column holds `slots` records of `zwords` 32-bit words (bit z
// = voxel z - z_first of the segment's shared z frame). Slot 0 is the union over the segment's
// frames; slots 1..frames, when present, are the single frames. Because a placement keeps z, a
// column of A and the column of B under it compare word by word.
#include <array>
#include <cstdint>
#include <functional>
#include <limits>
#include <vector>

#include "src/core/amhv.hpp"
#include "src/core/process.hpp"
#include "src/sweep/pose_map.hpp"
#include "src/sweep/problem.hpp"

namespace amhv {

struct ZFrame {
    std::int64_t z_first = 0;  // global lattice index of bit 0
    int words = 0;
};

// The z frame covering every grid given, the grids in `raised` lifted by every lift from `lift`
// to `lift_last` voxels (only by `lift` where lift_last is less).
ZFrame z_frame_covering(const std::vector<const VoxelGrid*>& grids, const std::vector<const VoxelGrid*>& raised = {}, int lift = 0,
                        int lift_last = std::numeric_limits<int>::min());
// The same frame as seen from a volume raised by `lift` voxels: its voxel z lands on bit z + lift.
inline ZFrame raised_frame(const ZFrame& z, int lift) { return {z.z_first - lift, z.words}; }

struct ColumnVolume {
    std::int64_t x0 = 0, y0 = 0;  // global lattice index of column (0, 0)
    int nx = 0, ny = 0;
    int slots = 1;
    int zwords = 0;
    std::vector<std::uint32_t, CallocAllocator<std::uint32_t>> bits;  // [y][x][slot][word]; only sized once from empty
    // Per row: first and last local x of an occupied column (first > last when the row is empty).
    std::vector<std::array<std::int32_t, 2>> rows;
    // Occupied columns' bounding box, local (x_first > x_last when empty).
    int x_first = 1, x_last = 0, y_first = 1, y_last = 0;
    // First and last z word with a set bit in any column's union (word_first > word_last when empty).
    int word_first = 1, word_last = 0;

    // Per slot: occupied columns' box, local [x_first, y_first, x_last, y_last] (empty: first > last).
    std::vector<std::array<std::int32_t, 4>> slot_boxes;

    int frames() const { return slots - 1; }
    std::size_t column_words() const { return std::size_t(slots) * zwords; }
    std::uint32_t* column(int x, int y) { return bits.data() + (std::size_t(y) * nx + x) * column_words(); }
    const std::uint32_t* column(int x, int y) const { return bits.data() + (std::size_t(y) * nx + x) * column_words(); }
    bool empty() const { return x_first > x_last; }
    // Computes rows and the bounding box from the union slot, and each slot's box; with
    // `slots_within_union` (every slot's bits are also slot 0's), only the union's columns are read.
    void finish(bool slots_within_union = false);
};

// Union (and, with `with_frames`, every frame) of `volume`.
ColumnVolume columns_of(const Amhv& volume, const ZFrame& z, bool with_frames);
// The voxels of a view cone: one slot (the union of its frames), and with `with_frames` and a cone
// per frame, every frame's cone too.
ColumnVolume columns_of(const ConeVolume& cone, const ZFrame& z, bool with_frames = false);
// One slot: the voxels of `volume` for which `keep(voxel index)` holds.
ColumnVolume columns_where(const Amhv& volume, const ZFrame& z, const std::function<bool(std::size_t)>& keep);
// Union plus, per frame t, the voxels with t_start <= t (`started_by`) or with t_end >= t.
ColumnVolume columns_cumulative(const Amhv& volume, const ZFrame& z, bool started_by);

// The volume OR-pooled over a block of `block` x `block` offsets: column v of the result is the OR
// of columns v .. v + block - 1 (in x and in y) of `volume`, every slot. A pose (i0, j0, theta)
// finds no overlap between the result and a moving volume only if no pose (i0 + di, j0 + dj,
// theta), 0 <= di, dj < block, finds one with `volume`: one test proves "no overlap" for the
// whole block (exact culling; see sweep_vulkan.cpp).
ColumnVolume dilated_columns(const ColumnVolume& volume, int block);

// The volume's bits ORed over lifts 0 .. lifts - 1 downwards: bit z is set where bit z + h is for
// some h < lifts, every slot. A run of B raised by h meets `volume` at slice z + h; its runs at
// slice z meet this volume at z exactly when they meet `volume` at some lift, so one prune of B's
// runs serves every lift (SweepRun with several heights).
ColumnVolume lowered_union(const ColumnVolume& volume, int lifts);

// Conservative bounding box [x_first, y_first, x_last, y_last] (global A lattice) of the A columns
// that the pull mapping of angle `trig` (pose offset 0) sends into an occupied column of `moving`.
std::array<std::int32_t, 4> mapped_bounds(const ColumnVolume& moving, const posemap::Trig& trig,
                                          const std::array<std::int64_t, 2>& root_a, const std::array<std::int64_t, 2>& root_b);
// The same for the occupied box of one slot (`box` local, as in slot_boxes).
std::array<std::int32_t, 4> mapped_bounds(const ColumnVolume& moving, const std::array<std::int32_t, 4>& box, const posemap::Trig& trig,
                                          const std::array<std::int64_t, 2>& root_a, const std::array<std::int64_t, 2>& root_b);

}  // namespace amhv
