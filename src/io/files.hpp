#pragma once
// Checked writes: a file is either written in full or the call throws amhv::Error naming it (a full
// disk, a quota, a file size limit). Streams buffer their last bytes until they close, so a write is
// checked only after the close.
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>

namespace amhv {

// Writes `bytes` to `path` (replacing it) and checks the write and the close.
void write_file(const std::filesystem::path& path, std::string_view bytes);

// The whole file: a regular file (a FIFO, a device or a folder in its place is refused without
// waiting on it) of at most `limit` bytes; throws amhv::Error naming `path` when it cannot be read.
std::string read_file_bytes(const std::filesystem::path& path, std::uintmax_t limit = std::uintmax_t(1) << 36);

// The shipped data (scenes/, cmu/, bodies/): AMHV_DATA_DIR in the environment, else the source tree's data/.
std::filesystem::path shipped_data_dir();

// Whether `path` is a regular file (following links) / a folder; false, without throwing, where the
// system cannot tell (a name too long, a loop of links, no permission): paths come from input files.
bool is_file(const std::filesystem::path& path) noexcept;
bool is_folder(const std::filesystem::path& path) noexcept;

// Closes `out` and throws amhv::Error naming `path` if any write to it or the close failed.
void finish_file(std::ofstream& out, const std::filesystem::path& path);

}  // namespace amhv
