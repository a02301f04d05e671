#include "src/edit/frame_check.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <limits>
#include <optional>

#include <fmt/format.h>
#include <nanoflann.hpp>

#include "src/core/amhv.hpp"
#include "src/core/parallel.hpp"

namespace amhv {

namespace {

// Voxel coordinates of one body's boundary voxels (occupied, with an empty 6-neighbour or on the
// grid's edge): the nearest voxel of a solid to anything outside it is one of these.
struct Boundary {
    std::vector<std::array<double, 3>> points;
    std::size_t kdtree_get_point_count() const { return points.size(); }
    double kdtree_get_pt(std::size_t i, std::size_t axis) const { return points[i][axis]; }
    template <typename Box>
    bool kdtree_get_bbox(Box&) const { return false; }
};

// How far from a body's box the gap's search looks: a gap is the voxel centres' distance less one
// voxel, so centres up to kGapReach and a voxel apart count, and a surface-rule voxel's centre may
// lie up to a voxel outside its mesh's box. The search, the scan's region and the frames skipped
// all use this one reach.
double gap_search_reach(double voxel) { return kGapReach + 2 * voxel; }

// Voxel index bounds [lo, hi] of the grid's voxels within `reach` of `box` (where a body's voxel
// can be nearest to the other body, when the gap is within reach).
struct Region {
    std::array<int, 3> lo{}, hi{};
};
Region near_box(const VoxelGrid& g, const Box3& box, double reach) {
    Region r;
    for (int axis = 0; axis < 3; ++axis) {
        r.lo[std::size_t(axis)] = std::max(0, int(std::floor((box.min[axis] - reach - g.origin[axis]) / g.voxel)));
        r.hi[std::size_t(axis)] = std::min(g.dims[std::size_t(axis)] - 1, int(std::ceil((box.max[axis] + reach - g.origin[axis]) / g.voxel)));
    }
    return r;
}

// A result set for nanoflann that keeps only the smallest squared distance seen over every query:
// the tree prunes each query by the best pair found so far, so most queries end at once.
class NearestSoFar {
public:
    explicit NearestSoFar(double& best) : best_(best) {}
    bool addPoint(double squared, std::size_t) {
        best_ = std::min(best_, squared);
        return true;
    }
    double worstDist() const { return best_; }
    bool full() const { return true; }

private:
    double& best_;
};

// The points of `all` inside `region`.
Boundary within(const std::vector<std::array<double, 3>>& all, const Region& region) {
    Boundary out;
    for (const auto& p : all)
        if (p[0] >= region.lo[0] && p[0] <= region.hi[0] && p[1] >= region.lo[1] && p[1] <= region.hi[1] && p[2] >= region.lo[2] &&
            p[2] <= region.hi[2])
            out.points.push_back(p);
    return out;
}

// The box of a set of voxel coordinates.
struct PointBox {
    std::array<double, 3> lo, hi;
    explicit PointBox(const Boundary& set) {
        lo.fill(std::numeric_limits<double>::infinity());
        hi.fill(-std::numeric_limits<double>::infinity());
        for (const auto& p : set.points)
            for (std::size_t axis = 0; axis < 3; ++axis) lo[axis] = std::min(lo[axis], p[axis]), hi[axis] = std::max(hi[axis], p[axis]);
    }
    // The squared distance from p to the box: a lower bound of p's distance to every point in it
    // (integer coordinates: exact).
    double squared_distance(const std::array<double, 3>& p) const {
        double squared = 0;
        for (std::size_t axis = 0; axis < 3; ++axis) {
            const double out = std::max({0.0, lo[axis] - p[axis], p[axis] - hi[axis]});
            squared += out * out;
        }
        return squared;
    }
};

double squared_between(const std::array<double, 3>& p, const std::array<double, 3>& q) {
    return (p[0] - q[0]) * (p[0] - q[0]) + (p[1] - q[1]) * (p[1] - q[1]) + (p[2] - q[2]) * (p[2] - q[2]);
}

}  // namespace

namespace detail {

// The smallest distance between the centres of A's and B's voxels, in voxels (exact: squared
// integer distances), by a k-d tree over one side's boundary (nanoflann). Only boundary voxels
// within the reach of the other body's box take part: a nearer pair within the reach lies there.
// The query nearest the other side's box gives a first answer u by brute force; only points of
// the other side nearer than sqrt(u) to the queries' box can make a nearer pair, so the tree holds
// those alone, and the queries are asked nearest-box first until their bound reaches the answer.
double nearest_voxels(const VoxelGrid& grid, const std::vector<std::array<double, 3>>& boundary_a, const std::vector<std::array<double, 3>>& boundary_b,
                      const Box3& box_a, const Box3& box_b) {
    const double reach = gap_search_reach(grid.voxel);
    const Boundary a = within(boundary_a, near_box(grid, box_b, reach)), b = within(boundary_b, near_box(grid, box_a, reach));
    if (a.points.empty() || b.points.empty()) return std::numeric_limits<double>::infinity();
    const Boundary& indexed = a.points.size() <= b.points.size() ? a : b;
    const Boundary& queries = &indexed == &a ? b : a;
    // Each query with its squared distance to the indexed points' box.
    const PointBox indexed_box(indexed);
    std::vector<std::pair<double, std::size_t>> order(queries.points.size());
    for (std::size_t q = 0; q < order.size(); ++q) order[q] = {indexed_box.squared_distance(queries.points[q]), q};
    const std::size_t first = std::size_t(std::min_element(order.begin(), order.end()) - order.begin());
    double best = std::numeric_limits<double>::infinity();
    for (const auto& p : indexed.points) best = std::min(best, squared_between(p, queries.points[order[first].second]));
    // Only the queries that can come nearer, nearest-box first.
    std::erase_if(order, [best](const std::pair<double, std::size_t>& query) { return query.first >= best; });
    std::sort(order.begin(), order.end());
    const PointBox query_box(queries);
    Boundary near;
    for (const auto& p : indexed.points)
        if (query_box.squared_distance(p) < best) near.points.push_back(p);
    if (near.points.empty()) return std::sqrt(best);
    using Tree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, Boundary>, Boundary, 3>;
    Tree tree(3, near, nanoflann::KDTreeSingleIndexAdaptorParams(16));
    tree.buildIndex();
    NearestSoFar result(best);
    for (const auto& [bound, q] : order) {
        // No later query can come nearer than its bound; and the bodies share no voxel here (the
        // caller handles overlap), so adjacent centres, one voxel apart, are the nearest there are.
        if (bound >= best || best <= 1) break;
        tree.findNeighbors(result, queries.points[q].data(), nanoflann::SearchParams());
    }
    return std::sqrt(best);
}

}  // namespace detail

namespace {

// Frames voxelised together: A's bodies take bits 0..n-1 of the word, B's n..2n-1.
constexpr std::size_t kBatch = 16;

struct Pending {
    FrameCheck* check;
    TriangleMesh a, b;
    Box3 box_a, box_b;
};

// What one pass over a batch's volume finds, per bit (a body at a frame) and per frame.
struct BatchScan {
    std::vector<std::vector<std::array<double, 3>>> boundary;  // per bit: voxels with an empty 6-neighbour
    std::vector<std::uint64_t> overlap;                       // per frame: voxels inside both bodies
    std::vector<double> low, high;                            // per frame: the overlap's extent along `apart`
    explicit BatchScan(std::size_t n)
        : boundary(2 * n), overlap(n, 0), low(n, std::numeric_limits<double>::infinity()), high(n, -std::numeric_limits<double>::infinity()) {}
    // Adds the overlap counts and extents of the next slab (scan_batch joins the boundaries).
    void append_counts(const BatchScan& next) {
        for (std::size_t f = 0; f < overlap.size(); ++f) {
            overlap[f] += next.overlap[f];
            low[f] = std::min(low[f], next.low[f]), high[f] = std::max(high[f], next.high[f]);
        }
    }
};

// The batch's volume: the columns of `grid` in `window` (the voxelisation's output grid).
struct WindowVolume {
    const Amhv& volume;
    const VoxelGrid& grid;  // the batch's grid, whose voxel indices the scan reports
    ColumnWindow window;
};

// Layers z0..z1-1 of `region` (the batch grid's voxels, in the window): each voxel's boundary bits
// (its word less the AND of its six neighbours' words; outside the volume is empty: the window
// holds the region's neighbours, or ends where the grid does) and its overlap bits (A's bit f with
// B's bit n + f), every frame at once.
BatchScan scan_slab(const WindowVolume& in, std::size_t n, const std::vector<Pending>& batch, const Region& region, int z0, int z1) {
    const Amhv& both = in.volume;
    const VoxelGrid& g = both.grid();
    const int x0 = in.window.x0, y0 = in.window.y0;
    BatchScan scan(n);
    auto word = [&](int x, int y, int z) {
        return x >= 0 && y >= 0 && z >= 0 && x < g.dims[0] && y < g.dims[1] && z < g.dims[2] ? both.word(0, g.index(x, y, z)) : 0u;
    };
    const std::uint32_t low_bits = n >= 32 ? ~0u : (1u << n) - 1;
    const std::uint32_t* plane = both.plane(0);
    const std::ptrdiff_t row = g.dims[0], layer = std::ptrdiff_t(g.dims[0]) * g.dims[1];
    // The AND of a voxel's six neighbours: inside the grid by offsets, on its faces with bounds.
    auto neighbours = [&](int x, int y, int z, std::size_t v) {
        if (x > 0 && y > 0 && z > 0 && x + 1 < g.dims[0] && y + 1 < g.dims[1] && z + 1 < g.dims[2])
            return plane[v - 1] & plane[v + 1] & plane[v - row] & plane[v + row] & plane[v - layer] & plane[v + layer];
        return word(x - 1, y, z) & word(x + 1, y, z) & word(x, y - 1, z) & word(x, y + 1, z) & word(x, y, z - 1) & word(x, y, z + 1);
    };
    // The region in the volume's columns.
    const int x_first = region.lo[0] - x0, x_last = region.hi[0] - x0, y_first = region.lo[1] - y0, y_last = region.hi[1] - y0;
    for (int z = z0; z < z1; ++z)
        for (int y = y_first; y <= y_last; ++y)
            for (int x = x_first; x <= x_last; ++x) {
                const std::size_t v = g.index(x, y, z);
                // The bodies fill a few percent of the batch's grid: eight empty voxels at once.
                if ((x & 7) == 0 && x + 8 <= x_last + 1 && eight_words_zero(plane + v)) {
                    x += 7;
                    continue;
                }
                const std::uint32_t w = plane[v];
                if (!w) continue;
                std::uint32_t edge = w & ~neighbours(x, y, z, v);
                for (; edge; edge &= edge - 1)
                    scan.boundary[std::size_t(std::countr_zero(edge))].push_back({double(x + x0), double(y + y0), double(z)});
                for (std::uint32_t overlap = w & (w >> n) & low_bits; overlap; overlap &= overlap - 1) {
                    const std::size_t f = std::size_t(std::countr_zero(overlap));
                    ++scan.overlap[f];
                    const Vec3 c = in.grid.centre(x + x0, y + y0, z);
                    const double along = batch[f].check->apart.dot(Eigen::Vector2d(c.x(), c.y()));
                    scan.low[f] = std::min(scan.low[f], along), scan.high[f] = std::max(scan.high[f], along);
                }
            }
    return scan;
}

// Where a frame's voxels can matter: a body's boundary voxel counts only within the reach of the
// other's box (nearest_voxels), and an overlap lies in both boxes, so both within each box's
// reach. The box of those regions over the batch's frames (first > last on an axis: none).
Region scan_region(const VoxelGrid& grid, const std::vector<Pending>& batch) {
    const double reach = gap_search_reach(grid.voxel);
    Region all{{grid.dims[0], grid.dims[1], grid.dims[2]}, {-1, -1, -1}};
    for (const Pending& p : batch) {
        const Region a = near_box(grid, p.box_a, reach), b = near_box(grid, p.box_b, reach);
        Region both;
        for (std::size_t axis = 0; axis < 3; ++axis) both.lo[axis] = std::max(a.lo[axis], b.lo[axis]), both.hi[axis] = std::min(a.hi[axis], b.hi[axis]);
        if (both.lo[0] > both.hi[0] || both.lo[1] > both.hi[1] || both.lo[2] > both.hi[2]) continue;
        for (std::size_t axis = 0; axis < 3; ++axis) all.lo[axis] = std::min(all.lo[axis], both.lo[axis]), all.hi[axis] = std::max(all.hi[axis], both.hi[axis]);
    }
    return all;
}

// The columns the voxelisation must fill for a scan of `region`: the region's, and one more on
// each side, where its voxels' neighbours lie (a voxel is on the boundary by its neighbours).
ColumnWindow scan_columns(const VoxelGrid& grid, const Region& region) {
    if (region.lo[0] > region.hi[0] || region.lo[1] > region.hi[1] || region.lo[2] > region.hi[2]) return {};
    return {std::max(0, region.lo[0] - 1), std::max(0, region.lo[1] - 1), std::min(grid.dims[0] - 1, region.hi[0] + 1),
            std::min(grid.dims[1] - 1, region.hi[1] + 1)};
}

// The volume's scan region in slabs of layers on every core, joined in z order: the same as one
// pass. Outside the region lie only boundary voxels that nearest_voxels leaves out, and no overlap.
BatchScan scan_batch(const WindowVolume& both, std::size_t n, const std::vector<Pending>& batch, const Region& region) {
    const int z_first = region.lo[2], layers = std::max(0, region.hi[2] - region.lo[2] + 1);
    const int slabs = std::min(layers, 16), per = slabs > 0 ? (layers + slabs - 1) / slabs : 0;
    std::vector<std::optional<BatchScan>> parts(static_cast<std::size_t>(slabs));
    parallel_for(std::size_t(slabs), [&](std::size_t s) {
        parts[s] = scan_slab(both, n, batch, region, z_first + int(s) * per, z_first + std::min(layers, int(s + 1) * per));
    });
    BatchScan scan(n);
    for (const auto& part : parts)
        if (part) scan.append_counts(*part);
    // Each body's boundary joined from the slabs in z order, the bodies on every core (a copy of
    // every boundary voxel: on one core, a tenth of the check at 5 mm).
    parallel_for(scan.boundary.size(), [&](std::size_t b) {
        std::size_t total = 0;
        for (const auto& part : parts)
            if (part) total += part->boundary[b].size();
        scan.boundary[b].reserve(total);
        for (const auto& part : parts)
            if (part) scan.boundary[b].insert(scan.boundary[b].end(), part->boundary[b].begin(), part->boundary[b].end());
    });
    for (std::size_t f = 0; f < n; ++f) batch[f].check->overlap = scan.overlap[f];
    return scan;
}

// Voxelises and scans the batch; then each frame's gap, unless `skip_gaps` (a frame of this call
// overlaps: see Gaps::UntilAnOverlap), which becomes true when one of the batch's frames overlaps.
void decide_batch(std::vector<Pending>& batch, double voxel, Voxeliser& voxeliser, bool& skip_gaps, Gaps gaps) {
    if (batch.empty()) return;
    const std::size_t n = batch.size();
    Box3 all;
    std::vector<MeshFrame> frames(2 * n);
    std::vector<const MeshFrame*> pointers(2 * n);
    for (std::size_t f = 0; f < n; ++f) {
        all.extend(batch[f].box_a);
        all.extend(batch[f].box_b);
        frames[f] = {std::move(batch[f].a), fmt::format("A at output frame {}", batch[f].check->frame)};
        frames[n + f] = {std::move(batch[f].b), fmt::format("B at output frame {}", batch[f].check->frame)};
    }
    for (std::size_t f = 0; f < 2 * n; ++f) pointers[f] = &frames[f];
    const VoxelGrid grid = grid_covering(all, voxel, fmt::format("output frames {}..{}", batch.front().check->frame, batch.back().check->frame));
    // Only the columns the scan reads: at 5 mm a batch's grid is 2-4 times as many.
    const Region region = scan_region(grid, batch);
    VoxelisationInput input = prepare_voxelisation(pointers, grid);
    input.window = scan_columns(grid, region);
    const Amhv volume = voxelise(input, voxeliser);
    const BatchScan scan = scan_batch({volume, grid, *input.window}, n, batch, region);
    for (std::size_t f = 0; f < n; ++f) skip_gaps |= gaps == Gaps::UntilAnOverlap && batch[f].check->overlap > 0;
    // Each frame's gap on its own (frames write only their own check).
    parallel_for(n, [&](std::size_t f) {
        FrameCheck& check = *batch[f].check;
        if (check.overlap > 0) {
            check.gap_m = 0.0;
            check.depth_m = scan.high[f] - scan.low[f] + voxel;
            return;
        }
        if (skip_gaps) return;
        const double centres = detail::nearest_voxels(grid, scan.boundary[f], scan.boundary[n + f], batch[f].box_a, batch[f].box_b) * voxel;
        if (centres - voxel <= kGapReach) check.gap_m = std::max(0.0, centres - voxel);
    });
    batch.clear();
}

}  // namespace

std::vector<FrameCheck> check_frames(const EditResult& edit, const std::vector<int>& frames, ObjectSource& a, ObjectSource& b, double voxel,
                                     Voxeliser& voxeliser, Gaps gaps) {
    std::vector<FrameCheck> checks(frames.size());
    std::vector<Pending> batch;
    bool skip_gaps = false;
    const Voxeliser::ScratchHold hold(voxeliser);  // the batches share one set of scratch
    for (std::size_t i = 0; i < frames.size(); ++i) {
        const int k = frames[i];
        FrameCheck& check = checks[i];
        check.frame = k;
        const Eigen::Vector2d between = edit.frames[1][std::size_t(k)].edited_root - edit.frames[0][std::size_t(k)].edited_root;
        if (between.norm() > 1e-9) check.apart = between.normalized();
        Pending p{&check, placed_mesh(edit, k, 0, a), placed_mesh(edit, k, 1, b), {}, {}};
        p.box_a = p.a.bounds(), p.box_b = p.b.bounds();
        // Boxes farther apart than the gap's search reaches: neither overlap nor a gap to measure.
        const Vec3 separation = (p.box_a.min - p.box_b.max).cwiseMax(p.box_b.min - p.box_a.max).cwiseMax(0.0);
        if (separation.norm() > gap_search_reach(voxel)) continue;
        batch.push_back(std::move(p));
        if (batch.size() == kBatch) decide_batch(batch, voxel, voxeliser, skip_gaps, gaps);
    }
    decide_batch(batch, voxel, voxeliser, skip_gaps, gaps);
    return checks;
}

}  // namespace amhv
