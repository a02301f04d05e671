#include "src/io/output_dir.hpp"

#include <fcntl.h>
#include <stdio.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <fstream>
#include <string>

#include "src/core/error.hpp"
#include "src/io/files.hpp"

namespace amhv {

namespace fs = std::filesystem;

namespace {

fs::path resolved(const fs::path& path) {
    std::error_code ec;
    fs::path out = fs::weakly_canonical(fs::absolute(path), ec);
    return ec ? fs::absolute(path).lexically_normal() : out;
}

// An output of an earlier amhv run: the marker, or (outputs written before the marker) a JSON
// report of amhv at the top.
bool written_by_amhv(const fs::path& folder) {
    if (fs::exists(folder / StagedOutput::kMarker)) return true;
    for (const char* report : {"result.json", "mhv.json", "import.json"}) {
        std::ifstream in(folder / report);
        std::string head(256, '\0');
        in.read(head.data(), std::streamsize(head.size()));
        head.resize(std::size_t(in.gcount()));
        if (head.find("\"program\": \"amhv ") != std::string::npos) return true;
    }
    return false;
}

}  // namespace

bool is_within(const fs::path& path, const fs::path& folder) {
    const fs::path p = resolved(path), f = resolved(folder);
    auto pi = p.begin();
    for (auto fi = f.begin(); fi != f.end(); ++fi, ++pi) {
        if (fi->empty() && std::next(fi) == f.end()) break;  // a trailing separator
        if (pi == p.end() || *pi != *fi) return false;
    }
    return true;
}

StagedOutput::StagedOutput(fs::path target, const std::vector<fs::path>& inputs) : target_(std::move(target)) {
    if (target_.empty()) throw Error("--out: an output folder is required");
    absolute_ = resolved(target_);
    refuse_unsafe_target(inputs);
    const fs::path parent = absolute_.parent_path();
    std::error_code ec;
    fs::create_directories(parent, ec);
    if (ec) fail(parent.string(), "cannot create the output's parent folder ({})", ec.message());
    take_lock();
    remove_stale_staging();
    staging_ = parent / fmt::format(".{}.partial-{}", absolute_.filename().string(), ::getpid());
    fs::create_directory(staging_, ec);
    if (ec) fail(staging_.string(), "cannot create the staging folder ({})", ec.message());
    write_file(staging_ / kMarker, "This folder was written by amhv; the next amhv run into it replaces it as a whole.\n");
}

void StagedOutput::refuse_unsafe_target(const std::vector<fs::path>& inputs) const {
    const std::string where = fmt::format("--out {}", target_.string());
    if (absolute_ == absolute_.root_path() || !absolute_.has_filename() || absolute_.filename() == "..")
        fail(where, "is the root of the file system; name a folder for the output");
    if (is_within(fs::current_path(), absolute_))
        fail(where, "is or contains the working folder, which would be replaced; name a new folder");
    for (const fs::path& input : inputs)
        if (!input.empty() && is_within(input, absolute_))
            fail(where, "is or contains the input {}, which would be replaced; name another folder", input.string());
    std::error_code ec;
    if (fs::exists(absolute_, ec) && !fs::is_directory(absolute_, ec)) fail(where, "exists and is not a folder");
    if (fs::is_directory(absolute_, ec) && !fs::is_empty(absolute_, ec) && !written_by_amhv(absolute_))
        fail(where, "is a folder amhv did not write (it has files and no {}); amhv never replaces it: name a new or empty folder",
             kMarker);
}

// flock on .NAME.lock; a lock whose file was removed (by the run that held it) while we waited for
// it is taken again on the new file.
void StagedOutput::take_lock() {
    lock_path_ = absolute_.parent_path() / fmt::format(".{}.lock", absolute_.filename().string());
    for (int attempt = 0; attempt < 100; ++attempt) {
        const int fd = ::open(lock_path_.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
        if (fd < 0) fail(lock_path_.string(), "cannot create the output's lock file");
        if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
            char text[32] = {};
            const ssize_t n = ::pread(fd, text, sizeof(text) - 1, 0);
            ::close(fd);
            fail(fmt::format("--out {}", target_.string()), "another amhv run (pid {}) is writing it; wait for it or name another folder",
                 n > 0 ? std::string(text, std::size_t(n)) : std::string("unknown"));
        }
        struct stat held {}, now {};
        if (::fstat(fd, &held) == 0 && ::stat(lock_path_.c_str(), &now) == 0 && held.st_ino == now.st_ino && held.st_dev == now.st_dev) {
            const std::string pid = std::to_string(::getpid());
            if (::ftruncate(fd, 0) != 0 || ::pwrite(fd, pid.data(), pid.size(), 0) != ssize_t(pid.size()))
                fail(lock_path_.string(), "cannot write the output's lock file");
            lock_fd_ = fd;
            return;
        }
        ::close(fd);
    }
    fail(lock_path_.string(), "cannot take the output's lock");
}

// Under the lock no other run writes this target, so its staging folders (half-written outputs, or
// old ones swapped out) are left over from runs that died.
void StagedOutput::remove_stale_staging() const {
    const std::string prefix = fmt::format(".{}.partial-", absolute_.filename().string());
    std::error_code ec;
    for (const auto& entry : fs::directory_iterator(absolute_.parent_path(), ec))
        if (entry.path().filename().string().rfind(prefix, 0) == 0) fs::remove_all(entry.path(), ec);
}

StagedOutput::~StagedOutput() {
    std::error_code ec;
    if (!committed_) fs::remove_all(staging_, ec);
    if (lock_fd_ >= 0) {
        ::unlink(lock_path_.c_str());
        ::close(lock_fd_);
    }
}

void StagedOutput::commit() {
    std::error_code ec;
    if (!fs::exists(absolute_, ec)) {
        fs::rename(staging_, absolute_, ec);
        if (ec) fail(target_.string(), "cannot move the finished output into place ({})", ec.message());
        committed_ = true;
        return;
    }
    // One atomic exchange: the finished output takes the target's name, the old one the staging
    // folder's, from where it is removed.
    if (::renameat2(AT_FDCWD, staging_.c_str(), AT_FDCWD, absolute_.c_str(), RENAME_EXCHANGE) != 0)
        fail(target_.string(), "cannot swap the finished output into place ({})", std::error_code(errno, std::generic_category()).message());
    committed_ = true;
    // A run killed during this clean-up leaves a staging folder the next run removes.
    fs::remove_all(staging_, ec);
}

}  // namespace amhv
