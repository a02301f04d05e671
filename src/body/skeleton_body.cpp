#include "src/body/skeleton_body.hpp"

#include "src/body/shapes.hpp"
#include "src/body/skeleton_roles.hpp"
#include "src/body/skinned_body.hpp"
#include "src/core/error.hpp"

#include <algorithm>
#include <cctype>

namespace amhv {

namespace {

bool contains(const std::string& name, const char* word) { return name.find(word) != std::string::npos; }

}  // namespace

double bone_radius(const std::string& parent, const std::string& child) {
    // Bone named by the joint it starts at; ordered from specific to general.
    if (contains(parent, "Sword") || contains(parent, "Prop")) return 0.02;  // a blade or a stick
    if (contains(child, "_end") && contains(parent, "Head")) return 0.10;  // skull
    // A hand is a mitten: about 9 cm across the palm, so 4 cm around the finger bones; the thumb 2 cm.
    if (contains(parent, "Thumb")) return 0.02;
    if (contains(parent, "Index") || contains(parent, "Finger") || contains(parent, "Hand")) return kMittenRadius;
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

std::string body_part(const std::string& parent) {
    // Side: "Left..."/"Right..." or CMU's short "L..."/"R..." prefix (LHipJoint, RThumb).
    std::string side;
    if (parent.rfind("Left", 0) == 0 || (parent.size() > 1 && parent[0] == 'L' && std::isupper(static_cast<unsigned char>(parent[1]))))
        side = "left_";
    if (parent.rfind("Right", 0) == 0 || (parent.size() > 1 && parent[0] == 'R' && std::isupper(static_cast<unsigned char>(parent[1]))))
        side = "right_";
    if (contains(parent, "Sword")) return "sword";
    if (contains(parent, "Prop")) return "prop";
    if (contains(parent, "Head") || contains(parent, "Neck")) return "head";
    if (contains(parent, "Hand") || contains(parent, "Finger") || contains(parent, "Thumb") || contains(parent, "Index")) return side + "hand";
    if (contains(parent, "ForeArm")) return side + "forearm";
    // The collar bone, from the neck's base to the shoulder joint: the top of the shoulder and the
    // trapezius over it (a side's own part; the skinned body keeps it in its torso).
    if (contains(parent, "Shoulder")) return side.empty() ? "torso" : side + "shoulder";
    if (contains(parent, "Arm")) return side + "upper_arm";
    if (contains(parent, "UpLeg")) return side + "thigh";
    if (contains(parent, "Foot") || contains(parent, "Toe")) return side + "foot";
    if (contains(parent, "Leg")) return side + "shin";
    return "torso";
}

const std::vector<std::string>& body_part_names() {
    static const std::vector<std::string> names{"head", "torso", "left_upper_arm", "left_forearm", "left_hand", "right_upper_arm",
                                                "right_forearm", "right_hand", "left_thigh", "left_shin", "left_foot",
                                                "right_thigh", "right_shin", "right_foot", "left_shoulder", "right_shoulder"};
    return names;
}

std::string skinned_body_part(const std::string& parent) {
    std::string part = body_part(parent);
    return part.ends_with("shoulder") ? "torso" : part;
}

std::vector<std::string> body_part_names(const BvhMotion& motion, bool skinned) {
    const std::vector<std::string> roles = role_names(motion);
    std::vector<std::string> present;
    for (const BvhJoint& joint : motion.joints)
        if (joint.parent >= 0) present.push_back(skinned ? skinned_body_part(roles[std::size_t(joint.parent)]) : body_part(roles[std::size_t(joint.parent)]));
    std::vector<std::string> names;
    for (const std::string& n : body_part_names())
        if (std::find(present.begin(), present.end(), n) != present.end()) names.push_back(n);
    for (const char* prop : {"sword", "prop"})
        if (std::find(present.begin(), present.end(), prop) != present.end()) names.push_back(prop);
    return names;
}

std::vector<BodyPart> skeleton_body_parts(const BvhMotion& motion, int frame, const SkeletonBodyOptions& options) {
    if (options.skinned) return skinned_body_parts(*options.skinned, motion, frame, options.units);
    auto global = motion.global_transforms(frame);
    auto world = [&](std::size_t j) { return to_scene_point(global[j].translation(), options.units); };
    const std::vector<std::string> names = role_names(motion);  // the joints by role, in one vocabulary
    std::vector<BodyPart> parts;
    auto part_mesh = [&](const std::string& name) -> TriangleMesh& {
        for (auto& p : parts)
            if (p.name == name) return p.mesh;
        parts.push_back({name, {}});
        return parts.back().mesh;
    };
    for (std::size_t j = 0; j < motion.joints.size(); ++j) {
        const BvhJoint& joint = motion.joints[j];
        if (joint.parent < 0) continue;
        const std::string& parent = names[std::size_t(joint.parent)];
        Vec3 a = world(std::size_t(joint.parent)), b = world(j);
        if ((b - a).norm() < 1e-4) continue;  // zero-length bones (CMU's hip joints) add nothing
        if (joint.end_site && body_part(parent).ends_with("hand")) {
            // Mocap hands stop at a marker near the knuckles (CMU: 8 cm from the wrist); a real
            // hand reaches kHandLength from the wrist (the thumb kThumbLength). The last bone is
            // extended along its direction so the body's hands are as long as a person's.
            int wrist = joint.parent;
            while (wrist >= 0 && !names[std::size_t(wrist)].ends_with("Hand")) wrist = motion.joints[std::size_t(wrist)].parent;
            if (wrist >= 0) {
                const double target = contains(parent, "Thumb") ? kThumbLength : kHandLength;
                const double reach = (b - world(std::size_t(wrist))).norm();
                if (reach < target) b += (b - a).normalized() * (target - reach);
            }
        }
        double radius = bone_radius(parent, names[j]);
        TriangleMesh& mesh = part_mesh(body_part(parent));
        if (contains(parent, "Head") && joint.end_site) {
            mesh.append(shapes::sphere((a + b) / 2, radius, options.cap_rings * 2, options.segments));
            continue;
        }
        if (contains(parent, "ForeArm") && names[j].ends_with("Hand"))
            mesh.append(shapes::tapered_capsule(a, b, radius, kWristRadius, options.cap_rings, options.segments));
        else
            mesh.append(shapes::capsule(a, b, radius, options.cap_rings, options.segments));
    }
    for (const auto& p : parts)
        for (const Vec3& v : p.mesh.vertices)
            if (!v.allFinite()) fail(motion.source, "frame {} gives a non-finite joint position", frame);
    return parts;
}

TriangleMesh skeleton_body(const BvhMotion& motion, int frame, const SkeletonBodyOptions& options) {
    TriangleMesh body;
    for (const BodyPart& part : skeleton_body_parts(motion, frame, options)) body.append(part.mesh);
    return body;
}

std::vector<TrackSample> joints_track(const JointFrames& joints, const UnitsAndAxes& units) {
    const std::vector<std::string>& roles = joints.roles;
    auto find = [&](const char* role) {
        const auto at = std::find(roles.begin(), roles.end(), role);
        if (at == roles.end()) fail(joints.source, "cannot derive a view track: no joint plays the role {}", role);
        return std::size_t(at - roles.begin());
    };
    const std::size_t head = find("Head"), left_arm = find("LeftArm"), right_arm = find("RightArm");
    const std::size_t left_leg = find("LeftUpLeg"), right_leg = find("RightUpLeg");
    int head_end = -1;
    for (std::size_t j = 0; j < joints.parent.size(); ++j)
        if (joints.parent[j] == int(head)) head_end = int(j);
    // The file's axes to the scene's, as a matrix (a rotation, or a reflection for a mirrored file).
    Eigen::Matrix3d axes;
    for (int c = 0; c < 3; ++c) axes.col(c) = to_scene_direction(Vec3::Unit(c), units);

    std::vector<TrackSample> track(std::size_t(joints.frame_count));
    std::vector<Eigen::Matrix3d> head_rotation(track.size());
    Vec3 head_local_forward = Vec3::Zero();
    for (int f = 0; f < joints.frame_count; ++f) {
        const std::vector<Eigen::Affine3d> g = joints.globals(f);
        auto at = [&](std::size_t j) { return to_scene_point(g[j].translation(), units); };
        // Facing from hips and shoulders: forward = left x up.
        Vec3 left = (at(left_arm) - at(right_arm)) + (at(left_leg) - at(right_leg));
        Vec3 forward(left.y(), -left.x(), 0);
        if (forward.norm() < 1e-9) forward = Vec3::UnitX();
        forward.normalize();
        head_rotation[std::size_t(f)] = axes * g[head].linear() * axes.transpose();
        if (f >= joints.first_frame) head_local_forward += head_rotation[std::size_t(f)].transpose() * forward;  // not the T-pose
        Vec3 top = head_end >= 0 ? at(std::size_t(head_end)) : at(head) + Vec3(0, 0, 0.2);
        track[std::size_t(f)].eye = 0.5 * (at(head) + top);
        track[std::size_t(f)].gaze = forward;
    }
    // The head's own forward axis, calibrated over the take: the direction that, carried by the
    // head's rotation, best matches the body's facing. Gaze then follows the head.
    if (head_local_forward.norm() > 1e-9) {
        head_local_forward.normalize();
        for (std::size_t f = 0; f < track.size(); ++f) {
            track[f].gaze = (head_rotation[f] * head_local_forward).normalized();
            track[f].eye += 0.08 * track[f].gaze;  // from the middle of the head to between the eyes
        }
    }
    return track;
}

std::vector<TrackSample> skeleton_track(const BvhMotion& motion, const SkeletonBodyOptions& options) {
    // The joints by role (role_names fails, naming the role, when one is missing).
    JointFrames joints{motion.source, role_names(motion), {}, motion.frame_count, motion.first_frame, {}};
    for (const BvhJoint& j : motion.joints) joints.parent.push_back(j.parent);
    joints.globals = [&](int f) {
        const auto g = motion.global_transforms(f);
        return std::vector<Eigen::Affine3d>(g.begin(), g.end());
    };
    return joints_track(joints, options.units);
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
