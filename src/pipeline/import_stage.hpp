#pragma once
// The stage of `amhv import-bvh`: a BVH take written as files other tools and scenes read: the
// body mesh per frame (PLY, a colour per part), part labels, the view track, an object table and
// import.json; with the skinned body, character.glb (the human animated by the take). The CLI loads the take, opens the output folder and calls this.
#include <filesystem>
#include <string>

#include "src/body/skeleton_body.hpp"
#include "src/io/bvh.hpp"

namespace amhv::pipeline {

// Writes frames `range` of `motion` (read from `bvh`) into `out`.
void import_bvh_into(const BvhMotion& motion, const std::string& bvh, const FrameRange& range, const SkeletonBodyOptions& options,
                     const std::filesystem::path& out);

}  // namespace amhv::pipeline
