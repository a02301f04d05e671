#pragma once
// From a scene's key segment pair to the sweep problem: read both objects' frames, normalise the
// pair's lengths, voxelise the whole bodies and parts, find roots and facings, build view cones.
#include <map>
#include <memory>
#include <optional>

#include "src/body/character_body.hpp"
#include "src/body/skeleton_body.hpp"
#include "src/core/normalise.hpp"
#include "src/voxelise/voxelise.hpp"
#include "src/scene/scene.hpp"
#include "src/sweep/problem.hpp"

namespace amhv {

class ObjectSource;

// Where an edit put one object at one frame of a placed group: capture -> scene is
// p -> R(yaw) p + translation, with z raised by lift.
struct MemberFrame {
    int source = 0;  // frame number in the object's sequence
    double yaw = 0;
    Eigen::Vector2d translation = Eigen::Vector2d::Zero();
    double lift = 0;
    Eigen::Vector2d root = Eigen::Vector2d::Zero();  // the frame's root, in the scene
    double facing = 0;                               // the frame's facing in the scene (radians)
};

// `mesh` (capture frame) moved into the scene: p -> R(yaw) p + translation on the floor, z + lift.
TriangleMesh moved_into_scene(TriangleMesh mesh, double yaw, const Eigen::Vector2d& translation, double lift);

// One placed object of a group: its source and where it is at each of the group's frames.
struct GroupMember {
    ObjectSource* source = nullptr;
    std::vector<MemberFrame> frames;
};

// One object's frames, read on demand: each frame split into labelled parts (one part named ""
// when the object has no labels) and its track sample when it has a track.
//
// Or a placed group (docs/method.md section 11): the objects a multi-party edit has placed so far,
// as one fixed object in the scene's frame whose frame k is every member where the edit put it at
// its output frame k. The first member is the partner of the key segments at hand: its parts keep
// their names and its track is the group's (moved with it; without one, its facing from the eye
// height, as a two-object sweep would take it). Every other member is one part named "@NAME".
class ObjectSource {
public:
    // `skinner` skins a character's frames (null: the CPU reference; both give the same bits).
    explicit ObjectSource(const SceneObject& spec, Skinner* skinner = nullptr);
    ObjectSource(const SceneObject& spec, std::vector<GroupMember> members);
    bool is_group() const { return !members_.empty(); }
    // The group's members (empty for one object).
    const std::vector<GroupMember>& members() const { return members_; }
    const SceneObject& spec() const { return spec_; }
    const std::vector<BodyPart>& frame_parts(int number);
    std::optional<TrackSample> track(int number) const;
    // The frame `number` of a part given as its own mesh sequence.
    const MeshFrame& part_frame(const std::string& meshes, int number);
    // Every part name the object's labels use (empty without labels).
    const std::vector<std::string>& label_names() const { return label_names_; }
    // What floor = "auto" found (empty otherwise), for `amhv check`.
    const std::string& floor_note() const { return floor_note_; }
    // The loaded take of a BVH object (at the scene's rate), else null.
    const BvhMotion* motion() const { return motion_ ? &*motion_ : nullptr; }
    // The character of a character object, else null.
    const CharacterBody* character() const { return character_.get(); }
    // A character's whole surface as the file holds it (every vertex, the file's triangles, in the
    // order of its materials and texture coordinates) at frame `number`, in the scene.
    TriangleMesh character_surface(int number);
    // The lift the object's frames get (-floor).
    double lift() const { return spec_.units.lift; }

private:
    double find_floor();
    std::vector<BodyPart> body_frame_parts(int number);
    // A character's frames from `number` on (up to `number`, when reading backwards), skinned in
    // one call of the skinner into skinned_ (which it replaces, so that it holds one call's frames
    // at most): as many as fit kSkinAheadBytes, up to 64.
    void skin_ahead(int number);
    // A character's every vertex at frame `number`, in the scene (skinned ahead when not yet).
    const std::vector<Vec3>& skinned_frame(int number);
    Skinner* skinner_ = nullptr;
    std::map<int, std::vector<Vec3>> skinned_;
    const std::vector<BodyPart>& group_parts(int number);
    void make_group_track();
    std::string floor_note_;
    SceneObject spec_;
    std::optional<BvhMotion> motion_;
    std::shared_ptr<const CharacterBody> character_;
    SkeletonBodyOptions body_options_;
    std::map<int, TrackSample> track_;
    std::map<int, std::vector<BodyPart>> frames_;
    std::map<std::pair<std::string, int>, MeshFrame> part_frames_;
    std::vector<std::string> label_names_;
    std::vector<GroupMember> members_;
};

struct SegmentBuild {
    SweepProblem problem;
    NormalisedPair frames;  // segment-relative source frame of each normalised frame, A and B
};

// Builds the sweep problem of key segment `segment` with `voxeliser` (the Vulkan path or the
// reference: both give identical volumes).
SegmentBuild build_segment(const Scene& scene, const KeySegment& segment, ObjectSource& a, ObjectSource& b, Voxeliser& voxeliser);

// Mean gaze over `frames` projected onto the floor, or the constant facing, or +x.
Eigen::Vector2d segment_facing(const ObjectSource& object, const std::vector<int>& frames);

// The editor's intent on one solution (docs/method.md section 7, "Intent"): weight x the sum of
// ((L - L0) / 5 cm)^2, ((thetaA - thetaA0) / 5 deg)^2 and ((thetaB - thetaB0) / 5 deg)^2 over the
// descriptors it names (angles the short way round). 0 without prefer.
double intent_cost(const Intent& intent, const Solution& solution);
// B's root offset from A's root, in A's capture axes, when B's capture frame is placed by
// `truth` in A's (the scene's [truth]); roots C^A, C^B in their capture frames.
Eigen::Vector2d truth_offset(const Placement& truth, const Vec3& root_a, const Vec3& root_b);
// Whether a solution's descriptors lie within the intent's limits (always, without limits).
bool within_limits(const Intent& intent, const Solution& solution);
// "distance_m [0.4, 1.2], thetaA_deg [-45, 45]" for result.json; empty without limits.
std::string describe_limits(const Intent& intent);

}  // namespace amhv
