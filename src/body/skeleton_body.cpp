#include "body/skeleton_body.hpp"

#include "body/shapes.hpp"
#include "core/error.hpp"

namespace amhv {

namespace {

bool contains(const std::string& name, const char* word) { return name.find(word) != std::string::npos; }

}  // namespace

double bone_radius(const std::string& parent, const std::string& child) {
    // Bone named by the joint it starts at; ordered from specific to general.
    if (contains(child, "_end") && contains(parent, "Head")) return 0.10;  // skull
    if (contains(parent, "Thumb") || contains(parent, "Index") || contains(parent, "Finger")) return 0.022;
    if (contains(parent, "Hand")) return 0.035;
    if (contains(parent, "ForeArm")) return 0.038;
    if (contains(parent, "Shoulder")) return 0.055;
    if (contains(parent, "Arm")) return 0.047;
    if (contains(parent, "UpLeg")) return 0.075;
    if (contains(parent, "Toe")) return 0.030;
    if (contains(parent, "Foot")) return 0.042;
    if (contains(parent, "Leg")) return 0.055;
    if (contains(parent, "HipJoint")) return 0.085;
    if (contains(parent, "Neck")) return 0.055;
    if (contains(parent, "Spine1")) return contains(child, "Neck") ? 0.13 : 0.06;
    if (contains(parent, "Spine")) return 0.14;
    if (contains(parent, "LowerBack")) return 0.13;
    if (contains(parent, "Hips")) return 0.12;
    return 0.04;
}

TriangleMesh skeleton_body(const BvhMotion& motion, int frame, const SkeletonBodyOptions& options) {
    auto global = motion.global_transforms(frame);
    auto world = [&](std::size_t j) { return to_z_up(global[j].translation() * options.units.metres_per_unit, options.units.up); };
    TriangleMesh body;
    for (std::size_t j = 0; j < motion.joints.size(); ++j) {
        const BvhJoint& joint = motion.joints[j];
        if (joint.parent < 0) continue;
        const std::string& parent = motion.joints[std::size_t(joint.parent)].name;
        Vec3 a = world(std::size_t(joint.parent)), b = world(j);
        if ((b - a).norm() < 1e-4) continue;  // zero-length bones (CMU's hip joints) add nothing
        double radius = bone_radius(parent, joint.name);
        if (contains(parent, "Head") && joint.end_site) {
            body.append(shapes::sphere((a + b) / 2, radius, options.cap_rings * 2, options.segments));
            continue;
        }
        body.append(shapes::capsule(a, b, radius, options.cap_rings, options.segments));
    }
    for (const Vec3& v : body.vertices)
        if (!v.allFinite()) fail(motion.source, "frame {} gives a non-finite joint position", frame);
    return body;
}

MeshSequence skeleton_body_sequence(const BvhMotion& motion, const FrameRange& range, const SkeletonBodyOptions& options) {
    if (range.last >= motion.frame_count)
        fail(motion.source, "--frames {}:{} goes beyond the file's {} frames (0..{})", range.first, range.last, motion.frame_count,
             motion.frame_count - 1);
    MeshSequence sequence;
    sequence.source = motion.source;
    for (int f = range.first; f <= range.last; ++f)
        sequence.frames.push_back({skeleton_body(motion, f, options), fmt::format("{} frame {}", motion.source, f)});
    return sequence;
}

}  // namespace amhv
