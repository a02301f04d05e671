#include "src/io/files.hpp"

#include <cstdlib>

#include "src/core/error.hpp"

namespace amhv {

void write_file(const std::filesystem::path& path, std::string_view bytes) {
    std::ofstream out(path, std::ios::binary);
    if (!out) fail(path.string(), "cannot create the file");
    out.write(bytes.data(), std::streamsize(bytes.size()));
    finish_file(out, path);
}

void finish_file(std::ofstream& out, const std::filesystem::path& path) {
    if (out) out.close();
    if (!out) fail(path.string(), "could not be written in full (is the disk full?)");
}

std::filesystem::path shipped_data_dir() {
    if (const char* env = std::getenv("AMHV_DATA_DIR")) return env;
    return AMHV_DATA_DIR;
}

std::string read_file_bytes(const std::filesystem::path& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) fail(path.string(), "cannot open the file");
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (in.bad()) fail(path.string(), "reading the file failed");
    return bytes;
}

}  // namespace amhv
