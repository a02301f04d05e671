#include "src/voxelise/voxelise.hpp"

#include <algorithm>
#include <cmath>

#include <spdlog/spdlog.h>

#include "src/core/error.hpp"
#include "src/core/parallel.hpp"

namespace amhv {

fixed::Point3 quantise(const Vec3& p, const VoxelGrid& grid) {
    Vec3 local = (p - grid.origin) / grid.voxel * double(fixed::kSubvoxel);
    return {std::int32_t(std::llround(local.x())), std::int32_t(std::llround(local.y())), std::int32_t(std::llround(local.z()))};
}

namespace {

// One frame in the grid's fixed point; a vertex outside the grid is an error naming the frame.
void prepare_frame(const MeshFrame& frame, const VoxelGrid& grid, PreparedFrame& prepared) {
    const std::int64_t limit[3] = {std::int64_t(grid.dims[0]) * fixed::kSubvoxel, std::int64_t(grid.dims[1]) * fixed::kSubvoxel,
                                   std::int64_t(grid.dims[2]) * fixed::kSubvoxel};
    prepared.source = frame.source;
    prepared.closed = frame.mesh.is_closed();
    std::vector<fixed::Point3> points;
    points.reserve(frame.mesh.vertices.size());
    for (const Vec3& v : frame.mesh.vertices) {
        fixed::Point3 q = quantise(v, grid);
        if (q.x < 0 || q.y < 0 || q.z < 0 || q.x > limit[0] || q.y > limit[1] || q.z > limit[2])
            fail(frame.source, "vertex ({:.4f}, {:.4f}, {:.4f}) lies outside the segment's voxel grid", v.x(), v.y(), v.z());
        points.push_back(q);
    }
    prepared.triangles.reserve(frame.mesh.triangles.size());
    for (const auto& t : frame.mesh.triangles) prepared.triangles.push_back({points[t[0]], points[t[1]], points[t[2]]});
}

}  // namespace

// Frames on every core; of several bad frames, the first one's error is reported (parallel_for).
VoxelisationInput prepare_voxelisation(const std::vector<const MeshFrame*>& frames, const VoxelGrid& grid) {
    VoxelisationInput input;
    input.grid = grid;
    input.frames.resize(frames.size());
    parallel_for(frames.size(), [&](std::size_t f) { prepare_frame(*frames[f], grid, input.frames[f]); });
    return input;
}

VoxelGrid VoxelisationInput::output_grid() const {
    if (!window) return grid;
    const ColumnWindow w = *window;
    VoxelGrid out = grid;
    const std::array<std::int64_t, 3> lattice = grid.lattice_origin();
    // On the lattice as grid_covering puts an origin: a whole number of voxels times the edge.
    out.origin.x() = double(lattice[0] + w.x0) * grid.voxel;
    out.origin.y() = double(lattice[1] + w.y0) * grid.voxel;
    out.dims[0] = std::max(0, w.x1 - w.x0 + 1);
    out.dims[1] = std::max(0, w.y1 - w.y0 + 1);
    if (out.dims[0] == 0 || out.dims[1] == 0) out.dims[0] = out.dims[1] = 0;
    return out;
}

VoxelisationInput prepare_voxelisation_stacked(const std::vector<const MeshFrame*>& frames, const std::vector<VoxelGrid>& grids) {
    if (frames.size() != grids.size() || frames.empty()) fail("voxelisation", "internal: {} frames stacked on {} grids", frames.size(), grids.size());
    VoxelisationInput input;
    input.grid.voxel = grids.front().voxel;
    for (const VoxelGrid& grid : grids) {
        if (grid.voxel != input.grid.voxel) fail(frames.front()->source, "internal: stacked grids of different voxel edges");
        for (std::size_t axis = 0; axis < 3; ++axis) input.grid.dims[axis] = std::max(input.grid.dims[axis], grid.dims[axis]);
    }
    input.frames.resize(frames.size());
    parallel_for(frames.size(), [&](std::size_t f) { prepare_frame(*frames[f], grids[f], input.frames[f]); });
    return input;
}

VoxelisationInput prepare_voxelisation(const MeshSequence& sequence, double voxel) {
    std::vector<const MeshFrame*> frames;
    for (const auto& frame : sequence.frames) frames.push_back(&frame);
    return prepare_voxelisation(frames, grid_covering(sequence.bounds(), voxel, sequence.source));
}

namespace {

// Separating-axis triangle/box overlap (Akenine-Moeller), in voxel units on exact inputs.
bool triangle_touches_box(const Vec3 (&tri)[3], const Vec3& centre, double half) {
    Vec3 v[3] = {tri[0] - centre, tri[1] - centre, tri[2] - centre};
    Vec3 e[3] = {v[1] - v[0], v[2] - v[1], v[0] - v[2]};
    for (int i = 0; i < 3; ++i)
        for (int axis = 0; axis < 3; ++axis) {
            Vec3 a = Vec3::Unit(axis).cross(e[i]);
            double p0 = a.dot(v[0]), p1 = a.dot(v[1]), p2 = a.dot(v[2]);
            double r = half * (std::abs(a.x()) + std::abs(a.y()) + std::abs(a.z()));
            if (std::min({p0, p1, p2}) > r || std::max({p0, p1, p2}) < -r) return false;
        }
    for (int axis = 0; axis < 3; ++axis)
        if (std::min({v[0][axis], v[1][axis], v[2][axis]}) > half || std::max({v[0][axis], v[1][axis], v[2][axis]}) < -half)
            return false;
    Vec3 n = e[0].cross(e[1]);
    double d = n.dot(v[0]);
    double r = half * (std::abs(n.x()) + std::abs(n.y()) + std::abs(n.z()));
    return std::abs(d) <= r;
}

}  // namespace

void voxelise_surface(const PreparedFrame& frame, int frame_index, const ColumnWindow& columns, Amhv& out) {
    const auto& dims = out.grid().dims;
    const double scale = 1.0 / double(fixed::kSubvoxel);
    for (const auto& t : frame.triangles) {
        Vec3 tri[3];
        for (int i = 0; i < 3; ++i) tri[i] = Vec3(t[i].x, t[i].y, t[i].z) * scale;  // exact: power-of-two scale
        Vec3 lo = tri[0].cwiseMin(tri[1]).cwiseMin(tri[2]);
        Vec3 hi = tri[0].cwiseMax(tri[1]).cwiseMax(tri[2]);
        int first[3], last[3];
        for (int a = 0; a < 3; ++a) {
            first[a] = int(std::floor(lo[a])) - 1;
            last[a] = int(std::floor(hi[a]));
        }
        // The grid's columns in the window (within the grid), and its layers: the volume's.
        first[0] = std::max(first[0], columns.x0), last[0] = std::min(last[0], columns.x1);
        first[1] = std::max(first[1], columns.y0), last[1] = std::min(last[1], columns.y1);
        first[2] = std::max(first[2], 0), last[2] = std::min(last[2], dims[2] - 1);
        // The volume is the window's: its column (x, y) is the grid's (x0 + x, y0 + y).
        for (int z = first[2]; z <= last[2]; ++z)
            for (int y = first[1]; y <= last[1]; ++y)
                for (int x = first[0]; x <= last[0]; ++x)
                    if (triangle_touches_box(tri, Vec3(x + 0.5, y + 0.5, z + 0.5), 0.5))
                        out.set(out.grid().index(x - columns.x0, y - columns.y0, z), frame_index);
    }
}

Amhv voxelise(const VoxelisationInput& input, Voxeliser& backend, VoxeliseReport* report) {
    if (const ColumnWindow w = input.columns(); w.x0 < 0 || w.y0 < 0 || w.x1 >= input.grid.dims[0] || w.y1 >= input.grid.dims[1])
        fail("voxelisation", "internal: columns {}..{} x {}..{} outside the {} x {} grid", w.x0, w.x1, w.y0, w.y1, input.grid.dims[0],
             input.grid.dims[1]);
    Amhv volume(input.output_grid(), int(input.frames.size()));
    if (volume.voxel_count() == 0) return volume;  // an empty window
    backend.voxelise_solid(input, volume);
    for (std::size_t f = 0; f < input.frames.size(); ++f) {
        if (input.frames[f].closed) continue;
        spdlog::warn("{}: mesh is not closed; frame {} uses the conservative surface voxelisation", input.frames[f].source, f);
        voxelise_surface(input.frames[f], int(f), input.columns(), volume);
        if (report) report->open_frames.push_back(int(f));
    }
    return volume;
}

}  // namespace amhv
