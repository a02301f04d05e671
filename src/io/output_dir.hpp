#pragma once
// All-or-nothing output folders that never lose a user's files.
//
// Everything is written into a hidden staging folder beside the target (.NAME.partial-PID), which
// replaces the target only on commit(), by one atomic exchange of the two folders: at every moment
// the target is either the old output, whole, or the new one, whole. An error (an exception, a kill)
// before that leaves the old output as it was. A lock (.NAME.lock, flock) keeps a second run from
// writing the same target at the same time; staging folders of dead runs are removed by the next
// run into the same target.
//
// The target is refused, before anything is written, when it is or contains the working folder or
// one of the run's inputs, when it is a file, or when it is a folder that amhv did not write (not
// empty and without the marker file .amhv-output that every output carries): amhv never deletes or
// overwrites what it did not create.
#include <filesystem>
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

    std::filesystem::path target_;   // as the user gave it (for messages)
    std::filesystem::path absolute_; // resolved
    std::filesystem::path staging_;
    std::filesystem::path lock_path_;
    int lock_fd_ = -1;
    bool committed_ = false;
};

// Whether `path` is `folder` or lies inside it (both resolved; symbolic links followed).
bool is_within(const std::filesystem::path& path, const std::filesystem::path& folder);

}  // namespace amhv
