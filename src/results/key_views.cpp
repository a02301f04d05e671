#include "src/results/key_views.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include <cairo.h>
#include <fmt/format.h>
#include <nanoflann.hpp>

#include "src/core/angles.hpp"
#include "src/core/parallel.hpp"
#include "src/results/picture.hpp"
#include "src/scene/interest.hpp"

namespace amhv {

namespace fs = std::filesystem;

namespace {

struct Cloud {
    const std::vector<Vec3>* points;
    std::size_t kdtree_get_point_count() const { return points->size(); }
    double kdtree_get_pt(std::size_t i, std::size_t axis) const { return (*points)[i][int(axis)]; }
    template <class Box>
    bool kdtree_get_bbox(Box&) const { return false; }
};

Vec3 centroid(const TriangleMesh& mesh) {
    Vec3 sum = Vec3::Zero();
    for (const Vec3& v : mesh.vertices) sum += v;
    return mesh.vertices.empty() ? sum : Vec3(sum / double(mesh.vertices.size()));
}

// Whether the ray from `p` toward the camera crosses triangle (a, b, c) farther than kNearMeeting
// from p (Moeller-Trumbore): surfaces within a few centimetres are the meeting's own surroundings
// (a hand pressed to a hip), not a body standing in front of it.
constexpr double kNearMeeting = 0.03;
bool hides(const Vec3& p, const Vec3& toward_camera, const Vec3& a, const Vec3& b, const Vec3& c) {
    const Vec3 e1 = b - a, e2 = c - a, h = toward_camera.cross(e2);
    const double det = e1.dot(h);
    if (std::abs(det) < 1e-14) return false;
    const Vec3 s = p - a;
    const double u = s.dot(h) / det;
    if (u < 0 || u > 1) return false;
    const Vec3 q = s.cross(e1);
    const double v = toward_camera.dot(q) / det;
    if (v < 0 || u + v > 1) return false;
    return e2.dot(q) / det > kNearMeeting;
}

KeyCamera camera_at(const Eigen::Vector2d& across, double turn_deg, double raise_deg) {
    KeyCamera c;
    const Eigen::Vector2d side = Eigen::Rotation2Dd(angles::radians(turn_deg)) * across;
    const double raise = angles::radians(raise_deg);
    c.forward = Vec3(side.x() * std::cos(raise), side.y() * std::cos(raise), -std::sin(raise)).normalized();
    c.right = c.forward.cross(Vec3::UnitZ()).normalized();
    c.up = c.right.cross(c.forward);
    c.turn_deg = turn_deg, c.raise_deg = raise_deg;
    return c;
}

int blocked_points(const TriangleMesh& scene, const std::vector<const std::array<std::uint32_t, 3>*>& far, const std::array<Vec3, 3>& samples,
                   const Vec3& forward) {
    int blocked = 0;
    for (const Vec3& p : samples)
        for (const auto* t : far)
            if (hides(p, -forward, scene.vertices[(*t)[0]], scene.vertices[(*t)[1]], scene.vertices[(*t)[2]])) {
                ++blocked;
                break;
            }
    return blocked;
}

}  // namespace

Meeting find_meeting(const TriangleMesh& first, const TriangleMesh& second, const Eigen::Vector2d& fallback_direction) {
    Meeting m;
    if (first.vertices.empty() || second.vertices.empty()) {
        m.first = centroid(first), m.second = centroid(second);
    } else {
        const Cloud cloud{&second.vertices};
        nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, Cloud>, Cloud, 3> tree(3, cloud, nanoflann::KDTreeSingleIndexAdaptorParams(16));
        tree.buildIndex();
        double best = std::numeric_limits<double>::infinity();
        for (const Vec3& v : first.vertices) {
            unsigned index = 0;  // nanoflann's default accessor type
            double d2 = 0;
            tree.knnSearch(v.data(), 1, &index, &d2);
            if (d2 < best) best = d2, m.first = v, m.second = second.vertices[index];  // the first of equals: same on every run
        }
    }
    // The parts' centroids when they lie apart on the floor (hands reaching for each other);
    // else (hands raised together, a part over another) the performers' own line.
    const Vec3 between = centroid(second) - centroid(first);
    const Eigen::Vector2d d = between.head<2>().norm() > 0.05 ? Eigen::Vector2d(between.head<2>()) : fallback_direction;
    m.direction = d.norm() > 1e-9 ? d.normalized() : Eigen::Vector2d::UnitX();
    return m;
}

KeyCamera choose_key_camera(const TriangleMesh& scene, const std::vector<bool>& meeting_part, const Meeting& meeting) {
    const Vec3 centre = meeting.centre();
    std::vector<const std::array<std::uint32_t, 3>*> far;
    for (std::size_t t = 0; t < scene.triangles.size(); ++t)
        if (t >= meeting_part.size() || !meeting_part[t]) far.push_back(&scene.triangles[t]);
    const std::array<Vec3, 3> samples{centre, meeting.first, meeting.second};
    const Eigen::Vector2d across(meeting.direction.y(), -meeting.direction.x());  // the camera looks across the meeting
    KeyCamera best;
    best.blocked = std::numeric_limits<int>::max();
    for (double raise : {0.0, 20.0, 40.0})
        for (int step = 0; step <= 16; ++step) {
            const double turn = step == 0 ? 0.0 : (step + 1) / 2 * 10.0 * (step % 2 ? 1 : -1);
            for (double side : {1.0, -1.0}) {
                KeyCamera c = camera_at(side * across, turn, raise);
                c.blocked = blocked_points(scene, far, samples, c.forward);
                if (c.blocked < best.blocked) best = c;
                if (best.blocked == 0) return best;
            }
        }
    return best;
}

namespace {

struct KeyPicture {
    fs::path path;
    TriangleMesh scene;
    std::vector<std::size_t> faces_from{0};
    std::vector<bool> meeting_part;  // per triangle of `scene`
    Meeting meeting;
    std::string caption;
    KeyCamera camera;  // chosen when drawn
};

// Orthographic: every body fits an 800 x 600 picture; far triangles first (equal depths keep mesh
// order: the same bytes on every run); the meeting place ringed.
void draw_key_picture(KeyPicture& p) {
    p.camera = choose_key_camera(p.scene, p.meeting_part, p.meeting);
    const KeyCamera& c = p.camera;
    Eigen::AlignedBox2d extent;
    for (const Vec3& v : p.scene.vertices) extent.extend(Eigen::Vector2d(v.dot(c.right), v.dot(c.up)));
    if (c.raise_deg == 0) extent.extend(Eigen::Vector2d(extent.min().x(), 0.0));  // the floor
    constexpr int kWidth = 800, kHeight = 600, kMargin = 30, kTop = 40;
    const double scale = std::min((kWidth - 2 * kMargin) / std::max(extent.sizes().x(), 1e-6), (kHeight - kMargin - kTop) / std::max(extent.sizes().y(), 1e-6));
    const Eigen::Vector2d offset(0.5 * (kWidth - scale * extent.sizes().x()), 0.5 * (kHeight - kTop - scale * extent.sizes().y()));
    auto pixel = [&](const Vec3& v) {
        return Eigen::Vector2d(offset.x() + (v.dot(c.right) - extent.min().x()) * scale, kHeight - offset.y() - (v.dot(c.up) - extent.min().y()) * scale);
    };
    std::vector<std::pair<double, std::size_t>> order(p.scene.triangles.size());
    for (std::size_t t = 0; t < order.size(); ++t) {
        const auto& tri = p.scene.triangles[t];
        order[t] = {-(p.scene.vertices[tri[0]] + p.scene.vertices[tri[1]] + p.scene.vertices[tri[2]]).dot(c.forward), t};
    }
    std::sort(order.begin(), order.end());
    cairo_surface_t* surface = cairo_image_surface_create(CAIRO_FORMAT_RGB24, kWidth, kHeight);
    cairo_t* cr = cairo_create(surface);
    cairo_set_source_rgb(cr, 1, 1, 1);
    cairo_paint(cr);
    const Vec3 light = (-0.8 * c.forward + 0.3 * c.right + 0.6 * Vec3::UnitZ()).normalized();
    for (const auto& [depth, t] : order) {
        const auto& tri = p.scene.triangles[t];
        const Vec3 normal = (p.scene.vertices[tri[1]] - p.scene.vertices[tri[0]]).cross(p.scene.vertices[tri[2]] - p.scene.vertices[tri[0]]);
        if (normal.norm() < 1e-15 || normal.dot(c.forward) > 0) continue;  // degenerate or facing away
        const double shade = 0.35 + 0.65 * std::max(0.0, normal.normalized().dot(light));
        const std::size_t object = std::size_t(std::upper_bound(p.faces_from.begin() + 1, p.faces_from.end(), t) - p.faces_from.begin() - 1);
        fill_triangle(cr, {pixel(p.scene.vertices[tri[0]]), pixel(p.scene.vertices[tri[1]]), pixel(p.scene.vertices[tri[2]])}, shade,
                      kObjectColours[object % kObjectColours.size()]);
    }
    if (c.raise_deg == 0) {
        const double floor_y = pixel(Vec3::Zero()).y();
        cairo_set_source_rgb(cr, 0.5, 0.5, 0.5);
        cairo_set_line_width(cr, 1);
        cairo_move_to(cr, kMargin / 2.0, floor_y + 0.5);
        cairo_line_to(cr, kWidth - kMargin / 2.0, floor_y + 0.5);
        cairo_stroke(cr);
    }
    const Eigen::Vector2d ring = pixel(p.meeting.centre());
    cairo_set_source_rgb(cr, 0.1, 0.1, 0.1);
    cairo_set_line_width(cr, 1.5);
    cairo_arc(cr, ring.x(), ring.y(), std::max(12.0, 0.06 * scale), 0, 2 * std::numbers::pi);
    cairo_stroke(cr);
    draw_text(cr, 10, 20, p.caption, 14);
    draw_text(cr, 10, 38,
              fmt::format("camera: across the meeting{}{}; ring: where the parts meet", c.turn_deg != 0 ? fmt::format(", turned {:g} deg", c.turn_deg) : "",
                          c.raise_deg != 0 ? fmt::format(", raised {:g} deg", c.raise_deg) : ""),
              12);
    finish_png(cr, surface, p.path);
}

std::string parts_named(const PartSpec& spec) {
    if (spec.kind == PartSpec::Kind::Parts) return fmt::format("{}", fmt::join(spec.labels, "+"));
    return spec.describe();
}

}  // namespace

namespace {

// The pair's parts at output frame k of a view, in the scene.
std::array<TriangleMesh, 2> meeting_parts(const Scene& scene, const KeyView& view, int k, const std::vector<const std::vector<ObjectFrameEdit>*>& frames,
                                          const std::vector<ObjectSource*>& sources) {
    const KeySegment& key = scene.segments[std::size_t(view.key - 1)];
    const ObjectFrameEdit& e1 = (*frames[view.first])[std::size_t(k)];
    const ObjectFrameEdit& e2 = (*frames[view.second])[std::size_t(k)];
    return {moved_into_scene(part_surface(*sources[view.first], key.interest_a, e1.source), e1.yaw, e1.translation, e1.lift),
            moved_into_scene(part_surface(*sources[view.second], key.interest_b, e2.source), e2.yaw, e2.translation, e2.lift)};
}

}  // namespace

void choose_meeting_frames(const Scene& scene, std::vector<KeyView>& views, const std::vector<const std::vector<ObjectFrameEdit>*>& frames,
                           const std::vector<ObjectSource*>& sources) {
    for (KeyView& view : views) {
        if (view.last_frame < view.first_frame) continue;
        const int middle = (view.first_frame + view.last_frame + 1) / 2;
        double best = std::numeric_limits<double>::infinity();
        for (int step = 0; step <= view.last_frame - view.first_frame; ++step) {
            // Outward from the middle, so that among equal gaps the nearest to it wins.
            const int k = middle + (step % 2 ? (step + 1) / 2 : -(step / 2));
            if (k < view.first_frame || k > view.last_frame) continue;
            const auto parts = meeting_parts(scene, view, k, frames, sources);
            const Meeting m = find_meeting(parts[0], parts[1], Eigen::Vector2d::UnitX());
            const double gap = (m.second - m.first).norm();
            if (gap < best - 1e-9) best = gap, view.frame = k;
        }
    }
}

std::vector<KeyCamera> write_key_views(const fs::path& folder, const Scene& scene, const std::vector<std::string>& names, const std::vector<KeyView>& views,
                                       const std::vector<const std::vector<ObjectFrameEdit>*>& frames, const std::vector<ObjectSource*>& sources) {
    fs::create_directories(folder);
    // Meshes are gathered on this thread (an ObjectSource caches as it reads); pictures drawn on every core.
    std::vector<KeyPicture> pictures;
    for (const KeyView& view : views) {
        KeyPicture& p = pictures.emplace_back();
        p.path = folder / fmt::format("key_{}.png", view.key);
        const KeySegment& key = scene.segments[std::size_t(view.key - 1)];
        for (std::size_t o = 0; o < frames.size(); ++o) {
            const ObjectFrameEdit& e = (*frames[o])[std::size_t(view.frame)];
            p.scene.append(placed_mesh(e, *sources[o]));
            p.faces_from.push_back(p.scene.triangles.size());
            std::vector<bool> in_part(p.faces_from.back() - p.faces_from[o], false);
            if (o == view.first || o == view.second) in_part = part_triangles(*sources[o], o == view.first ? key.interest_a : key.interest_b, e.source);
            p.meeting_part.insert(p.meeting_part.end(), in_part.begin(), in_part.end());
        }
        const auto parts = meeting_parts(scene, view, view.frame, frames, sources);
        const ObjectFrameEdit& e1 = (*frames[view.first])[std::size_t(view.frame)];
        const ObjectFrameEdit& e2 = (*frames[view.second])[std::size_t(view.frame)];
        p.meeting = find_meeting(parts[0], parts[1], e2.edited_root - e1.edited_root);
        p.caption = fmt::format("key {} ({}), output frame {}: {}'s {} and {}'s {} ({:.0f} mm apart)", view.key, key.type.name(), view.frame,
                                names[view.first], parts_named(key.interest_a), names[view.second], parts_named(key.interest_b),
                                1000 * (p.meeting.second - p.meeting.first).norm());
    }
    parallel_for(pictures.size(), [&pictures](std::size_t i) { draw_key_picture(pictures[i]); });
    std::vector<KeyCamera> cameras;
    for (const KeyPicture& p : pictures) cameras.push_back(p.camera);
    return cameras;
}

nlohmann::ordered_json key_views_json(const std::vector<KeyView>& views, const std::vector<KeyCamera>& cameras, const std::vector<std::string>& names) {
    nlohmann::ordered_json out = nlohmann::ordered_json::array();
    for (std::size_t v = 0; v < views.size(); ++v) {
        const KeyView& view = views[v];
        nlohmann::ordered_json entry = {{"key", view.key}, {"file", fmt::format("views/key_{}.png", view.key)}};
        for (std::size_t o : {view.first, view.second}) entry[fmt::format("from_{}", names[o])] = fmt::format("views/key_{}_from_{}.png", view.key, names[o]);
        entry["output_frame"] = view.frame;
        if (v < cameras.size())
            entry["camera"] = {{"turn_deg", cameras[v].turn_deg}, {"raise_deg", cameras[v].raise_deg}, {"meeting_points_hidden", cameras[v].blocked}};
        out.push_back(entry);
    }
    return out;
}

}  // namespace amhv
