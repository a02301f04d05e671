#pragma once
// BVH motion capture files: hierarchy (any channel order, end sites) and motion block.
// Tolerates CRLF/LF mixes, tabs and odd whitespace; malformed files give an error with the line.
#include <filesystem>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "core/geometry.hpp"

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

    int joint_index(const std::string& name) const;  // -1 if absent
    // Global transform of every joint at `frame`, in file units and axes.
    std::vector<Eigen::Isometry3d> global_transforms(int frame) const;
};

BvhMotion read_bvh(const std::filesystem::path& path);

}  // namespace amhv
