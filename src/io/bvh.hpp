#pragma once
// BVH motion capture files: hierarchy (any channel order, end sites) and motion block.
// Tolerates CRLF/LF mixes, tabs and odd whitespace; malformed files give an error with the line.
#include <array>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Geometry>

#include "src/core/geometry.hpp"

namespace amhv {

struct BvhJoint {
    enum class Channel { XPosition, YPosition, ZPosition, XRotation, YRotation, ZRotation };
    std::string name;  // "<parent>_end" for end sites
    int parent = -1;
    Vec3 offset = Vec3::Zero();
    std::vector<Channel> channels;
    int first_channel = 0;  // index of its first value in a frame's row
    bool end_site = false;
};

struct BvhMotion {
    std::string source;
    std::vector<BvhJoint> joints;  // parents come before children
    int channel_count = 0;
    int frame_count = 0;
    double frame_time = 0;          // seconds
    std::vector<double> values;     // frame_count x channel_count
    // Frames before this one are not part of the take (a converter's T-pose): they stay in
    // `values` so frame numbers keep their meaning, but nothing uses them.
    int first_frame = 0;

    // Frames per second. Files round the frame time (CMU: .0083333), so a rate within 1e-4 of a
    // whole number is taken as that number.
    double fps() const;

    int joint_index(const std::string& name) const;  // -1 if absent
    // Global transform of every joint at `frame`, in file units and axes.
    std::vector<Eigen::Isometry3d> global_transforms(int frame) const;
};

// Reads and validates a file: one ROOT, joint names unique, every motion row on one line with
// exactly the channels the hierarchy declares, finite values, sizes within reason.
BvhMotion read_bvh(const std::filesystem::path& path);

// True when frame 0 is a converter's T-pose rather than captured motion: the root is
// unrotated and every rotation is a whole number of degrees (CMU's MotionBuilder-friendly files
// start with such a T-pose), while frame 1 has fractional rotations.
bool starts_with_tpose(const BvhMotion& motion);

// What to do with such a frame 0: detect it, always skip frame 0, or keep it.
enum class TPose { Auto, Skip, Keep };
TPose parse_tpose(const std::string& text, const std::string& what);
std::string_view to_string(TPose mode);

// The motion at `fps` frames per second on the file's clock: frame k is the pose at k / fps
// seconds, interpolated between the two nearest captured frames (positions linearly, joints with
// three rotation channels by quaternion slerp, others per channel). Frame numbers therefore mean
// the same moment at any rate; first_frame moves to the first frame at or after the old one.
BvhMotion resample_bvh(const BvhMotion& motion, double fps);

// The file text of `motion`: its hierarchy (end sites as "End Site") and every frame of `values`,
// six decimals; read_bvh reads it back.
std::string bvh_text(const BvhMotion& motion);

// Rotation channel values in degrees for three rotation axes (0 x, 1 y, 2 z, applied in listed
// order, R = R(axes[0]) R(axes[1]) R(axes[2])) that give `rotation`: of the two solutions, the one
// nearest `near` (degrees), each angle moved by whole turns towards it, so edited channels do not
// flip between representations.
std::array<double, 3> euler_degrees_near(const Eigen::Matrix3d& rotation, const std::array<int, 3>& axes, const std::array<double, 3>& near);

// The rotation a joint's rotation channels give at `frame` (identity without any), and the
// reverse: its rotation channels set to `rotation` (a joint with three distinct rotation channels),
// each angle nearest the same channel's value in frame `near_frame` (or its own value when
// near_frame < 0), so edited takes do not flip between Euler representations.
Eigen::Quaterniond joint_rotation(const BvhMotion& motion, int joint, int frame);
void set_joint_rotation(BvhMotion& motion, int joint, int frame, const Eigen::Quaterniond& rotation, int near_frame);

// read_bvh, then the T-pose rule and, when fps is given and differs from the file's
// rate, resample_bvh: how scenes, `amhv mhv --bvh` and `amhv import-bvh` all load a take.
struct BvhLoadOptions {
    TPose tpose = TPose::Auto;
    double fps = 0;  // 0: the file's own rate
};
BvhMotion load_bvh(const std::filesystem::path& path, const BvhLoadOptions& options);

}  // namespace amhv
