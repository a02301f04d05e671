#pragma once
// views/key_N.png: the middle frame of each key segment, every performer in its colour, seen by a
// camera that looks at the interaction (docs/method.md section 10): across the line between the
// meeting parts, turned (and, if need be, raised) only as far as it takes for no body to stand in
// front of where they meet; a ring marks that place, and a caption names the parts.
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "src/results/edit_files.hpp"

namespace amhv {

// The camera of a key view: it looks along `forward` (orthographic), `right` and `up` span the
// picture; `blocked` is how many of the meeting place's sample points a body hides from it.
struct KeyCamera {
    Vec3 forward = Vec3::UnitY(), right = Vec3::UnitX(), up = Vec3::UnitZ();
    double turn_deg = 0, raise_deg = 0;
    int blocked = 0;
};

// Where two parts meet: the closest points of their surfaces, and the horizontal direction from the
// first part to the second (between their centroids, when those lie 5 cm apart or more on the
// floor; else `fallback_direction`, the performers' own line).
struct Meeting {
    Vec3 first = Vec3::Zero(), second = Vec3::Zero();
    Eigen::Vector2d direction = Eigen::Vector2d::UnitX();
    Vec3 centre() const { return 0.5 * (first + second); }
};
Meeting find_meeting(const TriangleMesh& first, const TriangleMesh& second, const Eigen::Vector2d& fallback_direction);

// The camera: perpendicular to the meeting's direction, on the side and at the turn (0, ±10, ...
// ±80 degrees) and raise (0, 20, 40 degrees) that leave the fewest of the meeting's points (its two
// closest points and their middle) hidden by a triangle of `scene` that is not one of the meeting
// parts' (`meeting_part[t]`), the least turned and raised first.
KeyCamera choose_key_camera(const TriangleMesh& scene, const std::vector<bool>& meeting_part, const Meeting& meeting);

// result.json's "views": per key view its files, output frame, meeting gap and camera (turn,
// raise, and how many of the meeting's three points a body hides: 0 when it is in plain view).
nlohmann::ordered_json key_views_json(const std::vector<KeyView>& views, const std::vector<KeyCamera>& cameras, const std::vector<std::string>& names);

// Sets each view's frame to the output frame of its key segment where the pair's parts come
// closest (the first of equals nearest the segment's middle): a `0&0b` segment touches at some
// frame, not at its middle.
void choose_meeting_frames(const Scene& scene, std::vector<KeyView>& views, const std::vector<const std::vector<ObjectFrameEdit>*>& frames,
                           const std::vector<ObjectSource*>& sources);

// Every key view of `views` (one per key segment: its frame and its pair) from the objects'
// frames; `names[o]` and `sources[o]` for object o. Drawn on every core. Returns each view's camera.
std::vector<KeyCamera> write_key_views(const std::filesystem::path& folder, const Scene& scene, const std::vector<std::string>& names,
                     const std::vector<KeyView>& views, const std::vector<const std::vector<ObjectFrameEdit>*>& frames,
                     const std::vector<ObjectSource*>& sources);

}  // namespace amhv
