#pragma once
// Voxelisation of a mesh segment into an aMHV (docs/method.md section 3).
//
// The host quantises every frame once (prepare_voxelisation); a Voxeliser backend (the Vulkan
// kernels or the plain CPU reference) computes solid occupancy of the closed frames by the
// non-zero winding rule; open frames get the conservative surface rule on the host, the same for
// every backend, so both backends always produce identical volumes.
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "src/core/amhv.hpp"
#include "src/voxelise/fixed_raster.hpp"
#include "src/core/geometry.hpp"

namespace amhv {

struct PreparedFrame {
    std::vector<fixed::Triangle> triangles;  // fixed point, relative to the grid origin
    bool closed = true;
    std::string source;
};

// The voxel columns x0..x1, y0..y1 of a grid.
struct ColumnWindow {
    int x0 = 0, y0 = 0, x1 = -1, y1 = -1;
    bool contains(int x, int y) const { return x >= x0 && x <= x1 && y >= y0 && y <= y1; }
};

struct VoxelisationInput {
    VoxelGrid grid;
    std::vector<PreparedFrame> frames;
    // Only these columns are voxelised, and the volume is theirs alone (output_grid): a column's
    // voxels depend on the surface's crossings with that column alone, so a window's are those of
    // the whole volume there. Unset: every column.
    std::optional<ColumnWindow> window;
    ColumnWindow columns() const { return window ? *window : ColumnWindow{0, 0, grid.dims[0] - 1, grid.dims[1] - 1}; }
    // The grid cropped to columns(): the voxelised volume's (on the same lattice; its column (x, y)
    // is the grid's (x0 + x, y0 + y)).
    VoxelGrid output_grid() const;
};

fixed::Point3 quantise(const Vec3& p, const VoxelGrid& grid);

// Quantises `frames` into `grid` (which must contain them) and classifies each as closed or open.
VoxelisationInput prepare_voxelisation(const std::vector<const MeshFrame*>& frames, const VoxelGrid& grid);
// Frames stacked: frame f quantised on grids[f] (its own grid, of one voxel edge for all) and laid
// in one grid as large as the largest, with grids[f]'s corner at the grid's corner. A frame's voxel
// (x, y, z) there is its voxel (x, y, z) on grids[f], so frames far apart share one frame's grid
// instead of a grid covering them all. The stacked grid's origin is zero: its positions are local.
VoxelisationInput prepare_voxelisation_stacked(const std::vector<const MeshFrame*>& frames, const std::vector<VoxelGrid>& grids);
// Every frame of `sequence` in the grid of edge `voxel` covering it (grid_covering).
VoxelisationInput prepare_voxelisation(const MeshSequence& sequence, double voxel);

class Voxeliser {
public:
    virtual ~Voxeliser() = default;
    virtual std::string name() const = 0;
    // Sets the occupancy bits of every closed frame of `input` in `out` (zeroed, same grid/frames).
    virtual void voxelise_solid(const VoxelisationInput& input, Amhv& out) = 0;

    // While one lives, the backend keeps its scratch between calls whatever its size, so that a
    // series of calls (the frame roots' batches, the frame check's, a key segment's volumes)
    // allocates it once; when the last one ends, scratch beyond the backend's usual limit goes
    // back. On a discrete GPU every allocation is a driver call that clears its pages.
    class ScratchHold {
    public:
        explicit ScratchHold(Voxeliser& voxeliser) : voxeliser_(voxeliser) { ++voxeliser_.holds_; }
        ~ScratchHold() {
            if (--voxeliser_.holds_ == 0) voxeliser_.release_scratch_over_limit();
        }
        ScratchHold(const ScratchHold&) = delete;
        ScratchHold& operator=(const ScratchHold&) = delete;

    private:
        Voxeliser& voxeliser_;
    };

protected:
    bool scratch_held() const { return holds_ > 0; }
    // Gives back the scratch over the backend's usual limit: after a call no hold keeps, and when
    // the last hold ends.
    virtual void release_scratch_over_limit() {}

private:
    int holds_ = 0;
};

// Conservative surface voxelisation of one frame: every voxel whose cube touches a triangle (in the
// input's columns).
void voxelise_surface(const PreparedFrame& frame, int frame_index, const ColumnWindow& columns, Amhv& out);

struct VoxeliseReport {
    std::vector<int> open_frames;  // frames voxelised by the surface rule
};

// Full voxelisation: solid frames through `backend`, open frames through the surface rule.
Amhv voxelise(const VoxelisationInput& input, Voxeliser& backend, VoxeliseReport* report = nullptr);

}  // namespace amhv
