#include "src/cli/bvh_options.hpp"

#include "src/body/skinned_body.hpp"
#include "src/core/error.hpp"

namespace amhv::cli {

void add_bvh_options(CLI::App& command, BvhArguments& args) {
    command.add_option("--fps", args.fps, "BVH: resample the take to this frame rate (frame k = the pose at k/fps s; default: the file's rate); character: sample its animation at it");
    command.add_option("--tpose", args.tpose, "BVH: frame 0 is a converter's T-pose: auto (detect), skip or keep")->capture_default_str();
    command.add_option("--body", args.body, "BVH: capsules around the bones, or skinned (the CC0 Mesh2Motion human fitted to the take)")
        ->capture_default_str();
}

void apply_body_option(const BvhArguments& args, const BvhMotion& motion, SkeletonBodyOptions& options) {
    if (parse_body_kind(args.body, "--body") == BodyKind::Skinned)
        options.skinned = fit_skin_model(load_skin_model(shipped_body_model()), motion, options.units);
}

BvhLoadOptions bvh_load_options(const BvhArguments& args) {
    if (args.fps < 0 || args.fps > 1000) throw Error(fmt::format("--fps: {} is not a frame rate in (0, 1000]", args.fps));
    return {parse_tpose(args.tpose, "--tpose"), args.fps};
}

FrameRange bvh_frames(const BvhMotion& motion, const std::string& frames) {
    if (frames.empty()) return {motion.first_frame, motion.frame_count - 1};
    FrameRange range = parse_frame_range(frames, "--frames");
    if (range.last >= motion.frame_count)
        fail(motion.source, "--frames {}:{} goes beyond the take's {} frames (0..{})", range.first, range.last, motion.frame_count,
             motion.frame_count - 1);
    if (range.first < motion.first_frame)
        fail(motion.source, "--frames {}:{} starts before frame {}, the first after the converter's T-pose (--tpose keep keeps it)",
             range.first, range.last, motion.first_frame);
    return range;
}

}  // namespace amhv::cli
