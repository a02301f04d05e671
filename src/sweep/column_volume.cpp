#include "src/sweep/column_volume.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>

#include "src/core/error.hpp"

namespace amhv {

namespace {

ColumnVolume empty_like(const VoxelGrid& g, const ZFrame& z, int slots) {
    ColumnVolume c;
    const auto origin = g.lattice_origin();
    c.x0 = origin[0];
    c.y0 = origin[1];
    c.nx = g.dims[0];
    c.ny = g.dims[1];
    c.slots = slots;
    c.zwords = z.words;
    c.bits.resize(std::size_t(c.nx) * c.ny * c.column_words());  // zero, untouched
    return c;
}

// Calls visit(column words, bit word, bit mask, voxel index) for every occupied voxel of the grid,
// in memory order of the volume (z, then y, then x). The occupied voxels are found first on every
// core (occupied_by_slice skips empty stretches eight voxels at a time).
template <typename Visit>
void for_each_occupied_voxel(const Amhv& volume, const ZFrame& z, ColumnVolume& c, Visit visit) {
    const VoxelGrid& g = volume.grid();
    const std::int64_t z0 = g.lattice_origin()[2] - z.z_first;
    const std::size_t slice_voxels = std::size_t(g.dims[0]) * std::size_t(g.dims[1]);
    const std::vector<std::vector<std::uint32_t>> slices = occupied_by_slice(volume);
    for (int vz = 0; vz < g.dims[2]; ++vz) {
        const std::int64_t bit = z0 + vz;
        const int word = int(bit / 32);
        const std::uint32_t mask = 1u << (bit % 32);
        for (const std::uint32_t in_slice : slices[std::size_t(vz)]) {
            const int x = int(in_slice % std::uint32_t(g.dims[0])), y = int(in_slice / std::uint32_t(g.dims[0]));
            visit(c.column(x, y), word, mask, std::size_t(vz) * slice_voxels + in_slice);
        }
    }
}

// Sets bits first..last (first <= last) of the words at `words`, a word at a time.
void set_bits(std::uint32_t* words, std::int64_t first, std::int64_t last) {
    const std::int64_t w_first = first / 32, w_last = last / 32;
    for (std::int64_t w = w_first; w <= w_last; ++w) {
        const int from = w == w_first ? int(first % 32) : 0, to = w == w_last ? int(last % 32) : 31;
        words[w] |= (0xffffffffu >> (31 - to)) & (0xffffffffu << from);
    }
}

}  // namespace

ZFrame z_frame_covering(const std::vector<const VoxelGrid*>& grids, const std::vector<const VoxelGrid*>& raised, int lift, int lift_last) {
    std::int64_t first = std::numeric_limits<std::int64_t>::max(), last = std::numeric_limits<std::int64_t>::min();
    auto cover = [&](const VoxelGrid* g, int by) {
        if (g->dims[2] == 0) return;
        std::int64_t z0 = g->lattice_origin()[2] + by;
        first = std::min(first, z0);
        last = std::max(last, z0 + g->dims[2] - 1);
    };
    for (const VoxelGrid* g : grids) cover(g, 0);
    for (const VoxelGrid* g : raised) cover(g, lift), cover(g, std::max(lift, lift_last));
    if (first > last) return {0, 1};
    return {first, int((last - first) / 32 + 1)};
}

void ColumnVolume::finish(bool slots_within_union) {
    rows.assign(std::size_t(ny), {1, 0});
    x_first = y_first = word_first = std::numeric_limits<int>::max();
    x_last = y_last = word_last = std::numeric_limits<int>::min();
    for (int y = 0; y < ny; ++y)
        for (int x = 0; x < nx; ++x) {
            const std::uint32_t* c = column(x, y);
            if (std::none_of(c, c + zwords, [](std::uint32_t w) { return w != 0; })) continue;
            for (int w = 0; w < zwords; ++w)
                if (c[w]) {
                    word_first = std::min(word_first, w);
                    word_last = std::max(word_last, w);
                }
            auto& row = rows[std::size_t(y)];
            if (row[0] > row[1]) row = {x, x};
            row[1] = x;
            x_first = std::min(x_first, x);
            x_last = std::max(x_last, x);
            y_first = std::min(y_first, y);
            y_last = std::max(y_last, y);
        }
    if (x_first > x_last) x_first = y_first = word_first = 1, x_last = y_last = word_last = 0;
    slot_boxes.assign(std::size_t(slots), {1, 1, 0, 0});
    for (int y = 0; y < ny; ++y)
        for (int x = 0; x < nx; ++x) {
            // Where every slot lies within slot 0, a column outside the union's rows holds nothing
            // (and is never read: most of a volume's pages stay untouched).
            const auto& row = rows[std::size_t(y)];
            if (slots_within_union && (x < row[0] || x > row[1])) continue;
            const std::uint32_t* c = column(x, y);
            for (int slot = 0; slot < slots; ++slot) {
                const std::uint32_t* words = c + std::size_t(slot) * zwords;
                if (std::none_of(words, words + zwords, [](std::uint32_t w) { return w != 0; })) continue;
                auto& b = slot_boxes[std::size_t(slot)];
                if (b[0] > b[2]) b = {x, y, x, y};
                b = {std::min(b[0], x), std::min(b[1], y), std::max(b[2], x), std::max(b[3], y)};
            }
        }
}

ColumnVolume columns_of(const Amhv& volume, const ZFrame& z, bool with_frames) {
    const int frames = volume.frames();
    ColumnVolume c = empty_like(volume.grid(), z, with_frames ? frames + 1 : 1);
    const std::size_t slot_words = std::size_t(z.words);
    for_each_occupied_voxel(volume, z, c, [&](std::uint32_t* column, int word, std::uint32_t bit, std::size_t v) {
        column[word] |= bit;
        if (!with_frames) return;
        for (int w = 0; w < volume.words(); ++w)
            for (std::uint32_t frames_set = volume.word(w, v); frames_set; frames_set &= frames_set - 1) {
                const int t = w * 32 + std::countr_zero(frames_set);
                column[(1 + std::size_t(t)) * slot_words + word] |= bit;
            }
    });
    c.finish(true);
    return c;
}

ColumnVolume columns_of(const ConeVolume& cone, const ZFrame& z, bool with_frames) {
    const bool per_frame = with_frames && cone.frames > 1;
    ColumnVolume c = empty_like(cone.grid, z, per_frame ? cone.frames + 1 : 1);
    const std::int64_t z0 = cone.grid.lattice_origin()[2] - z.z_first;
    const std::size_t slot_words = std::size_t(z.words);
    for (int y = 0; y < cone.grid.dims[1]; ++y)
        for (int x = 0; x < cone.grid.dims[0]; ++x) {
            std::uint32_t* column = c.column(x, y);
            for (int t = 0; t < cone.frames; ++t) {
                const auto span = cone.span(x, y, t);
                if (span[0] > span[1]) continue;
                set_bits(column, z0 + span[0], z0 + span[1]);
                if (per_frame) set_bits(column + (1 + std::size_t(t)) * slot_words, z0 + span[0], z0 + span[1]);
            }
        }
    c.finish(true);
    return c;
}

ColumnVolume columns_where(const Amhv& volume, const ZFrame& z, const std::function<bool(std::size_t)>& keep) {
    ColumnVolume c = empty_like(volume.grid(), z, 1);
    for_each_occupied_voxel(volume, z, c, [&](std::uint32_t* column, int word, std::uint32_t bit, std::size_t v) {
        if (keep(v)) column[word] |= bit;
    });
    c.finish();
    return c;
}

ColumnVolume columns_cumulative(const Amhv& volume, const ZFrame& z, bool started_by) {
    const int frames = volume.frames();
    ColumnVolume c = empty_like(volume.grid(), z, frames + 1);
    const std::size_t slot_words = std::size_t(z.words);
    for_each_occupied_voxel(volume, z, c, [&](std::uint32_t* column, int word, std::uint32_t bit, std::size_t v) {
        column[word] |= bit;
        const int first = started_by ? volume.t_start(v) : 0;
        const int last = started_by ? frames - 1 : volume.t_end(v);
        for (int t = first; t <= last; ++t) column[(1 + std::size_t(t)) * slot_words + word] |= bit;
    });
    c.finish(true);
    return c;
}

ColumnVolume dilated_columns(const ColumnVolume& volume, int block) {
    if (block < 1) fail("sweep", "internal: block size {} is not positive", block);
    const int grow = block - 1;
    ColumnVolume d;
    d.x0 = volume.x0 - grow;
    d.y0 = volume.y0 - grow;
    d.nx = volume.nx + grow;
    d.ny = volume.ny + grow;
    d.slots = volume.slots;
    d.zwords = volume.zwords;
    const std::size_t words = volume.column_words();
    // Separable: OR along x into `rows_pooled` (new x, old y), then along y.
    std::vector<std::uint32_t> rows_pooled(std::size_t(d.nx) * std::size_t(volume.ny) * words, 0u);
    for (int y = 0; y < volume.ny; ++y)
        for (int x = 0; x < volume.nx; ++x) {
            const std::uint32_t* source = volume.column(x, y);
            if (std::none_of(source, source + words, [](std::uint32_t w) { return w != 0; })) continue;
            // Old column x lands in new columns v with v - grow <= x <= v, i.e. v in [x, x + grow].
            for (int v = x; v <= x + grow; ++v) {
                std::uint32_t* target = rows_pooled.data() + (std::size_t(y) * std::size_t(d.nx) + std::size_t(v)) * words;
                for (std::size_t w = 0; w < words; ++w) target[w] |= source[w];
            }
        }
    d.bits.assign(std::size_t(d.nx) * std::size_t(d.ny) * words, 0u);
    for (int y = 0; y < volume.ny; ++y)
        for (int x = 0; x < d.nx; ++x) {
            const std::uint32_t* source = rows_pooled.data() + (std::size_t(y) * std::size_t(d.nx) + std::size_t(x)) * words;
            if (std::none_of(source, source + words, [](std::uint32_t w) { return w != 0; })) continue;
            for (int v = y; v <= y + grow; ++v) {
                std::uint32_t* target = d.column(x, v);
                for (std::size_t w = 0; w < words; ++w) target[w] |= source[w];
            }
        }
    d.finish();
    return d;
}

namespace {

// One slot's words (n of them) ORed with themselves moved down by 1 .. lifts - 1 bits (bit z + h
// to bit z), doubling the lifts covered per step; `scratch` holds n words.
void lower_union_words(std::uint32_t* words, int n, int lifts, std::uint32_t* scratch) {
    for (int covered = 1; covered < lifts;) {
        const int step = std::min(covered, lifts - covered);
        const int word_shift = step / 32, bit_shift = step % 32;
        for (int w = 0; w < n; ++w) {
            const int source = w + word_shift;
            std::uint32_t bits = source < n ? words[source] >> bit_shift : 0u;
            if (bit_shift != 0 && source + 1 < n) bits |= words[source + 1] << (32 - bit_shift);
            scratch[w] = bits;
        }
        for (int w = 0; w < n; ++w) words[w] |= scratch[w];
        covered += step;
    }
}

}  // namespace

ColumnVolume lowered_union(const ColumnVolume& volume, int lifts) {
    if (lifts < 1) fail("sweep", "internal: a union over {} lifts", lifts);
    ColumnVolume pooled = volume;
    if (lifts == 1) return pooled;
    const int n = pooled.zwords;
    std::vector<std::uint32_t> scratch(std::size_t(std::max(n, 1)));
    // A column whose union slot is empty holds nothing in any slot.
    for (int y = 0; y < pooled.ny; ++y) {
        const auto& row = pooled.rows[std::size_t(y)];
        for (int x = row[0]; x <= row[1]; ++x) {
            std::uint32_t* column = pooled.column(x, y);
            for (int slot = 0; slot < pooled.slots; ++slot) lower_union_words(column + std::size_t(slot) * std::size_t(n), n, lifts, scratch.data());
        }
    }
    pooled.finish(true);
    return pooled;
}

std::array<std::int32_t, 4> mapped_bounds(const ColumnVolume& moving, const posemap::Trig& trig,
                                          const std::array<std::int64_t, 2>& root_a, const std::array<std::int64_t, 2>& root_b) {
    return mapped_bounds(moving, {moving.x_first, moving.y_first, moving.x_last, moving.y_last}, trig, root_a, root_b);
}

std::array<std::int32_t, 4> mapped_bounds(const ColumnVolume& moving, const std::array<std::int32_t, 4>& box, const posemap::Trig& trig,
                                          const std::array<std::int64_t, 2>& root_a, const std::array<std::int64_t, 2>& root_b) {
    if (box[0] > box[2]) return {1, 1, 0, 0};
    // Forward image of the occupied cells' corners (voxel units): u = R(theta) (b - C^B) + C^A.
    const double scale = double(std::int64_t(1) << posemap::kTrigBits);
    const double c = double(trig.cos_q) / scale, s = double(trig.sin_q) / scale;
    const double unit = double(std::int64_t(1) << posemap::kPositionBits);
    const double ax = double(root_a[0]) / unit, ay = double(root_a[1]) / unit;
    const double bx = double(root_b[0]) / unit, by = double(root_b[1]) / unit;
    double x_min = 1e300, x_max = -1e300, y_min = 1e300, y_max = -1e300;
    for (int corner = 0; corner < 4; ++corner) {
        double px = double(moving.x0 + ((corner & 1) ? box[2] + 1 : box[0])) - bx;
        double py = double(moving.y0 + ((corner & 2) ? box[3] + 1 : box[1])) - by;
        double ux = c * px - s * py + ax, uy = s * px + c * py + ay;
        x_min = std::min(x_min, ux), x_max = std::max(x_max, ux);
        y_min = std::min(y_min, uy), y_max = std::max(y_max, uy);
    }
    // Column g's centre is g + 1/2; two columns of margin cover the fixed-point rounding.
    return {std::int32_t(std::floor(x_min - 0.5)) - 2, std::int32_t(std::floor(y_min - 0.5)) - 2,
            std::int32_t(std::ceil(x_max - 0.5)) + 2, std::int32_t(std::ceil(y_max - 0.5)) + 2};
}

}  // namespace amhv
