#pragma once
// An animated, skinned character as a glTF binary: the mesh in its bind pose with four joints and
// weights per vertex, the joints as a node hierarchy, their inverse bind matrices, and one
// animation ("take") that moves every joint with translation and rotation keys, one a frame.
// Written for `amhv import-bvh --body skinned` (character.glb) and read back by scenes'
// `character = ...` (src/io/character_file.hpp).
#include <filesystem>

#include <vector>

#include "src/body/skinned_body.hpp"
#include "src/io/character_file.hpp"
#include "src/io/mesh_sequence.hpp"

namespace amhv {

void write_character_glb(const AnimatedSkin& skin, const std::filesystem::path& path);

// An edited character: the file's node hierarchy, skin and bind pose as read, under one top node
// that takes the file's units and axes to glTF's (metres, y up) with the floor lift; output frame k
// plays the file's frame sources[k] with its root node moved by edits[k] (the edit in the file's
// own axes and units), every other node's keys as they are. False (nothing written) when two
// meshes bind one joint differently, which one skin cannot hold.
bool write_edited_character_glb(const CharacterFile& file, const UnitsAndAxes& units, const std::vector<int>& sources,
                                const std::vector<Eigen::Isometry3d>& edits, double fps, const std::filesystem::path& path);

}  // namespace amhv
