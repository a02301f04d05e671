#include "src/io/vdb_file.hpp"

#include "src/core/error.hpp"

#include <openvdb/openvdb.h>

namespace amhv {

void write_vdb(const Amhv& volume, const std::filesystem::path& path) {
    openvdb::initialize();
    const auto& grid = volume.grid();
    auto transform = openvdb::math::Transform::createLinearTransform(grid.voxel);
    transform->postTranslate(openvdb::Vec3d(grid.origin.x() + grid.voxel / 2, grid.origin.y() + grid.voxel / 2,
                                            grid.origin.z() + grid.voxel / 2));
    auto density = openvdb::FloatGrid::create(0.0f);
    auto t_start = openvdb::FloatGrid::create(-1.0f);
    auto t_end = openvdb::FloatGrid::create(-1.0f);
    auto density_access = density->getAccessor();
    auto start_access = t_start->getAccessor();
    auto end_access = t_end->getAccessor();
    for (int z = 0; z < grid.dims[2]; ++z)
        for (int y = 0; y < grid.dims[1]; ++y)
            for (int x = 0; x < grid.dims[0]; ++x) {
                std::size_t v = grid.index(x, y, z);
                int first = volume.t_start(v);
                if (first < 0) continue;
                openvdb::Coord c(x, y, z);
                density_access.setValue(c, float(volume.frame_count(v)) / float(volume.frames()));
                start_access.setValue(c, float(first));
                end_access.setValue(c, float(volume.t_end(v)));
            }
    openvdb::GridPtrVec grids;
    for (auto [g, name] : {std::pair{density, "density"}, std::pair{t_start, "t_start"}, std::pair{t_end, "t_end"}}) {
        g->setTransform(transform->copy());
        g->setName(name);
        g->setGridClass(openvdb::GRID_FOG_VOLUME);
        grids.push_back(g);
    }
    try {
        openvdb::io::File file(path.string());
        file.write(grids);
        file.close();
    } catch (const std::exception& e) {
        fail(path.string(), "writing the OpenVDB file failed: {}", e.what());
    }
}

}  // namespace amhv
