#include "src/edit/natural.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>
#include <span>

#include <fmt/format.h>

#include "src/body/skeleton_body.hpp"
#include "src/body/skeleton_roles.hpp"
#include "src/core/angles.hpp"
#include "src/core/distance.hpp"
#include "src/core/parallel.hpp"
#include "src/scene/interest.hpp"

namespace amhv {

namespace {

double square(double v) { return v * v; }

Vec3 floor_plane(const Vec3& v) { return Vec3(v.x(), v.y(), 0.0); }

// What a side's body adds to its interest part beyond a person's surface: a BVH capsule body's
// hands are mittens kMittenRadius round the finger bones, a real hand half kHandThickness thick.
double surface_excess(const ObjectSource& o, const PartSpec& part) {
    if (o.spec().bvh.empty() || o.spec().body != BodyKind::Capsules || part.kind != PartSpec::Kind::Parts || part.labels.empty()) return 0;
    for (const std::string& label : part.labels)
        if (!label.ends_with("hand")) return 0;
    return kMittenRadius - 0.5 * kHandThickness;
}

// At most `count` of the mesh's vertices, evenly strided (deterministic).
std::vector<Vec3> sample_points(const TriangleMesh& mesh, std::size_t count) {
    std::vector<Vec3> out;
    const std::size_t n = mesh.vertices.size();
    if (n == 0) return out;
    const std::size_t stride = std::max<std::size_t>(1, (n + count - 1) / count);
    for (std::size_t v = 0; v < n; v += stride) out.push_back(mesh.vertices[v]);
    return out;
}

// 1 - cos of the angle between a head's floor gaze (unit) at `frame` and the floor direction its
// eye travels over kWalkingWindow either side, when that travel is at least kWalkingSpeed; NaN
// when the head stands (or the take has no neighbouring track samples).
double travel_cost(const ObjectSource& o, int frame, const Vec3& gaze) {
    const int reach = std::max(1, int(std::lround(kWalkingWindow * o.spec().fps)));
    const auto before = o.track(frame - reach), after = o.track(frame + reach);
    const auto from = before ? before : o.track(frame), to = after ? after : o.track(frame);
    const int span = (before ? reach : 0) + (after ? reach : 0);
    if (!from || !to || span == 0) return NaturalTerms::kNone;
    const Vec3 travel = floor_plane(to->eye - from->eye);
    const double length = travel.norm();
    if (length * o.spec().fps / double(span) < kWalkingSpeed) return NaturalTerms::kNone;
    return 1.0 - gaze.dot(travel) / length;
}

// The joints (by role) from the root to the end of the limb a strike is made with: an interest
// part that is one hand or one foot. Empty otherwise.
std::array<std::string, 2> limb_roles(const PartSpec& part) {
    if (part.kind != PartSpec::Kind::Parts || part.labels.size() != 1) return {};
    static const std::array<std::array<std::string, 3>, 4> limbs{{{"right_hand", "RightArm", "RightHand"},
                                                                  {"left_hand", "LeftArm", "LeftHand"},
                                                                  {"right_foot", "RightUpLeg", "RightFoot"},
                                                                  {"left_foot", "LeftUpLeg", "LeftFoot"}}};
    for (const auto& limb : limbs)
        if (part.labels[0] == limb[0]) return {limb[1], limb[2]};
    return {};
}

// What lies between a limb's end joint and the surface it strikes with (metres; `part` is a limb's
// end, limb_roles).
double end_depth(const PartSpec& part) { return part.labels[0].ends_with("foot") ? kImpactFootDepth : kImpactHandDepth; }

// Per frame of `frames`, the limb from its root joint to its end joint in a BVH object's capture
// frame (scene metres). Empty when the object has no skeleton or the part is not a limb's end.
std::vector<Limb> limb_segments(const ObjectSource& o, const PartSpec& part, const std::vector<int>& frames) {
    const auto roles = limb_roles(part);
    const BvhMotion* motion = o.motion();
    if (roles[0].empty() || !motion || o.character()) return {};
    const std::vector<std::string> names = role_names(*motion);
    const auto root = std::find(names.begin(), names.end(), roles[0]), end = std::find(names.begin(), names.end(), roles[1]);
    if (root == names.end() || end == names.end()) return {};
    std::vector<Limb> out;
    for (const int f : frames) {
        const auto global = motion->global_transforms(f);
        out.push_back({to_scene_point(global[std::size_t(root - names.begin())].translation(), o.spec().units),
                       to_scene_point(global[std::size_t(end - names.begin())].translation(), o.spec().units)});
    }
    return out;
}

// The floor distance (metres) of point p from the line through `limb` on the floor plane, whose
// floor direction is unit `along`.
double off_line(const Vec3& p, const Limb& limb, const Vec3& along) {
    const Vec3 d = floor_plane(p - limb.root);
    return std::abs(d.x() * along.y() - d.y() * along.x());
}

}  // namespace

double NaturalTerms::cost() const {
    const double gaze_scale = 1.0 - std::cos(kNaturalGazeHalfAngleDeg * std::numbers::pi / 180.0);
    double c = 0;
    if (!std::isnan(gaze)) c += square(gaze / gaze_scale);
    if (!std::isnan(depth_m)) c += square(depth_m / kNaturalDepthScale);
    if (!std::isnan(sliding_m)) c += square(sliding_m / kNaturalSlidingScale);
    if (!std::isnan(crowding)) c += crowding;
    if (!std::isnan(reach)) c += square(reach / gaze_scale);
    if (!std::isnan(reach_offset_m)) c += square(reach_offset_m / kReachOffsetScale);
    if (!std::isnan(impact_gap_m)) {
        // The touch falls anywhere in the frame after the impact frame, where the ends would have
        // closed as far again: uniform over [0, closing], mean closing / 2, deviation closing / sqrt 12.
        const double spread = std::max(impact_closing_m / std::sqrt(12.0), kNaturalDepthScale);
        c += square((impact_gap_m - 0.5 * impact_closing_m) / spread);
    }
    return c;
}

double natural_weight(const Scene& scene, const KeySegment& key) {
    if (!(scene.weights.natural > 0)) return 0;
    return key.intent.prefers() ? key.intent.weight : scene.weights.natural;
}

std::vector<int> natural_samples(int length) {
    const int count = std::min(kNaturalFrames, length);
    std::vector<int> out;
    for (int n = 0; n < count; ++n) out.push_back(count > 1 ? int(std::lround(double(n) * (length - 1) / (count - 1))) : 0);
    return out;
}

void sample_key_frames(NaturalFrames& frames) {
    frames.a.clear(), frames.b.clear();
    for (const int n : natural_samples(int(frames.key_a.size()))) {
        frames.a.push_back(frames.key_a[std::size_t(n)]);
        frames.b.push_back(frames.key_b[std::size_t(n)]);
    }
}

NaturalFrames natural_frames(const EditResult& edit, int key_index, double fps) {
    NaturalFrames out;
    const auto seg = std::find_if(edit.timeline.segments.begin(), edit.timeline.segments.end(),
                                  [&](const TimelineSegment& s) { return s.key == key_index; });
    if (seg == edit.timeline.segments.end() || seg->length == 0) return out;
    for (int m = seg->first; m < seg->first + seg->length; ++m) {
        out.key_a.push_back(edit.frames[0][std::size_t(m)].source);
        out.key_b.push_back(edit.frames[1][std::size_t(m)].source);
    }
    sample_key_frames(out);
    // Every other frame within a second (at 25-30 fps, 12-15 samples a second: a walk is smooth).
    const int reach = std::max(1, int(std::lround(fps)));
    for (int m = std::max(0, seg->first - reach); m < std::min(edit.timeline.length(), seg->first + seg->length + reach); ++m) {
        if ((m >= seg->first && m < seg->first + seg->length) || (m - seg->first) % 2 != 0) continue;
        out.around_a.push_back(edit.frames[0][std::size_t(m)].root);
        out.around_b.push_back(edit.frames[1][std::size_t(m)].root);
    }
    return out;
}

std::array<int, 3> NaturalScorer::Field::cell(const Vec3& p) const {
    const Vec3 u = (p - grid.origin) / grid.voxel;
    return {int(std::floor(u.x())), int(std::floor(u.y())), int(std::floor(u.z()))};
}

double NaturalScorer::Field::at(int x, int y, int z) const {
    if (x < 0 || y < 0 || z < 0 || x >= grid.dims[0] || y >= grid.dims[1] || z >= grid.dims[2]) return 0;
    return depth[grid.index(x, y, z)];
}

NaturalScorer::NaturalScorer(const KeySegment& key, const KeySweep& sweep, const NaturalFrames& frames, ObjectSource& a, ObjectSource& b,
                             Voxeliser& voxeliser, int angles)
    : sweep_(sweep), frames_(frames), h_(sweep.describe.voxel), root_a_(sweep_root(sweep.root_a, sweep.describe.voxel)),
      root_b_(sweep_root(sweep.root_b, sweep.describe.voxel)) {
    if (frames_.a.empty()) return;
    prepare_tracks(a, b);
    prepare_depth(key, a, b, voxeliser);
    // Bound the depth lookups of a large group (the paper scene's is tens of millions of members).
    const double per_member = kNaturalLookups / std::max(1.0, double(sweep.group.size())) / double(frames_.a.size());
    points_ = std::size_t(std::clamp(per_member, double(kNaturalMinPoints), double(kNaturalPoints)));
    prepare_reaches(key, a, b);
    prepare_angles(key, a, b, angles);
}

// A strike between two limbs' ends (0&0 (b): a slap, a punch, a kick) passes an impulse from one
// limb to the other: each limb drives its end at the other's, so on the floor the two limbs
// point at each other (Newton's third law; a limb pushes hardest along its own line).
void NaturalScorer::prepare_reaches(const KeySegment& key, ObjectSource& a, ObjectSource& b) {
    if (!key.type.lateral_pair() || key.type.variant != 'b' || key.type.near) return;
    const bool every = !frames_.key_a.empty();
    std::vector<Limb> la = limb_segments(a, key.interest_a, every ? frames_.key_a : frames_.a);
    std::vector<Limb> lb = limb_segments(b, key.interest_b, every ? frames_.key_b : frames_.b);
    if (la.empty() || lb.empty()) return;
    std::vector<char> both(la.size());
    for (std::size_t t = 0; t < la.size(); ++t)
        both[t] = floor_plane(la[t].end - la[t].root).norm() >= kReachMinLength && floor_plane(lb[t].end - lb[t].root).norm() >= kReachMinLength;
    if (std::find(both.begin(), both.end(), char(1)) == both.end()) return;
    // The impact: where the two ends' speeds (per key frame, in their own capture frames, which a
    // placement only turns and shifts) drop the most across one frame, summed over both.
    double strongest = 0;
    for (std::size_t t = 1; t + 1 < la.size(); ++t) {
        if (!both[t]) continue;
        const double drop = (la[t].end - la[t - 1].end).norm() - (la[t + 1].end - la[t].end).norm() + (lb[t].end - lb[t - 1].end).norm() -
                            (lb[t + 1].end - lb[t].end).norm();
        if (drop > strongest) strongest = drop, impact_ = t;
    }
    limbs_a_ = std::move(la), limbs_b_ = std::move(lb), reach_frames_ = std::move(both);
    impact_depth_ = end_depth(key.interest_a) + end_depth(key.interest_b);
}

void NaturalScorer::prepare_tracks(ObjectSource& a, ObjectSource& b) {
    tracks_ = true;
    for (std::size_t t = 0; t < frames_.a.size() && tracks_; ++t) {
        const auto ta = a.track(frames_.a[t]), tb = b.track(frames_.b[t]);
        // Headings on the floor plane (see gaze()): a head looking straight up or down has none.
        if (!ta || !tb || floor_plane(ta->gaze).norm() < 1e-9 || floor_plane(tb->gaze).norm() < 1e-9) {
            tracks_ = false;
            break;
        }
        eyes_a_.push_back(ta->eye), gazes_a_.push_back(floor_plane(ta->gaze).normalized());
        eyes_b_.push_back(tb->eye), gazes_b_.push_back(floor_plane(tb->gaze).normalized());
        travel_a_.push_back(travel_cost(a, frames_.a[t], gazes_a_.back()));
        travel_b_.push_back(travel_cost(b, frames_.b[t], gazes_b_.back()));
    }
}

// A's interest part voxelised at each scored frame (by the edit's backend: both give the same
// volume), each frame on a grid of its own, and the depth of every voxel inside it: the distance
// from its centre to the nearest outside voxel's centre, less half a voxel.
void NaturalScorer::prepare_depth(const KeySegment& key, ObjectSource& a, ObjectSource& b, Voxeliser& voxeliser) {
    if (key.interest_a.kind == PartSpec::Kind::WholeMinusInterest) return;
    depth_allowance_ = surface_excess(a, key.interest_a) + surface_excess(b, key.interest_b);
    std::vector<MeshFrame> meshes(frames_.a.size());
    std::vector<const MeshFrame*> pointers;
    std::vector<VoxelGrid> grids;
    for (std::size_t t = 0; t < frames_.a.size(); ++t) {
        meshes[t].mesh = part_surface(a, key.interest_a, frames_.a[t]);
        meshes[t].source = fmt::format("object {} frame {}", a.spec().name, frames_.a[t]);
        if (meshes[t].mesh.triangles.empty()) return;
        grids.push_back(grid_covering(meshes[t].mesh.bounds(), h_, meshes[t].source));
        pointers.push_back(&meshes[t]);
    }
    const Voxeliser::ScratchHold hold(voxeliser);
    const Amhv volume = voxelise(prepare_voxelisation_stacked(pointers, grids), voxeliser);
    const VoxelGrid& stacked = volume.grid();
    for (std::size_t t = 0; t < grids.size(); ++t) {
        Field field{grids[t], {}};
        const auto& d = grids[t].dims;
        std::vector<double> f(grids[t].voxel_count());
        for (int z = 0; z < d[2]; ++z)
            for (int y = 0; y < d[1]; ++y)
                for (int x = 0; x < d[0]; ++x) {
                    const bool inside = (volume.plane(0)[stacked.index(x, y, z)] >> t) & 1u;
                    f[grids[t].index(x, y, z)] = inside ? 1e30 : 0.0;
                }
        squared_distance_transform(f, d);
        field.depth.resize(f.size());
        for (std::size_t v = 0; v < f.size(); ++v) field.depth[v] = f[v] > 0 ? float((std::sqrt(f[v]) - 0.5) * h_) : 0.0f;
        fields_.push_back(std::move(field));
    }
}

void NaturalScorer::prepare_angles(const KeySegment& key, ObjectSource& a, ObjectSource& b, int angles) {
    const std::size_t n = frames_.a.size();
    std::vector<std::vector<Vec3>> points(n);
    std::vector<std::optional<Vec3>> centroid_a(n), centroid_b(n);
    for (std::size_t t = 0; t < n; ++t) {
        const TriangleMesh surface_b = part_surface(b, key.interest_b, frames_.b[t]);
        if (!fields_.empty()) points[t] = sample_points(surface_b, points_);
        centroid_b[t] = surface_centroid(surface_b);
        centroid_a[t] = surface_centroid(part_surface(a, key.interest_a, frames_.a[t]));
    }
    const bool centroids = std::all_of(centroid_a.begin(), centroid_a.end(), [](auto& c) { return c.has_value(); }) &&
                           std::all_of(centroid_b.begin(), centroid_b.end(), [](auto& c) { return c.has_value(); });
    if (centroids)
        for (const auto& c : centroid_a) centroids_a_.push_back(*c);
    const bool sliding = key.type.variant == 'a' && n > 1 && centroids;
    angles_.resize(std::size_t(angles));
    parallel_for(std::size_t(angles), [&](std::size_t k) {
        Angle& g = angles_[k];
        const double theta = angles::radians(sweep_.describe.theta_deg(int(k))), c = std::cos(theta), s = std::sin(theta);
        auto turn = [c, s](const Vec3& v) { return Vec3(c * v.x() - s * v.y(), s * v.x() + c * v.y(), v.z()); };
        const Vec3 planar_b(root_b_.x(), root_b_.y(), 0);
        for (std::size_t t = 0; t < eyes_b_.size() && tracks_; ++t) g.eyes.push_back(turn(eyes_b_[t] - planar_b)), g.gazes.push_back(turn(gazes_b_[t]));
        for (const Eigen::Vector2d& r : frames_.around_b) g.around.push_back(turn(Vec3(r.x() - root_b_.x(), r.y() - root_b_.y(), 0)));
        // A member's offset is whole voxels from C^A, so a point's cell is its cell at C^A moved
        // by (i, j, l): found once per angle.
        if (!fields_.empty()) {
            g.cells.resize(n);
            const Vec3 at_a(root_a_.x(), root_a_.y(), 0);
            g.bounds.resize(n);  // empty boxes
            for (std::size_t t = 0; t < n; ++t)
                for (const Vec3& p : points[t]) {
                    const auto cell = g.cells[t].emplace_back(fields_[t].cell(turn(p - planar_b) + at_a));
                    g.bounds[t].extend(Eigen::Vector3i(cell[0], cell[1], cell[2]));
                }
        }
        if (centroids)
            for (const auto& centroid : centroid_b) g.centroids.push_back(turn(*centroid - planar_b));
        for (const Limb& l : limbs_b_) g.limbs.push_back({turn(l.root - planar_b), turn(l.end - planar_b)});
        if (!sliding) return;
        std::vector<Vec3> rel(n);
        Vec3 mean = Vec3::Zero();
        for (std::size_t t = 0; t < n; ++t) mean += rel[t] = turn(*centroid_b[t] - planar_b) - *centroid_a[t];
        mean /= double(n);
        double sum = 0;
        for (const Vec3& r : rel) sum += (r - mean).squaredNorm();
        g.sliding = std::sqrt(sum / double(n));
    });
}

double NaturalScorer::gaze(const Angle& g, const Vec3& offset) const {
    double out = 0;
    gazes(g, {&offset.x(), 1}, {&offset.y(), 1}, {&out, 1});
    return out;
}

namespace {

// 1 - cos of the angle between unit gaze (gx, gy) and the direction (ux, uy) of `length` (0 when it
// has none: nothing to look away from). Branch-free, so that a loop over members vectorises: the
// division always runs, by 1 where the direction has no length.
inline double along(double gx, double gy, double ux, double uy, double length) {
    const bool none = length < 1e-9;
    const double cosine = (gx * ux + gy * uy) / (none ? 1.0 : length);
    return none ? 0.0 : 1.0 - cosine;
}

// One frame of NaturalScorer::gazes for every member: adds each member's two heads' terms to
// sum[n]. `centroids` is the sum of the two interest parts' centroids (with kContact); travel_a and
// travel_b are the walkers' terms, infinite where a head does not walk.
template <bool kContact>
void gaze_frame(const Vec3& ea, const Vec3& ga, const Vec3& eb, const Vec3& gb, const Vec3& centroids, double travel_a, double travel_b,
                std::span<const double> x, std::span<const double> y, std::span<double> sum) {
    // Read once, before the loop: a read inside it may not be moved out of a branch.
    const double eax = ea.x(), eay = ea.y(), gax = ga.x(), gay = ga.y(), ebx0 = eb.x(), eby0 = eb.y(), gbx = gb.x(), gby = gb.y();
    const double mx = centroids.x(), my = centroids.y();
    for (std::size_t n = 0; n < sum.size(); ++n) {
        // Each head toward the other's eye: one direction and one length for both.
        const double ebx = ebx0 + x[n], eby = eby0 + y[n];
        const double ux = ebx - eax, uy = eby - eay;
        const double length = std::sqrt(ux * ux + uy * uy);
        double a = along(gax, gay, ux, uy, length), b = along(gbx, gby, -ux, -uy, length);
        if constexpr (kContact) {  // or toward the contact, the midpoint of the two centroids
            const double cx = 0.5 * (mx + x[n]), cy = 0.5 * (my + y[n]);
            const double vx = cx - eax, vy = cy - eay, wx = cx - ebx, wy = cy - eby;
            a = std::min(a, along(gax, gay, vx, vy, std::sqrt(vx * vx + vy * vy)));
            b = std::min(b, along(gbx, gby, wx, wy, std::sqrt(wx * wx + wy * wy)));
        }
        // A walker may look where it goes (placement turns its gaze and its path alike).
        sum[n] += std::min(a, travel_a) + std::min(b, travel_b);
    }
}

}  // namespace

void NaturalScorer::gazes(const Angle& g, std::span<const double> x, std::span<const double> y, std::span<double> out) const {
    // Members are the inner loop; each member's sum runs over the frames in order, so a batch
    // gives each member gaze()'s bits.
    constexpr double kNoTravel = std::numeric_limits<double>::infinity();
    std::fill(out.begin(), out.end(), 0.0);
    for (std::size_t t = 0; t < g.eyes.size(); ++t) {
        const double travel_a = std::isnan(travel_a_[t]) ? kNoTravel : travel_a_[t], travel_b = std::isnan(travel_b_[t]) ? kNoTravel : travel_b_[t];
        if (g.centroids.empty())
            gaze_frame<false>(eyes_a_[t], gazes_a_[t], g.eyes[t], g.gazes[t], Vec3::Zero(), travel_a, travel_b, x, y, out);
        else
            gaze_frame<true>(eyes_a_[t], gazes_a_[t], g.eyes[t], g.gazes[t], centroids_a_[t] + g.centroids[t], travel_a, travel_b, x, y, out);
    }
    for (double& sum : out) sum /= 2.0 * double(g.eyes.size());
}

double NaturalScorer::depth(const Angle& g, const PoseIndex& pose) const {
    double sum = 0;
    for (std::size_t t = 0; t < g.cells.size(); ++t) {
        // Points whose box, moved by the offset, misses A's grid all read 0 there: skip them.
        if (g.cells[t].empty()) continue;
        const auto& dims = fields_[t].grid.dims;
        const Eigen::AlignedBox3i grid(Eigen::Vector3i::Zero(), Eigen::Vector3i(dims[0] - 1, dims[1] - 1, dims[2] - 1));
        if (!g.bounds[t].translated(Eigen::Vector3i(pose.i, pose.j, pose.l)).intersects(grid)) continue;
        double deepest = 0;
        for (const auto& c : g.cells[t]) deepest = std::max(deepest, fields_[t].at(c[0] + pose.i, c[1] + pose.j, c[2] + pose.l));
        sum += std::max(0.0, deepest - depth_allowance_);
    }
    return sum / double(g.cells.size());
}

double NaturalScorer::crowding(const Angle& g, const Vec3& offset) const {
    double sum = 0;
    for (std::size_t m = 0; m < g.around.size(); ++m) {
        const double dx = g.around[m].x() + offset.x() - frames_.around_a[m].x(), dy = g.around[m].y() + offset.y() - frames_.around_a[m].y();
        const double d2 = dx * dx + dy * dy;
        if (d2 < kIntimateDistance * kIntimateDistance) sum += square((kIntimateDistance - std::sqrt(d2)) / kNaturalCrowdingScale);
    }
    return sum / double(g.around.size());
}

void NaturalScorer::reach(const Angle& g, const Vec3& offset, NaturalTerms& out) const {
    // The contact frame: the impact (prepare_reaches), else the key frame (with both limbs'
    // directions) where the limbs' ends are nearest.
    std::size_t contact = impact_.value_or(0);
    double nearest = std::numeric_limits<double>::infinity();
    for (std::size_t t = 0; t < g.limbs.size() && !impact_; ++t) {
        const double d = (g.limbs[t].end + offset - limbs_a_[t].end).squaredNorm();
        if (reach_frames_[t] && d < nearest) nearest = d, contact = t;
    }
    const Limb& la = limbs_a_[contact];
    const Limb lb{g.limbs[contact].root + offset, g.limbs[contact].end + offset};
    const Vec3 da = floor_plane(la.end - la.root).normalized(), db = floor_plane(lb.end - lb.root).normalized();
    // 1 - cos of the angle between A's limb and B's reversed; each end's distance from the other's line.
    out.reach = 1.0 + da.dot(db);
    out.reach_offset_m = 0.5 * (off_line(lb.end, la, da) + off_line(la.end, lb, db));
    if (!impact_) return;
    // The impact's frame is the last before the ends meet (they lose their speed over the next):
    // B's end relative to A's there and a key frame before, closing along `closing`.
    const Vec3 now = lb.end - la.end, before = g.limbs[contact - 1].end + offset - limbs_a_[contact - 1].end;
    const Vec3 closing = now - before;
    const double closed = closing.norm();
    if (closed < 1e-9) return;
    out.impact_closing_m = closed;
    out.impact_gap_m = -now.dot(closing) / closed - impact_depth_;
}

Vec3 NaturalScorer::member_offset(const PoseIndex& pose) const {
    // B's point q goes to R(theta) (q - C^B) + C^A + (i h, j h, l h): the samples are turned about
    // C^B already; the offset adds the rest.
    return {root_a_.x() + pose.i * h_, root_a_.y() + pose.j * h_, pose.l * h_};
}

NaturalTerms NaturalScorer::terms(const PoseIndex& pose) const {
    if (angles_.empty()) return {};
    const Angle& g = angles_[std::size_t(pose.k)];
    return terms(pose, tracks_ && !g.eyes.empty() ? gaze(g, member_offset(pose)) : NaturalTerms::kNone);
}

NaturalTerms NaturalScorer::terms(const PoseIndex& pose, double gaze) const {
    NaturalTerms out;
    const Angle& g = angles_[std::size_t(pose.k)];
    const Vec3 at = member_offset(pose);
    out.gaze = gaze;
    if (!g.cells.empty()) out.depth_m = depth(g, pose);
    out.sliding_m = g.sliding;
    if (!g.around.empty()) out.crowding = crowding(g, at);
    if (!g.limbs.empty()) reach(g, at, out);
    return out;
}

std::vector<double> NaturalScorer::costs(const SolutionGroup& group) const {
    constexpr std::uint64_t kChunk = std::uint64_t(1) << 16;
    constexpr std::size_t kBatch = 64;  // members of one angle whose gazes are found together
    const std::uint64_t n = group.size();
    std::vector<double> out(n);
    if (angles_.empty()) return out;
    parallel_for(std::size_t((n + kChunk - 1) / kChunk), [&](std::size_t chunk) {
        std::uint64_t at = chunk * kChunk;
        std::vector<PoseIndex> batch;
        std::array<double, kBatch> x{}, y{}, gaze{};
        auto flush = [&] {
            const Angle& g = angles_[std::size_t(batch.front().k)];
            const bool looks = tracks_ && !g.eyes.empty();
            if (looks) gazes(g, {x.data(), batch.size()}, {y.data(), batch.size()}, {gaze.data(), batch.size()});
            for (std::size_t m = 0; m < batch.size(); ++m) out[at++] = terms(batch[m], looks ? gaze[m] : NaturalTerms::kNone).cost();
            batch.clear();
        };
        group.for_range(at, std::min(n, at + kChunk), [&](const PoseIndex& p) {
            if (!batch.empty() && (batch.size() == kBatch || p.k != batch.front().k)) flush();
            const Vec3 o = member_offset(p);
            x[batch.size()] = o.x(), y[batch.size()] = o.y();
            batch.push_back(p);
        });
        if (!batch.empty()) flush();
    });
    return out;
}

}  // namespace amhv
