#pragma once
// Building one object's sweep volumes for one key segment (docs/method.md sections 3, 5 and 9): the
// whole body, the volume of interest and the fidelity volume on one shared grid, and a view cone.
#include <optional>
#include <vector>

#include "src/voxelise/voxelise.hpp"
#include "src/sweep/problem.hpp"

namespace amhv {

// One normalised frame of an object: the whole body's parts, and (when the interest or the
// fidelity volume is given as meshes) those meshes.
struct ObjectFrame {
    std::vector<const MeshFrame*> whole;     // their union is the body
    std::vector<const MeshFrame*> interest;  // empty: interest comes from a box (or is the whole)
    std::vector<const MeshFrame*> fidelity;  // empty: fidelity is derived (see PartRule)
};

enum class PartRule {
    Meshes,        // the part's own meshes
    Box,           // the whole body's voxels whose centre lies in a box (capture coordinates)
    Whole,         // the whole body
    WholeMinusInterest,  // fidelity only: the whole body minus the interest voxels, frame by frame
};

struct ObjectParts {
    PartRule interest = PartRule::Meshes;
    std::optional<Box3> interest_box;
    PartRule fidelity = PartRule::WholeMinusInterest;
    std::optional<Box3> fidelity_box;
    // True when the part's meshes are not among the whole body's (a sword next to the body): the
    // whole body is then the union of both.
    bool interest_is_separate = true;
    bool fidelity_is_separate = false;
    // contact_tolerance (metres): the interest part is grown by a ball of this radius (grow_part)
    // after the fidelity part is derived from it; the grid gets room for the growth.
    double grow_interest = 0;
};

// Voxelises the frames on one grid covering every mesh (edge `voxel`) and derives the parts.
// Fills name, interest, fidelity, whole and root; facing and view cone are left to the caller.
SweepObject build_sweep_object(const std::string& name, const std::vector<ObjectFrame>& frames, const ObjectParts& parts,
                               double voxel, Voxeliser& voxeliser);

// Voxels of `volume` whose centre lies in `box`, at every frame.
Amhv restrict_to_box(const Amhv& volume, const Box3& box);
// Voxel-frames of `a` that are not in `b` (same grid and frames).
Amhv difference(const Amhv& a, const Amhv& b);
// The part grown by a ball (docs/method.md section 5a): voxel v is in it at frame t when some voxel
// of `part` at frame t has its centre within `radius` of v's centre. Growth beyond the grid is lost
// (build_sweep_object leaves room for it).
Amhv grow_part(const Amhv& part, double radius);

struct ViewCone {
    Vec3 eye = Vec3::Zero();
    Vec3 gaze = Vec3::UnitX();  // unit
    double half_angle_deg = 30;
    double range = 0;           // 0: unlimited
};
// The voxels of the lattice of edge `voxel` inside `region` whose centre lies inside the cone.
// Evaluated once on the host; both sweep backends read the same voxels.
ConeVolume view_cone_volume(const ViewCone& cone, const Box3& region, double voxel);
// One cone per frame (per-frame visibility), on one grid covering `region`.
ConeVolume view_cone_volumes(const std::vector<ViewCone>& cones, const Box3& region, double voxel);

}  // namespace amhv
