#pragma once
// Animated, skinned characters (glTF, FBX, Collada) read with assimp: the node hierarchy, the skinned
// meshes in their bind pose with up to four joint weights per vertex, and one animation sampled at a
// fixed rate into every node's local transform per frame. Skinning (src/body/character_body.hpp)
// turns a frame into a mesh.
//
// Files the character names (a glTF's buffers and images, an FBX's textures) are opened only inside
// the character file's folder; assimp never reaches outside it.
#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "src/core/geometry.hpp"

namespace amhv {

// Limits a character must keep (hostile files): joints, vertices, frames.
inline constexpr int kMaxCharacterJoints = 1024;
inline constexpr std::size_t kMaxCharacterVertices = 4'000'000;
inline constexpr int kMaxCharacterFrames = 100'000;
inline constexpr std::size_t kMaxCharacterTextureBytes = std::size_t(64) << 20;

struct CharacterNode {
    std::string name;
    int parent = -1;                  // parents come before children
    Eigen::Affine3d rest = Eigen::Affine3d::Identity();  // local transform in the file's bind pose
    bool holds_mesh = false;
};

// A bone of a skinned mesh: the node it follows and its offset (mesh space to the node's space in
// the bind pose, the inverse bind matrix).
struct CharacterBone {
    int node = -1;
    Eigen::Affine3d offset = Eigen::Affine3d::Identity();
};

// A material of the character's meshes, as scene.glb writes it back: its base colour and its base
// colour texture (PNG or JPEG bytes, embedded in the file or a file inside the character's folder).
struct CharacterMaterial {
    std::string name;
    std::array<double, 4> colour{0.8, 0.8, 0.8, 1.0};  // linear RGBA
    std::string texture_name;            // as the file names it; empty: none
    std::string texture_mime;            // "image/png" or "image/jpeg" when the texture is kept
    std::vector<unsigned char> texture;  // its bytes
    std::string texture_note;            // why a named texture was not kept ("lies outside ...")
};

struct CharacterFile {
    std::string source;
    std::vector<CharacterNode> nodes;
    std::vector<CharacterBone> bones;
    std::vector<Vec3> vertices;                           // bind pose, mesh space, the file's units and axes
    std::vector<std::array<std::uint32_t, 3>> triangles;
    std::vector<std::array<int, 4>> vertex_bones;         // into bones; -1: unused slot
    std::vector<std::array<double, 4>> vertex_weights;    // summing to 1
    std::vector<int> rigid_node;                          // per vertex of an unskinned mesh: the node it rides on; else -1
    std::vector<std::array<float, 2>> uvs;                // per vertex: texture coordinates (assimp's: v up), (0, 0) where none
    bool has_uvs = false;                                 // some mesh has texture coordinates
    std::vector<CharacterMaterial> materials;
    std::vector<int> triangle_material;                   // per triangle, into materials
    std::vector<std::string> animations;                  // every animation's name, in the file's order
    std::string animation;                                // the one sampled
    double fps = 0;
    // Per frame, per node, its local transform.
    std::vector<std::vector<Eigen::Affine3d>> frames;

    int frame_count() const { return int(frames.size()); }
    // Every node's global transform at `frame`.
    std::vector<Eigen::Affine3d> globals(int frame) const;
};

// Reads `path`; `animation`: the animation's name (required when the file holds several), `fps`:
// the sampling rate (default: the rate of the animation's keys when they are evenly spaced, as a
// baked take's are, else 30). One clear line naming the file when assimp cannot read it, when
// it holds no skinned mesh or no animation, names an animation it lacks, or breaks a limit or a
// weight rule (NaN, negative, or summing to 0 at a vertex).
CharacterFile read_character(const std::filesystem::path& path, const std::optional<std::string>& animation, std::optional<double> fps);

}  // namespace amhv
