#include "src/results/group_vdb.hpp"

#include <algorithm>
#include <limits>
#include <map>
#include <sstream>
#include <string_view>

#include <fmt/format.h>
#include <openvdb/openvdb.h>
#include <openvdb/io/Stream.h>

#include "src/core/angles.hpp"
#include "src/core/budget.hpp"
#include "src/core/error.hpp"
#include "src/io/files.hpp"
#include "src/io/vdb_file.hpp"

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

// Every grid of `path`; throws naming the file when it cannot be read.
openvdb::GridPtrVecPtr read_grids(const std::filesystem::path& path) {
    openvdb::initialize();
    const std::string where = path.string();
    const ReadingFile reading(where);
    if (!std::filesystem::is_regular_file(path)) fail(where, "cannot open the solution group");
    try {
        // From memory as a stream: io::File on a truncated file can spend seconds or hang in its
        // header and metadata reads, where a stream that ends simply fails.
        const std::string file = read_file_bytes(path, std::uintmax_t(1) << 32);
        check_vdb_layout(file, where);  // every length OpenVDB will trust, before it allocates
        std::istringstream bytes(file, std::ios::binary);
        bytes.exceptions(std::ios::failbit | std::ios::badbit);
        openvdb::io::Stream stream(bytes, /*delayLoad=*/false);
        return stream.getGrids();
    } catch (const Error&) {
        throw;
    } catch (const std::bad_alloc&) {
        throw;
    } catch (const std::exception&) {
        fail(where, "is not a readable OpenVDB file (OpenVDB could not read it: damaged or truncated)");
    }
}

void check_grid_lattice(const openvdb::BoolGrid& grid, const GroupLattice& expected, int l, const std::string& where) {
    const std::string& name = grid.getName();
    if (meta_or_fail<openvdb::DoubleMetadata, double>(grid, "voxel_m", where) != expected.voxel ||
        meta_or_fail<openvdb::DoubleMetadata, double>(grid, "angle_step_deg", where) != expected.angle_step_deg ||
        meta_or_fail<openvdb::Int32Metadata, int>(grid, "angles", where) != expected.angles ||
        meta_or_fail<openvdb::Int32Metadata, int>(grid, "segment", where) != expected.segment ||
        meta_or_fail<openvdb::Int32Metadata, int>(grid, "z_voxels", where) != l)
        fail(where, "grid {} was swept on another lattice or for another key segment than the scene's", name);
    if (meta_or_fail<openvdb::StringMetadata, std::string>(grid, "scene_hash", where) != expected.scene_hash)
        fail(where, "grid {} is the group of another scene (scene_hash differs)", name);
}

// The lattice indices a group may hold: x and y within 2 km of the origin (scenes are refused
// beyond 1 km), angles within the lattice. A grid is checked against them before it is expanded,
// so a crafted file cannot make the reader loop or allocate without bound.
struct IndexBounds {
    std::int64_t xy = 0;
    int angles = 0;
    // Fails naming the grid unless `box` lies within the bounds.
    void check(const openvdb::CoordBBox& box, const std::string& grid, const std::string& where) const {
        if (box.min().z() < 0 || box.max().z() >= angles)
            fail(where, "grid {} has poses at angle index {}, outside 0..{}", grid, box.min().z() < 0 ? box.min().z() : box.max().z(), angles - 1);
        if (box.min().x() < -xy || box.max().x() > xy || box.min().y() < -xy || box.max().y() > xy)
            fail(where, "grid {} has poses beyond 2 km of the origin: not a group amhv wrote", grid);
    }
};

IndexBounds index_bounds(const GroupLattice& lattice) { return {std::int64_t(std::ceil(2000.0 / lattice.voxel)), lattice.angles}; }

// The active voxels of one height's grid as pieces of runs of i along (k, j) rows, in the sweep's
// order (theta, y, x); SolutionGroup::add_run joins those that continue across leaves. Leaves (8^3 poses) are read row by row
// from their masks; solid blocks stored as tiles (pruneGrid) expand row by row of their box. Every
// leaf and tile must lie within `bounds`, and the rows they expand to must fit the memory budget.
std::vector<PoseRun> grid_runs(const openvdb::BoolGrid& grid, int l, const IndexBounds& bounds, const std::string& where) {
    std::uint64_t rows = 0;
    for (auto leaf = grid.tree().cbeginLeaf(); leaf; ++leaf) {
        openvdb::CoordBBox active;
        leaf->evalActiveBoundingBox(active, true);  // the active voxels, not the whole 8^3 node
        if (!active.empty()) bounds.check(active, grid.getName(), where);
        rows += 64;
    }
    auto tile = grid.tree().cbeginValueOn();
    tile.setMaxDepth(openvdb::BoolTree::ValueOnCIter::LEAF_DEPTH - 1);  // tiles only: leaves are read below
    for (; tile; ++tile) {
        const openvdb::CoordBBox box = tile.getBoundingBox();
        bounds.check(box, grid.getName(), where);
        rows += std::uint64_t(box.dim().z()) * std::uint64_t(box.dim().y());
    }
    budget::require_memory(rows * sizeof(PoseRun) * 2, fmt::format("reading {}", where), "is it a group amhv wrote?");
    std::vector<PoseRun> pieces;
    for (auto leaf = grid.tree().cbeginLeaf(); leaf; ++leaf) {
        const openvdb::Coord origin = leaf->origin();
        const auto& mask = leaf->getValueMask();
        for (int y = 0; y < 8; ++y)
            for (int z = 0; z < 8; ++z)
                for (int x = 0; x < 8;) {
                    if (!mask.isOn(openvdb::BoolTree::LeafNodeType::coordToOffset(origin + openvdb::Coord(x, y, z)))) {
                        ++x;
                        continue;
                    }
                    int end = x;
                    while (end + 1 < 8 && mask.isOn(openvdb::BoolTree::LeafNodeType::coordToOffset(origin + openvdb::Coord(end + 1, y, z)))) ++end;
                    pieces.push_back({l, origin.z() + z, origin.y() + y, origin.x() + x, origin.x() + end});
                    x = end + 1;
                }
    }
    for (tile = grid.tree().cbeginValueOn(), tile.setMaxDepth(openvdb::BoolTree::ValueOnCIter::LEAF_DEPTH - 1); tile; ++tile) {
        const openvdb::CoordBBox box = tile.getBoundingBox();
        for (int k = box.min().z(); k <= box.max().z(); ++k)
            for (int j = box.min().y(); j <= box.max().y(); ++j) pieces.push_back({l, k, j, box.min().x(), box.max().x()});
    }
    std::sort(pieces.begin(), pieces.end(), [](const PoseRun& a, const PoseRun& b) { return std::tie(a.k, a.j, a.i_first) < std::tie(b.k, b.j, b.i_first); });
    return pieces;
}

// The resolved scene as it reads wherever its folder lies: without the comment that names the
// file, and with every absolute path (a quoted string starting with '/') relative to the scene's
// folder, so that a project moved or copied elsewhere keeps its groups.
std::string portable_toml(const Scene& scene) {
    const std::string text = resolved_toml(scene);
    const std::filesystem::path folder = std::filesystem::absolute(scene.file).parent_path();
    std::string out;
    std::size_t at = 0;
    while (at < text.size()) {
        std::size_t end = text.find('\n', at);
        end = end == std::string::npos ? text.size() : end + 1;
        std::string line = text.substr(at, end - at);
        at = end;
        if (line.rfind('#', 0) == 0) continue;
        for (std::size_t quote = line.find("'/"); quote != std::string::npos; quote = line.find("'/", quote + 1)) {
            const std::size_t close = line.find('\'', quote + 1);
            if (close == std::string::npos) break;
            const std::string relative = std::filesystem::path(line.substr(quote + 1, close - quote - 1)).lexically_relative(folder).generic_string();
            line.replace(quote + 1, close - quote - 1, relative);
        }
        out += line;
    }
    return out;
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
    return fmt::format("{:016x}", fnv1a(portable_toml(scene)));
}

void write_group_vdb(const std::filesystem::path& path, const SolutionGroup& group, const GroupLattice& lattice) {
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
    // One pass over the runs, each into its height's grid.
    std::map<int, openvdb::BoolGrid::Accessor> access;
    for (auto& [l, grid] : by_level) access.emplace(l, grid->getAccessor());
    for (const PoseRun& run : group.runs())
        for (int i = run.i_first; i <= run.i_last; ++i) access.at(run.l).setValueOn(openvdb::Coord(i, run.j, run.k), true);
    access.clear();
    for (auto& [l, grid] : by_level) grid->pruneGrid();
    try {
        openvdb::io::File file(path.string());
        // Without Blosc or zip: a compressed block states its own size, which a reader must trust
        // before it allocates; amhv refuses such blocks when it reads a group (check_vdb_layout).
        file.setCompression(openvdb::io::COMPRESS_ACTIVE_MASK);
        file.write(grids);
        file.close();
    } catch (const std::exception& e) {
        fail(path.string(), "writing the solution group failed: {}", e.what());
    }
    stamp_content_uuid(path);
}

SolutionGroup read_group_vdb(const std::filesystem::path& path, const GroupLattice& expected) {
    const std::string where = path.string();
    const openvdb::GridPtrVecPtr grids = read_grids(path);
    SolutionGroup group;
    for (int l = expected.z_first; l <= expected.z_last; ++l) {
        const std::string name = grid_name(expected, l);
        const auto found = std::find_if(grids->begin(), grids->end(), [&](const openvdb::GridBase::Ptr& g) { return g->getName() == name; });
        if (found == grids->end()) fail(where, "has no grid {}: not the group of this key segment's sweep", name);
        const auto grid = openvdb::gridPtrCast<openvdb::BoolGrid>(*found);
        if (!grid) fail(where, "grid {} is not a BoolGrid", name);
        check_grid_lattice(*grid, expected, l, where);
        std::vector<PoseRun> pieces = grid_runs(*grid, l, index_bounds(expected), where);
        for (const PoseRun& piece : pieces) group.add_run(piece);
    }
    return group;
}

GroupLattice read_group_lattice(const std::filesystem::path& path) {
    const std::string where = path.string();
    const openvdb::GridPtrVecPtr grids = read_grids(path);
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
    if (!(lattice.voxel >= 0.001 && lattice.voxel <= 10) || lattice.angles < 1 || lattice.angles > 36000 ||
        !(std::abs(lattice.angle_step_deg * lattice.angles - 360.0) < 1e-6) || std::int64_t(lattice.z_last) - lattice.z_first + 1 != std::int64_t(grids->size()))
        fail(where, "its grids do not describe one lattice of heights (voxel, angle step and angles as amhv sweeps): not written by amhv");
    return lattice;
}

Json group_summary(const SolutionGroup& group, const GroupLattice& lattice) {
    struct Angle {
        std::uint64_t count = 0;
        int i0 = std::numeric_limits<int>::max(), i1 = std::numeric_limits<int>::min();
        int j0 = std::numeric_limits<int>::max(), j1 = std::numeric_limits<int>::min();
    };
    std::map<int, Angle> by_angle;
    for (const PoseRun& r : group.runs()) {
        Angle& a = by_angle[r.k];
        a.count += r.size();
        a.i0 = std::min(a.i0, r.i_first), a.i1 = std::max(a.i1, r.i_last), a.j0 = std::min(a.j0, r.j), a.j1 = std::max(a.j1, r.j);
    }
    const angles::AngleLattice angle_lattice{lattice.angle_step_deg, lattice.angles};
    const double h = lattice.voxel;
    Json per_angle = Json::array();
    for (const auto& [k, a] : by_angle)
        per_angle.push_back({{"k", k}, {"theta_deg", angle_lattice.wrapped_degrees(k)}, {"count", a.count}, {"x_m", {a.i0 * h, a.i1 * h}}, {"y_m", {a.j0 * h, a.j1 * h}}});
    return {{"segment", lattice.segment},
            {"solutions", group.size()},
            {"voxel_m", lattice.voxel},
            {"angle_step_deg", lattice.angle_step_deg},
            {"z_m", {lattice.z_first * lattice.voxel, lattice.z_last * lattice.voxel}},
            {"per_angle", per_angle}};
}

}  // namespace amhv::results
