#pragma once
// `--fps` and `--tpose`, shared by the subcommands that read a BVH take (mhv, import-bvh).
#include <string>

#include <CLI/CLI.hpp>

#include "src/body/skeleton_body.hpp"
#include "src/io/bvh.hpp"
#include "src/io/mesh_sequence.hpp"

namespace amhv::cli {

struct BvhArguments {
    std::string tpose = "auto";
    double fps = 0;  // 0: the file's rate
    std::string body = "capsules";
};

void add_bvh_options(CLI::App& command, BvhArguments& args);
BvhLoadOptions bvh_load_options(const BvhArguments& args);
// --body: the skinned human fitted to `motion` into `options` (after its units are set).
void apply_body_option(const BvhArguments& args, const BvhMotion& motion, SkeletonBodyOptions& options);

// The take's frames FIRST:LAST from --frames, or every frame after a skipped T-pose; checked
// against the take.
FrameRange bvh_frames(const BvhMotion& motion, const std::string& frames);

}  // namespace amhv::cli
