#include "src/results/group_vdb.hpp"

#include <algorithm>
#include <limits>
#include <map>
#include <string_view>

#include <fmt/format.h>
#include <openvdb/openvdb.h>

#include "src/core/angles.hpp"
#include "src/core/error.hpp"
#include "src/io/files.hpp"

namespace amhv::results {

namespace {

std::string grid_name(const GroupLattice& lattice, int l) {
    return lattice.z_first == 0 && lattice.z_last == 0 ? std::string("solutions") : fmt::format("solutions_z{}", l);
}

// (i, j, k) -> (x m, y m, theta deg): the grid's own transform says what a voxel means.
openvdb::math::Transform::Ptr pose_transform(const GroupLattice& lattice) {
    openvdb::Mat4d scale = openvdb::Mat4d::identity();
    scale.setToScale(openvdb::Vec3d(lattice.voxel, lattice.voxel, lattice.angle_step_deg));
    return openvdb::math::Transform::createLinearTransform(scale);
}

template <typename Meta, typename Value>
Value meta_or_fail(const openvdb::GridBase& grid, const char* key, const std::string& where) {
    const auto value = grid.getMetadata<Meta>(key);
    if (!value) fail(where, "grid {} has no {} metadata: not an amhv solution group", grid.getName(), key);
    return value->value();
}

// 64-bit FNV-1a.
std::uint64_t fnv1a(std::string_view bytes) {
    std::uint64_t hash = 1469598103934665603ull;
    for (unsigned char c : bytes) hash = (hash ^ c) * 1099511628211ull;
    return hash;
}

// Every grid of `path`, or only their metadata; throws naming the file when it cannot be read.
openvdb::GridPtrVecPtr read_grids(const std::filesystem::path& path, bool metadata_only) {
    openvdb::initialize();
    const std::string where = path.string();
    if (!std::filesystem::is_regular_file(path)) fail(where, "cannot open the solution group");
    try {
        openvdb::io::File file(where);
        file.open(/*delayLoad=*/!metadata_only);
        openvdb::GridPtrVecPtr grids = metadata_only ? file.readAllGridMetadata() : file.getGrids();
        file.close();
        return grids;
    } catch (const std::exception& e) {
        fail(where, "is not a readable OpenVDB file ({})", e.what());
    }
}

// OpenVDB stamps every file with a random UUID (36 characters at byte 21 of the header), so two
// writes of one group would differ. The UUID becomes a hash of the file's content after it: same
// group, same bytes; another group, another id.
void stamp_content_uuid(const std::filesystem::path& path) {
    constexpr std::size_t kAt = 21, kLength = 36;
    std::string bytes = read_file_bytes(path);
    const auto dash = [&](std::size_t n) { return bytes[kAt + n] == '-'; };
    if (bytes.size() < kAt + kLength || !dash(8) || !dash(13) || !dash(18) || !dash(23))
        fail(path.string(), "internal: the OpenVDB header does not hold its UUID where expected");
    const std::string_view content = std::string_view(bytes).substr(kAt + kLength);
    const std::uint64_t h1 = fnv1a(content);
    std::uint64_t h2 = 0x9e3779b97f4a7c15ull;
    for (unsigned char c : content) h2 = (h2 ^ c) * 0x100000001b3ull + 0x632be59bd9b4e019ull;
    const std::string hex = fmt::format("{:016x}{:016x}", h1, h2);
    const std::string uuid = hex.substr(0, 8) + "-" + hex.substr(8, 4) + "-" + hex.substr(12, 4) + "-" + hex.substr(16, 4) + "-" + hex.substr(20, 12);
    bytes.replace(kAt, kLength, uuid);
    write_file(path, bytes);
}

}  // namespace

GroupLattice group_lattice(const Scene& scene, int segment, const PoseRange& range) {
    return {scene.sampling.voxel, scene.sampling.angle_step_deg, scene.sampling.angles(), segment, range.z_first, range.z_last, scene_hash(scene)};
}

std::string scene_hash(const Scene& scene) {
    return fmt::format("{:016x}", fnv1a(resolved_toml(scene)));
}

void write_group_vdb(const std::filesystem::path& path, const std::vector<Solution>& group, const GroupLattice& lattice) {
    openvdb::initialize();
    openvdb::GridPtrVec grids;
    std::map<int, openvdb::BoolGrid::Ptr> by_level;
    for (int l = lattice.z_first; l <= lattice.z_last; ++l) {
        auto grid = openvdb::BoolGrid::create(false);
        grid->setName(grid_name(lattice, l));
        grid->setTransform(pose_transform(lattice));
        grid->insertMeta("voxel_m", openvdb::DoubleMetadata(lattice.voxel));
        grid->insertMeta("angle_step_deg", openvdb::DoubleMetadata(lattice.angle_step_deg));
        grid->insertMeta("angles", openvdb::Int32Metadata(lattice.angles));
        grid->insertMeta("segment", openvdb::Int32Metadata(lattice.segment));
        grid->insertMeta("z_voxels", openvdb::Int32Metadata(l));
        grid->insertMeta("scene_hash", openvdb::StringMetadata(lattice.scene_hash));
        by_level[l] = grid;
        grids.push_back(grid);
    }
    for (auto& [l, grid] : by_level) {
        auto access = grid->getAccessor();
        for (const Solution& s : group)
            if (s.l == l) access.setValueOn(openvdb::Coord(s.i, s.j, s.k), true);
        grid->pruneGrid();
    }
    try {
        openvdb::io::File file(path.string());
        file.write(grids);
        file.close();
    } catch (const std::exception& e) {
        fail(path.string(), "writing the solution group failed: {}", e.what());
    }
    stamp_content_uuid(path);
}

std::vector<std::array<int, 4>> read_group_vdb(const std::filesystem::path& path, const GroupLattice& expected) {
    const std::string where = path.string();
    const openvdb::GridPtrVecPtr grids = read_grids(path, false);
    std::vector<std::array<int, 4>> poses;
    for (int l = expected.z_first; l <= expected.z_last; ++l) {
        const std::string name = grid_name(expected, l);
        const auto found = std::find_if(grids->begin(), grids->end(), [&](const openvdb::GridBase::Ptr& g) { return g->getName() == name; });
        if (found == grids->end()) fail(where, "has no grid {}: not the group of this key segment's sweep", name);
        const auto grid = openvdb::gridPtrCast<openvdb::BoolGrid>(*found);
        if (!grid) fail(where, "grid {} is not a BoolGrid", name);
        if (meta_or_fail<openvdb::DoubleMetadata, double>(*grid, "voxel_m", where) != expected.voxel ||
            meta_or_fail<openvdb::DoubleMetadata, double>(*grid, "angle_step_deg", where) != expected.angle_step_deg ||
            meta_or_fail<openvdb::Int32Metadata, int>(*grid, "angles", where) != expected.angles ||
            meta_or_fail<openvdb::Int32Metadata, int>(*grid, "segment", where) != expected.segment ||
            meta_or_fail<openvdb::Int32Metadata, int>(*grid, "z_voxels", where) != l)
            fail(where, "grid {} was swept on another lattice or for another key segment than the scene's", name);
        if (meta_or_fail<openvdb::StringMetadata, std::string>(*grid, "scene_hash", where) != expected.scene_hash)
            fail(where, "grid {} is the group of another scene (scene_hash differs)", name);
        std::vector<std::array<int, 4>> level;
        // Solid blocks of 8^3 poses and more are stored as tiles (pruneGrid): their boxes expand.
        for (auto on = grid->cbeginValueOn(); on; ++on) {
            const openvdb::CoordBBox box = on.getBoundingBox();
            if (box.min().z() < 0 || box.max().z() >= expected.angles)
                fail(where, "grid {} has poses at angle indices {}..{}, outside 0..{}", name, box.min().z(), box.max().z(), expected.angles - 1);
            for (auto c = box.begin(); c; ++c) level.push_back({(*c).x(), (*c).y(), (*c).z(), l});
        }
        std::sort(level.begin(), level.end(), [](const auto& a, const auto& b) { return std::tie(a[2], a[1], a[0]) < std::tie(b[2], b[1], b[0]); });
        poses.insert(poses.end(), level.begin(), level.end());
    }
    return poses;
}

GroupLattice read_group_lattice(const std::filesystem::path& path) {
    const std::string where = path.string();
    const openvdb::GridPtrVecPtr grids = read_grids(path, true);
    if (grids->empty()) fail(where, "holds no grid: not an amhv solution group");
    GroupLattice lattice;
    const openvdb::GridBase& first = *grids->front();
    lattice.voxel = meta_or_fail<openvdb::DoubleMetadata, double>(first, "voxel_m", where);
    lattice.angle_step_deg = meta_or_fail<openvdb::DoubleMetadata, double>(first, "angle_step_deg", where);
    lattice.angles = meta_or_fail<openvdb::Int32Metadata, int>(first, "angles", where);
    lattice.segment = meta_or_fail<openvdb::Int32Metadata, int>(first, "segment", where);
    lattice.scene_hash = meta_or_fail<openvdb::StringMetadata, std::string>(first, "scene_hash", where);
    lattice.z_first = std::numeric_limits<int>::max();
    lattice.z_last = std::numeric_limits<int>::min();
    for (const auto& grid : *grids) {
        const int l = meta_or_fail<openvdb::Int32Metadata, int>(*grid, "z_voxels", where);
        lattice.z_first = std::min(lattice.z_first, l);
        lattice.z_last = std::max(lattice.z_last, l);
    }
    if (!(lattice.voxel > 0) || lattice.angles < 1 || lattice.z_last - lattice.z_first + 1 != int(grids->size()))
        fail(where, "its grids do not describe one lattice of heights: not written by amhv");
    return lattice;
}

Json group_summary(const std::vector<Solution>& group, const GroupLattice& lattice) {
    struct Angle {
        std::uint64_t count = 0;
        double x0 = 1e300, x1 = -1e300, y0 = 1e300, y1 = -1e300;
    };
    std::map<int, Angle> by_angle;
    for (const Solution& s : group) {
        Angle& a = by_angle[s.k];
        ++a.count;
        a.x0 = std::min(a.x0, s.x), a.x1 = std::max(a.x1, s.x), a.y0 = std::min(a.y0, s.y), a.y1 = std::max(a.y1, s.y);
    }
    const angles::AngleLattice angle_lattice{lattice.angle_step_deg, lattice.angles};
    Json per_angle = Json::array();
    for (const auto& [k, a] : by_angle)
        per_angle.push_back({{"k", k}, {"theta_deg", angle_lattice.wrapped_degrees(k)}, {"count", a.count}, {"x_m", {a.x0, a.x1}}, {"y_m", {a.y0, a.y1}}});
    return {{"segment", lattice.segment},
            {"solutions", group.size()},
            {"voxel_m", lattice.voxel},
            {"angle_step_deg", lattice.angle_step_deg},
            {"z_m", {lattice.z_first * lattice.voxel, lattice.z_last * lattice.voxel}},
            {"per_angle", per_angle}};
}

}  // namespace amhv::results
