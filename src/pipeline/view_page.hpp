#pragma once
// The page of an edited scene (docs/scenes.md, "The page"): DIR/index.html and DIR/view/ for an
// output folder of `amhv edit`. It plays scene.glb with three.js and plots each key segment's
// solution group; it reads only its folder, so it opens from file:// and offline, and its data are
// the folder's own outputs (result.json, transforms.json, the groups, scene.glb), so it never
// disagrees with them.
#include <cstdint>
#include <filesystem>

namespace amhv::pipeline {

// At most this many members of a group are plotted: every n-th by rank beyond it.
inline constexpr std::uint64_t kPagePlottedMembers = 20000;

// three.js r147 (classic scripts), as tools/setup.sh installs it: AMHV_THREE_DIR in the environment,
// else tools/npm/node_modules/three in the source tree.
std::filesystem::path three_js_dir();

struct PageReport {
    std::uint64_t bytes = 0;  // index.html and view/ together
};

// Writes `dir`/index.html and `dir`/view/ from the outputs in `dir`; fails naming what is missing
// (scene.glb after --no-glb, a group, three.js). `out` is where the files go (a staging folder, or
// `dir` itself).
PageReport write_view_page(const std::filesystem::path& dir, const std::filesystem::path& out);

}  // namespace amhv::pipeline
