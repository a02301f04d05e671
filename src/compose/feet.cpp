#include "src/compose/feet.hpp"

#include <algorithm>
#include <cmath>

namespace amhv::compose {

namespace {

// The ankle targets of one foot: per frame, where the ankle is now plus the correction that holds
// it during each planted run and fades around it.
std::vector<Vec3> ankle_targets(const std::vector<Vec3>& ankle, const std::vector<std::array<bool, 2>>& planted, int side, int ease) {
    const int n = int(ankle.size());
    std::vector<Vec3> correction(std::size_t(n), Vec3::Zero());
    std::vector<double> weight(std::size_t(n), 0.0);
    for (int start = 0; start < n;) {
        if (!planted[std::size_t(start)][std::size_t(side)]) {
            ++start;
            continue;
        }
        int end = start;
        while (end + 1 < n && planted[std::size_t(end + 1)][std::size_t(side)]) ++end;
        Vec3 hold = Vec3::Zero();
        for (int f = start; f <= end; ++f) hold += ankle[std::size_t(f)];
        hold /= double(end - start + 1);
        for (int f = std::max(0, start - ease); f <= std::min(n - 1, end + ease); ++f) {
            const int outside = f < start ? start - f : f > end ? f - end : 0;
            const double w = 1.0 - double(outside) / double(ease + 1);
            const Vec3 edge = ankle[std::size_t(f < start ? start : f > end ? end : f)];
            if (w > weight[std::size_t(f)]) weight[std::size_t(f)] = w, correction[std::size_t(f)] = w * (hold - edge);
        }
        start = end + 1;
    }
    std::vector<Vec3> target(static_cast<std::size_t>(n));
    for (int f = 0; f < n; ++f) target[std::size_t(f)] = ankle[std::size_t(f)] + correction[std::size_t(f)];
    return target;
}

// Turns the leg of `side` in frame f so that its ankle reaches `target`.
void reach(BvhMotion& m, const KeyJoints& key, int side, int f, const Vec3& target) {
    const auto global = m.global_transforms(f);
    const int hip = key.hip[std::size_t(side)], knee = key.knee[std::size_t(side)], foot = key.foot[std::size_t(side)];
    const Vec3 h = global[std::size_t(hip)].translation(), k = global[std::size_t(knee)].translation(), a = global[std::size_t(foot)].translation();
    if ((a - target).norm() < 1e-9) return;
    const Vec3 k2 = knee_for(h, k, a, target);
    const Eigen::Quaterniond thigh = Eigen::Quaterniond::FromTwoVectors(k - h, k2 - h);
    const Vec3 a1 = k2 + thigh * (a - k);
    const Vec3 reached = k2 + (target - k2).normalized() * (a - k).norm();
    const Eigen::Quaterniond shank = Eigen::Quaterniond::FromTwoVectors(a1 - k2, reached - k2);
    const Eigen::Matrix3d thigh_global = thigh.toRotationMatrix() * global[std::size_t(hip)].linear();
    const Eigen::Matrix3d shank_global = (shank * thigh).toRotationMatrix() * global[std::size_t(knee)].linear();
    const Eigen::Matrix3d parent = global[std::size_t(m.joints[std::size_t(hip)].parent)].linear();
    set_joint_rotation(m, hip, f, Eigen::Quaterniond(parent.transpose() * thigh_global), -1);
    set_joint_rotation(m, knee, f, Eigen::Quaterniond(thigh_global.transpose() * shank_global), -1);
    set_joint_rotation(m, foot, f, Eigen::Quaterniond(shank_global.transpose() * global[std::size_t(foot)].linear()), -1);
}

}  // namespace

Vec3 knee_for(const Vec3& hip, const Vec3& knee, const Vec3& ankle, const Vec3& target) {
    const double l1 = (knee - hip).norm(), l2 = (ankle - knee).norm();
    Vec3 toward = target - hip;
    const double d = std::clamp(toward.norm(), std::abs(l1 - l2) + 1e-9, l1 + l2 - 1e-9);
    toward.normalize();
    // The knee's side: its offset from the hip-target line, or the current bend plane's normal
    // turned into the line's perpendicular when the knee lies on the line.
    Vec3 side = (knee - hip) - (knee - hip).dot(toward) * toward;
    if (side.norm() < 1e-9 * l1) side = toward.cross((knee - hip).cross(ankle - hip)).normalized();
    if (!side.allFinite() || side.norm() < 1e-12) side = toward.unitOrthogonal();
    side.normalize();
    const double cos_a = std::clamp((l1 * l1 + d * d - l2 * l2) / (2 * l1 * d), -1.0, 1.0);
    return hip + l1 * (cos_a * toward + std::sqrt(1 - cos_a * cos_a) * side);
}

void keep_feet_planted(const Library& library, const KeyJoints& key, Spliced& spliced) {
    BvhMotion& m = spliced.motion;
    const int ease = std::max(1, int(std::lround(kEaseSeconds * library.fps)));
    for (int side = 0; side < 2; ++side) {
        std::vector<Vec3> ankle(std::size_t(m.frame_count));
        for (int f = 0; f < m.frame_count; ++f) ankle[std::size_t(f)] = m.global_transforms(f)[std::size_t(key.foot[std::size_t(side)])].translation();
        const std::vector<Vec3> target = ankle_targets(ankle, spliced.planted, side, ease);
        for (int f = 0; f < m.frame_count; ++f)
            if ((target[std::size_t(f)] - ankle[std::size_t(f)]).norm() > 0) reach(m, key, side, f, target[std::size_t(f)]);
    }
}

}  // namespace amhv::compose
