#include "src/io/output_dir.hpp"

#include <fcntl.h>
#include <pthread.h>
#include <signal.h>
#include <stdio.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <mutex>
#include <random>
#include <regex>
#include <string>
#include <thread>

#include <nlohmann/json.hpp>

#include "src/core/error.hpp"
#include "src/io/files.hpp"

namespace amhv {

namespace fs = std::filesystem;
using Json = nlohmann::ordered_json;

namespace {

constexpr std::uintmax_t kMaxMarkerBytes = 64u << 20;

fs::path resolved(const fs::path& path) {
    std::error_code ec;
    fs::path out = fs::weakly_canonical(fs::absolute(path), ec);
    return ec ? fs::absolute(path).lexically_normal() : out;
}

// The marker's bytes: opened without following a link or waiting on a FIFO, a regular file of
// bounded size; empty when there is none (or it is not a readable regular file).
std::string marker_text(const fs::path& folder) {
    const int fd = ::open((folder / StagedOutput::kMarker).c_str(), O_RDONLY | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0) return {};
    struct stat st {};
    std::string text;
    if (::fstat(fd, &st) == 0 && S_ISREG(st.st_mode) && std::uintmax_t(st.st_size) <= kMaxMarkerBytes) {
        text.resize(std::size_t(st.st_size));
        std::size_t got = 0;
        while (got < text.size()) {
            const ssize_t n = ::read(fd, text.data() + got, text.size() - got);
            if (n <= 0) break;
            got += std::size_t(n);
        }
        text.resize(got);
    }
    ::close(fd);
    return text;
}

// Everything below `folder` but the marker: its folders and its files with their sizes; false when
// something is neither a folder nor a regular file (a link, a FIFO, a device).
bool list_contents(const fs::path& folder, std::vector<std::string>& folders, std::map<std::string, std::uintmax_t>& files, std::string& odd) {
    std::error_code ec;
    for (auto it = fs::recursive_directory_iterator(folder, ec); !ec && it != fs::recursive_directory_iterator(); it.increment(ec)) {
        const fs::path relative = it->path().lexically_relative(folder);
        if (relative == StagedOutput::kMarker) continue;
        const fs::file_status status = it->symlink_status(ec);
        if (fs::is_directory(status)) {
            folders.push_back(relative.generic_string());
        } else if (fs::is_regular_file(status)) {
            files[relative.generic_string()] = it->file_size(ec);
        } else {
            odd = relative.generic_string();
            return false;
        }
    }
    if (ec) odd = "(unreadable)";
    return !ec;
}

std::string random_run_identity() {
    std::random_device device;
    const std::uint64_t r = (std::uint64_t(device()) << 32) ^ device();
    return fmt::format("{}-{:016x}", ::getpid(), r);
}

// Removes an amhv folder (a staging folder, or an old output swapped out) with its marker last: a
// run killed part way leaves a folder whose marker still says it is amhv's and lists a superset of
// what is left, so the next run recognises it and finishes the removal.
void remove_marked_folder(const fs::path& folder, std::error_code& ec) {
    std::vector<fs::path> entries;
    for (const auto& entry : fs::directory_iterator(folder, ec))
        if (entry.path().filename() != StagedOutput::kMarker) entries.push_back(entry.path());
    for (const fs::path& entry : entries) fs::remove_all(entry, ec);
    fs::remove(folder / StagedOutput::kMarker, ec);
    fs::remove(folder, ec);
}

bool process_is_alive(long pid) { return pid > 0 && (::kill(pid_t(pid), 0) == 0 || errno == EPERM); }

// The outputs being written by this process, for the interrupt watcher.
struct Active {
    std::mutex mutex;
    std::vector<std::pair<fs::path, fs::path>> outputs;  // staging folder, lock file
};
Active& active() {
    static Active a;
    return a;
}

}  // namespace

OutputMarker read_output_marker(const fs::path& folder) {
    OutputMarker marker;
    const std::string text = marker_text(folder);
    if (text.empty()) {
        std::error_code ec;
        if (fs::exists(fs::symlink_status(folder / StagedOutput::kMarker, ec))) marker.kind = OutputMarker::Kind::Unknown;
        return marker;
    }
    marker.kind = OutputMarker::Kind::Unknown;
    const Json json = Json::parse(text, nullptr, false);
    if (!json.is_object() || json.value("amhv_output", 0) != 2) return marker;
    try {
        if (json.contains("staging")) {
            marker.run = json.at("staging").get<std::string>();
            marker.kind = OutputMarker::Kind::Staging;
        } else {
            marker.folders = json.at("folders").get<std::vector<std::string>>();
            for (const auto& f : json.at("files")) marker.files[f.at(0).get<std::string>()] = f.at(1).get<std::uintmax_t>();
            marker.kind = OutputMarker::Kind::Finished;
        }
    } catch (const Json::exception&) {
        marker.kind = OutputMarker::Kind::Unknown;
    }
    return marker;
}

bool is_amhv_output(const fs::path& folder) {
    const OutputMarker marker = read_output_marker(folder);
    if (marker.kind != OutputMarker::Kind::Finished) return false;
    std::vector<std::string> folders;
    std::map<std::string, std::uintmax_t> files;
    std::string odd;
    if (!list_contents(folder, folders, files, odd)) return false;
    for (const std::string& f : folders)
        if (std::find(marker.folders.begin(), marker.folders.end(), f) == marker.folders.end()) return false;
    for (const auto& [name, size] : files) {
        const auto listed = marker.files.find(name);
        if (listed == marker.files.end() || listed->second != size) return false;
    }
    return true;
}

namespace {

// Where a marker is written before it is renamed into place.
const std::string kMarkerWriting = std::string(StagedOutput::kMarker) + ".writing";

// The marker's bytes under a temporary name, then renamed over it: a run killed while writing it
// leaves the marker it had (or none) and at most the temporary file, never a partial marker in a
// folder full of outputs, which no later run could tell for amhv's.
void write_marker(const fs::path& folder, const std::string& text) {
    const fs::path writing = folder / kMarkerWriting;
    write_file(writing, text);
    std::error_code ec;
    fs::rename(writing, folder / StagedOutput::kMarker, ec);
    if (ec) fail((folder / StagedOutput::kMarker).string(), "cannot write the output's marker ({})", ec.message());
}

}  // namespace

void write_output_marker(const fs::path& folder) {
    std::vector<std::string> folders;
    std::map<std::string, std::uintmax_t> files;
    std::string odd;
    if (!list_contents(folder, folders, files, odd)) fail((folder / odd).string(), "is not a regular file or folder: amhv did not write it");
    std::sort(folders.begin(), folders.end());
    Json list = Json::array();
    for (const auto& [name, size] : files) list.push_back(Json::array({name, size}));
    const Json json = {{"amhv_output", 2},
                       {"program", "amhv"},
                       {"note", "this folder was written by amhv; the next amhv run into it replaces it whole if it holds only what is listed here"},
                       {"folders", folders},
                       {"files", list}};
    write_marker(folder, json.dump(1) + "\n");
}

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
    if (::access(parent.c_str(), W_OK | X_OK) != 0) fail(parent.string(), "cannot be written: the output {} could not be put there", target_.string());
    try {
        take_lock();
        remove_stale_staging();
        const std::string run = random_run_identity();
        staging_ = parent / fmt::format(".{}.partial-{}", absolute_.filename().string(), run);
        {
            std::lock_guard<std::mutex> hold(active().mutex);
            if (!fs::create_directory(staging_, ec) || ec) {
                staging_.clear();
                fail(parent.string(), "cannot create the staging folder of the output ({})", ec ? ec.message() : "it exists");
            }
            active().outputs.emplace_back(staging_, lock_path_);
        }
        write_marker(staging_, Json({{"amhv_output", 2}, {"staging", run}}).dump() + "\n");
    } catch (...) {
        release();  // the lock and the staging folder go; nothing else was made
        throw;
    }
}

void StagedOutput::refuse_unsafe_target(const std::vector<fs::path>& inputs) const {
    const std::string where = fmt::format("--out {}", target_.string());
    if (absolute_ == absolute_.root_path() || !absolute_.has_filename() || absolute_.filename() == "..")
        fail(where, "is the root of the file system; name a folder for the output");
    std::error_code ec;
    if (fs::is_symlink(fs::symlink_status(target_, ec)))
        fail(where, "is a symbolic link; amhv writes its output only into a real folder: name the folder itself");
    if (is_within(fs::current_path(), absolute_))
        fail(where, "is or contains the working folder, which would be replaced; name a new folder");
    for (const fs::path& input : inputs)
        if (!input.empty() && is_within(input, absolute_))
            fail(where, "is or contains the input {}, which would be replaced; name another folder", input.string());
    const fs::file_status status = fs::symlink_status(absolute_, ec);
    if (fs::exists(status) && !fs::is_directory(status)) fail(where, "exists and is not a folder");
    if (fs::is_directory(status) && !fs::is_empty(absolute_, ec) && !is_amhv_output(absolute_)) {
        const OutputMarker marker = read_output_marker(absolute_);
        if (marker.kind == OutputMarker::Kind::Finished)
            fail(where, "holds files that amhv did not write (they are not in its {}); amhv never replaces it: name a new or empty folder",
                 kMarker);
        fail(where, "is a folder amhv did not write (it has files and no {} of this amhv listing them); amhv never replaces it: name a new or empty folder",
             kMarker);
    }
}

// flock on .NAME.lock, created exclusively or opened as it is, never through a link; a lock whose
// file was removed (by the run that held it) while we waited for it is taken again on the new file.
void StagedOutput::take_lock() {
    lock_path_ = absolute_.parent_path() / fmt::format(".{}.lock", absolute_.filename().string());
    for (int attempt = 0; attempt < 100; ++attempt) {
        int fd = ::open(lock_path_.c_str(), O_RDWR | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0600);
        if (fd < 0 && errno == EEXIST) fd = ::open(lock_path_.c_str(), O_RDWR | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC);
        if (fd < 0 && errno == ENOENT) continue;  // removed between the two opens
        if (fd < 0) fail(lock_path_.string(), "cannot open the output's lock file (a link or not ours? remove it if no amhv runs)");
        struct stat held {};
        if (::fstat(fd, &held) != 0 || !S_ISREG(held.st_mode) || held.st_nlink != 1 || held.st_uid != ::geteuid() || held.st_size > 64) {
            ::close(fd);
            fail(lock_path_.string(), "is not an amhv lock file (not a small regular file of yours with one link); amhv leaves it alone: "
                                      "remove it or name another output folder");
        }
        if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
            char text[32] = {};
            const ssize_t n = ::pread(fd, text, sizeof(text) - 1, 0);
            ::close(fd);
            fail(fmt::format("--out {}", target_.string()), "another amhv run (pid {}) is writing it; wait for it or name another folder",
                 n > 0 ? printable(std::string(text, std::size_t(n)), 20) : std::string("unknown"));
        }
        struct stat now {};
        if (::lstat(lock_path_.c_str(), &now) == 0 && held.st_ino == now.st_ino && held.st_dev == now.st_dev) {
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

// Under the lock no other run writes this target. A staging folder is removed only when it is
// amhv's (its marker: the staging marker of the run its name carries, or a finished output's that
// lists everything in it: an old output swapped out by a run killed before it removed it) and the
// run that made it is dead.
void StagedOutput::remove_stale_staging() const {
    const std::regex name("\\." + std::regex_replace(absolute_.filename().string(), std::regex(R"([.^$|()\[\]{}*+?\\])"), R"(\$&)") +
                          R"(\.partial-(\d{1,10})-([0-9a-f]{16}))");
    std::error_code ec;
    std::vector<fs::path> stale;
    for (const auto& entry : fs::directory_iterator(absolute_.parent_path(), ec)) {
        std::smatch m;
        const std::string file = entry.path().filename().string();
        if (!std::regex_match(file, m, name) || !fs::is_directory(entry.symlink_status(ec))) continue;
        if (process_is_alive(std::stol(m[1].str()))) continue;
        const OutputMarker marker = read_output_marker(entry.path());
        const bool ours = (marker.kind == OutputMarker::Kind::Staging && marker.run == m[1].str() + "-" + m[2].str()) ||
                          (marker.kind == OutputMarker::Kind::Finished && is_amhv_output(entry.path()));
        // A run killed between creating its staging folder and finishing its marker leaves the
        // folder empty or holding only a partial marker (or its temporary file): nothing of anyone's to lose.
        bool unstarted = marker.kind == OutputMarker::Kind::None || marker.kind == OutputMarker::Kind::Unknown;
        for (const auto& inside : fs::directory_iterator(entry.path(), ec)) {
            const std::string inner = inside.path().filename().string();
            unstarted = unstarted && (inner == kMarker || inner == kMarkerWriting) && fs::is_regular_file(inside.symlink_status(ec));
        }
        if (ours || (unstarted && !ec)) stale.push_back(entry.path());
    }
    for (const fs::path& p : stale) remove_marked_folder(p, ec);
}

StagedOutput::~StagedOutput() { release(); }

void StagedOutput::release() {
    std::error_code ec;
    std::lock_guard<std::mutex> hold(active().mutex);
    if (!committed_ && !staging_.empty()) remove_marked_folder(staging_, ec);
    if (lock_fd_ >= 0) {
        struct stat held {}, now {};
        if (::fstat(lock_fd_, &held) == 0 && ::lstat(lock_path_.c_str(), &now) == 0 && held.st_ino == now.st_ino && held.st_dev == now.st_dev)
            ::unlink(lock_path_.c_str());
        ::close(lock_fd_);
        lock_fd_ = -1;
    }
    auto& outputs = active().outputs;
    outputs.erase(std::remove_if(outputs.begin(), outputs.end(), [&](const auto& o) { return o.first == staging_; }), outputs.end());
}

void StagedOutput::commit() {
    write_output_marker(staging_);
    std::error_code ec;
    std::lock_guard<std::mutex> hold(active().mutex);
    if (!fs::exists(fs::symlink_status(absolute_, ec))) {
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
    remove_marked_folder(staging_, ec);
}

void watch_interrupts() {
    sigset_t signals;
    sigemptyset(&signals);
    for (int s : {SIGINT, SIGTERM, SIGHUP}) sigaddset(&signals, s);
    if (pthread_sigmask(SIG_BLOCK, &signals, nullptr) != 0) return;
    std::thread([signals] {
        int signal = 0;
        if (sigwait(&signals, &signal) != 0) return;
        std::lock_guard<std::mutex> hold(active().mutex);
        std::error_code ec;
        for (const auto& [staging, lock] : active().outputs) {
            // Renamed first, so that no file the run still writes lands in it after the removal.
            const fs::path gone = staging.string() + ".interrupted";
            fs::rename(staging, gone, ec);
            fs::remove_all(ec ? staging : gone, ec);
            ::unlink(lock.c_str());
        }
        std::cerr << fmt::format("amhv: interrupted ({}){}\n", ::strsignal(signal),
                                 active().outputs.empty() ? "" : "; the output it was writing is left as it was before");
        std::_Exit(128 + signal);
    }).detach();
}

}  // namespace amhv
