#include "src/results/edit_files.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <functional>
#include <numbers>

#include <cairo.h>
#include <Eigen/Geometry>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "src/core/angles.hpp"
#include "src/core/budget.hpp"
#include "src/core/error.hpp"
#include "src/core/parallel.hpp"
#include "src/io/files.hpp"
#include "src/io/ply_file.hpp"
#include "src/results/character_glb.hpp"
#include "src/results/key_views.hpp"
#include "src/results/picture.hpp"

namespace amhv {

namespace fs = std::filesystem;

namespace {

constexpr double kPi = std::numbers::pi;

std::string segment_name(const TimelineSegment& s, int index) {
    return s.key ? fmt::format("key {}", s.key) : fmt::format("transition {}", index / 2);
}



}  // namespace

nlohmann::ordered_json frame_transform_json(const ObjectFrameEdit& e) {
    const double c = std::cos(e.yaw), s = std::sin(e.yaw);
    return {
        {"source", e.source},
        {"x", e.translation.x()},
        {"y", e.translation.y()},
        {"z", e.lift},
        {"yaw_deg", angles::wrap_degrees(angles::degrees(e.yaw))},
        {"matrix", {{c, -s, 0.0, e.translation.x()}, {s, c, 0.0, e.translation.y()}, {0.0, 0.0, 1.0, e.lift}, {0.0, 0.0, 0.0, 1.0}}},
        {"root", {e.edited_root.x(), e.edited_root.y()}},
        {"facing_deg", angles::wrap_degrees(angles::degrees(e.edited_facing))},
    };
}

void write_transforms_json(const fs::path& path, const Scene& scene, const EditResult& edit) {
    nlohmann::ordered_json json;
    json["program"] = std::string("amhv ") + AMHV_VERSION;
    json["scene"] = scene.file.string();
    json["convention"] = "scene point = R(yaw) * capture point + (x, y, 0): a turn about the vertical (z) axis, then a move on the floor; "
                         "metres, z up, yaw in degrees counter-clockwise; matrix is the same map, row-major 4x4";
    json["frames"] = edit.timeline.length();
    json["objects"] = {{"A", object_source_path(scene.a)}, {"B", object_source_path(scene.b)}};
    nlohmann::ordered_json segments = nlohmann::ordered_json::array();
    for (std::size_t s = 0; s < edit.timeline.segments.size(); ++s) {
        const TimelineSegment& seg = edit.timeline.segments[s];
        segments.push_back({{"name", segment_name(seg, int(s))},
                            {"output_frames", {seg.first, seg.first + seg.length - 1}},
                            {"frames_a", {seg.a[0], seg.a[1]}},
                            {"frames_b", {seg.b[0], seg.b[1]}}});
    }
    json["segments"] = segments;
    nlohmann::ordered_json frames = nlohmann::ordered_json::array();
    for (int k = 0; k < edit.timeline.length(); ++k) {
        nlohmann::ordered_json f;
        f["frame"] = k;
        f["segment"] = segment_name(edit.timeline.segments[std::size_t(edit.timeline.segment[std::size_t(k)])], edit.timeline.segment[std::size_t(k)]);
        for (int o = 0; o < 2; ++o) f[o == 0 ? "A" : "B"] = frame_transform_json(edit.frames[std::size_t(o)][std::size_t(k)]);
        frames.push_back(f);
    }
    json["output"] = frames;
    write_file(path, json.dump(1) + '\n');
}

namespace {

// Both objects' meshes at output frame k, moved into the scene; A's vertices first.
struct EditedFrame {
    TriangleMesh both;
    std::array<std::size_t, 3> vertices_from{}, faces_from{};  // object o owns [from[o], from[o + 1])
};

EditedFrame edited_frame(const EditResult& edit, int k, ObjectSource& a, ObjectSource& b) {
    EditedFrame frame;
    ObjectSource* sources[2] = {&a, &b};
    for (int o = 0; o < 2; ++o) {
        frame.both.append(placed_mesh(edit, k, o, *sources[o]));
        frame.vertices_from[std::size_t(o) + 1] = frame.both.vertices.size();
        frame.faces_from[std::size_t(o) + 1] = frame.both.triangles.size();
    }
    return frame;
}

}  // namespace

void write_frame_checks_csv(const fs::path& path, const EditResult& edit) {
    std::string text = "frame,segment,overlap_voxels,overlap_cm3,gap_mm\n";
    const double voxel_cm3 = std::pow(edit.voxel * 100, 3);
    for (const FrameCheck& f : edit.frame_checks) {
        const int s = edit.timeline.segment[std::size_t(f.frame)];
        text += fmt::format("{},{},{},{:.3f},{}\n", f.frame, segment_name(edit.timeline.segments[std::size_t(s)], s), f.overlap, double(f.overlap) * voxel_cm3,
                            f.gap_m ? fmt::format("{:.1f}", *f.gap_m * 1000) : std::string());
    }
    write_file(path, text);
}

int write_scene_frames(const fs::path& folder, const EditResult& edit, ObjectSource& a, ObjectSource& b) {
    fs::create_directories(folder);
    for (int k = 0; k < edit.timeline.length(); ++k) {
        const EditedFrame frame = edited_frame(edit, k, a, b);
        if (k == 0) {
            // Disk for every frame, estimated from the first (binary PLY: 15 bytes a vertex, 13 a face).
            const std::uint64_t bytes = (frame.both.vertices.size() * 15 + frame.both.triangles.size() * 13 + 1024) * std::uint64_t(edit.timeline.length());
            budget::require_disk(folder, bytes + bytes / 2, fmt::format("frames/ ({} PLY files)", edit.timeline.length()),
                                 "free some disk or pass --no-frames");
        }
        std::vector<std::array<std::uint8_t, 3>> colours(frame.both.vertices.size(), kObjectColours[1]);
        std::fill(colours.begin(), colours.begin() + std::ptrdiff_t(frame.vertices_from[1]), kObjectColours[0]);
        std::vector<std::string> comments{fmt::format("amhv edit output frame {}: A = source frame {}, B = source frame {}", k,
                                                      edit.frames[0][std::size_t(k)].source, edit.frames[1][std::size_t(k)].source)};
        for (std::size_t o = 0; o < 2; ++o)
            comments.push_back(fmt::format("object {}: vertices {}..{}, faces {}..{}, colour {} {} {}", "AB"[o], frame.vertices_from[o],
                                           frame.vertices_from[o + 1] - 1, frame.faces_from[o], frame.faces_from[o + 1] - 1, kObjectColours[o][0],
                                           kObjectColours[o][1], kObjectColours[o][2]));
        write_ply(folder / fmt::format("{:04d}.ply", k), frame.both, colours, comments);
    }
    return edit.timeline.length();
}

nlohmann::ordered_json write_key_and_eye_views(const fs::path& folder, const Scene& scene, const EditResult& edit, ObjectSource& a, ObjectSource& b) {
    std::vector<KeyView> views;
    for (const TimelineSegment& segment : edit.timeline.segments)
        if (segment.key && segment.length > 0)
            views.push_back({segment.key, segment.first + segment.length / 2, 0, 1, segment.first, segment.first + segment.length - 1});
    const std::vector<const std::vector<ObjectFrameEdit>*> frames{&edit.frames[0], &edit.frames[1]};
    const std::vector<ObjectSource*> sources{&a, &b};
    choose_meeting_frames(scene, views, frames, sources);
    const std::vector<KeyCamera> cameras = write_key_views(folder, scene, {"A", "B"}, views, frames, sources);
    write_eye_views(folder, scene, {"A", "B"}, views, frames, sources);
    return key_views_json(views, cameras, {"A", "B"});
}

namespace {

constexpr int kEyeSize = 600;
constexpr double kCone = 170, kNear = 0.05;

}  // namespace

EyeCamera eye_camera(const ObjectFrameEdit& e, ObjectSource& source, const TriangleMesh& placed, double half_angle_deg) {
    EyeCamera c;
    const auto sample = source.track(e.source);
    const Eigen::Rotation2Dd yaw(e.yaw);
    if (sample && sample->gaze.norm() > 1e-9) {
        const Eigen::Vector2d at = yaw * Eigen::Vector2d(sample->eye.x(), sample->eye.y()) + e.translation;
        const Eigen::Vector2d gaze = yaw * Eigen::Vector2d(sample->gaze.x(), sample->gaze.y());
        c.eye = Vec3(at.x(), at.y(), sample->eye.z() + e.lift);
        c.forward = Vec3(gaze.x(), gaze.y(), sample->gaze.z()).normalized();
    } else {
        c.eye = Vec3(e.edited_root.x(), e.edited_root.y(), placed.bounds().max.z() - 0.1);
        c.forward = Vec3(std::cos(e.edited_facing), std::sin(e.edited_facing), 0);
    }
    const Vec3 side = c.forward.cross(Vec3::UnitZ());
    c.right = side.norm() > 1e-6 ? Vec3(side.normalized()) : Vec3::UnitX();
    c.up = c.right.cross(c.forward);
    c.focal = kCone / std::tan(angles::radians(std::clamp(half_angle_deg, 1.0, 89.0)));
    return c;
}

void draw_eye_view(const fs::path& path, const EyeCamera& c, const TriangleMesh& other, const std::vector<std::size_t>& faces_from,
                   const std::vector<std::size_t>& colours, const std::string& caption) {
    auto camera = [&](const Vec3& p) { const Vec3 d = p - c.eye; return Vec3(d.dot(c.right), d.dot(c.up), d.dot(c.forward)); };
    auto pixel = [&](const Vec3& q) { return Eigen::Vector2d(kEyeSize / 2.0 + c.focal * q.x() / q.z(), kEyeSize / 2.0 - c.focal * q.y() / q.z()); };
    cairo_surface_t* surface = cairo_image_surface_create(CAIRO_FORMAT_RGB24, kEyeSize, kEyeSize);
    cairo_t* cr = cairo_create(surface);
    cairo_set_source_rgb(cr, 1, 1, 1);
    cairo_paint(cr);
    // The floor: lines every 0.5 m within 5 m of the eye, clipped to in front of it.
    cairo_set_source_rgb(cr, 0.8, 0.8, 0.8);
    cairo_set_line_width(cr, 1);
    for (int axis = 0; axis < 2; ++axis)
        for (int i = -10; i <= 10; ++i)
            for (int j = -10; j < 10; ++j) {
                Vec3 p0 = Vec3::Zero(), p1 = Vec3::Zero();
                p0[axis] = p1[axis] = std::round(c.eye[axis] * 2) / 2 + 0.5 * i;
                p0[1 - axis] = std::round(c.eye[1 - axis] * 2) / 2 + 0.5 * j;
                p1[1 - axis] = p0[1 - axis] + 0.5;
                const Vec3 q0 = camera(p0), q1 = camera(p1);
                if (q0.z() < kNear || q1.z() < kNear) continue;
                const Eigen::Vector2d a = pixel(q0), b = pixel(q1);
                cairo_move_to(cr, a.x(), a.y());
                cairo_line_to(cr, b.x(), b.y());
                cairo_stroke(cr);
            }
    std::vector<std::pair<double, std::size_t>> order;
    for (std::size_t t = 0; t < other.triangles.size(); ++t) {
        const auto& tri = other.triangles[t];
        const Vec3 q = camera(other.vertices[tri[0]]), r = camera(other.vertices[tri[1]]), s = camera(other.vertices[tri[2]]);
        if (std::min({q.z(), r.z(), s.z()}) < kNear) continue;
        order.emplace_back(-(q.z() + r.z() + s.z()), t);
    }
    std::sort(order.begin(), order.end());
    for (const auto& [depth, t] : order) {
        const std::size_t range = std::size_t(std::upper_bound(faces_from.begin(), faces_from.end(), t) - faces_from.begin()) - 1;
        const auto& colour = kObjectColours[colours[range] % kObjectColours.size()];
        const auto& tri = other.triangles[t];
        const Vec3 normal = (other.vertices[tri[1]] - other.vertices[tri[0]]).cross(other.vertices[tri[2]] - other.vertices[tri[0]]);
        if (normal.norm() < 1e-15 || normal.dot(other.vertices[tri[0]] - c.eye) > 0) continue;  // degenerate or facing away
        const double shade = 0.35 + 0.65 * std::max(0.0, -normal.normalized().dot(c.forward));
        fill_triangle(cr, {pixel(camera(other.vertices[tri[0]])), pixel(camera(other.vertices[tri[1]])), pixel(camera(other.vertices[tri[2]]))},
                      shade, colour);
    }
    cairo_set_source_rgb(cr, 0.2, 0.2, 0.2);
    cairo_set_line_width(cr, 2);
    cairo_arc(cr, kEyeSize / 2.0, kEyeSize / 2.0, kCone, 0, 2 * std::numbers::pi);
    cairo_stroke(cr);
    cairo_set_source_rgb(cr, 0.1, 0.1, 0.1);
    draw_text(cr, 10, 20, caption, 14);
    finish_png(cr, surface, path);
}

void write_eye_views(const fs::path& folder, const Scene& scene, const std::vector<std::string>& names, const std::vector<KeyView>& views,
                     const std::vector<const std::vector<ObjectFrameEdit>*>& frames, const std::vector<ObjectSource*>& sources) {
    fs::create_directories(folder);
    // Cameras and meshes are gathered on this thread (an ObjectSource caches as it reads); the
    // pictures are drawn on every core.
    struct EyePicture {
        fs::path path;
        EyeCamera camera;
        TriangleMesh others;
        std::vector<std::size_t> faces_from{0}, colours;
        std::string caption;
    };
    std::vector<EyePicture> pictures;
    for (const KeyView& view : views) {
        std::vector<TriangleMesh> placed;
        for (std::size_t o = 0; o < frames.size(); ++o) placed.push_back(placed_mesh((*frames[o])[std::size_t(view.frame)], *sources[o]));
        const VisibilitySpec& visibility = scene.segments[std::size_t(view.key - 1)].visibility;
        for (const std::size_t viewer : {view.first, view.second}) {
            EyePicture& picture = pictures.emplace_back();
            for (std::size_t o = 0; o < frames.size(); ++o) {
                if (o == viewer) continue;
                picture.others.append(placed[o]);
                picture.faces_from.push_back(picture.others.triangles.size());
                picture.colours.push_back(o);
            }
            picture.path = folder / fmt::format("key_{}_from_{}.png", view.key, names[viewer]);
            picture.camera = eye_camera((*frames[viewer])[std::size_t(view.frame)], *sources[viewer], placed[viewer], visibility.half_angle_deg);
            picture.caption = fmt::format("key {}, output frame {}: from {}'s eyes; circle: the {:g} deg view cone{}", view.key, view.frame,
                                          names[viewer], visibility.half_angle_deg, visibility.enabled ? "" : " (visibility not asked)");
        }
    }
    parallel_for(pictures.size(), [&pictures](std::size_t p) {
        const EyePicture& picture = pictures[p];
        draw_eye_view(picture.path, picture.camera, picture.others, picture.faces_from, picture.colours, picture.caption);
    });
}

namespace {

// The edit of output frame k in the file's own axes and units: capture -> scene is
// p_s = A (u p_f) + l (A the signed axis permutation, u metres per unit, l the floor lift along
// z), and the edit moves p_s to R(yaw) p_s + (t, lift); in the file that is p_f -> L p_f + t_f with
// L = A^T R A and t_f = A^T (t, lift) / u (R l = l: the turn is about z).
Eigen::Isometry3d edit_in_file(const ObjectFrameEdit& e, const UnitsAndAxes& units) {
    const Eigen::Matrix3d a = units.map().matrix();
    Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
    t.linear() = a.transpose() * Eigen::AngleAxisd(e.yaw, Vec3::UnitZ()).toRotationMatrix() * a;
    t.translation() = a.transpose() * Vec3(e.translation.x(), e.translation.y(), e.lift) / units.metres_per_unit;
    return t;
}

// One output frame's row: the source frame's channels, the root's rewritten to carry the edit.
std::vector<double> edited_row(const BvhMotion& motion, const ObjectFrameEdit& e, const UnitsAndAxes& units) {
    const BvhJoint& root = motion.joints[0];
    const double* source = motion.values.data() + std::size_t(e.source) * std::size_t(motion.channel_count);
    std::vector<double> row(source, source + motion.channel_count);
    const Eigen::Isometry3d moved = edit_in_file(e, units) * motion.global_transforms(e.source)[0];
    std::array<int, 3> axes{};
    std::array<double, 3> near{};
    std::array<int, 3> slots{};
    int rotations = 0;
    for (std::size_t c = 0; c < root.channels.size(); ++c) {
        const int axis = int(root.channels[c]) % 3, slot = root.first_channel + int(c);
        if (int(root.channels[c]) < 3) {
            row[std::size_t(slot)] = moved.translation()[axis] - root.offset[axis];
        } else {
            axes[std::size_t(rotations)] = axis, near[std::size_t(rotations)] = row[std::size_t(slot)], slots[std::size_t(rotations)] = slot;
            ++rotations;
        }
    }
    const std::array<double, 3> degrees = euler_degrees_near(moved.linear(), axes, near);
    for (int r = 0; r < 3; ++r) row[std::size_t(slots[std::size_t(r)])] = degrees[std::size_t(r)];
    return row;
}

// Whether the root can carry a rigid edit: three position and three rotation channels.
bool root_carries_edit(const BvhJoint& root) {
    int positions = 0, rotations = 0;
    for (BvhJoint::Channel c : root.channels) (int(c) < 3 ? positions : rotations) += 1;
    return positions == 3 && rotations == 3;
}

}  // namespace

std::vector<std::string> write_edited_bvh(const fs::path& folder, const EditResult& edit, ObjectSource& a, ObjectSource& b) {
    return write_edited_bvh(folder, {"A", "B"}, {&edit.frames[0], &edit.frames[1]}, {&a, &b});
}

std::vector<std::string> write_edited_bvh(const fs::path& folder, const std::vector<std::string>& names,
                                          const std::vector<const std::vector<ObjectFrameEdit>*>& frames, const std::vector<ObjectSource*>& sources) {
    std::vector<std::string> written;
    for (std::size_t o = 0; o < names.size(); ++o) {
        const BvhMotion* motion = sources[o]->motion();
        if (!motion || !root_carries_edit(motion->joints[0])) continue;
        BvhMotion out = *motion;
        out.source.clear();
        out.first_frame = 0;
        out.frame_count = int(frames[o]->size());
        out.values.clear();
        for (const ObjectFrameEdit& e : *frames[o]) {
            const std::vector<double> row = edited_row(*motion, e, sources[o]->spec().units);
            out.values.insert(out.values.end(), row.begin(), row.end());
        }
        const std::string name = names[o] + ".bvh";
        write_file(folder / name, bvh_text(out));
        written.push_back(name);
    }
    return written;
}

std::vector<std::string> write_edited_characters(const fs::path& folder, const std::vector<std::string>& names,
                                                 const std::vector<const std::vector<ObjectFrameEdit>*>& frames,
                                                 const std::vector<ObjectSource*>& sources) {
    std::vector<std::string> written;
    for (std::size_t o = 0; o < names.size(); ++o) {
        const CharacterBody* character = sources[o]->character();
        if (!character) continue;
        const UnitsAndAxes& units = sources[o]->spec().units;
        std::vector<int> from;
        std::vector<Eigen::Isometry3d> edits;
        for (const ObjectFrameEdit& e : *frames[o]) {
            from.push_back(e.source);
            edits.push_back(edit_in_file(e, units));
        }
        const std::string name = names[o] + ".glb";
        if (write_edited_character_glb(character_file(*character), units, from, edits, sources[o]->spec().fps, folder / name))
            written.push_back(name);
        else
            spdlog::warn("object {}: its meshes bind one joint differently, which one glTF skin cannot hold; {} is not written", names[o], name);
    }
    return written;
}

void write_paths_picture(const fs::path& svg, const fs::path& png, const EditResult& edit) {
    std::vector<std::array<int, 3>> keys;
    for (const TimelineSegment& seg : edit.timeline.segments)
        if (seg.key && seg.length > 0) keys.push_back({seg.key, seg.first, seg.length});
    write_paths_picture(svg, png, {{"A", &edit.frames[0], keys}, {"B", &edit.frames[1], keys}});
}

}  // namespace amhv
