#pragma once
#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "core/geometry.hpp"
#include "gpu/context.hpp"

namespace amhv::test {

// One Vulkan context for the whole test binary, validation layers on.
gpu::Context& context();

// Fails the current test if the validation layers reported anything since the last call.
void expect_no_validation_messages();

// A fresh, empty temporary folder removed at exit of the scope.
class TempDir {
public:
    TempDir();
    ~TempDir();
    const std::filesystem::path& path() const { return path_; }

private:
    std::filesystem::path path_;
};

std::filesystem::path source_dir();

// Writes `mesh` as an OBJ file (9 significant digits).
void write_obj(const std::filesystem::path& path, const TriangleMesh& mesh);
// The whole file as bytes.
std::string read_text(const std::filesystem::path& path);

struct CommandResult {
    int exit_code;
    std::string output;  // stdout and stderr together
};
// Runs the built `amhv` binary with `arguments` (a shell-quoted string).
CommandResult run_amhv(const std::string& arguments);

}  // namespace amhv::test
