#include "src/propose/events.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "src/body/skeleton_roles.hpp"
#include "src/core/error.hpp"
#include "src/compose/features.hpp"

namespace amhv::propose {

namespace {

int frames_of(double seconds, double fps) { return std::max(1, int(std::lround(seconds * fps))); }

// |p(f + h) - p(f - h)| / (2h / fps), clamped to the track's ends.
std::vector<double> speeds(const std::vector<Vec3>& p, double fps, int h, bool planar) {
    const int n = int(p.size());
    std::vector<double> out(p.size(), 0.0);
    for (int f = 0; f < n; ++f) {
        const int a = std::max(0, f - h), b = std::min(n - 1, f + h);
        if (a == b) continue;
        Vec3 d = p[std::size_t(b)] - p[std::size_t(a)];
        if (planar) d.z() = 0;
        out[std::size_t(f)] = d.norm() * fps / double(b - a);
    }
    return out;
}

std::vector<ContactEvent> slaps(const HandTrack& t, Hand hand) {
    const int h = frames_of(kSpanSeconds / 2, t.fps), n = t.frames(), near = frames_of(kImpactSeconds, t.fps);
    const std::vector<double> s = speeds(t.hand[int(hand)], t.fps, h, false);
    std::vector<double> decel(s.size(), 0.0);
    for (int f = h; f + h < n; ++f) decel[std::size_t(f)] = (s[std::size_t(f - h)] - s[std::size_t(f + h)]) * t.fps / double(2 * h);
    std::vector<ContactEvent> out;
    const int half = frames_of(kSlapHalfSeconds, t.fps);
    for (int f = h; f + h < n; ++f) {
        const double d = decel[std::size_t(f)];
        if (d < kImpactDeceleration || s[std::size_t(f - h)] < kSlapSpeed) continue;
        bool strongest = true;
        for (int g = std::max(0, f - near); g <= std::min(n - 1, f + near) && strongest; ++g)
            strongest = decel[std::size_t(g)] < d || (decel[std::size_t(g)] == d && g >= f);
        if (!strongest) continue;
        ContactEvent e;
        e.hand = hand;
        e.variant = 'b';
        e.moment = t.first + f;
        e.first = t.first + std::max(0, f - half);
        e.last = t.first + std::min(n - 1, f + half);
        e.strength = d;
        e.why = fmt::format("{} arrives at {:.2f} m/s and loses speed at {:.0f} m/s^2 at frame {}", hand_part(hand), s[std::size_t(f - h)], d, e.moment);
        out.push_back(e);
    }
    return out;
}

// The runs of standing frames at least kMinHoldSeconds long, one event per hand.
std::vector<ContactEvent> holds(const HandTrack& t) {
    const int n = t.frames();
    const std::vector<double> root = speeds(t.hips, t.fps, frames_of(kStandSeconds / 2, t.fps), true);
    std::vector<ContactEvent> out;
    const int shortest = frames_of(kMinHoldSeconds, t.fps);
    for (int f = 0; f < n;) {
        if (root[std::size_t(f)] >= kStandSpeed) {
            ++f;
            continue;
        }
        int g = f;
        while (g + 1 < n && root[std::size_t(g + 1)] < kStandSpeed) ++g;
        if (g - f + 1 >= shortest)
            for (Hand hand : {Hand::Left, Hand::Right}) {
                ContactEvent e;
                e.hand = hand;
                e.variant = 'a';
                e.first = e.moment = t.first + f;
                e.last = t.first + g;
                e.strength = double(g - f + 1) / t.fps;
                e.why = fmt::format("stands (root under {:.1f} m/s) over frames {}-{}, {} free", kStandSpeed, e.first, e.last, hand_part(hand));
                out.push_back(e);
            }
        f = g + 1;
    }
    return out;
}

}  // namespace

const char* hand_part(Hand hand) { return hand == Hand::Left ? "left_hand" : "right_hand"; }

HandTrack hand_track(const BvhMotion& motion, const UnitsAndAxes& units, int first, int last, const std::string& source) {
    const compose::KeyJoints key = compose::key_joints(role_names(motion), source);
    const compose::PoseTrack poses = compose::pose_track(motion, units, key);
    HandTrack t;
    t.fps = motion.fps();
    t.first = first;
    for (int f = first; f <= last; ++f) {
        const auto& joints = poses.joints[std::size_t(f)];
        t.hips.push_back(joints[std::size_t(key.hips)]);
        for (int s = 0; s < 2; ++s) t.hand[s].push_back(joints[std::size_t(key.hand[s])]);
    }
    return t;
}

HandTrack hand_track(const JointFrames& joints, const UnitsAndAxes& units, double fps, int first, int last) {
    auto find = [&](const char* role) {
        const auto at = std::find(joints.roles.begin(), joints.roles.end(), role);
        if (at == joints.roles.end()) fail(joints.source, "no joint plays the role {}: amhv propose follows the hips and both hands", role);
        return std::size_t(at - joints.roles.begin());
    };
    const std::size_t hips = find("Hips"), hands[2] = {find("LeftHand"), find("RightHand")};
    HandTrack t;
    t.fps = fps;
    t.first = first;
    for (int f = first; f <= last; ++f) {
        const std::vector<Eigen::Affine3d> globals = joints.globals(f);
        t.hips.push_back(to_scene_point(globals[hips].translation(), units));
        for (int s = 0; s < 2; ++s) t.hand[s].push_back(to_scene_point(globals[hands[s]].translation(), units));
    }
    return t;
}

std::vector<ContactEvent> contact_events(const HandTrack& track) {
    std::vector<ContactEvent> out;
    for (Hand hand : {Hand::Left, Hand::Right})
        for (ContactEvent& e : slaps(track, hand)) out.push_back(std::move(e));
    for (ContactEvent& e : holds(track)) out.push_back(std::move(e));
    std::stable_sort(out.begin(), out.end(), [](const ContactEvent& a, const ContactEvent& b) { return a.moment < b.moment; });
    return out;
}

}  // namespace amhv::propose
