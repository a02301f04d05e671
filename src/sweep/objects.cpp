#include "sweep/objects.hpp"

#include <cmath>
#include <numbers>

#include "core/error.hpp"

namespace amhv {

namespace {

Amhv voxelise_frames(const std::vector<std::vector<const MeshFrame*>>& frames, const VoxelGrid& grid, Voxeliser& voxeliser) {
    // A frame made of several meshes is voxelised as one mesh: the non-zero winding rule makes it the union.
    std::vector<MeshFrame> merged(frames.size());
    std::vector<const MeshFrame*> pointers;
    for (std::size_t f = 0; f < frames.size(); ++f) {
        for (const MeshFrame* part : frames[f]) {
            merged[f].mesh.append(part->mesh);
            merged[f].source += (merged[f].source.empty() ? "" : " + ") + part->source;
        }
        pointers.push_back(&merged[f]);
    }
    return voxelise(prepare_voxelisation(pointers, grid), voxeliser);
}

}  // namespace

Amhv restrict_to_box(const Amhv& volume, const Box3& box) {
    Amhv out(volume.grid(), volume.frames());
    const VoxelGrid& g = volume.grid();
    for (int z = 0; z < g.dims[2]; ++z)
        for (int y = 0; y < g.dims[1]; ++y)
            for (int x = 0; x < g.dims[0]; ++x) {
                Vec3 c = g.centre(x, y, z);
                if ((c.array() < box.min.array()).any() || (c.array() > box.max.array()).any()) continue;
                std::size_t v = g.index(x, y, z);
                for (int w = 0; w < volume.words(); ++w) out.plane(w)[v] = volume.word(w, v);
            }
    return out;
}

Amhv difference(const Amhv& a, const Amhv& b) {
    Amhv out = a;
    for (int w = 0; w < a.words(); ++w)
        for (std::size_t v = 0; v < a.voxel_count(); ++v) out.plane(w)[v] &= ~b.word(w, v);
    return out;
}

SweepObject build_sweep_object(const std::string& name, const std::vector<ObjectFrame>& frames, const ObjectParts& parts,
                               double voxel, Voxeliser& voxeliser) {
    if (frames.empty()) fail("object " + name, "has no frames in this key segment");
    Box3 bounds;
    std::vector<std::vector<const MeshFrame*>> whole, interest, fidelity;
    for (const ObjectFrame& f : frames) {
        for (auto* list : {&f.whole, &f.interest, &f.fidelity})
            for (const MeshFrame* m : *list) bounds.extend(m->mesh.bounds());
        // The whole body includes the separate parts (e.g. a sword held in the hand).
        std::vector<const MeshFrame*> all = f.whole;
        if (parts.interest == PartRule::Meshes && parts.interest_is_separate) all.insert(all.end(), f.interest.begin(), f.interest.end());
        if (parts.fidelity == PartRule::Meshes && parts.fidelity_is_separate) all.insert(all.end(), f.fidelity.begin(), f.fidelity.end());
        whole.push_back(all);
        interest.push_back(f.interest);
        fidelity.push_back(f.fidelity);
    }
    SweepObject object;
    object.name = name;
    VoxelGrid grid = grid_covering(bounds, voxel, "object " + name);
    object.whole = voxelise_frames(whole, grid, voxeliser);
    switch (parts.interest) {
        case PartRule::Meshes: object.interest = voxelise_frames(interest, grid, voxeliser); break;
        case PartRule::Box: object.interest = restrict_to_box(object.whole, *parts.interest_box); break;
        default: object.interest = object.whole; break;
    }
    switch (parts.fidelity) {
        case PartRule::Meshes: object.fidelity = voxelise_frames(fidelity, grid, voxeliser); break;
        case PartRule::Box: object.fidelity = restrict_to_box(object.whole, *parts.fidelity_box); break;
        case PartRule::Whole: object.fidelity = object.whole; break;
        case PartRule::WholeMinusInterest: object.fidelity = difference(object.whole, object.interest); break;
    }
    object.root = summarise(object.whole).root;
    return object;
}

Amhv view_cone_volume(const ViewCone& cone, const Box3& region, double voxel) {
    // The grid on the lattice covering `region` (no margin needed: it is already generous).
    VoxelGrid grid;
    grid.voxel = voxel;
    for (int axis = 0; axis < 3; ++axis) {
        double first = std::floor(region.min[axis] / voxel), last = std::ceil(region.max[axis] / voxel);
        grid.origin[axis] = first * voxel;
        grid.dims[axis] = int(last - first);
        if (grid.dims[axis] < 1 || grid.dims[axis] > 4 * kMaxGridAxis)
            fail("view cone", "its region spans {} voxels along an axis; narrow the range or use a larger voxel", grid.dims[axis]);
    }
    Amhv out(grid, 1);
    const Vec3 axis = cone.gaze.normalized();
    const double cos_half = std::cos(cone.half_angle_deg * std::numbers::pi / 180.0);
    for (int z = 0; z < grid.dims[2]; ++z)
        for (int y = 0; y < grid.dims[1]; ++y)
            for (int x = 0; x < grid.dims[0]; ++x) {
                Vec3 d = grid.centre(x, y, z) - cone.eye;
                double along = d.dot(axis), length = d.norm();
                if (length == 0 || along < cos_half * length) continue;
                if (cone.range > 0 && length > cone.range) continue;
                out.set(grid.index(x, y, z), 0);
            }
    return out;
}

}  // namespace amhv
