#include "src/sweep/problem.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>

#ifdef __SSE2__
#include <emmintrin.h>
#endif

#include "src/core/angles.hpp"
#include "src/core/budget.hpp"
#include "src/core/error.hpp"
#include "src/core/parallel.hpp"
#include "src/sweep/solution_group.hpp"

namespace amhv {

namespace {

bool is_lattice_aligned(const VoxelGrid& grid, double voxel) {
    if (grid.voxel != voxel) return false;
    for (int axis = 0; axis < 3; ++axis) {
        double units = grid.origin[axis] / voxel;
        if (std::abs(units - std::round(units)) > 1e-6) return false;
        if (std::abs(units) + grid.dims[axis] >= double(posemap::kMaxLatticeIndex)) return false;
    }
    return true;
}

void validate_object(const SweepObject& object, const SweepProblem& problem) {
    const std::string what = "object " + object.name;
    const int frames = object.interest.frames();
    for (const Amhv* volume : {&object.interest, &object.fidelity, &object.whole}) {
        if (volume->frames() != frames) fail(what, "its interest, fidelity and whole volumes have different frame counts");
        const VoxelGrid& g = volume->grid();
        const VoxelGrid& w = object.whole.grid();
        if (g.dims != w.dims || g.origin != w.origin || g.voxel != w.voxel)
            fail(what, "its interest, fidelity and whole volumes are not on one grid");
    }
    if (object.has_clearance()) {
        const VoxelGrid& g = object.clearance.grid();
        const VoxelGrid& w = object.whole.grid();
        if (object.clearance.frames() != frames || g.dims != w.dims || g.origin != w.origin || g.voxel != w.voxel)
            fail(what, "its clearance volume is not on its grid or has another frame count");
        if (&object == &problem.b) fail(what, "only A (the placed objects) has a clearance volume");
    }
    if (!is_lattice_aligned(object.whole.grid(), problem.voxel))
        fail(what, "its grid is not on the {} m lattice or is too far from the origin", problem.voxel);
    if (!any_occupied(object.interest)) fail(what, "its volume of interest is empty in this key segment");
    if (problem.visibility) {
        const VoxelGrid& cone = object.view_cone.grid;
        const int cones = problem.per_frame_visibility() ? frames : 1;
        if (object.view_cone.empty() || object.view_cone.frames != cones || object.view_cone.spans.size() != std::size_t(cones) * object.view_cone.columns())
            fail(what, "visibility is asked for but it has no view cone{}", cones > 1 ? " per frame" : "");
        if (!is_lattice_aligned(cone, problem.voxel)) fail(what, "its view cone grid is not on the lattice");
    }
    if (!(std::abs(object.facing.norm() - 1.0) < 1e-6)) fail(what, "its facing is not a unit vector");
}

}  // namespace

posemap::Trig SweepProblem::trig(int k) const { return posemap::quantise_rotation(angles::radians(angle_deg(k))); }

Amhv ConeVolume::to_amhv() const {
    Amhv out(grid, frames);
    for (int t = 0; t < frames; ++t)
        for (int y = 0; y < grid.dims[1]; ++y)
            for (int x = 0; x < grid.dims[0]; ++x)
                for (int z = span(x, y, t)[0]; z <= span(x, y, t)[1]; ++z) out.set(grid.index(x, y, z), t);
    return out;
}

std::array<std::int64_t, 2> SweepProblem::root_a_q() const {
    return {posemap::quantise_root(a.root.x() / voxel), posemap::quantise_root(a.root.y() / voxel)};
}
std::array<std::int64_t, 2> SweepProblem::root_b_q() const {
    return {posemap::quantise_root(b.root.x() / voxel), posemap::quantise_root(b.root.y() / voxel)};
}

void validate(const SweepProblem& problem) {
    if (!(problem.voxel > 0) || !std::isfinite(problem.voxel)) fail("sampling.voxel", "must be a positive number of metres");
    if (problem.a.interest.frames() != problem.b.interest.frames())
        fail("key segment", "A has {} normalised frames and B {}", problem.a.interest.frames(), problem.b.interest.frames());
    if (problem.frames() < 1) fail("key segment", "has no frames");
    validate_object(problem.a, problem);
    validate_object(problem.b, problem);
    if (problem.range.angles < 1) fail("sampling.angle_step_deg", "gives no angle");
    if (problem.first_angle < 0 || problem.first_angle > problem.range.angles || problem.angle_count < -1)
        fail("sweep", "angles {} (+{}) are not angles of the {} swept", problem.first_angle, problem.angle_count, problem.range.angles);
    // The step is stored beside the angle count: both must describe the same full circle.
    if (!(problem.angle_step_deg > 0) || std::abs(problem.range.angles * problem.angle_step_deg - 360.0) > 1e-6)
        fail("sampling.angle_step_deg", "{} angles of {} deg do not make the full circle", problem.range.angles, problem.angle_step_deg);
    if (problem.tolerance < 0) fail("tolerance", "must not be negative");
    if (problem.contact_frames < 0 || problem.contact_frames > problem.frames())
        fail("contact_frames", "asks for {} of the segment's {} frames", problem.contact_frames, problem.frames());
    if (problem.visibility_frames < 0 || problem.visibility_frames > problem.frames())
        fail("visibility.frames", "asks for {} of the segment's {} frames", problem.visibility_frames, problem.frames());
    if (problem.range.depth() < 1 || std::abs(problem.range.z_first) > posemap::kMaxLatticeIndex / 2 ||
        std::abs(problem.range.z_last) > posemap::kMaxLatticeIndex / 2)
        fail("z_range", "gives no height or one too far from the floor");
    // One outcome byte per pose, and as much again for the candidates of a stage.
    budget::require_memory(2 * problem.range.size(), fmt::format("the sweep's {} poses", problem.range.size()),
                           "narrow x_range / y_range or use a larger angle step");
}

PoseRange automatic_range(const SweepObject& a, const SweepObject& b, double voxel, int angles) {
    PoseRange range;
    range.angles = angles;
    // A's occupied interest columns, in metres: origin + voxel * index grows with the index, so the
    // extreme indices give the box.
    const VoxelGrid& ga = a.interest.grid();
    Box3 a_box;
    if (const auto extremes = occupied_index_bounds(a.interest)) {
        const auto& [low, high] = *extremes;
        a_box.extend(ga.origin + voxel * Vec3(low[0], low[1], low[2]));
        a_box.extend(ga.origin + voxel * Vec3(high[0] + 1, high[1] + 1, high[2] + 1));
    }
    // B's occupied interest cells lie within `reach` of its root on the floor, at any angle: the
    // corners of its occupied columns (a maximum, the same in any order).
    const VoxelGrid& gb = b.interest.grid();
    std::vector<std::uint8_t> occupied_column(std::size_t(gb.dims[0]) * std::size_t(gb.dims[1]), 0);
    for (const auto& slice : occupied_by_slice(b.interest))
        for (const std::uint32_t v : slice) occupied_column[v] = 1;
    double reach = 0;
    for (int y = 0; y < gb.dims[1]; ++y)
        for (int x = 0; x < gb.dims[0]; ++x)
            if (occupied_column[std::size_t(y) * std::size_t(gb.dims[0]) + std::size_t(x)])
                for (int corner = 0; corner < 4; ++corner) {
                    Vec3 p = gb.origin + voxel * Vec3(x + (corner & 1), y + (corner >> 1), 0);
                    reach = std::max(reach, std::hypot(p.x() - b.root.x(), p.y() - b.root.y()));
                }
    if (a_box.empty()) return range;
    // A column u of A can only take B's value at offset s if |centre(u) - (C^A + s)| <= reach.
    range.i_first = int(std::floor((a_box.min.x() - reach - a.root.x()) / voxel)) - 1;
    range.i_last = int(std::ceil((a_box.max.x() + reach - a.root.x()) / voxel)) + 1;
    range.j_first = int(std::floor((a_box.min.y() - reach - a.root.y()) / voxel)) - 1;
    range.j_last = int(std::ceil((a_box.max.y() + reach - a.root.y()) / voxel)) + 1;
    return range;
}

void narrow_range(PoseRange& range, double voxel, const std::array<double, 2>* x_range, const std::array<double, 2>* y_range) {
    // In double precision, clamped to the automatic range before any conversion to int: a range of
    // a billion metres narrows nothing and must not overflow.
    auto narrow = [voxel](int& first, int& last, const std::array<double, 2>& metres) {
        const double lo = std::ceil(metres[0] / voxel - 1e-9), hi = std::floor(metres[1] / voxel + 1e-9);
        if (lo > double(first)) first = lo > double(last) + 1 ? last + 1 : int(lo);
        if (hi < double(last)) last = hi < double(first) - 1 ? first - 1 : int(hi);
    };
    if (x_range) narrow(range.i_first, range.i_last, *x_range);
    if (y_range) narrow(range.j_first, range.j_last, *y_range);
}

namespace {

constexpr std::size_t kOutcomes = std::size_t(PoseOutcome::Solution) + 1;
using OutcomeTally = std::array<std::uint64_t, kOutcomes>;  // per PoseOutcome

// The outcomes among n, 16 at a time: a byte counter per outcome and lane, added up every 255
// blocks before it could wrap. A tally per pose waited on the counter it had just added to (most
// poses fail contact in long runs): the count was 4% of a sweep at 5 mm.
OutcomeTally tally_outcomes(const PoseOutcome* outcomes, std::size_t n) {
    OutcomeTally tally{};
    const auto* bytes = reinterpret_cast<const std::uint8_t*>(outcomes);
    std::size_t p = 0;
#ifdef __SSE2__
    const __m128i zero = _mm_setzero_si128();
    while (p + 16 <= n) {
        __m128i counts[kOutcomes];
        std::fill(std::begin(counts), std::end(counts), zero);
        const std::size_t blocks = std::min<std::size_t>(255, (n - p) / 16);
        for (std::size_t b = 0; b < blocks; ++b, p += 16) {
            const __m128i block = _mm_loadu_si128(reinterpret_cast<const __m128i*>(bytes + p));
            for (std::size_t o = 0; o < kOutcomes; ++o)
                counts[o] = _mm_sub_epi8(counts[o], _mm_cmpeq_epi8(block, _mm_set1_epi8(char(o))));
        }
        for (std::size_t o = 0; o < kOutcomes; ++o) {
            const __m128i sums = _mm_sad_epu8(counts[o], zero);  // two 64-bit lane sums
            tally[o] += std::uint64_t(_mm_cvtsi128_si64(sums)) + std::uint64_t(_mm_cvtsi128_si64(_mm_unpackhi_epi64(sums, sums)));
        }
    }
#endif
    for (; p < n; ++p)
        if (bytes[p] < tally.size()) ++tally[bytes[p]];
    return tally;
}

}  // namespace

void SweepResult::count() {
    // Chunks on every core; integer sums, so the totals do not depend on the split.
    constexpr std::size_t kChunk = std::size_t(1) << 22;
    const std::size_t size = outcomes.size(), chunks = (size + kChunk - 1) / kChunk;
    std::vector<OutcomeTally> per_chunk(chunks, OutcomeTally{});
    parallel_for(chunks, [&](std::size_t c) {
        const std::size_t first = c * kChunk;
        per_chunk[c] = tally_outcomes(outcomes.data() + first, std::min(size, first + kChunk) - first);
    });
    rejected = {};
    solutions = 0;
    for (const OutcomeTally& tally : per_chunk) {
        for (std::size_t o = 0; o < rejected.size(); ++o) rejected[o] += tally[o];
        solutions += tally[std::size_t(PoseOutcome::Solution)];
    }
}

std::string rejection_counts(const std::array<std::uint64_t, 4>& rejected) {
    return fmt::format("contact {}, dictionary {}, fidelity {}, visibility {}", rejected[0], rejected[1], rejected[2], rejected[3]);
}

Solution describe(const SweepProblem& problem, int i, int j, int k, int l) { return describer(problem)(PoseIndex{i, j, k, l}); }

}  // namespace amhv
