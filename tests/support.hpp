#pragma once
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "src/core/geometry.hpp"
#include "src/gpu/context.hpp"
#include "src/scene/segment.hpp"
#include "src/voxelise/voxelise.hpp"

#include <nlohmann/json.hpp>

namespace amhv::test {

// Whether this binary is built with AddressSanitizer (tools/sanitize.sh).
#if defined(__SANITIZE_ADDRESS__)
inline constexpr bool kAddressSanitizer = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
inline constexpr bool kAddressSanitizer = true;
#else
inline constexpr bool kAddressSanitizer = false;
#endif
#else
inline constexpr bool kAddressSanitizer = false;
#endif

// One Vulkan context for the whole test binary, validation layers on.
gpu::Context& context();
// NAME.bvh of each (NAME, object) in `out` against transforms.json: the edited take (docs/scenes.md).
void expect_edited_takes(const std::filesystem::path& out, const std::vector<std::pair<std::string, const SceneObject*>>& objects,
                         const nlohmann::json& transforms);
// A second context on the same device with staged transfers (ContextOptions::staged_transfers):
// the discrete-GPU memory path, device-local buffers moved by copies, on any device.
gpu::Context& staged_context();

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
// Replaces the first `from` in the file with `to`; a test failure when `from` is not there.
void replace_in_file(const std::filesystem::path& path, const std::string& from, const std::string& to);
// The parts' union as an OBJ file and, beside it, a labels file: one part name per vertex.
void write_labelled_obj(const std::filesystem::path& obj, const std::filesystem::path& labels,
                        const std::vector<std::pair<std::string, TriangleMesh>>& parts);

struct CommandResult {
    int exit_code;
    std::string output;  // stdout and stderr together
};
// Runs the built `amhv` binary with `arguments` (a shell-quoted string).
CommandResult run_amhv(const std::string& arguments);
// Runs `command` in sh (stdout and stderr together).
CommandResult run_shell(const std::string& command);
// The built `amhv` binary, shell-quoted.
std::string amhv_command();
// The Khronos glTF validator (tools/validate_gltf.cjs, installed by tools/setup.sh) on `file`:
// exit 0 when it finds no error; its report line and first issues as output.
CommandResult validate_gltf(const std::filesystem::path& file);
// How many lines of the output are "amhv: error: ..." lines.
int one_line_error(const CommandResult& result);

// The union of the parts of `source`'s frame (transforms.json's `source`) selected by `keep`, moved
// into the scene by one object's entry of transforms.json (x, y, z, yaw_deg).
MeshFrame moved_parts(ObjectSource& source, const nlohmann::json& transform, bool (*keep)(const std::string&));
// Voxels (edge h, on the scene lattice) whose centre lies inside `a` and, within `reach` voxels
// (26-neighbourhood steps), inside `b`.
std::size_t shared_voxels(const MeshFrame& a, const MeshFrame& b, double h, Voxeliser& voxeliser, int reach = 0);
// The transitional output frames of an edit's transforms.json where both whole bodies of `scene`
// share a voxel of edge h: re-voxelised from the file alone by the CPU reference.
std::vector<int> overlapping_transitional_frames(const std::filesystem::path& scene, const std::filesystem::path& transforms, double h);

}  // namespace amhv::test
