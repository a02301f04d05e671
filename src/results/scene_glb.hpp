#pragma once
// scene.glb (docs/scenes.md, "The edited scene in one file"): the edited scene as one glTF 2.0
// binary that Blender's importer and three.js play. Frame-wise meshes may change topology every
// frame, so each output frame of each performer is its own node ("A frame 0012 src 0033"), shown
// only on its frame by a step-interpolated scale animation ("play", at A's frame rate): the common
// idiom for mesh sequences in glTF. Frames of one performer that keep their triangles share one
// index accessor. glTF is y-up: the scene's (x, y, z) is written as (x, z, -y), in metres.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "src/edit/edit.hpp"
#include "src/scene/segment.hpp"

namespace amhv {

struct SceneGlbReport {
    int nodes = 0;             // frame nodes (output frames x 2 performers)
    int index_accessors = 0;   // distinct triangle lists written
    std::uint64_t bytes = 0;   // the file's size
};

// One performer of the scene: its name, its frames and where the edit put each.
struct GlbObject {
    std::string name;
    ObjectSource* source = nullptr;
    const std::vector<ObjectFrameEdit>* frames = nullptr;  // per output frame
};

// Writes `path` (fails naming it when it cannot). `fps`: the output's frame rate.
SceneGlbReport write_scene_glb(const std::filesystem::path& path, const EditResult& edit, ObjectSource& a, ObjectSource& b, double fps);
// Any number of performers (a multi-party edit); the two-object call is this one with A and B.
SceneGlbReport write_scene_glb(const std::filesystem::path& path, const std::vector<GlbObject>& objects, double fps);

}  // namespace amhv
