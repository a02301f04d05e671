#include "src/io/output_dir.hpp"

#include <unistd.h>

#include "src/core/error.hpp"

namespace amhv {

namespace fs = std::filesystem;

StagedOutput::StagedOutput(fs::path target) : target_(std::move(target)) {
    if (target_.empty()) throw Error("--out: an output folder is required");
    if (!target_.has_filename()) target_ = target_.parent_path();
    fs::path parent = fs::absolute(target_).parent_path();
    std::error_code ec;
    fs::create_directories(parent, ec);
    if (ec) fail(parent.string(), "cannot create the output's parent folder ({})", ec.message());
    if (fs::exists(target_) && !fs::is_directory(target_)) fail(target_.string(), "exists and is not a folder");
    staging_ = parent / fmt::format(".{}.partial-{}", target_.filename().string(), ::getpid());
    fs::remove_all(staging_, ec);
    fs::create_directory(staging_, ec);
    if (ec) fail(staging_.string(), "cannot create the staging folder ({})", ec.message());
}

StagedOutput::~StagedOutput() {
    if (committed_) return;
    std::error_code ec;
    fs::remove_all(staging_, ec);
}

void StagedOutput::commit() {
    std::error_code ec;
    fs::remove_all(target_, ec);
    if (ec) fail(target_.string(), "cannot replace the previous output ({})", ec.message());
    fs::rename(staging_, target_, ec);
    if (ec) fail(target_.string(), "cannot move the finished output into place ({})", ec.message());
    committed_ = true;
}

}  // namespace amhv
