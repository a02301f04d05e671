#pragma once
// The natural choice inside a key segment's solution group (docs/method.md section 7b): for every
// member, how far the placed pair is from what real people do at such a moment, as a sum of
// squared, scaled terms that the DP adds to its unary cost (weights.natural). Each term is a
// physical or social criterion with its unit and scale; a term that does not apply (no view
// tracks, no held contact) is left out.
//   gaze      joint attention: each head looks at the other's eyes or at the contact (the midpoint
//             of the interest parts' centroids), whichever is nearer its gaze, on the floor plane
//             (a placement turns gazes about the vertical only; a capture's head pitch is its
//             marker set's as much as the eyes'): mean over the key's frames and both heads of
//             1 - cos(angle), scale 1 - cos 30 deg (the default view cone's half angle); a
//             head whose body walks (at least kWalkingSpeed) may look along its path instead;
//   depth     contact that touches rather than merges: mean over the key's frames of the deepest
//             point of B's interest part inside A's (metres) beyond what the bodies add to a
//             person's surface there (capsule hands: mittens), scale 1 cm;
//   sliding   a held contact (0&0 (a)) moves together: RMS over the key's frames of the interest
//             parts' relative offset about its mean (metres), scale 2 cm;
//   reach     a strike (0&0 (b) between two skeletons' hands or feet) drives the limbs at each
//             other: at the contact frame (the impact: the key frame where the two ends lose
//             the most speed, from the takes alone; else the key frame where they are nearest),
//             1 - cos of the angle on the floor plane between A's limb (shoulder to wrist, hip to
//             ankle) and B's reversed, scale 1 - cos 30 deg; and each limb's end on the other's
//             line: mean floor distance (metres) of each end from the other limb's line, scale 4 cm;
//             and the impact gap: at the impact, how far B's end is short of A's along their
//             closing motion, less the ends' depth (metres), against half the closing c over the
//             frame into the impact (where the touch falls in the next frame is unknown: uniform),
//             scale c / sqrt 12, at least 1 cm;
//   crowding  outside the contact people keep out of each other's intimate zone: over the frames
//             within one second before and after the key (the key's placement carried on), the
//             mean of (max(0, 0.45 m - root distance on the floor) / 10 cm)^2.
// Scores are computed on the host, in double precision, each member on its own: deterministic.
#include <array>
#include <cstdint>
#include <limits>
#include <optional>
#include <span>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "src/edit/edit.hpp"
#include "src/edit/natural_terms.hpp"
#include "src/sweep/solution_group.hpp"
#include "src/voxelise/voxelise.hpp"

namespace amhv {

struct Limb {  // a limb from its root joint (shoulder, hip) to its end joint (wrist, ankle), metres
    Vec3 root, end;
};

// The frames a key segment's scores look at, from the edit's timeline and roots.
struct NaturalFrames {
    std::vector<int> a, b;  // source frames of the key's normalised frames (sampled)
    std::vector<Eigen::Vector2d> around_a, around_b;  // roots (capture frames) of the frames around the key
    std::vector<int> key_a, key_b;  // source frames of every normalised frame of the key (empty: use a, b)
};
NaturalFrames natural_frames(const EditResult& edit, int key_index, double fps);
// The scored frames of a key of `length` normalised frames: at most kNaturalFrames of them, evenly
// spaced with both ends (indices into the key's frames).
std::vector<int> natural_samples(int length);
// Sets frames.a and frames.b to the scored frames (natural_samples) of frames.key_a and key_b.
void sample_key_frames(NaturalFrames& frames);

// The weight of a key segment's natural score in the DP's unary cost: weights.natural, or where
// the key segment states `prefer`, the intent's own weight (the editor's intent leads, and one
// scale of a criterion counts as much as a 5 cm or 5 degree miss of it). 0 with weights.natural 0.
double natural_weight(const Scene& scene, const KeySegment& key);

class NaturalScorer {
public:
    NaturalScorer(const KeySegment& key, const KeySweep& sweep, const NaturalFrames& frames, ObjectSource& a, ObjectSource& b,
                  Voxeliser& voxeliser, int angles);
    NaturalTerms terms(const PoseIndex& pose) const;
    double cost(const PoseIndex& pose) const { return terms(pose).cost(); }
    // cost() of every member of `group`, in its order (in parallel; each member on its own).
    std::vector<double> costs(const SolutionGroup& group) const;

private:
    struct Field {  // depth inside A's interest part at one frame (metres), on the frame's grid
        VoxelGrid grid;
        std::vector<float> depth;
        std::array<int, 3> cell(const Vec3& p) const;  // the voxel holding p (may lie outside)
        double at(int x, int y, int z) const;           // 0 outside the grid
    };
    struct Angle {  // B's samples turned by one angle, relative to C^B
        std::vector<Vec3> eyes, gazes, around;
        std::vector<Limb> limbs;                // B's limb per key frame, turned (empty: no reach term)
        std::vector<Vec3> centroids;            // B's interest part's centroid per frame (empty: none)
        std::vector<std::vector<std::array<int, 3>>> cells;  // B's points' voxels in A's field at C^A, per frame
        std::vector<Eigen::AlignedBox3i> bounds;  // per frame, the box of those cells
        double sliding = NaturalTerms::kNone;
    };
    void prepare_tracks(ObjectSource& a, ObjectSource& b);
    void prepare_depth(const KeySegment& key, ObjectSource& a, ObjectSource& b, Voxeliser& voxeliser);
    void prepare_reaches(const KeySegment& key, ObjectSource& a, ObjectSource& b);
    void prepare_angles(const KeySegment& key, ObjectSource& a, ObjectSource& b, int angles);
    double gaze(const Angle& g, const Vec3& offset) const;
    // gaze() of the members whose offsets are (x[n], y[n], any height), into out[n].
    void gazes(const Angle& g, std::span<const double> x, std::span<const double> y, std::span<double> out) const;
    Vec3 member_offset(const PoseIndex& pose) const;  // where a member moves B beyond its turn about C^B
    NaturalTerms terms(const PoseIndex& pose, double gaze) const;  // with its gaze already found
    double depth(const Angle& g, const PoseIndex& pose) const;
    double crowding(const Angle& g, const Vec3& offset) const;
    void reach(const Angle& g, const Vec3& offset, NaturalTerms& out) const;

    const KeySweep& sweep_;
    NaturalFrames frames_;
    double h_;
    Vec3 root_a_, root_b_;
    bool tracks_ = false;
    std::vector<Vec3> eyes_a_, gazes_a_, eyes_b_, gazes_b_;  // capture frames
    // Per scored frame, 1 - cos of the angle between each head's gaze and its travel on the floor
    // when it walks (kWalkingSpeed), else NaN: a walker may look where it goes (gaze()).
    std::vector<double> travel_a_, travel_b_;
    // Per key frame (every one where the frames list them, else the scored ones), each limb, and
    // whether both have a floor direction there (prepare_reaches); empty: no reach term.
    std::vector<Limb> limbs_a_, limbs_b_;
    std::vector<char> reach_frames_;
    // The impact: the key frame (with both limbs' directions) where the two ends lose the most
    // speed, from the takes alone; none when they never slow down (reach() then takes the frame
    // where the ends are nearest).
    std::optional<std::size_t> impact_;
    double impact_depth_ = 0;  // what lies between the two end joints when the ends touch (metres)
    std::vector<Vec3> centroids_a_;  // A's interest part's centroid per frame (empty: none)
    double depth_allowance_ = 0;  // metres of depth the bodies' mittens add when hands touch (depth())
    std::vector<Field> fields_;                             // per frame (empty: no depth term)
    std::vector<Angle> angles_;
    std::size_t points_ = kNaturalPoints;
};

}  // namespace amhv
