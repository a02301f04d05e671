#include "host/reference/voxelise_reference.hpp"

#include <vector>

namespace amhv {

void ReferenceVoxeliser::voxelise_solid(const VoxelisationInput& input, Amhv& out) {
    const auto& grid = input.grid;
    const int nx = grid.dims[0], ny = grid.dims[1], nz = grid.dims[2];
    const ColumnWindow window = input.columns();
    struct Crossing {
        std::int64_t first_above;
        int winding_change;
    };
    std::vector<std::vector<Crossing>> columns(std::size_t(nx) * ny);
    for (std::size_t f = 0; f < input.frames.size(); ++f) {
        const PreparedFrame& frame = input.frames[f];
        if (!frame.closed) continue;
        for (auto& column : columns) column.clear();
        // Every crossing of the surface with every column's vertical line.
        for (const auto& triangle : frame.triangles) {
            fixed::Oriented t;
            if (!fixed::orient(triangle, t)) continue;
            for (int y = std::max(t.columns_y.first, window.y0); y <= std::min(t.columns_y.last, window.y1); ++y)
                for (int x = std::max(t.columns_x.first, window.x0); x <= std::min(t.columns_x.last, window.x1); ++x) {
                    std::int64_t first_above;
                    if (fixed::column_crossing(t, x, y, first_above))
                        columns[std::size_t(y) * nx + x].push_back({first_above, t.winding_change});
                }
        }
        // Each voxel of the window: the winding number from the crossings below its centre.
        for (int y = window.y0; y <= window.y1; ++y)
            for (int x = window.x0; x <= window.x1; ++x) {
                const auto& crossings = columns[std::size_t(y) * nx + x];
                if (crossings.empty()) continue;
                for (int z = 0; z < nz; ++z) {
                    int winding = 0;
                    for (const Crossing& c : crossings)
                        if (c.first_above <= z) winding += c.winding_change;
                    if (winding != 0) out.set(out.grid().index(x - window.x0, y - window.y0, z), int(f));
                }
            }
    }
}

}  // namespace amhv
