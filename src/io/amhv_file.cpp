#include "src/io/amhv_file.hpp"

#include <bit>
#include <cstring>
#include <fstream>

#include "src/core/error.hpp"
#include "src/io/files.hpp"

namespace amhv {

static_assert(std::endian::native == std::endian::little, "the volume format is little-endian");

namespace {

constexpr char kMagic[8] = {'A', 'M', 'H', 'V', 'V', 'O', 'L', '1'};
constexpr std::uint32_t kVersion = 1;

template <typename T>
void put(std::ofstream& out, const T& value) {
    out.write(reinterpret_cast<const char*>(&value), sizeof(T));
}

template <typename T>
T get(std::ifstream& in, const std::string& source) {
    T value{};
    if (!in.read(reinterpret_cast<char*>(&value), sizeof(T))) fail(source, "volume file is truncated");
    return value;
}

}  // namespace

void write_amhv(const Amhv& volume, const std::filesystem::path& path) {
    std::ofstream out(path, std::ios::binary);
    if (!out) fail(path.string(), "cannot create file");
    const auto& grid = volume.grid();
    out.write(kMagic, sizeof(kMagic));
    put(out, kVersion);
    put(out, std::uint32_t(volume.frames()));
    for (int d : grid.dims) put(out, std::int32_t(d));
    put(out, std::uint32_t(volume.words()));
    put(out, grid.voxel);
    for (int a = 0; a < 3; ++a) put(out, grid.origin[a]);
    std::uint64_t count = 0;
    for (std::size_t v = 0; v < volume.voxel_count(); ++v) count += volume.any(v);
    put(out, count);
    for (std::size_t v = 0; v < volume.voxel_count(); ++v) {
        if (!volume.any(v)) continue;
        put(out, std::uint32_t(v));
        for (int w = 0; w < volume.words(); ++w) put(out, volume.word(w, v));
    }
    finish_file(out, path);
}

Amhv read_amhv(const std::filesystem::path& path) {
    const std::string source = path.string();
    std::ifstream in(path, std::ios::binary);
    if (!in) fail(source, "cannot open volume file");
    char magic[8];
    if (!in.read(magic, 8) || std::memcmp(magic, kMagic, 8) != 0) fail(source, "not an amhv volume file (bad magic)");
    if (auto version = get<std::uint32_t>(in, source); version != kVersion) fail(source, "unsupported volume format version {}", version);
    auto frames = get<std::uint32_t>(in, source);
    VoxelGrid grid;
    for (int& d : grid.dims) d = get<std::int32_t>(in, source);
    auto words = get<std::uint32_t>(in, source);
    grid.voxel = get<double>(in, source);
    for (int a = 0; a < 3; ++a) grid.origin[a] = get<double>(in, source);
    for (int d : grid.dims)
        if (d <= 0 || d > kMaxGridAxis) fail(source, "grid dimension {} is out of range", d);
    if (frames == 0 || frames > (1u << 20) || words != (frames + 31) / 32) fail(source, "inconsistent frame count {} / {} words", frames, words);
    Amhv volume(grid, int(frames));
    auto count = get<std::uint64_t>(in, source);
    if (count > volume.voxel_count()) fail(source, "{} occupied voxels in a grid of {}", count, volume.voxel_count());
    std::uint32_t previous = 0;
    // The last word's bits past the last frame must be 0: later stages index frames by bit.
    const std::uint32_t last_word_frames = frames - (words - 1) * 32;
    const std::uint32_t past_last_frame = last_word_frames == 32 ? 0u : ~((1u << last_word_frames) - 1u);
    for (std::uint64_t i = 0; i < count; ++i) {
        auto v = get<std::uint32_t>(in, source);
        if (v >= volume.voxel_count() || (i > 0 && v <= previous)) fail(source, "voxel record {} has a bad index {}", i, v);
        previous = v;
        for (std::uint32_t w = 0; w < words; ++w) volume.plane(int(w))[v] = get<std::uint32_t>(in, source);
        if (volume.plane(int(words - 1))[v] & past_last_frame)
            fail(source, "voxel record {} is occupied in frame {}, past the last frame {}", i,
                 (words - 1) * 32 + std::uint32_t(std::countr_zero(volume.plane(int(words - 1))[v] & past_last_frame)), frames - 1);
    }
    return volume;
}

}  // namespace amhv
