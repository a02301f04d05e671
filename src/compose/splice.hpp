#pragma once
// Splicing clips of a library into one take (after the splicing document, section 5.2, in 3D):
// each clip is turned and moved on the floor so that it continues where the previous one ends,
// the joint rotations and the root are blended across each splice, and planted feet stay planted.
#include <array>
#include <vector>

#include <Eigen/Geometry>

#include "src/compose/library.hpp"

namespace amhv::compose {

// The blend: kBlendSeconds on each side of a splice (0.4 s in all, about half a step); a clip
// shorter than two of them plus a frame cannot be spliced.
inline constexpr double kBlendSeconds = 0.2;
// A foot is planted while its ankle moves slower than kPlantSpeed (m/s) within kPlantHeight (m)
// of the lowest the take's ankles go; corrections that keep it planted fade in and out over
// kEaseSeconds.
inline constexpr double kPlantSpeed = 0.15, kPlantHeight = 0.05, kEaseSeconds = 0.1;

struct Clip {
    int take = 0;
    int first = 0, last = 0;  // frames of the take at the library's clock, inclusive
};

// A turn about the up axis and a shift on the floor plane, in file units: q -> R q + shift.
struct FloorMove {
    double angle = 0;
    Vec3 shift = Vec3::Zero();  // no component along up
    Vec3 apply(const Vec3& p, int up) const;
    Eigen::Quaterniond rotation(int up) const;
};
// The floor move that brings the points q onto the points p best (least squares; heights kept).
FloorMove align_on_floor(const std::vector<Vec3>& p, const std::vector<Vec3>& q, int up);
int up_index(const UnitsAndAxes& units);  // the file's up axis: 0 x, 1 y, 2 z

struct Spliced {
    BvhMotion motion;                          // the first take's skeleton, the library's clock
    std::vector<std::array<int, 2>> source;    // per frame: take, frame
    std::vector<int> splices;                  // frames where a clip starts (after the first)
    std::vector<std::array<bool, 2>> planted;  // per frame: left, right foot planted
};

// The clips in order, spliced. Throws amhv::Error when a clip is too short to blend.
Spliced splice(const Library& library, const std::vector<Clip>& clips);

// Per frame of the take (every frame of its motion): whether each foot is planted.
std::vector<std::array<bool, 2>> planted_feet(const Library& library, const BvhMotion& motion);

}  // namespace amhv::compose
