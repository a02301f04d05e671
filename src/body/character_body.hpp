#pragma once
// A character performer (docs/method.md section 9, "Characters"): a skinned, animated mesh read
// with assimp (src/io/character_file.hpp), its rig's joints mapped to amhv's roles and parts, each
// frame skinned by linear blend skinning, welded, closed and cut into the same parts as the BVH
// bodies, with a view track from the head.
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "src/body/skeleton_body.hpp"
#include "src/body/skinning.hpp"
#include "src/core/geometry.hpp"
#include "src/io/character_file.hpp"
#include "src/io/mesh_sequence.hpp"

namespace amhv {

// Every vertex of the file at `frame`, in the file's units and axes: per vertex the sum over its
// bones of weight x (the bone node's global transform x its offset) x the bind position, bones in
// the order read (largest weight first); a vertex of an unskinned mesh follows its node. Skinned
// by skin_reference (src/body/skinning.hpp), as every backend skins.
std::vector<Vec3> skin_character_vertices(const CharacterFile& character, int frame);
TriangleMesh skin_character(const CharacterFile& character, int frame);

// A rig joint's name as skeleton_roles reads names: a namespace ("mixamorig:") and a Rigify layer
// prefix ("DEF-") dropped (Rigify's spine.004 to .006 named Neck, Neck1, Head), a side suffix
// ("_l", ".R") made a prefix ("Left", "Right").
std::string rig_joint_name(const std::string& name);

struct CharacterBody;
// `joint_roles`: file joint name -> role (role_vocabulary), for rigs whose names do not say.
std::shared_ptr<const CharacterBody> build_character_body(std::shared_ptr<const CharacterFile> file,
                                                          const std::map<std::string, std::string>& joint_roles = {});

// For `amhv check` and tests: the rig's joints with the role each plays and the part its vertices
// go to, the parts present, and how the surface was closed.
struct CharacterMapping {
    std::vector<std::pair<std::string, std::string>> joint_roles;  // file joint name, role
    std::vector<std::pair<std::string, std::string>> joint_parts;  // file joint name, part
    std::vector<std::string> parts;
    int capped_holes = 0, part_caps = 0;
};
const CharacterMapping& character_mapping(const CharacterBody& body);
const CharacterFile& character_file(const CharacterBody& body);
// The character's vertices as a Skinner takes them (built once).
const SkinVertices& character_skin(const CharacterBody& body);

// The body at animation frame `frame` split by part (body_part_names' order), scene axes, metres,
// skinned by the CPU reference.
std::vector<BodyPart> character_body_parts(const CharacterBody& body, int frame, const UnitsAndAxes& units);
// The same from the file's every vertex at that frame already skinned into the scene (a Skinner's
// output through skinned_points).
std::vector<BodyPart> character_body_parts(const CharacterBody& body, const std::vector<Vec3>& skinned, int frame);
// Per frame, eye and gaze from the head, as for BVH takes.
std::vector<TrackSample> character_track(const CharacterBody& body, const UnitsAndAxes& units);
// The rig's joints with their roles and per frame their global transforms (the file's units and
// axes); it refers to `body`, which must outlive it.
JointFrames character_joints(const CharacterBody& body);

}  // namespace amhv
