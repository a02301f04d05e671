#include "src/scene/segment.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <numbers>
#include <sstream>

#include <Eigen/Geometry>

#include "src/core/angles.hpp"
#include "src/core/error.hpp"
#include "src/io/bvh.hpp"
#include "src/sweep/objects.hpp"
#include "src/io/files.hpp"

namespace amhv {

namespace fs = std::filesystem;

namespace {

std::map<int, TrackSample> read_track_csv(const std::string& path, const UnitsAndAxes& units) {
    std::istringstream in(read_file_bytes(path, std::uintmax_t(1) << 30));  // a regular file only: a FIFO must not hang the run
    std::map<int, TrackSample> track;
    std::string line;
    int line_number = 0;
    while (std::getline(in, line)) {
        ++line_number;
        if (!line.empty() && line.back() == '\r') line.pop_back();
        if (line.empty() || line[0] == '#') continue;
        std::replace(line.begin(), line.end(), ',', ' ');
        std::istringstream fields(line);
        double v[7];
        int count = 0;
        std::string token;
        bool numeric = true;
        while (fields >> token) {
            if (count >= 7) {
                count = 8;
                break;
            }
            try {
                std::size_t used = 0;
                v[count] = std::stod(token, &used);
                numeric = numeric && used == token.size();
            } catch (const std::exception&) {
                numeric = false;
            }
            ++count;
        }
        if (line_number == 1 && !numeric) continue;  // a header row
        if (count != 7 || !numeric)
            fail(fmt::format("{}:{}", path, line_number), "expected 7 numbers: frame, eye_x, eye_y, eye_z, gaze_x, gaze_y, gaze_z");
        for (double x : v)
            if (!std::isfinite(x)) fail(fmt::format("{}:{}", path, line_number), "non-finite value");
        if (v[0] < 0 || v[0] > 10'000'000 || v[0] != std::floor(v[0]))
            fail(fmt::format("{}:{}", path, line_number), "frame {} is not a whole frame number in 0..10000000", v[0]);
        Vec3 gaze = to_scene_direction(Vec3(v[4], v[5], v[6]), units);
        if (gaze.norm() < 1e-12) fail(fmt::format("{}:{}", path, line_number), "the gaze direction is zero");
        track[int(v[0])] = {to_scene_point(Vec3(v[1], v[2], v[3]), units), gaze.normalized()};
    }
    if (track.empty()) fail(path, "the track has no rows");
    return track;
}

// One text file per frame: a part label per vertex (names or numbers), whitespace-separated.
std::vector<std::string> read_labels(const fs::path& path, std::size_t vertex_count) {
    std::istringstream in(read_file_bytes(path, std::uintmax_t(1) << 30));
    std::vector<std::string> labels;
    std::string token;
    while (in >> token) {
        // A placed group names its other members "@NAME" (make_group): a user's part may not.
        if (token.front() == '@')
            fail(path.string(), "label '{}' of vertex {} starts with '@', which amhv keeps for the members of a placed group; rename the part",
                 token, labels.size());
        labels.push_back(token);
    }
    if (labels.size() != vertex_count)
        fail(path.string(), "has {} labels but the frame's mesh has {} vertices", labels.size(), vertex_count);
    return labels;
}

std::vector<BodyPart> split_by_labels(const TriangleMesh& mesh, const std::vector<std::string>& labels) {
    // A triangle belongs to the part of its first vertex.
    std::vector<BodyPart> parts;
    std::map<std::string, std::size_t> index;
    std::vector<std::vector<std::int64_t>> remap;
    for (const auto& t : mesh.triangles) {
        const std::string& label = labels[t[0]];
        auto [it, added] = index.emplace(label, parts.size());
        if (added) {
            parts.push_back({label, {}});
            remap.emplace_back(mesh.vertices.size(), -1);
        }
        BodyPart& part = parts[it->second];
        auto& map = remap[it->second];
        std::array<std::uint32_t, 3> out{};
        for (int k = 0; k < 3; ++k) {
            if (map[t[std::size_t(k)]] < 0) {
                map[t[std::size_t(k)]] = std::int64_t(part.mesh.vertices.size());
                part.mesh.vertices.push_back(mesh.vertices[t[std::size_t(k)]]);
            }
            out[std::size_t(k)] = std::uint32_t(map[t[std::size_t(k)]]);
        }
        part.mesh.triangles.push_back(out);
    }
    return parts;
}

// The file of frame `number` of a folder or pattern (list_frames checks it exists).
fs::path frame_file(const std::string& spec, int number) { return list_frames(spec, FrameRange{number, number}).front().path; }

// Mean eye position and gaze over `frames`, when the track has every one of them.
std::optional<TrackSample> mean_track(const ObjectSource& object, const std::vector<int>& frames) {
    if (frames.empty()) return std::nullopt;
    TrackSample mean{Vec3::Zero(), Vec3::Zero()};
    for (int f : frames) {
        auto sample = object.track(f);
        if (!sample) return std::nullopt;
        mean.eye += sample->eye;
        mean.gaze += sample->gaze;
    }
    mean.eye /= double(frames.size());
    mean.gaze /= double(frames.size());
    return mean;
}

double reach_from(const Amhv& volume, const Vec3& root) {
    Box3 b = occupied_bounds(volume);
    if (b.empty()) return 0;
    double reach = 0;
    for (int c = 0; c < 4; ++c) {
        Vec3 p((c & 1) ? b.max.x() : b.min.x(), (c & 2) ? b.max.y() : b.min.y(), 0);
        reach = std::max(reach, std::hypot(p.x() - root.x(), p.y() - root.y()));
    }
    return reach;
}

}  // namespace

// floor = "auto": the 5th percentile (nearest rank) of each frame's lowest point over the object's
// frames, so that a few frames where a foot goes through the floor or the capture glitches do
// not set it. Read with no lift.
double ObjectSource::find_floor() {
    std::vector<double> lowest;
    for (int f = spec_.frame_first; f <= spec_.frame_last; ++f) {
        double low = std::numeric_limits<double>::infinity();
        if (motion_ || character_) {
            for (const BodyPart& part : body_frame_parts(f))
                for (const Vec3& v : part.mesh.vertices) low = std::min(low, v.z());
        } else {
            for (const Vec3& v : read_mesh(frame_file(spec_.meshes, f), spec_.units, spec_.files_root).vertices) low = std::min(low, v.z());
        }
        if (std::isfinite(low)) lowest.push_back(low);
    }
    if (lowest.empty()) fail("object " + spec_.name, "floor = \"auto\" found no vertex in its frames");
    std::vector<double> sorted = lowest;
    std::sort(sorted.begin(), sorted.end());
    const double floor = sorted[std::size_t(std::floor(0.05 * double(sorted.size() - 1)))];
    floor_note_ = fmt::format("object {}: floor = \"auto\" found {:.4f} m (5th percentile of the lowest points of {} frames; lowest {:.4f} m, "
                              "median {:.4f} m); the capture is moved by {:.4f} m",
                              spec_.name, floor, sorted.size(), sorted.front(), sorted[sorted.size() / 2], -floor);
    return floor;
}

// A BVH body's or a character's parts at frame `number`, with the object's units as they are now.
std::vector<BodyPart> ObjectSource::body_frame_parts(int number) {
    if (character_) {
        return character_body_parts(*character_, skinned_frame(number), number);
    }
    return skeleton_body_parts(*motion_, number, body_options_);
}

TriangleMesh ObjectSource::character_surface(int number) {
    if (!character_) fail("object " + spec_.name, "internal: not a character");
    return {skinned_frame(number), character_file(*character_).triangles};
}

const std::vector<Vec3>& ObjectSource::skinned_frame(int number) {
    if (number < 0 || number >= character_file(*character_).frame_count())
        fail("object " + spec_.name, "has no frame {} (its animation has frames 0..{})", number, character_file(*character_).frame_count() - 1);
    if (!skinned_.count(number)) skin_ahead(number);
    return skinned_.at(number);
}

void ObjectSource::skin_ahead(int number) {
    constexpr std::size_t kSkinAheadBytes = std::size_t(256) << 20;
    const SkinVertices& vertices = character_skin(*character_);
    const std::size_t frame_bytes = std::max<std::size_t>(1, vertices.count() * (sizeof(Vec3) + 12));
    const int ahead = int(std::clamp<std::size_t>(kSkinAheadBytes / frame_bytes, 1, 64));
    // Reading backwards (a frame before those skinned last), the window ends at `number`.
    const bool backwards = !skinned_.empty() && number < skinned_.begin()->first;
    const int first = backwards ? std::max(0, number - ahead + 1) : number;
    const int last = std::min(first + ahead, character_file(*character_).frame_count()) - 1;
    CpuSkinner reference;
    std::vector<std::vector<Vec3>> frames = skin_frames(skinner_ ? *skinner_ : reference, vertices, character_file(*character_), first, last, spec_.units);
    skinned_.clear();
    for (int f = first; f <= last; ++f) skinned_[f] = std::move(frames[std::size_t(f - first)]);
}

ObjectSource::ObjectSource(const SceneObject& spec, Skinner* skinner) : skinner_(skinner), spec_(spec) {
    if (!spec_.bvh.empty()) {
        motion_ = load_bvh(spec_.bvh, BvhLoadOptions{spec_.tpose, spec_.fps});
        body_options_.units = spec_.units;
        // The fit depends on the axes and unit only (a lift moves the rest and every frame alike).
        if (spec_.body == BodyKind::Skinned) body_options_.skinned = fit_skin_model(load_skin_model(shipped_body_model()), *motion_, spec_.units);
    }
    if (!spec_.character.empty())
        character_ = build_character_body(spec_.character_file ? spec_.character_file
                                                                : std::make_shared<const CharacterFile>(read_character(spec_.character, spec_.animation, spec_.fps)),
                                          spec_.joint_roles);
    if (spec_.floor_auto) {
        spec_.units.lift = -find_floor();
        skinned_.clear();  // skinned without the lift
    }
    if (motion_) {
        body_options_.units = spec_.units;
        auto samples = skeleton_track(*motion_, body_options_);
        for (std::size_t f = 0; f < samples.size(); ++f) track_[int(f)] = samples[f];
        label_names_ = body_part_names(*motion_, spec_.body == BodyKind::Skinned);
    }
    if (character_) {
        auto samples = character_track(*character_, spec_.units);
        for (std::size_t f = 0; f < samples.size(); ++f) track_[int(f)] = samples[f];
        label_names_ = character_mapping(*character_).parts;
    }
    if (!spec_.track.empty()) track_ = read_track_csv(spec_.track, spec_.units);
}

namespace {

TriangleMesh moved(const TriangleMesh& mesh, const MemberFrame& f) { return moved_into_scene(mesh, f.yaw, f.translation, f.lift); }

}  // namespace

TriangleMesh moved_into_scene(TriangleMesh mesh, double yaw, const Eigen::Vector2d& translation, double lift) {
    const Eigen::Rotation2Dd rotation(yaw);
    for (Vec3& v : mesh.vertices) {
        const Eigen::Vector2d p = rotation * Eigen::Vector2d(v.x(), v.y()) + translation;
        v = Vec3(p.x(), p.y(), v.z() + lift);
    }
    return mesh;
}

ObjectSource::ObjectSource(const SceneObject& spec, std::vector<GroupMember> members) : spec_(spec), members_(std::move(members)) {
    if (members_.empty()) throw Error("a placed group needs at least one member");
    for (const GroupMember& m : members_)
        if (int(m.frames.size()) != spec_.frame_last + 1) throw Error(fmt::format("group {}: a member's frames do not cover the group's", spec_.name));
    label_names_ = members_.front().source->label_names();
    for (std::size_t m = 1; m < members_.size(); ++m) label_names_.push_back("@" + members_[m].source->spec().name);
    make_group_track();
}

// The partner's track moved with it; where it has none, its facing from the eye height (10 cm below
// the top of its body) above its root.
void ObjectSource::make_group_track() {
    const GroupMember& partner = members_.front();
    for (int k = 0; k <= spec_.frame_last; ++k) {
        const MemberFrame& f = partner.frames[std::size_t(k)];
        const Eigen::Rotation2Dd rotation(f.yaw);
        if (auto sample = partner.source->track(f.source)) {
            const Eigen::Vector2d eye = rotation * Eigen::Vector2d(sample->eye.x(), sample->eye.y()) + f.translation;
            const Eigen::Vector2d gaze = rotation * Eigen::Vector2d(sample->gaze.x(), sample->gaze.y());
            track_[k] = {Vec3(eye.x(), eye.y(), sample->eye.z() + f.lift), Vec3(gaze.x(), gaze.y(), sample->gaze.z())};
            continue;
        }
        double top = -std::numeric_limits<double>::infinity();
        for (const BodyPart& part : partner.source->frame_parts(f.source))
            for (const Vec3& v : part.mesh.vertices) top = std::max(top, v.z() + f.lift);
        track_[k] = {Vec3(f.root.x(), f.root.y(), top - 0.1), Vec3(std::cos(f.facing), std::sin(f.facing), 0)};
    }
}

const std::vector<BodyPart>& ObjectSource::group_parts(int number) {
    if (number < 0 || number > spec_.frame_last) fail("group " + spec_.name, "has no frame {} (frames 0..{})", number, spec_.frame_last);
    std::vector<BodyPart> parts;
    for (std::size_t m = 0; m < members_.size(); ++m) {
        const MemberFrame& f = members_[m].frames[std::size_t(number)];
        const std::vector<BodyPart>& own = members_[m].source->frame_parts(f.source);
        if (m == 0) {
            for (const BodyPart& p : own) parts.push_back({p.name, moved(p.mesh, f)});
            for (const std::string& name : members_[m].source->label_names())
                if (std::find(label_names_.begin(), label_names_.end(), name) == label_names_.end()) label_names_.push_back(name);
            continue;
        }
        BodyPart all{"@" + members_[m].source->spec().name, {}};
        for (const BodyPart& p : own) all.mesh.append(moved(p.mesh, f));
        parts.push_back(std::move(all));
    }
    return frames_.emplace(number, std::move(parts)).first->second;
}

const std::vector<BodyPart>& ObjectSource::frame_parts(int number) {
    if (auto it = frames_.find(number); it != frames_.end()) return it->second;
    if (is_group()) return group_parts(number);
    std::vector<BodyPart> parts;
    if (motion_ || character_) {
        parts = body_frame_parts(number);
    } else {
        const fs::path file = frame_file(spec_.meshes, number);
        TriangleMesh mesh = read_mesh(file, spec_.units, spec_.files_root);
        if (!spec_.labels.empty()) {
            parts = split_by_labels(mesh, read_labels(frame_file(spec_.labels, number), mesh.vertices.size()));
            for (const auto& p : parts)
                if (std::find(label_names_.begin(), label_names_.end(), p.name) == label_names_.end()) label_names_.push_back(p.name);
        } else {
            parts.push_back({"", std::move(mesh)});
        }
    }
    return frames_.emplace(number, std::move(parts)).first->second;
}

std::optional<TrackSample> ObjectSource::track(int number) const {
    if (auto it = track_.find(number); it != track_.end()) return it->second;
    return std::nullopt;
}

const MeshFrame& ObjectSource::part_frame(const std::string& meshes, int number) {
    auto key = std::make_pair(meshes, number);
    if (auto it = part_frames_.find(key); it != part_frames_.end()) return it->second;
    if (is_group()) {  // the partner's part sequence, moved with it
        const GroupMember& partner = members_.front();
        const MemberFrame& f = partner.frames[std::size_t(number)];
        const MeshFrame& own = partner.source->part_frame(meshes, f.source);
        return part_frames_.emplace(key, MeshFrame{moved(own.mesh, f), own.source}).first->second;
    }
    const fs::path file = frame_file(meshes, number);
    MeshFrame frame{read_mesh(file, spec_.units, spec_.files_root), file.string()};
    return part_frames_.emplace(key, std::move(frame)).first->second;
}

Eigen::Vector2d segment_facing(const ObjectSource& object, const std::vector<int>& frames) {
    if (auto mean = mean_track(object, frames)) {
        Eigen::Vector2d facing(mean->gaze.x(), mean->gaze.y());
        if (facing.norm() > 1e-9) return facing.normalized();
    }
    const double facing = angles::radians(object.spec().facing_deg.value_or(0.0));
    return {std::cos(facing), std::sin(facing)};
}

namespace {

// The labelled parts of one frame that a part spec names (Parts) or leaves out (PartsExcept).
std::vector<MeshFrame> select_parts(const std::vector<BodyPart>& parts, const PartSpec& spec, const std::string& name, int number) {
    std::vector<MeshFrame> out;
    for (const BodyPart& p : parts) {
        const bool listed = std::find(spec.labels.begin(), spec.labels.end(), p.name) != spec.labels.end();
        if (listed == (spec.kind == PartSpec::Kind::Parts)) out.push_back({p.mesh, fmt::format("object {} frame {} part {}", name, number, p.name)});
    }
    return out;
}

PartRule part_rule(const PartSpec& spec) {
    switch (spec.kind) {
        case PartSpec::Kind::Whole: return PartRule::Whole;
        case PartSpec::Kind::WholeMinusInterest: return PartRule::WholeMinusInterest;
        case PartSpec::Kind::Box: return PartRule::Box;
        default: return PartRule::Meshes;
    }
}

// One object's meshes of one key segment, as the volume builder reads them: per normalised frame,
// the whole body and the meshes of its interest and fidelity parts. `storage` owns the copies.
struct SegmentMeshes {
    std::vector<std::vector<MeshFrame>> storage;
    std::vector<ObjectFrame> frames;
    std::vector<int> numbers;  // the source frame of each normalised frame
};

// Adds the meshes a part spec names (a separate sequence, or labelled parts) to one frame's list.
void attach_part(ObjectSource& source, const PartSpec& spec, const std::vector<BodyPart>& parts, int number, std::vector<MeshFrame>& own,
                 std::vector<const MeshFrame*>& list) {
    if (spec.kind == PartSpec::Kind::Meshes) {
        own.push_back(source.part_frame(spec.meshes, number));
        list.push_back(&own.back());
    } else if (spec.kind == PartSpec::Kind::Parts || spec.kind == PartSpec::Kind::PartsExcept) {
        for (MeshFrame& f : select_parts(parts, spec, source.spec().name, number)) {
            own.push_back(std::move(f));
            list.push_back(&own.back());
        }
    }
}

SegmentMeshes segment_meshes(ObjectSource& source, int first, const std::vector<int>& relative, const PartSpec& interest,
                             const PartSpec& fidelity) {
    const std::string& name = source.spec().name;
    SegmentMeshes m;
    m.storage.resize(relative.size());
    m.frames.resize(relative.size());
    for (std::size_t f = 0; f < relative.size(); ++f) {
        const int number = first + relative[f];
        m.numbers.push_back(number);
        const auto& parts = source.frame_parts(number);
        auto& own = m.storage[f];
        // Room for every copy up front: the frames keep pointers into it.
        own.reserve(parts.size() * 3 + 2);
        for (const BodyPart& p : parts) own.push_back({p.mesh, fmt::format("object {} frame {}{}", name, number, p.name.empty() ? "" : " part " + p.name)});
        const std::size_t whole_count = own.size();
        for (std::size_t k = 0; k < whole_count; ++k) m.frames[f].whole.push_back(&own[k]);
        attach_part(source, interest, parts, number, own, m.frames[f].interest);
        attach_part(source, fidelity, parts, number, own, m.frames[f].fidelity);
    }
    return m;
}

// One object's volumes in one key segment (docs/method.md sections 3 and 9); the interest part
// grown by `grow` metres (contact_tolerance).
SweepObject segment_object(ObjectSource& source, int first, const std::vector<int>& relative, const PartSpec& interest,
                           const PartSpec& fidelity, double h, Voxeliser& voxeliser, const std::string& where, std::vector<int>& numbers,
                           double grow) {
    const std::string& name = source.spec().name;
    SegmentMeshes meshes = segment_meshes(source, first, relative, interest, fidelity);
    numbers = meshes.numbers;
    // Every part named must exist: label files name their parts only as frames are read, so this
    // comes after the segment's frames (and before any voxelisation).
    for (const PartSpec* spec : {&interest, &fidelity})
        for (const std::string& label : spec->labels)
            if (std::find(source.label_names().begin(), source.label_names().end(), label) == source.label_names().end())
                fail(where, "object {} has no part '{}'", name, label);
    ObjectParts parts;
    parts.interest = part_rule(interest);
    parts.fidelity = part_rule(fidelity);
    parts.interest_is_separate = interest.kind == PartSpec::Kind::Meshes;
    parts.fidelity_is_separate = fidelity.kind == PartSpec::Kind::Meshes;
    if (interest.kind == PartSpec::Kind::Box) parts.interest_box = interest.box;
    if (fidelity.kind == PartSpec::Kind::Box) parts.fidelity_box = fidelity.box;
    parts.grow_interest = grow;
    SweepObject object = build_sweep_object(name, meshes.frames, parts, h, voxeliser);
    object.facing = segment_facing(source, numbers);
    return object;
}

// `region` cut to where cones of a limited range reach from their eyes.
Box3 within_range(const Box3& region, const std::vector<ViewCone>& cones, double h) {
    if (cones.front().range <= 0) return region;
    Box3 reach;
    for (const ViewCone& cone : cones) {
        reach.extend(cone.eye - Vec3::Constant(cone.range));
        reach.extend(cone.eye + Vec3::Constant(cone.range));
    }
    Box3 r = region;
    r.min = r.min.cwiseMax(reach.min);
    r.max = r.max.cwiseMin(reach.max);
    if (r.empty()) r.min = r.max = cones.front().eye;
    r.max += Vec3::Constant(h);
    return r;
}

// An object's view cone over `region` (docs/method.md section 5): from the mean track, or without
// one, eyes 10 cm below the top of the body above the root, looking along the facing. Per frame
// (visibility.per_frame), one cone per normalised frame from the track at that frame.
ConeVolume segment_cone(const SweepObject& self, ObjectSource& source, const std::vector<int>& numbers, const Box3& region,
                        const VisibilitySpec& visibility, double h) {
    ViewCone cone;
    cone.half_angle_deg = visibility.half_angle_deg;
    cone.range = visibility.range;
    if (visibility.per_frame) {
        std::vector<ViewCone> cones;
        for (int number : numbers) {
            const auto sample = source.track(number);
            if (!sample || !(sample->gaze.norm() > 1e-9))
                fail("object " + source.spec().name, "has no view track at frame {}; per-frame visibility needs one at every frame (a track file, or a BVH take)",
                     number);
            cone.eye = sample->eye;
            cone.gaze = sample->gaze.normalized();
            cones.push_back(cone);
        }
        return view_cone_volumes(cones, within_range(region, cones, h), h);
    }
    auto mean = mean_track(source, numbers);
    if (mean && mean->gaze.norm() > 1e-9) {
        cone.eye = mean->eye;
        cone.gaze = mean->gaze.normalized();
    } else {
        Box3 bounds = occupied_bounds(self.whole);
        cone.eye = Vec3(self.root.x(), self.root.y(), bounds.max.z() - 0.1);
        cone.gaze = Vec3(self.facing.x(), self.facing.y(), 0);
    }
    return view_cone_volume(cone, within_range(region, {cone}, h), h);
}

// Each cone is rasterised over the region where the other's body can be at any pose of the range.
void add_view_cones(SweepProblem& p, ObjectSource& a, ObjectSource& b, const std::vector<int>& numbers_a, const std::vector<int>& numbers_b,
                    const VisibilitySpec& visibility) {
    const double h = p.voxel;
    const double s_max = std::max({std::hypot(p.range.i_first * h, p.range.j_first * h), std::hypot(p.range.i_last * h, p.range.j_first * h),
                                   std::hypot(p.range.i_first * h, p.range.j_last * h), std::hypot(p.range.i_last * h, p.range.j_last * h)});
    const VoxelGrid& ga = p.a.whole.grid();
    const VoxelGrid& gb = p.b.whole.grid();
    const double reach_a = reach_from(p.a.whole, p.a.root), reach_b = reach_from(p.b.whole, p.b.root);
    // B raised by z_first .. z_last voxels: A's body seen from B is lowered as much.
    const double raise_first = p.range.z_first * h, raise_last = p.range.z_last * h;
    Box3 region_a;  // where B's body can be, in A's frame
    region_a.min = Vec3(p.a.root.x() + p.range.i_first * h - reach_b, p.a.root.y() + p.range.j_first * h - reach_b, gb.origin.z() + raise_first);
    region_a.max = Vec3(p.a.root.x() + p.range.i_last * h + reach_b, p.a.root.y() + p.range.j_last * h + reach_b,
                        gb.origin.z() + gb.dims[2] * h + raise_last);
    Box3 region_b;  // where A's body can be, in B's frame
    const double r = reach_a + s_max + h;
    region_b.min = Vec3(p.b.root.x() - r, p.b.root.y() - r, ga.origin.z() - raise_last);
    region_b.max = Vec3(p.b.root.x() + r, p.b.root.y() + r, ga.origin.z() + ga.dims[2] * h - raise_first);
    p.a.view_cone = segment_cone(p.a, a, numbers_a, region_a, visibility, h);
    p.b.view_cone = segment_cone(p.b, b, numbers_b, region_b, visibility, h);
}

// A key segment's parts on a placed group's side (docs/method.md section 11): the interest is the
// partner's alone; the fidelity volume also holds every other member (which the clearance test
// covers with B's whole body anyway, so the solutions are the same either way).
std::array<PartSpec, 2> group_side_parts(const ObjectSource& group, PartSpec interest, PartSpec fidelity, const std::string& where) {
    std::vector<std::string> others;
    for (std::size_t m = 1; m < group.members().size(); ++m) others.push_back("@" + group.members()[m].source->spec().name);
    const std::string& partner = group.members().front().source->spec().name;
    for (const PartSpec* spec : {&interest, &fidelity})
        if (spec->kind == PartSpec::Kind::Box || (spec == &fidelity && spec->kind == PartSpec::Kind::Meshes))
            fail(where, "object {} is placed in a group here, and its {} part is {}: name its parts instead (a box or a fidelity "
                 "sequence on the placed side is not supported yet)", partner, spec == &interest ? "interest" : "fidelity", spec->describe());
    if (interest.kind == PartSpec::Kind::Whole) interest = PartSpec{PartSpec::Kind::PartsExcept, "", others, {}};
    else if (interest.kind == PartSpec::Kind::PartsExcept) interest.labels.insert(interest.labels.end(), others.begin(), others.end());
    if (fidelity.kind == PartSpec::Kind::Parts) fidelity.labels.insert(fidelity.labels.end(), others.begin(), others.end());
    return {interest, fidelity};
}

// The partner's (`partner`) or the other members' volume of a group over the segment's frames, on
// the group's grid.
Amhv member_volume(ObjectSource& group, bool partner, int first, const std::vector<int>& relative, const VoxelGrid& grid, Voxeliser& voxeliser) {
    std::vector<MeshFrame> merged(relative.size());
    std::vector<const MeshFrame*> pointers;
    for (std::size_t f = 0; f < relative.size(); ++f) {
        const int number = first + relative[f];
        for (const BodyPart& part : group.frame_parts(number))
            if ((part.name.empty() || part.name.front() != '@') == partner) merged[f].mesh.append(part.mesh);
        merged[f].source = fmt::format("group {} frame {}", group.spec().name, number);
        pointers.push_back(&merged[f]);
    }
    return voxelise(prepare_voxelisation(pointers, grid), voxeliser);
}

// A placed group's side of a key segment (docs/method.md section 11): its whole body is the
// partner's (what the newcomer's view cone must see), the pose lattice and the descriptors
// (distance, angles) are about the partner's root, not the group's centroid, and the other members
// are the clearance volume B's whole body must keep out of. (The fidelity volume, derived before,
// may hold them too.)
void group_side(SweepObject& a, ObjectSource& group, int first, const std::vector<int>& relative, Voxeliser& voxeliser) {
    Amhv partner = member_volume(group, true, first, relative, a.whole.grid(), voxeliser);
    a.root = occupied_root(partner);
    if (group.members().size() > 1) a.clearance = member_volume(group, false, first, relative, a.whole.grid(), voxeliser);
    a.whole = std::move(partner);
}

}  // namespace

SegmentBuild build_segment(const Scene& scene, const KeySegment& segment, ObjectSource& a, ObjectSource& b, Voxeliser& voxeliser) {
    SegmentBuild build;
    const Voxeliser::ScratchHold hold(voxeliser);  // the segment's volumes share one set of scratch
    const int length_a = segment.a[1] - segment.a[0] + 1, length_b = segment.b[1] - segment.b[0] + 1;
    build.frames = scene.a_sets_time ? normalise_to_a(length_a, length_b) : normalise_pair(length_a, length_b);
    const double h = scene.sampling.voxel;
    const std::string where = fmt::format("{}: segments[{}]", scene.file.string(), segment.index);
    std::vector<int> numbers_a, numbers_b;
    SweepProblem& p = build.problem;
    // contact_tolerance grows A's part only: the gap between the parts closes by the radius once.
    std::array<PartSpec, 2> parts_a{segment.interest_a, segment.fidelity_a};
    if (a.is_group()) parts_a = group_side_parts(a, segment.interest_a, segment.fidelity_a, where);
    p.a = segment_object(a, segment.a[0], build.frames.frames_a, parts_a[0], parts_a[1], h, voxeliser, where, numbers_a, segment.contact_tolerance);
    if (a.is_group()) group_side(p.a, a, segment.a[0], build.frames.frames_a, voxeliser);
    p.b = segment_object(b, segment.b[0], build.frames.frames_b, segment.interest_b, segment.fidelity_b, h, voxeliser, where, numbers_b, 0);
    p.type = segment.type;
    p.tolerance = segment.tolerance;
    const int tau = build.frames.length;
    // ceil(f tau), with a guard against 0.9 * 40 landing a hair above 36.
    auto frames_of = [tau](double fraction) { return std::clamp(int(std::ceil(fraction * tau - 1e-9)), 1, tau); };
    if (segment.contact_frames < 1) p.contact_frames = frames_of(segment.contact_frames);
    p.voxel = h;
    p.angle_step_deg = scene.sampling.angle_step_deg;
    for (const SweepObject* o : {&p.a, &p.b})
        if (!any_occupied(o->interest)) fail(where, "object {}'s volume of interest is empty", o->name);
    p.range = automatic_range(p.a, p.b, h, scene.sampling.angles());
    narrow_range(p.range, h, scene.sampling.x_range ? &*scene.sampling.x_range : nullptr,
                 scene.sampling.y_range ? &*scene.sampling.y_range : nullptr);
    if (segment.z_range) {
        p.range.z_first = int(std::ceil((*segment.z_range)[0] / h - 1e-9));
        p.range.z_last = int(std::floor((*segment.z_range)[1] / h + 1e-9));
        if (p.range.z_first > p.range.z_last)
            fail(where, "z_range [{}, {}] holds no whole voxel of {} m", (*segment.z_range)[0], (*segment.z_range)[1], h);
    }
    p.visibility = segment.visibility.enabled;
    if (p.visibility && segment.visibility.per_frame) p.visibility_frames = frames_of(segment.visibility.frames);
    if (p.visibility) add_view_cones(p, a, b, numbers_a, numbers_b, segment.visibility);
    validate(p);
    return build;
}

double intent_cost(const Intent& intent, const Solution& s) {
    if (!intent.prefers()) return 0;
    double sum = 0;
    if (intent.distance_m) sum += std::pow((s.distance - *intent.distance_m) / 0.05, 2);
    if (intent.theta_a_deg) sum += std::pow(angles::wrap_degrees(s.theta_a_deg - *intent.theta_a_deg) / 5.0, 2);
    if (intent.theta_b_deg) sum += std::pow(angles::wrap_degrees(s.theta_b_deg - *intent.theta_b_deg) / 5.0, 2);
    return intent.weight * sum;
}

Eigen::Vector2d truth_offset(const Placement& truth, const Vec3& root_a, const Vec3& root_b) {
    return Eigen::Rotation2Dd(angles::radians(truth.yaw_deg)) * Eigen::Vector2d(root_b.x(), root_b.y()) + Eigen::Vector2d(truth.x, truth.y) -
           Eigen::Vector2d(root_a.x(), root_a.y());
}

bool within_limits(const Intent& intent, const Solution& s) {
    auto inside = [](const std::optional<std::array<double, 2>>& r, double v) { return !r || ((*r)[0] <= v && v <= (*r)[1]); };
    return inside(intent.distance_limits_m, s.distance) && inside(intent.theta_a_limits_deg, s.theta_a_deg) &&
           inside(intent.theta_b_limits_deg, s.theta_b_deg);
}

std::string describe_limits(const Intent& intent) {
    std::string out;
    intent.for_each_limit([&](const char* key, const std::optional<std::array<double, 2>>& r) {
        if (r) out += fmt::format("{}{} [{}, {}]", out.empty() ? "" : ", ", key, (*r)[0], (*r)[1]);
    });
    return out;
}

}  // namespace amhv
