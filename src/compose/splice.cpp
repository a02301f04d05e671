#include "src/compose/splice.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "src/compose/feet.hpp"
#include "src/compose/features.hpp"
#include "src/core/error.hpp"

namespace amhv::compose {

namespace {

// One frame as splicing sees it: the root's position channels and every joint's rotation.
struct Pose {
    Vec3 root = Vec3::Zero();
    std::vector<Eigen::Quaterniond> rotations;
};

Vec3 root_position(const BvhMotion& m, int frame) {
    const BvhJoint& root = m.joints.front();
    const double* row = m.values.data() + std::size_t(frame) * std::size_t(m.channel_count);
    Vec3 p = Vec3::Zero();
    for (std::size_t c = 0; c < root.channels.size(); ++c)
        if (int(root.channels[c]) < 3) p[int(root.channels[c])] = row[std::size_t(root.first_channel) + c];
    return p;
}

void set_root_position(BvhMotion& m, int frame, const Vec3& p) {
    const BvhJoint& root = m.joints.front();
    double* row = m.values.data() + std::size_t(frame) * std::size_t(m.channel_count);
    for (std::size_t c = 0; c < root.channels.size(); ++c)
        if (int(root.channels[c]) < 3) row[std::size_t(root.first_channel) + c] = p[int(root.channels[c])];
}

Pose pose_of(const BvhMotion& m, int frame) {
    Pose pose;
    pose.root = root_position(m, frame);
    for (std::size_t j = 0; j < m.joints.size(); ++j) pose.rotations.push_back(joint_rotation(m, int(j), frame));
    return pose;
}

// The key joints' positions (file units) at frames around `frame`, clamped to [first, last].
std::vector<Vec3> window_points(const BvhMotion& m, const KeyJoints& key, int frame, int first, int last, int half, const FloorMove* move, int up) {
    const std::vector<int> joints = key.with_hips();
    std::vector<Vec3> out;
    for (int o = -half; o <= half; ++o) {
        const auto global = m.global_transforms(std::clamp(frame + o, first, last));
        for (int j : joints) out.push_back(move ? move->apply(global[std::size_t(j)].translation(), up) : Vec3(global[std::size_t(j)].translation()));
    }
    return out;
}

Eigen::Quaterniond part_of(const Eigen::Quaterniond& q, double t) { return Eigen::Quaterniond::Identity().slerp(t, q); }

// Blends across the splice between composed frames `end` (the last of the earlier clip) and
// `end + 1` (the second frame of the later one; its first, `next`, merges with `end`).
void blend(std::vector<Pose>& poses, int end, const Pose& next, int w) {
    const Pose& last = poses[std::size_t(end)];
    const Vec3 step = next.root - last.root;
    std::vector<Eigen::Quaterniond> turn(last.rotations.size());
    for (std::size_t j = 0; j < turn.size(); ++j) turn[j] = (next.rotations[j] * last.rotations[j].inverse()).normalized();
    for (int k = 0; k < w; ++k) {
        const double t = 0.5 * (1.0 - double(k) / w);
        Pose& before = poses[std::size_t(end - k)];
        before.root += t * step;
        for (std::size_t j = 0; j < turn.size(); ++j) before.rotations[j] = (part_of(turn[j], t) * before.rotations[j]).normalized();
    }
    for (int k = 1; k <= w; ++k) {
        const double t = 0.5 * (1.0 - double(k) / w);
        Pose& after = poses[std::size_t(end + k)];
        after.root -= t * step;
        for (std::size_t j = 0; j < turn.size(); ++j) after.rotations[j] = (part_of(turn[j].inverse(), t) * after.rotations[j]).normalized();
    }
}


// Writes every pose into its frame's row (the row holds the source frame's values, so each
// angle stays nearest the representation the capture used).
void write_poses(BvhMotion& m, const std::vector<Pose>& poses) {
    for (std::size_t f = 0; f < poses.size(); ++f) {
        set_root_position(m, int(f), poses[f].root);
        for (std::size_t j = 0; j < m.joints.size(); ++j)
            if (!m.joints[j].end_site) set_joint_rotation(m, int(j), int(f), poses[f].rotations[j], -1);
    }
}

}  // namespace

int up_index(const UnitsAndAxes& units) { return units.up == UpAxis::X ? 0 : units.up == UpAxis::Y ? 1 : 2; }

Vec3 FloorMove::apply(const Vec3& p, int up) const { return rotation(up) * p + shift; }

Eigen::Quaterniond FloorMove::rotation(int up) const { return Eigen::Quaterniond(Eigen::AngleAxisd(angle, Vec3::Unit(up))); }

FloorMove align_on_floor(const std::vector<Vec3>& p, const std::vector<Vec3>& q, int up) {
    // In the floor plane's axes a = up + 1, b = up + 2 (right-handed about up): the turn that best
    // maps the centred q onto the centred p, then the shift between the centroids.
    const int a = (up + 1) % 3, b = (up + 2) % 3;
    Vec3 cp = Vec3::Zero(), cq = Vec3::Zero();
    for (std::size_t i = 0; i < p.size(); ++i) cp += p[i], cq += q[i];
    cp /= double(p.size());
    cq /= double(q.size());
    double dot = 0, cross = 0;
    for (std::size_t i = 0; i < p.size(); ++i) {
        const Vec3 u = p[i] - cp, v = q[i] - cq;
        dot += u[a] * v[a] + u[b] * v[b];
        cross += v[a] * u[b] - v[b] * u[a];
    }
    FloorMove move;
    move.angle = std::atan2(cross, dot);
    move.shift = cp - move.rotation(up) * cq;
    move.shift[up] = 0;
    return move;
}

std::vector<std::array<bool, 2>> planted_feet(const Library& library, const BvhMotion& motion) {
    const KeyJoints key = key_joints(library.roles, library.file.string());
    const int up = up_index(library.units);
    const double metres = library.units.metres_per_unit;
    std::vector<std::array<Vec3, 2>> ankle(std::size_t(motion.frame_count));
    double lowest = std::numeric_limits<double>::infinity();
    for (int f = motion.first_frame; f < motion.frame_count; ++f) {
        const auto global = motion.global_transforms(f);
        for (int s = 0; s < 2; ++s) {
            ankle[std::size_t(f)][std::size_t(s)] = global[std::size_t(key.foot[s])].translation() * metres;
            lowest = std::min(lowest, ankle[std::size_t(f)][std::size_t(s)][up]);
        }
    }
    const int span = std::max(1, int(std::lround(kVelocitySpan * library.fps / 2)));
    std::vector<std::array<bool, 2>> planted(std::size_t(motion.frame_count), {false, false});
    for (int f = motion.first_frame; f < motion.frame_count; ++f) {
        const int a = std::max(motion.first_frame, f - span), b = std::min(motion.frame_count - 1, f + span);
        for (std::size_t s = 0; s < 2; ++s) {
            const double speed = (ankle[std::size_t(b)][s] - ankle[std::size_t(a)][s]).norm() * library.fps / double(b - a);
            planted[std::size_t(f)][s] = speed < kPlantSpeed && ankle[std::size_t(f)][s][up] < lowest + kPlantHeight;
        }
    }
    return planted;
}

Spliced splice(const Library& library, const std::vector<Clip>& pieces) {
    // Pieces that continue one another in the same take play on as one clip.
    std::vector<Clip> clips;
    for (const Clip& piece : pieces) {
        if (!clips.empty() && clips.back().take == piece.take && clips.back().last + 1 == piece.first) clips.back().last = piece.last;
        else clips.push_back(piece);
    }
    const KeyJoints key = key_joints(library.roles, library.file.string());
    const int up = up_index(library.units);
    const int w = std::max(1, int(std::lround(kBlendSeconds * library.fps)));
    Spliced out;
    out.motion = library.takes.front().motion;
    std::vector<Pose> poses;
    std::vector<std::pair<int, Pose>> joins;  // the earlier clip's last composed frame, the later clip's first pose
    std::vector<std::vector<std::array<bool, 2>>> plants(library.takes.size());
    FloorMove move;
    for (std::size_t k = 0; k < clips.size(); ++k) {
        const Clip& clip = clips[k];
        const LibraryTake& take = library.takes[std::size_t(clip.take)];
        const int needed = 1 + (k > 0 ? w : 0) + (k + 1 < clips.size() ? w : 0);
        if (clip.last - clip.first + 1 < needed)
            fail(library.file.string(), "a clip of take '{}' (frames {}..{}) is shorter than the {} frames its splices blend", take.name, clip.first, clip.last, needed);
        if (plants[std::size_t(clip.take)].empty()) plants[std::size_t(clip.take)] = planted_feet(library, take.motion);
        if (k > 0) {
            const Clip& before = clips[k - 1];
            const LibraryTake& earlier = library.takes[std::size_t(before.take)];
            const FloorMove previous = move;
            move = align_on_floor(window_points(earlier.motion, key, before.last, earlier.first, earlier.last, w, &previous, up),
                                  window_points(take.motion, key, clip.first, take.first, take.last, w, nullptr, up), up);
        }
        const Vec3 offset = take.motion.joints.front().offset;
        for (int f = clip.first; f <= clip.last; ++f) {
            Pose pose = pose_of(take.motion, f);
            pose.root = move.apply(pose.root + offset, up) - offset;
            pose.rotations.front() = (move.rotation(up) * pose.rotations.front()).normalized();
            if (k > 0 && f == clip.first) {  // merges with the earlier clip's last frame
                joins.emplace_back(int(poses.size()) - 1, std::move(pose));
                out.splices.push_back(int(poses.size()));
                continue;
            }
            poses.push_back(std::move(pose));
            out.source.push_back({clip.take, f});
            out.planted.push_back(plants[std::size_t(clip.take)][std::size_t(f)]);
        }
    }
    for (const auto& [end, next] : joins) blend(poses, end, next, w);
    BvhMotion& m = out.motion;
    m.frame_count = int(poses.size());
    m.first_frame = 0;
    m.values.assign(poses.size() * std::size_t(m.channel_count), 0.0);
    for (std::size_t f = 0; f < poses.size(); ++f) {
        const BvhMotion& from = library.takes[std::size_t(out.source[f][0])].motion;
        std::copy_n(from.values.begin() + std::ptrdiff_t(std::size_t(out.source[f][1]) * std::size_t(m.channel_count)), m.channel_count,
                    m.values.begin() + std::ptrdiff_t(f * std::size_t(m.channel_count)));
    }
    write_poses(m, poses);
    keep_feet_planted(library, key, out);
    return out;
}

}  // namespace amhv::compose
