#pragma once
// Scene files (docs/method.md section 9): a human-written TOML file that describes the two objects,
// their parts, the key segment pairs, the sampling and the weights. Everything is validated before
// any work, and every error names the file, the line and the key.
#include <array>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "src/body/skinned_body.hpp"
#include "src/core/geometry.hpp"
#include "src/io/bvh.hpp"
#include "src/io/character_file.hpp"
#include "src/io/mesh_sequence.hpp"
#include "src/sweep/interaction.hpp"

namespace amhv {

// A volume of interest or fidelity volume of one object in one key segment.
struct PartSpec {
    enum class Kind { Whole, WholeMinusInterest, Meshes, Parts, PartsExcept, Box } kind = Kind::Whole;
    std::string meshes;               // Meshes: folder or pattern, frame numbers as the object's
    std::vector<std::string> labels;  // Parts / PartsExcept
    Box3 box;                         // Box: metres, z up, in the object's capture frame
    std::string describe() const;
};

struct Placement {
    double x = 0, y = 0, yaw_deg = 0;
};

struct SceneObject {
    std::string name;                  // the key of [objects.NAME]: "A", "B", ...
    bool anchor = false;               // the object that stays fixed (docs/method.md section 11)
    std::string meshes;                // folder or printf pattern (resolved path), or
    std::string bvh;                   // a BVH file: a body built from the bones, or
    std::string character;             // an animated, skinned character (glTF, FBX, Collada; src/body/character_body.hpp)
    std::shared_ptr<const CharacterFile> character_file;  // as the scene's reading read it (objects share it: read once)
    std::optional<std::string> animation;  // character: the animation to play (required when the file holds several)
    std::map<std::string, std::string> joint_roles;  // character: joint name -> role, for rigs whose names do not say
    BodyKind body = BodyKind::Capsules;  // BVH: capsules around the bones, or the skinned human
    UnitsAndAxes units;                // unit, up / axes, and (floor) the lift that puts the floor at z = 0
    // floor: a height in the scene's axes (units.lift = -floor), or "auto" (floor_auto: a low
    // percentile of the frames' lowest points, found when the object's frames are read).
    std::optional<double> floor_m;
    bool floor_auto = false;
    double fps = 25;                   // a BVH is resampled to it (default: the file's rate); a character sampled at it (default 30)
    TPose tpose = TPose::Auto;         // BVH: skip or keep frame 0 (resolved from auto when loaded)
    std::string labels;                // optional per-vertex part labels (pattern of text files)
    std::string track;                 // optional CSV: frame, eye xyz, gaze xyz (object units/axes)
    // The folder every file the meshes name (an OBJ's mtllib, an MTL's textures) must lie in; empty:
    // each mesh file's own folder (src/io/obj_appearance.hpp, confined_reference).
    std::filesystem::path files_root;
    std::optional<double> facing_deg;  // constant facing when there is no track
    Placement placement;               // editor's initial placement of the capture frame in the scene
    int frame_first = 0, frame_last = -1;  // frame numbers available (inclusive)
};

// The file or pattern an object is read from: its meshes, its BVH take or its character.
inline const std::string& object_source_path(const SceneObject& o) { return !o.bvh.empty() ? o.bvh : !o.character.empty() ? o.character : o.meshes; }

struct VisibilitySpec {
    bool enabled = false;
    double half_angle_deg = 30;
    double range = 0;  // metres; 0 = unlimited
    // Each cone at frame t (from the track at t) against the other's body at frame t, on at least
    // this fraction of the frames; off: the cones over the segment against the swept bodies.
    bool per_frame = false;
    double frames = 1;
};

// The editor's intent for a key segment (docs/method.md section 7, "Intent"): the descriptors it
// prefers (a term of the DP's unary cost) and hard bounds on them (poses outside are rejected).
struct Intent {
    std::optional<double> distance_m, theta_a_deg, theta_b_deg;  // prefer: any subset
    double weight = 1;
    std::optional<std::array<double, 2>> distance_limits_m, theta_a_limits_deg, theta_b_limits_deg;  // limits: any subset
    bool prefers() const { return distance_m || theta_a_deg || theta_b_deg; }
    bool limits() const { return distance_limits_m || theta_a_limits_deg || theta_b_limits_deg; }
    // visit(scene key, bounds) for each limit, in the file's order.
    template <typename Visit>
    void for_each_limit(Visit&& visit) const {
        visit("distance_m", distance_limits_m);
        visit("thetaA_deg", theta_a_limits_deg);
        visit("thetaB_deg", theta_b_limits_deg);
    }
};

struct KeySegment {
    int index = 0;  // 1-based, in file order
    // The pair's objects: the first is placed before the second (the anchor first). In a two-object
    // scene they are [anchor, other] by default; below, "A" is pair[0] and "B" is pair[1].
    std::array<std::string, 2> pair{"A", "B"};
    std::array<int, 2> a{}, b{};  // inclusive frame numbers in A and in B
    InteractionType type;
    int tolerance = 0;
    // For real captures (docs/method.md section 5a): A's interest part grown by this radius
    // (metres); 0&0 (a) on at least this fraction of the frames; B raised or lowered within z_range.
    double contact_tolerance = 0;
    double contact_frames = 1;
    std::optional<std::array<double, 2>> z_range;
    VisibilitySpec visibility;
    PartSpec interest_a, interest_b, fidelity_a, fidelity_b;
    Intent intent;
    int line = 0;  // in the scene file
};

struct Sampling {
    double voxel = 0.01;
    double angle_step_deg = 2.0;
    std::optional<std::array<double, 2>> x_range, y_range;
    int angles() const;
};

struct Weights {
    double lambda = 1.0;  // facing vs position
    double delta = 0.5;   // acceleration vs velocity in path optimisation
    double alpha = 20.0;  // steepness of the speed weights
    double v_c = 0.02;    // metres per frame
    double r_c = 0.05;    // radians per frame
    double w_a = 1.0, w_b = 1.0;
    double mu = 1e-6;     // tie-breaking prior toward the editor's placement
    double natural = 10;  // the natural choice's weight (docs/method.md section 7b); 0: off
    std::vector<double> a_rotations_deg{0.0};
};

struct Scene {
    std::filesystem::path file;
    Sampling sampling;
    Weights weights;
    // The pair the two-object pipeline edits: the anchor and the other object (a multi-party scene:
    // the first two objects of `order`; its later stages are scenes of their own,
    // src/pipeline/party_stage.hpp).
    SceneObject a, b;
    std::vector<KeySegment> segments;
    // Optional ground truth for evaluation: where B's capture frame really sits in A's capture
    // frame (captures made together, e.g. the CMU pair: identity). Results then report how far the
    // solution group and the chosen pose are from it.
    std::optional<Placement> truth;
    // Every object in file order; two for a two-object scene (a and b above).
    std::vector<SceneObject> objects;
    // Placement order (docs/method.md section 11): the anchor first, then each object against the
    // ones before it; `order_rule` says how it was found (for `amhv check`).
    std::vector<std::string> order;
    std::string order_rule;
    // Multi-party ground truth: each object's capture frame in the anchor's ([truth.NAME]).
    std::map<std::string, Placement> truths;
    // A multi-party stage scene (src/pipeline/party_stage.hpp): A, the objects placed so far, keeps
    // its timing; every segment pair takes A's length, and where B has no frames it holds its nearest.
    bool a_sets_time = false;
    bool multi_party() const { return objects.size() > 2; }
    const SceneObject& object(const std::string& name) const;
};

// Parses and validates `file`; relative paths are resolved against the file's folder. Checks the
// referenced sequences exist and the frame ranges fit them. Throws amhv::Error "file:line: key: what".
// `segments_optional`: a two-object scene may state no key segment (`amhv propose` finds them).
Scene load_scene(const std::filesystem::path& file, bool segments_optional = false);

// load_scene for a command that takes two objects only (`amhv sweep`, `merge`, `plan`, `probe`):
// a multi-party scene gets one line saying why and what to run instead.
Scene load_two_object_scene(const std::filesystem::path& file, const std::string& command, bool segments_optional = false);

// The scene with every default filled in, as TOML text (what `amhv check` prints).
std::string resolved_toml(const Scene& scene);

// Every file and folder the scene reads (the scene file, meshes, BVH takes, labels, tracks, part
// sequences): an output folder must not be or contain any of them. A pattern stands for its folder.
std::vector<std::filesystem::path> scene_inputs(const Scene& scene);

}  // namespace amhv
