#pragma once
// All-or-nothing output folders that never lose a user's files.
//
// Everything is written into a hidden staging folder beside the target (.NAME.partial-PID-RANDOM),
// which replaces the target only on commit(), by one atomic exchange of the two folders: at every
// moment the target is either the old output, whole, or the new one, whole. An error, a kill, or
// SIGINT / SIGTERM / SIGHUP (watch_interrupts) before that leaves the old output as it was.
//
// amhv's own folders are known by their marker, .amhv-output: a JSON file that lists every folder
// and file the run wrote, with each file's size. A folder is replaced only when it is empty or its
// marker lists everything in it (a file added, a link, a FIFO or a file of another size: refused):
// a copied report, a copied marker or a legacy one makes no folder amhv's. A staging folder is
// removed only when its name and its marker carry the same run identity and that run is dead.
//
// A lock (.NAME.lock, created or opened without following links, a regular file with one link,
// flock) keeps a second run from writing the same target at the same time.
//
// The target is refused, before anything is written, when it is or contains the working folder or
// one of the run's inputs, when it is a file or a symbolic link, when its parent cannot be written,
// or when it is a folder that amhv did not write.
#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

namespace amhv {

class StagedOutput {
public:
    // `inputs`: files and folders the run reads (scene, meshes, --from-sweep ...).
    explicit StagedOutput(std::filesystem::path target, const std::vector<std::filesystem::path>& inputs = {});
    ~StagedOutput();
    StagedOutput(const StagedOutput&) = delete;
    StagedOutput& operator=(const StagedOutput&) = delete;

    const std::filesystem::path& dir() const { return staging_; }  // write here
    const std::filesystem::path& target() const { return target_; }
    void commit();

    static constexpr const char* kMarker = ".amhv-output";

private:
    void refuse_unsafe_target(const std::vector<std::filesystem::path>& inputs) const;
    void take_lock();
    void remove_stale_staging() const;
    void release();  // removes the staging folder (unless committed) and the lock

    std::filesystem::path target_;   // as the user gave it (for messages)
    std::filesystem::path absolute_; // resolved
    std::filesystem::path staging_;
    std::filesystem::path lock_path_;
    int lock_fd_ = -1;
    bool committed_ = false;
};

// What a folder's marker says.
struct OutputMarker {
    enum class Kind { None, Staging, Finished, Unknown } kind = Kind::None;
    std::string run;                                // Staging: the run's identity (PID-RANDOM)
    std::vector<std::string> folders;               // Finished: every folder written, relative
    std::map<std::string, std::uintmax_t> files;    // Finished: every file written, relative, with its size
};
OutputMarker read_output_marker(const std::filesystem::path& folder);

// Whether `folder` is an output amhv finished: its marker lists everything in it.
bool is_amhv_output(const std::filesystem::path& folder);

// Writes `folder`'s marker listing everything in it now (after amhv added files to its own
// output: `amhv view`).
void write_output_marker(const std::filesystem::path& folder);

// Blocks SIGINT, SIGTERM and SIGHUP in the calling thread (call it first in main, before any
// thread starts, so that every thread inherits the mask) and starts a thread that, on one of them,
// removes the staging folders and locks of the outputs being written and exits (128 + signal).
void watch_interrupts();

// Whether `path` is `folder` or lies inside it (both resolved; symbolic links followed).
bool is_within(const std::filesystem::path& path, const std::filesystem::path& folder);

}  // namespace amhv
