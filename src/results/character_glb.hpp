#pragma once
// An animated, skinned character as a glTF binary: the mesh in its bind pose with four joints and
// weights per vertex, the joints as a node hierarchy, their inverse bind matrices, and one
// animation ("take") that moves every joint with translation and rotation keys, one a frame.
// Written for `amhv import-bvh --body skinned` (character.glb) and read back by scenes'
// `character = ...` (src/io/character_file.hpp).
#include <filesystem>

#include "src/body/skinned_body.hpp"

namespace amhv {

void write_character_glb(const AnimatedSkin& skin, const std::filesystem::path& path);

}  // namespace amhv
