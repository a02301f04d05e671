#include "src/compose/features.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "src/core/error.hpp"

namespace amhv::compose {

namespace {

int role(const std::vector<std::string>& roles, const std::string& name, const std::string& source) {
    auto it = std::find(roles.begin(), roles.end(), name);
    if (it == roles.end()) fail(source, "no joint plays the role {}: composing needs it", name);
    return int(it - roles.begin());
}

// The angle from a to b, wrapped to (-pi, pi].
double turn(double a, double b) { return std::remainder(b - a, 2 * std::numbers::pi); }

}  // namespace

std::vector<int> KeyJoints::all() const {
    return {head, hand[0], hand[1], elbow[0], elbow[1], knee[0], knee[1], foot[0], foot[1]};
}

std::vector<int> KeyJoints::with_hips() const {
    std::vector<int> joints = all();
    joints.push_back(hips);
    return joints;
}

KeyJoints key_joints(const std::vector<std::string>& roles, const std::string& source) {
    KeyJoints k;
    k.hips = role(roles, "Hips", source);
    k.head = role(roles, "Head", source);
    const char* side[2] = {"Left", "Right"};
    for (int s = 0; s < 2; ++s) {
        k.hand[s] = role(roles, fmt::format("{}Hand", side[s]), source);
        k.elbow[s] = role(roles, fmt::format("{}ForeArm", side[s]), source);
        k.hip[s] = role(roles, fmt::format("{}UpLeg", side[s]), source);
        k.knee[s] = role(roles, fmt::format("{}Leg", side[s]), source);
        k.foot[s] = role(roles, fmt::format("{}Foot", side[s]), source);
    }
    return k;
}

double heading_of(const Vec3& left_hip, const Vec3& right_hip) {
    const Vec3 left = left_hip - right_hip;
    // Facing f, z up: left = z x f, so f = left x z.
    const Vec3 forward = left.cross(Vec3::UnitZ());
    return std::atan2(forward.y(), forward.x());
}

PoseTrack pose_track(const BvhMotion& motion, const UnitsAndAxes& units, const KeyJoints& key) {
    PoseTrack track;
    track.joints.resize(std::size_t(motion.frame_count));
    track.heading.resize(std::size_t(motion.frame_count));
    for (int f = 0; f < motion.frame_count; ++f) {
        const auto global = motion.global_transforms(f);
        auto& joints = track.joints[std::size_t(f)];
        joints.reserve(global.size());
        for (const auto& g : global) joints.push_back(to_scene_point(g.translation(), units));
        track.heading[std::size_t(f)] = heading_of(joints[std::size_t(key.hip[0])], joints[std::size_t(key.hip[1])]);
    }
    // The hips turn by +-10 degrees within each step: the heading is their mean direction over
    // kHeadingSpan, the length of a step cycle.
    const int half = std::max(1, int(std::lround(kHeadingSpan * motion.fps() / 2)));
    std::vector<double> smooth(track.heading.size());
    for (int f = 0; f < motion.frame_count; ++f) {
        double c = 0, s = 0;
        for (int g = std::max(motion.first_frame, f - half); g <= std::min(motion.frame_count - 1, f + half); ++g)
            c += std::cos(track.heading[std::size_t(g)]), s += std::sin(track.heading[std::size_t(g)]);
        smooth[std::size_t(f)] = std::atan2(s, c);
    }
    track.heading = std::move(smooth);
    return track;
}

std::vector<Eigen::VectorXd> motion_features(const PoseTrack& track, const KeyJoints& key, double fps, int first, int last) {
    const std::vector<int> joints = key.all();
    const double n = double(joints.size());
    const int span = std::max(1, int(std::lround(kVelocitySpan * fps / 2)));
    // Positions of the key joints in the root frame of frame f.
    auto local = [&](int f) {
        const auto& at = track.joints[std::size_t(f)];
        const Vec3 origin(at[std::size_t(key.hips)].x(), at[std::size_t(key.hips)].y(), 0.0);
        const Eigen::Matrix3d to_root = Eigen::AngleAxisd(-track.heading[std::size_t(f)], Vec3::UnitZ()).toRotationMatrix();
        std::vector<Vec3> out;
        for (int j : joints) out.push_back(to_root * (at[std::size_t(j)] - origin));
        return out;
    };
    // Bodies of other sizes move alike in proportion: lengths are measured in leg lengths (hip
    // joint to ankle, thigh plus shank, from the skeleton), times a nominal kLegLength.
    const auto& rest = track.joints[std::size_t(first)];
    double leg = 0;
    for (int s = 0; s < 2; ++s)
        leg += 0.5 * ((rest[std::size_t(key.knee[s])] - rest[std::size_t(key.hip[s])]).norm() + (rest[std::size_t(key.foot[s])] - rest[std::size_t(key.knee[s])]).norm());
    const double scale = leg > 0 ? kLegLength / leg : 1.0;
    std::vector<Eigen::VectorXd> features;
    for (int f = first; f <= last; ++f) {
        const int a = std::max(first, f - span), b = std::min(last, f + span);
        const double dt = double(b - a) / fps;
        const std::vector<Vec3> here = local(f);
        const Eigen::Matrix3d to_root = Eigen::AngleAxisd(-track.heading[std::size_t(f)], Vec3::UnitZ()).toRotationMatrix();
        Eigen::VectorXd v(6 * joints.size() + 1);
        for (std::size_t j = 0; j < joints.size(); ++j) {
            v.segment<3>(Eigen::Index(3 * j)) = here[j] / std::sqrt(n);
            // The joint's own velocity (the body's travel included), seen along frame f's heading.
            const std::size_t at = std::size_t(joints[j]);
            const Vec3 velocity = dt > 0 ? Vec3(to_root * (track.joints[std::size_t(b)][at] - track.joints[std::size_t(a)][at]) / dt) : Vec3::Zero();
            v.segment<3>(Eigen::Index(3 * (joints.size() + j))) = velocity * kVelocityTime / std::sqrt(n);
        }
        const double turning = dt > 0 ? turn(track.heading[std::size_t(a)], track.heading[std::size_t(b)]) / dt : 0.0;
        v[Eigen::Index(6 * joints.size())] = turning * kTurnRadius * kVelocityTime;
        v.head(Eigen::Index(6 * joints.size())) *= scale;
        features.push_back(std::move(v));
    }
    return features;
}

Eigen::VectorXd mirrored_feature(const Eigen::VectorXd& feature) {
    // all() is the head, then left and right of each pair: joint j's mirror is j + 1 (odd j) or
    // j - 1 (even j > 0).
    const Eigen::Index joints = (feature.size() - 1) / 6;
    Eigen::VectorXd out = feature;
    for (Eigen::Index block = 0; block < 2; ++block)  // positions, then velocities
        for (Eigen::Index j = 0; j < joints; ++j) {
            const Eigen::Index from = j == 0 ? 0 : j % 2 == 1 ? j + 1 : j - 1, at = 3 * (block * joints + j);
            out.segment<3>(at) = feature.segment<3>(3 * (block * joints + from));
            out[at + 1] = -out[at + 1];
        }
    out[feature.size() - 1] = -feature[feature.size() - 1];
    return out;
}

}  // namespace amhv::compose
