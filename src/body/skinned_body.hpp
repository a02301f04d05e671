#pragma once
// A realistic body for a BVH take (docs/method.md section 9, "Skinned bodies"): the CC0 Mesh2Motion
// human (data/bodies/), closed where its surface has holes, fitted to the take's skeleton (joints
// mapped by role, bones stretched to the take's lengths) and skinned per frame by linear blend
// skinning. It is split into the same parts as the capsule body (by each vertex's strongest
// joint), every part closed by caps across its cuts, so scenes work unchanged.
#include <array>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "src/core/geometry.hpp"
#include "src/io/bvh.hpp"
#include "src/io/mesh_sequence.hpp"

namespace amhv {

struct BodyPart;

// Which body a BVH object gets: capsules around the bones, or the skinned human.
enum class BodyKind { Capsules, Skinned };
BodyKind parse_body_kind(const std::string& text, const std::string& what);
std::string to_string(BodyKind kind);

// The shipped model, data/bodies/human-male.glb (AMHV_DATA_DIR overrides data/).
std::filesystem::path shipped_body_model();

// A skinned mesh as read from a glTF binary: welded by position (glTF splits vertices along UV
// seams), its holes capped, in the scene's axes (z up) and metres, in its bind pose.
struct SkinModel {
    std::string source;
    std::vector<Vec3> vertices;                          // welded vertices, then one centre per capped hole
    std::vector<std::array<std::uint32_t, 3>> triangles; // closed: holes capped by fans to their centres
    std::vector<std::array<int, 4>> joints;              // per welded vertex: model joints and weights
    std::vector<std::array<float, 4>> weights;
    std::vector<std::vector<std::uint32_t>> derived;     // per vertex past the welded ones: the loop it is the mean of
    std::vector<std::string> joint_names;
    std::vector<Vec3> joint_rest;                        // bind-pose joint positions
    std::vector<int> joint_parent;                       // per joint, its parent joint (-1: none)
    int capped_holes = 0;
    std::size_t welded_vertices() const { return joints.size(); }
};
// Reads `path` (the first skinned mesh of the first scene); fails naming the file when it is not a
// glTF binary, holds no skinned mesh, or its surface cannot be closed.
SkinModel load_skin_model(const std::filesystem::path& path);

// A model fitted to one take: per model joint the take's joint that drives it and the affine map
// from the bind pose to the take's rest pose; per part the triangles and the cut caps.
struct SkinnedFit;
std::shared_ptr<const SkinnedFit> fit_skin_model(const SkinModel& model, const BvhMotion& motion, const UnitsAndAxes& units);

// The fitted body at BVH frame `frame`, split by part (body_part_names' order), metres, z up.
std::vector<BodyPart> skinned_body_parts(const SkinnedFit& fit, const BvhMotion& motion, int frame, const UnitsAndAxes& units);

// A skinned mesh and its joints' motion, as an animated glTF holds them (src/results/character_glb.hpp):
// scene axes (z up), metres. Vertex v at frame f is sum_k weight[v][k] * global[f][j] *
// inverse_bind[j] * vertices[v] over its joints j = joints[v][k].
struct AnimatedSkin {
    std::vector<Vec3> vertices;                            // bind pose
    std::vector<std::array<std::uint32_t, 3>> triangles;   // the model's surface (its holes left open)
    std::vector<std::array<int, 4>> joints;                // per vertex
    std::vector<std::array<float, 4>> weights;
    std::vector<std::string> joint_names;                  // the take's joint roles
    std::vector<int> joint_parent;                         // parents first; -1: the root
    std::vector<Eigen::Affine3d> inverse_bind;             // per joint (it may stretch: the fit)
    std::vector<std::vector<Eigen::Isometry3d>> global;    // per frame, per joint
    double fps = 30;
};
// The fitted human driven by frames `range` of the take.
AnimatedSkin skinned_body_animation(const SkinnedFit& fit, const BvhMotion& motion, const FrameRange& range, const UnitsAndAxes& units);

// For tests and `amhv check`: how the fit went.
struct SkinnedFitSummary {
    double scale = 1;                      // uniform scale of the model to the take's height
    int part_caps = 0;                     // caps across the parts' cuts
    int capped_holes = 0;                  // holes of the model closed
    std::vector<std::string> joint_roles;  // per model joint, the take's joint role driving it
};
SkinnedFitSummary summarise(const SkinnedFit& fit);

}  // namespace amhv
