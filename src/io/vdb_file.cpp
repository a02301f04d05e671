#include "src/io/vdb_file.hpp"

#include <bit>
#include <cstring>
#include <array>
#include <map>
#include <set>
#include <vector>

#include <fmt/format.h>

#include "src/core/budget.hpp"
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


namespace {

// Reads little-endian values and length-prefixed strings from `bytes`, failing (naming `where`)
// instead of reading past its end.
class LayoutReader {
public:
    LayoutReader(std::string_view bytes, const std::string& where) : bytes_(bytes), where_(where) {}
    template <typename T>
    T value() {
        need(sizeof(T));
        T v{};
        std::memcpy(&v, bytes_.data() + at_, sizeof(T));
        at_ += sizeof(T);
        return v;
    }
    void skip(std::uint64_t n) {
        need(n);
        at_ += std::size_t(n);
    }
    // Skips `n` bytes that OpenVDB reads as bool values: each must be 0 or 1 (any other byte in a
    // bool is undefined behaviour in the reader).
    void bools(std::uint64_t n) {
        need(n);
        for (std::uint64_t i = 0; i < n; ++i)
            if (static_cast<unsigned char>(bytes_[at_ + i]) > 1) fail(where_, "is not a readable OpenVDB file (a bool value is neither 0 nor 1)");
        at_ += std::size_t(n);
    }
    void string(std::uint32_t max) {
        const auto size = value<std::uint32_t>();
        if (size > max) fail(where_, "is not a readable OpenVDB file (a name of {} bytes)", size);
        skip(size);
    }
    void seek(std::int64_t to) {
        if (to < 0 || std::uint64_t(to) > bytes_.size()) fail(where_, "is not a readable OpenVDB file (an offset outside the file)");
        at_ = std::size_t(to);
    }
    std::size_t at() const { return at_; }
    char byte_at(std::size_t i) const { return bytes_[i]; }
    std::string_view text(std::size_t from, std::size_t length) const { return bytes_.substr(from, length); }
    std::size_t size() const { return bytes_.size(); }
    const std::string& where() const { return where_; }

private:
    void need(std::uint64_t n) const {
        if (n > bytes_.size() - at_) fail(where_, "is not a readable OpenVDB file (it ends {} bytes too early)", n - (bytes_.size() - at_));
    }
    std::string_view bytes_;
    const std::string& where_;
    std::size_t at_ = 0;
};

// A MetaMap: a count, then per entry a name, a type name and a value of a stated size. OpenVDB
// reads a value of a known type by its type's size whatever the stated one (a "mat4d" stated as 8
// bytes makes it read 128 and lose its place), so only the types amhv and OpenVDB's own file
// statistics write are accepted, each at its size; a string at any size.
void check_meta_map(LayoutReader& in) {
    static const std::map<std::string_view, std::uint32_t> kSizes{{"bool", 1},  {"int32", 4},  {"int64", 8},  {"float", 4}, {"double", 8},
                                                                  {"vec3i", 12}, {"vec3s", 12}, {"vec3d", 24}, {"string", 0}};
    const auto count = in.value<std::uint32_t>();
    if (count > 64) fail(in.where(), "is not a readable OpenVDB file ({} metadata entries)", count);
    for (std::uint32_t e = 0; e < count; ++e) {
        in.string(4096);
        const std::size_t type_at = in.at();
        in.string(256);
        const auto type = kSizes.find(in.text(type_at + 4, in.at() - type_at - 4));
        const auto size = in.value<std::uint32_t>();
        if (type == kSizes.end() || (type->second != 0 && size != type->second) || size > (1u << 20))
            fail(in.where(), "is not a readable OpenVDB file (metadata of another type or size than amhv writes)");
        in.skip(size);
    }
}

// The bits set in `bytes` bytes of a node mask at the reader's position (the mask is skipped).
std::uint64_t mask_bits(LayoutReader& in, std::uint32_t bytes, std::vector<std::uint32_t>* positions = nullptr) {
    const std::size_t at = in.at();
    in.skip(bytes);
    std::uint64_t count = 0;
    for (std::uint32_t b = 0; b < bytes; ++b) {
        const auto byte = static_cast<unsigned char>(in.byte_at(at + b));
        count += std::uint64_t(std::popcount(unsigned(byte)));
        if (positions)
            for (int bit = 0; bit < 8; ++bit)
                if (byte >> bit & 1) positions->push_back(b * 8 + std::uint32_t(bit));
    }
    return count;
}

// How many nodes of each kind a BoolGrid's tree holds: its allocation (about 0.5 MiB an upper
// internal node, 64 KiB a lower one) is checked against the memory budget before OpenVDB reads it.
struct TreeCount {
    std::uint64_t upper = 0, lower = 0, leaves = 0;
};

// An internal node's topology (OpenVDB's InternalNode::readTopology with the active-mask flag
// alone): its child and value masks, its values (io::readCompressedValues: a metadata byte, at
// most two inactive values, a selection mask, then the active values or all), then its children.
void check_internal(LayoutReader& in, int log2, TreeCount& count) {
    const std::uint32_t values = 1u << (3 * log2), mask_bytes = values / 8;
    std::vector<std::uint32_t> children;
    mask_bits(in, mask_bytes, &children);
    const std::uint64_t active = mask_bits(in, mask_bytes);
    const auto metadata = in.value<std::int8_t>();
    if (metadata < 0 || metadata > 6) fail(in.where(), "is not a readable OpenVDB file (a node's value metadata is {})", int(metadata));
    if (metadata == 2 || metadata == 4 || metadata == 5) in.bools(metadata == 5 ? 2 : 1);
    if (metadata >= 3 && metadata <= 5) in.skip(mask_bytes);
    in.bools(metadata == 6 ? values : active);
    (log2 == 5 ? count.upper : count.lower) += 1;
    for (std::size_t c = 0; c < children.size(); ++c) {
        if (log2 == 5) check_internal(in, 4, count);
        else {
            in.skip(64);  // a leaf's value mask
            ++count.leaves;
        }
    }
}

// A BoolGrid's topology from the grid's transform on: a ScaleMap (what amhv writes), the tree's
// buffer count, the root's background, tiles and children; then its buffers, 140 bytes a leaf.
void check_bool_tree(LayoutReader& in, std::int64_t block_pos, std::int64_t end_pos, int grid) {
    const std::size_t type_at = in.at();
    in.string(64);
    if (in.text(type_at + 4, in.at() - type_at - 4) != "ScaleMap") fail(in.where(), "is not a readable OpenVDB file (grid {}'s transform is no ScaleMap)", grid);
    in.skip(5 * 24);  // ScaleMap: five Vec3d
    in.skip(4);   // buffer count
    in.bools(1);  // background
    const auto tiles = in.value<std::uint32_t>(), children = in.value<std::uint32_t>();
    if (std::uint64_t(tiles) * 14 + std::uint64_t(children) * (12 + 8193) > std::uint64_t(block_pos) - in.at())
        fail(in.where(), "is not a readable OpenVDB file (grid {} claims more nodes than it holds)", grid);
    // Every tile and child at its own origin, on the 4096-voxel lattice of the root's nodes (two at
    // one origin make OpenVDB drop the first without freeing it).
    std::set<std::array<std::int32_t, 3>> origins;
    auto origin = [&] {
        std::array<std::int32_t, 3> o{in.value<std::int32_t>(), in.value<std::int32_t>(), in.value<std::int32_t>()};
        for (std::int32_t v : o)
            if (v % 4096 != 0) fail(in.where(), "is not a readable OpenVDB file (grid {} has a node off the root's lattice)", grid);
        if (!origins.insert(o).second) fail(in.where(), "is not a readable OpenVDB file (grid {} has two nodes at one place)", grid);
    };
    for (std::uint32_t t = 0; t < tiles; ++t) {
        origin();
        in.bools(2);  // value, active
    }
    TreeCount count;
    for (std::uint32_t c = 0; c < children; ++c) {
        origin();
        check_internal(in, 5, count);
    }
    if (std::int64_t(in.at()) != block_pos || std::uint64_t(end_pos - block_pos) != count.leaves * 140)
        fail(in.where(), "is not a readable OpenVDB file (grid {}'s nodes do not fill its data)", grid);
    budget::require_memory(count.upper * (std::uint64_t(1) << 19) + count.lower * (std::uint64_t(1) << 16) + count.leaves * 256,
                           fmt::format("reading grid {} of {}", grid, in.where()), "is it a group amhv wrote?");
}

}  // namespace

void check_vdb_layout(std::string_view bytes, const std::string& where) {
    LayoutReader in(bytes, where);
    if (in.value<std::int64_t>() != 0x56444220) fail(where, "is not a readable OpenVDB file (it is not OpenVDB at all)");
    const auto version = in.value<std::uint32_t>();
    if (version < 222 || version > 225) fail(where, "is an OpenVDB file of format version {}; amhv reads versions 222 to 225", version);
    in.skip(8);  // the library's major and minor version
    if (in.value<char>() != 1) fail(where, "is an OpenVDB stream without grid offsets; amhv reads files written by io::File");
    in.skip(36);  // the UUID
    check_meta_map(in);
    const auto grids = in.value<std::int32_t>();
    if (grids < 1 || grids > 4096) fail(where, "is not a readable OpenVDB file ({} grids)", grids);
    for (std::int32_t g = 0; g < grids; ++g) {
        in.string(4096);  // unique name
        const std::size_t type_at = in.at();
        in.string(256);  // grid type
        if (bytes.substr(type_at + 4, in.at() - type_at - 4) != "Tree_bool_5_4_3")
            fail(where, "is not a readable OpenVDB file (grid {} is not a BoolGrid)", g);
        in.string(4096);  // instance parent
        const auto grid_pos = in.value<std::int64_t>(), block_pos = in.value<std::int64_t>(), end_pos = in.value<std::int64_t>();
        if (grid_pos != std::int64_t(in.at()) || block_pos < grid_pos || end_pos < block_pos || std::uint64_t(end_pos) > in.size())
            fail(where, "is not a readable OpenVDB file (grid {}'s offsets do not follow its descriptor within the file)", g);
        // Blosc and zip blocks state their own sizes, which OpenVDB allocates before it reads: amhv
        // writes its groups without them (the active-mask flag alone) and reads no others.
        if ((in.value<std::uint32_t>() & ~0x2u) != 0)
            fail(where, "is compressed with Blosc or zip, which amhv does not read (an amhv before 0.5.0 wrote it: sweep again)");
        check_meta_map(in);
        if (std::int64_t(in.at()) > block_pos) fail(where, "is not a readable OpenVDB file (grid {}'s metadata runs into its data)", g);
        check_bool_tree(in, block_pos, end_pos, g);
        in.seek(end_pos);
    }
}

}  // namespace amhv
