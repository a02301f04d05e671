#pragma once
// Files of the edited scene (docs/method.md section 10): per-frame transforms, the transformed meshes of
// every output frame, and a top view of the original and edited root paths.
#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "src/edit/edit.hpp"
#include "src/results/paths_picture.hpp"
#include "src/scene/scene.hpp"
#include "src/scene/segment.hpp"

namespace amhv {

// Object colours in meshes and pictures: A orange, B blue, then green, purple, yellow, red (cycling).
inline constexpr std::array<std::array<std::uint8_t, 3>, 6> kObjectColours{
    {{230, 120, 40}, {40, 120, 230}, {60, 170, 80}, {150, 80, 190}, {220, 190, 40}, {200, 60, 90}}};
inline constexpr std::array<const char*, 6> kObjectColourNames{"orange", "blue", "green", "purple", "yellow", "red"};

// A pinhole camera at a performer's eye (docs/method.md section 10): the visibility cone's
// half-angle reaches a circle of 170 pixels (kCone) around the picture's centre.
struct EyeCamera {
    Vec3 eye, forward, right, up;
    double focal = 1;  // pixels per unit of tangent
};

// Eye and gaze of an object at one output frame `e` in the scene: from its view track, else 10 cm
// below the top of its placed body `placed` above its root, looking along its edited facing.
EyeCamera eye_camera(const ObjectFrameEdit& e, ObjectSource& source, const TriangleMesh& placed, double half_angle_deg);

// Draws `other` as the camera sees it (far triangles first, those behind the eye left out; faces
// [faces_from[r], faces_from[r + 1]) in the colour of object colours[r]), the floor grid and the
// cone's circle; writes `path`.
void draw_eye_view(const std::filesystem::path& path, const EyeCamera& c, const TriangleMesh& other, const std::vector<std::size_t>& faces_from,
                   const std::vector<std::size_t>& colours, const std::string& caption);

// One object's transform at one output frame, as transforms.json gives it.
nlohmann::ordered_json frame_transform_json(const ObjectFrameEdit& e);

// transforms.json: for every output frame and object, the source frame and capture -> scene as
// x, y, yaw and as a row-major 4x4 matrix.
void write_transforms_json(const std::filesystem::path& path, const Scene& scene, const EditResult& edit);

// frames.csv: per output frame, the check of both whole bodies (docs/scenes.md):
// frame,segment,overlap_voxels,overlap_cm3,gap_mm (gap empty when farther than kGapReach).
void write_frame_checks_csv(const std::filesystem::path& path, const EditResult& edit);

// `folder`/NNNN.ply, one binary PLY per output frame holding both objects' transformed meshes: A's
// vertices first, coloured orange (230, 120, 40), then B's, blue (40, 120, 230); the header's
// comments give each object's vertex and face ranges. Returns the number of files.
int write_scene_frames(const std::filesystem::path& folder, const EditResult& edit, ObjectSource& a, ObjectSource& b);

// The key views and eye views of a two-object edit, at the frame of each key segment where the
// parts meet (src/results/key_views.hpp). Returns result.json's "views".
nlohmann::ordered_json write_key_and_eye_views(const std::filesystem::path& folder, const Scene& scene, const EditResult& edit, ObjectSource& a, ObjectSource& b);

// `folder`/key_N_from_A.png and key_N_from_B.png: the paper's first-person views (its Fig. 8) at
// the middle output frame of key segment N: from each performer's eye (its view track, moved with
// it) along its gaze, the other performer shaded, the floor grid, and the visibility cone's
// half-angle as a circle around the centre.
// A key segment's view: the output frame `frame` it shows (its middle, until choose_meeting_frames
// picks the frame where the pair's parts come closest), the segment's output frames
// [first_frame, last_frame], and its pair (indices of the objects).
struct KeyView {
    int key = 0, frame = 0;
    std::size_t first = 0, second = 0;
    int first_frame = 0, last_frame = -1;
};
// The same for any number of objects: `folder`/key_N_from_NAME.png for each of a key view's pair,
// every other object in its colour; `frames[o]` is object o's per output frame.
void write_eye_views(const std::filesystem::path& folder, const Scene& scene, const std::vector<std::string>& names, const std::vector<KeyView>& views,
                     const std::vector<const std::vector<ObjectFrameEdit>*>& frames, const std::vector<ObjectSource*>& sources);

// `folder`/NAME.glb for each object of `names` that is a character: the character animated as the
// edit plays it (its root moved, the rest as read; src/results/character_glb.hpp); returns the names
// written.
std::vector<std::string> write_edited_characters(const std::filesystem::path& folder, const std::vector<std::string>& names,
                                                 const std::vector<const std::vector<ObjectFrameEdit>*>& frames,
                                                 const std::vector<ObjectSource*>& sources);

// `folder`/A.bvh and B.bvh for the objects read from BVH takes: one frame per output frame (the
// scene's rate), each the source frame's channels with the root's position and rotation rewritten
// to carry the edit (in the file's own units and axes); every other channel untouched. A root
// without three position and three rotation channels cannot carry it: no file. Returns the names.
std::vector<std::string> write_edited_bvh(const std::filesystem::path& folder, const EditResult& edit, ObjectSource& a, ObjectSource& b);
// The same for any number of objects: NAME.bvh for each object of `names` whose source is a BVH
// take, over its frames (`frames[o]`, per output frame).
std::vector<std::string> write_edited_bvh(const std::filesystem::path& folder, const std::vector<std::string>& names,
                                          const std::vector<const std::vector<ObjectFrameEdit>*>& frames, const std::vector<ObjectSource*>& sources);

// paths.svg and paths.png for a two-object edit (src/results/paths_picture.hpp).
void write_paths_picture(const std::filesystem::path& svg, const std::filesystem::path& png, const EditResult& edit);

}  // namespace amhv
