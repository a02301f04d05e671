#include "src/sweep/objects.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <vector>

#include "src/core/angles.hpp"
#include "src/core/budget.hpp"
#include "src/core/error.hpp"
#include "src/core/parallel.hpp"

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
    Amhv out(a.grid(), a.frames());
    // The planes are contiguous: the words are split into chunks over every core.
    const std::size_t words = std::size_t(a.words()) * a.voxel_count(), chunk = std::size_t(1) << 18;
    const std::uint32_t* from = a.mask().data();
    const std::uint32_t* minus = b.mask().data();
    std::uint32_t* to = out.plane(0);
    parallel_for((words + chunk - 1) / chunk, [&](std::size_t c) {
        for (std::size_t i = c * chunk; i < std::min(words, (c + 1) * chunk); ++i) to[i] = from[i] & ~minus[i];
    });
    return out;
}

Amhv grow_part(const Amhv& part, double radius) {
    const VoxelGrid& g = part.grid();
    const double units = radius / g.voxel;
    if (!(units >= 0) || units > 64) fail("contact_tolerance", "of {} m is {} voxels; at most 64 voxels are allowed", radius, units);
    // The ball's offsets, by whole voxels: dx^2 + dy^2 + dz^2 <= (radius / h)^2 (centre to centre).
    const int reach = int(std::floor(units + 1e-9));
    const std::int64_t r2 = std::int64_t(std::floor(units * units + 1e-9));
    std::vector<std::array<int, 3>> ball;
    for (int dz = -reach; dz <= reach; ++dz)
        for (int dy = -reach; dy <= reach; ++dy)
            for (int dx = -reach; dx <= reach; ++dx)
                if (std::int64_t(dx) * dx + std::int64_t(dy) * dy + std::int64_t(dz) * dz <= r2) ball.push_back({dx, dy, dz});
    Amhv out(g, part.frames());
    for (int z = 0; z < g.dims[2]; ++z)
        for (int y = 0; y < g.dims[1]; ++y)
            for (int x = 0; x < g.dims[0]; ++x) {
                const std::size_t v = g.index(x, y, z);
                if (!part.any(v)) continue;
                for (const auto& [dx, dy, dz] : ball) {
                    const int tx = x + dx, ty = y + dy, tz = z + dz;
                    if (tx < 0 || ty < 0 || tz < 0 || tx >= g.dims[0] || ty >= g.dims[1] || tz >= g.dims[2]) continue;
                    const std::size_t target = g.index(tx, ty, tz);
                    for (int w = 0; w < part.words(); ++w) out.plane(w)[target] |= part.word(w, v);
                }
            }
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
    // Room for the grown interest part.
    if (parts.grow_interest > 0 && !bounds.empty()) {
        bounds.min -= Vec3::Constant(parts.grow_interest);
        bounds.max += Vec3::Constant(parts.grow_interest);
    }
    VoxelGrid grid = grid_covering(bounds, voxel, "object " + name);
    {
        // Before any voxel is written: its whole, interest and fidelity volumes, and as much again
        // while the sweep cuts them into columns and runs.
        const std::uint64_t bytes = std::uint64_t((frames.size() + 31) / 32) * grid.voxel_count() * 4;
        const budget::Reservation check(6 * bytes, fmt::format("object {}'s volumes in this key segment ({} x {} x {} voxels of {} m, {} frames)", name,
                                                               grid.dims[0], grid.dims[1], grid.dims[2], voxel, frames.size()),
                                        fmt::format("use a voxel of at least {} mm", budget::voxel_that_fits(voxel, 6 * bytes, budget::memory_limit()) * 1000));
    }
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
    if (parts.grow_interest > 0) object.interest = grow_part(object.interest, parts.grow_interest);
    object.root = occupied_root(object.whole);
    return object;
}

namespace {

// One view cone rasterised column by column on `grid`: a voxel is in the cone when its centre is.
class ConeColumns {
public:
    ConeColumns(const ViewCone& cone, const VoxelGrid& grid)
        : cone_(cone), grid_(grid), axis_(cone.gaze.normalized()), cos_half_(std::cos(angles::radians(cone.half_angle_deg))) {}

    // The column's span of voxels in the cone ({1, 0}: none).
    std::array<int, 2> span(int x, int y) const {
        // The cone (half angle <= 90 degrees) and the range ball are convex, so each vertical column
        // meets them in one interval of heights t = z - eye.z. Its ends are roots of
        //   (az^2 - c^2) t^2 + 2 p az t + (p^2 - c^2 r^2) = 0      (along^2 = c^2 length^2)
        // or of t^2 = range^2 - r^2, so the column is split at those roots and each piece tested at
        // its middle; the voxel ends are then settled by the predicate itself. Each column's interval
        // is found without visiting its voxels (the region often holds 10^8 at 1 cm).
        const double h = grid_.voxel, c2 = cos_half_ * cos_half_;
        const double z_low = grid_.origin.z() + 0.5 * h - cone_.eye.z(), z_high = z_low + (grid_.dims[2] - 1) * h;
        const Vec3 base = grid_.centre(x, y, 0) - cone_.eye;
        const double r2 = base.x() * base.x() + base.y() * base.y();
        const double p = base.x() * axis_.x() + base.y() * axis_.y(), az = axis_.z();
        Cuts cuts;
        cuts.add(z_low), cuts.add(z_high);  // the column's ends, then the roots below
        cuts.add_roots(az * az - c2, 2 * p * az, p * p - c2 * r2);
        if (az != 0) cuts.add(-p / az);  // where `along` changes sign
        if (cone_.range > 0) cuts.add_roots(1, 0, r2 - cone_.range * cone_.range);
        std::sort(cuts.at.begin(), cuts.at.begin() + cuts.count);
        double t_first = 1, t_last = 0;  // the union of the inside pieces (one interval)
        for (int i = 0; i + 1 < cuts.count; ++i) {
            const double a = std::max(cuts.at[std::size_t(i)], z_low), b = std::min(cuts.at[std::size_t(i) + 1], z_high);
            const double t = 0.5 * (a + b);
            if (a > b || !accepts(p + az * t, std::sqrt(r2 + t * t))) continue;
            if (t_first > t_last) t_first = a;
            t_last = b;
        }
        if (t_first > t_last) return {1, 0};
        // Settle the ends voxel by voxel with the predicate; an interval that falls between
        // two centres starts empty (first = last + 1) and is settled the same way.
        int first = std::clamp(int(std::ceil((t_first - z_low) / h)), 0, grid_.dims[2]);
        int last = std::clamp(int(std::floor((t_last - z_low) / h)), first - 1, grid_.dims[2] - 1);
        while (first > 0 && inside(x, y, first - 1)) --first;
        while (last + 1 < grid_.dims[2] && inside(x, y, last + 1)) ++last;
        while (first <= last && !inside(x, y, first)) ++first;
        while (last >= first && !inside(x, y, last)) --last;
        return {first, last};
    }

private:
    // The column's cut heights: its two ends and at most five roots.
    struct Cuts {
        std::array<double, 8> at{};
        int count = 0;
        void add(double t) { at[std::size_t(count++)] = t; }
        void add_roots(double qa, double qb, double qc) {  // qa t^2 + qb t + qc = 0
            if (std::abs(qa) < 1e-12) {
                if (qb != 0) add(-qc / qb);
                return;
            }
            const double disc = qb * qb - 4 * qa * qc;
            if (disc < 0) return;
            const double root = std::sqrt(disc);
            add((-qb - root) / (2 * qa));
            add((-qb + root) / (2 * qa));
        }
    };
    // A point at `length` from the eye, `along` of it along the gaze, is in the cone.
    bool accepts(double along, double length) const {
        return length > 0 && along >= cos_half_ * length && (cone_.range <= 0 || length <= cone_.range);
    }
    // A voxel is in the cone when its centre is: the one predicate every voxel decision uses.
    bool inside(int x, int y, int z) const {
        const Vec3 d = grid_.centre(x, y, z) - cone_.eye;
        return accepts(d.dot(axis_), d.norm());
    }

    const ViewCone& cone_;
    const VoxelGrid& grid_;
    const Vec3 axis_;
    const double cos_half_;
};

}  // namespace

ConeVolume view_cone_volume(const ViewCone& cone, const Box3& region, double voxel) {
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
    ConeVolume out;
    out.grid = grid;
    out.spans.assign(std::size_t(grid.dims[0]) * std::size_t(grid.dims[1]), {1, 0});
    // Rows on every core, each writing its own columns (the region's columns were a serial step of
    // every segment's volumes).
    const ConeColumns columns(cone, grid);
    parallel_for(std::size_t(grid.dims[1]), [&](std::size_t y) {
        for (int x = 0; x < grid.dims[0]; ++x) {
            const std::array<int, 2> span = columns.span(x, int(y));
            if (span[0] <= span[1]) out.spans[y * std::size_t(grid.dims[0]) + std::size_t(x)] = {span[0], span[1]};
        }
    });
    return out;
}

ConeVolume view_cone_volumes(const std::vector<ViewCone>& cones, const Box3& region, double voxel) {
    if (cones.empty()) fail("view cone", "no frames");
    ConeVolume out = view_cone_volume(cones.front(), region, voxel);
    out.frames = int(cones.size());
    {
        const std::uint64_t bytes = std::uint64_t(out.columns()) * cones.size() * sizeof(out.spans[0]);
        const budget::Reservation check(bytes, fmt::format("{} per-frame view cones over {} x {} columns", cones.size(), out.grid.dims[0], out.grid.dims[1]),
                                        "narrow x_range / y_range, give the cones a range, or use a larger voxel");
    }
    out.spans.reserve(out.columns() * cones.size());
    for (std::size_t t = 1; t < cones.size(); ++t) {
        const ConeVolume frame = view_cone_volume(cones[t], region, voxel);
        out.spans.insert(out.spans.end(), frame.spans.begin(), frame.spans.end());
    }
    return out;
}

}  // namespace amhv
