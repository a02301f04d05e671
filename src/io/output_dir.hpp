#pragma once
// All-or-nothing output folders: everything is written into a hidden staging folder next to the
// target, which replaces the target only when commit() is called. An error (exception) before
// that leaves no partial output behind.
#include <filesystem>

namespace amhv {

class StagedOutput {
public:
    explicit StagedOutput(std::filesystem::path target);
    ~StagedOutput();
    StagedOutput(const StagedOutput&) = delete;
    StagedOutput& operator=(const StagedOutput&) = delete;

    const std::filesystem::path& dir() const { return staging_; }  // write here
    const std::filesystem::path& target() const { return target_; }
    void commit();

private:
    std::filesystem::path target_;
    std::filesystem::path staging_;
    bool committed_ = false;
};

}  // namespace amhv
