#include "src/io/files.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
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

std::string read_file_bytes(const std::filesystem::path& path, std::uintmax_t limit) {
    const ReadingFile reading(path.string());
    // O_NONBLOCK: a FIFO in a file's place must not hang the run; only a regular file is read.
    const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0) fail(path.string(), "cannot open the file");
    struct stat st {};
    if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
        ::close(fd);
        fail(path.string(), "is not a regular file");
    }
    if (std::uintmax_t(st.st_size) > limit) {
        ::close(fd);
        fail(path.string(), "is {} bytes, more than the {} this file may have", st.st_size, limit);
    }
    std::string bytes(std::size_t(st.st_size), '\0');
    std::size_t got = 0;
    while (got < bytes.size()) {
        const ssize_t n = ::read(fd, bytes.data() + got, bytes.size() - got);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) break;
        got += std::size_t(n);
    }
    ::close(fd);
    if (got != bytes.size()) fail(path.string(), "reading the file failed (it changed while read?)");
    return bytes;
}

bool is_file(const std::filesystem::path& path) noexcept {
    std::error_code ec;
    return std::filesystem::is_regular_file(path, ec);
}

bool is_folder(const std::filesystem::path& path) noexcept {
    std::error_code ec;
    return std::filesystem::is_directory(path, ec);
}

}  // namespace amhv
