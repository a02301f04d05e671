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

// Writes `path` (fails naming it when it cannot) for any number of performers (an edit's A and
// B, or a multi-party edit's). `fps`: the output's frame rate.
SceneGlbReport write_scene_glb(const std::filesystem::path& path, const std::vector<GlbObject>& objects, double fps);

// Per output frame and performer, its mesh placed in the scene (empty for a performer with OBJ
// appearance, whose files are read as the scene is written): what writing scene.glb reads of the
// object sources, gathered first, so that the rest can run beside other work that uses them (an
// ObjectSource caches, one thread at a time).
using GlbMeshes = std::vector<std::vector<TriangleMesh>>;
GlbMeshes gather_glb_meshes(const std::vector<GlbObject>& objects);
// Writes `path` from meshes gathered by gather_glb_meshes(objects); reads no ObjectSource but
// through const calls.
SceneGlbReport write_scene_glb(const std::filesystem::path& path, const std::vector<GlbObject>& objects, const GlbMeshes& meshes, double fps);

}  // namespace amhv
