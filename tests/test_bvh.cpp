// BVH takes: the reader's tolerance and its errors, the T-pose rule, resampling, and
// `amhv import-bvh` read back through the mesh, labels and track readers scenes use.
#include <algorithm>
#include <cmath>
#include <numbers>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>
#include <fmt/format.h>

#include "src/body/shapes.hpp"
#include "src/body/skeleton_body.hpp"
#include "src/body/skeleton_roles.hpp"
#include "src/core/error.hpp"
#include "src/io/bvh.hpp"
#include "src/scene/scene.hpp"
#include "src/scene/segment.hpp"
#include "support.hpp"

namespace amhv {
namespace {

namespace fs = std::filesystem;

// A root with six channels and one child with three, in a rotation order other than the root's.
const std::string kHierarchy =
    "HIERARCHY\nROOT Hips\n{\n OFFSET 0 0 0\n CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n"
    " JOINT Chest\n {\n  OFFSET 0 1 0\n  CHANNELS 3 Yrotation Xrotation Zrotation\n  End Site\n  {\n   OFFSET 0 1 0\n  }\n }\n}\n";

std::string take(const std::vector<std::string>& rows, double frame_time = 0.1) {
    std::string text = kHierarchy + fmt::format("MOTION\nFrames: {}\nFrame Time: {}\n", rows.size(), frame_time);
    for (const std::string& row : rows) text += row + "\n";
    return text;
}

BvhMotion read_text_as_bvh(const fs::path& folder, const std::string& text) {
    const fs::path path = folder / "take.bvh";
    std::ofstream(path, std::ios::binary) << text;
    return read_bvh(path);
}

Eigen::Quaterniond global_rotation(const BvhMotion& motion, int frame, int joint) {
    return Eigen::Quaterniond(motion.global_transforms(frame)[std::size_t(joint)].linear());
}

TEST(Bvh, LineEndingsTabsAndCommentsDoNotChangeTheTake) {
    test::TempDir tmp;
    const std::string plain = take({"0.5 1 2 10.5 -20 30 5 6 7", "1 2 3 40 50 60 -7 8 9"});
    BvhMotion reference = read_text_as_bvh(tmp.path(), plain);
    std::string messy;
    int line = 0;
    for (char c : plain) {
        if (c == ' ') {
            messy += "\t ";
        } else if (c == '\n') {
            ++line;
            messy += line % 3 == 0 ? "\r\n" : line % 3 == 1 ? "\n" : "  // a comment\r";
        } else {
            messy += c;
        }
    }
    messy = "# exported by a tool that writes comments\r\n" + messy;
    BvhMotion parsed = read_text_as_bvh(tmp.path(), messy);
    ASSERT_EQ(parsed.joints.size(), reference.joints.size());
    for (std::size_t j = 0; j < parsed.joints.size(); ++j) {
        EXPECT_EQ(parsed.joints[j].name, reference.joints[j].name);
        EXPECT_EQ(parsed.joints[j].offset, reference.joints[j].offset);
        EXPECT_EQ(parsed.joints[j].channels, reference.joints[j].channels);
    }
    EXPECT_EQ(parsed.values, reference.values);
    EXPECT_EQ(parsed.frame_count, 2);
}

TEST(Bvh, MalformedFilesGiveTheLineAndNeverCrash) {
    test::TempDir tmp;
    std::string deep = "HIERARCHY\nROOT J0\n{\nOFFSET 0 0 0\nCHANNELS 3 Xrotation Yrotation Zrotation\n";
    for (int j = 1; j < 1100; ++j) deep += fmt::format("JOINT J{}\n{{\nOFFSET 0 1 0\nCHANNELS 3 Xrotation Yrotation Zrotation\n", j);
    std::string duplicate = kHierarchy;
    duplicate.replace(duplicate.find("JOINT Chest"), 11, "JOINT Hips");
    std::string seven = kHierarchy;
    seven.replace(seven.find("CHANNELS 3"), 10, "CHANNELS 7");
    const std::string row = "0 0 0 0 0 0 0 0 0";
    for (const auto& [content, expected] : std::vector<std::pair<std::string, std::string>>{
             {take({"0 0 0 0 0 0 0 0", row}), ":19: frame 0 has 8 values but the hierarchy declares 9 channels"},
             {kHierarchy + "MOTION\nFrames: 2\nFrame Time: 0.1\n" + row + "\n" + row + "\n" + row + "\n", ":21: motion block has more rows than the 2 frames"},
             {take({row}, 0), ":18: frame time 0 s is not between 0.00001 and 60 seconds"},
             {kHierarchy + "MOTION\nFrames: -4\nFrame Time: 0.1\n", ":17: frame count -4 is not a whole number"},
             {kHierarchy + "MOTION\nFrames: 1e12\nFrame Time: 0.1\n", ":17: frame count"},
             {kHierarchy + "MOTION\nFrames: 2\nFrame Time: 0.1\n" + row + "\n", ":20: motion block is truncated: 1 of 2 frames"},
             {kHierarchy + "Frames: 2\n", ":16: expected 'MOTION', found 'Frames:'"},
             {duplicate, ":6: joint 'Hips' is defined twice"},
             {seven, ":9: channel count 7 is not a whole number in 0..6"},
             {deep, ":4099: more than 1024 joints"},
             {"", ":1: file ends where HIERARCHY was expected"},
             {std::string("\x7f" "ELF\x02\x01\x01\0\0\0", 10), ":1: is not a BVH file: it does not start with HIERARCHY"},
         }) {
        try {
            read_text_as_bvh(tmp.path(), content);
            ADD_FAILURE() << "no error for " << expected;
        } catch (const Error& e) {
            EXPECT_NE(std::string(e.what()).find("take.bvh" + expected), std::string::npos) << e.what();
        }
    }
}

TEST(Bvh, TPoseIsDetectedSkippedOrKept) {
    const fs::path cmu = test::source_dir() / "data/cmu/18_01.bvh";
    EXPECT_TRUE(starts_with_tpose(read_bvh(cmu)));
    EXPECT_EQ(load_bvh(cmu, {TPose::Auto, 0}).first_frame, 1);
    EXPECT_EQ(load_bvh(cmu, {TPose::Keep, 0}).first_frame, 0);

    test::TempDir tmp;
    const std::string captured = "0.5 1 2 10.5 -20 30 5 6 7";
    EXPECT_TRUE(starts_with_tpose(read_text_as_bvh(tmp.path(), take({"0.5 1 2 0 0 0 0 -21 0", captured}))));
    EXPECT_FALSE(starts_with_tpose(read_text_as_bvh(tmp.path(), take({captured, captured}))));
    EXPECT_FALSE(starts_with_tpose(read_text_as_bvh(tmp.path(), take({"0 0 0 90 0 0 0 0 0", captured}))));  // root turned
    EXPECT_FALSE(starts_with_tpose(read_text_as_bvh(tmp.path(), take({"0 0 0 0 0 0 0 0 0", "0 0 0 0 0 0 0 1 0"}))));  // all whole

    std::ofstream(tmp.path() / "one.bvh") << take({captured});
    EXPECT_EQ(load_bvh(tmp.path() / "one.bvh", {TPose::Auto, 0}).first_frame, 0);
    EXPECT_THROW(load_bvh(tmp.path() / "one.bvh", {TPose::Skip, 0}), Error);
    EXPECT_THROW(parse_tpose("maybe", "--tpose"), Error);
}

TEST(Bvh, ResamplingKeepsCapturedFramesAndInterpolatesRotationsAsRotations) {
    const fs::path cmu = test::source_dir() / "data/cmu/18_01.bvh";
    const BvhMotion file = load_bvh(cmu, {TPose::Auto, 0});
    EXPECT_EQ(file.fps(), 120.0);  // "Frame Time: .0083333"
    const BvhMotion at30 = load_bvh(cmu, {TPose::Auto, 30});
    EXPECT_EQ(at30.frame_count, 76);  // 0 .. 303/4
    EXPECT_EQ(at30.first_frame, 1);
    EXPECT_DOUBLE_EQ(at30.fps(), 30.0);
    const std::size_t channels = std::size_t(file.channel_count);
    for (int k : {1, 10, 47, 75})  // every fourth captured frame, bit for bit
        EXPECT_TRUE(std::equal(at30.values.begin() + std::ptrdiff_t(std::size_t(k) * channels),
                               at30.values.begin() + std::ptrdiff_t(std::size_t(k + 1) * channels),
                               file.values.begin() + std::ptrdiff_t(std::size_t(4 * k) * channels)))
            << k;

    // Upsampling a two-frame take fourfold: the middle frame is the slerp midpoint of every joint.
    test::TempDir tmp;
    const BvhMotion two = read_text_as_bvh(tmp.path(), take({"0 0 0 10 80 -30 60 45 -20", "1 2 -3 -50 20 40 -70 10 90"}));
    const BvhMotion fine = resample_bvh(two, 40);
    ASSERT_EQ(fine.frame_count, 5);
    for (int joint = 0; joint < 2; ++joint) {
        const Eigen::Quaterniond expected = global_rotation(two, 0, 0).slerp(0.5, global_rotation(two, 1, 0));
        const Eigen::Quaterniond local0 = global_rotation(two, 0, 0).inverse() * global_rotation(two, 0, 1);
        const Eigen::Quaterniond local1 = global_rotation(two, 1, 0).inverse() * global_rotation(two, 1, 1);
        const Eigen::Quaterniond got_root = global_rotation(fine, 2, 0);
        const Eigen::Quaterniond got_local = got_root.inverse() * global_rotation(fine, 2, 1);
        if (joint == 0) {
            EXPECT_LT(got_root.angularDistance(expected), 1e-9);
        } else {
            EXPECT_LT(got_local.angularDistance(local0.slerp(0.5, local1)), 1e-9);
        }
    }
    EXPECT_LT((fine.global_transforms(2)[0].translation() - Vec3(0.5, 1, -1.5)).norm(), 1e-12);
    EXPECT_LT((fine.global_transforms(1)[0].translation() - Vec3(0.25, 0.5, -0.75)).norm(), 1e-12);
    EXPECT_TRUE(std::equal(fine.values.end() - 9, fine.values.end(), two.values.end() - 9));

    // A turn across +-180 degrees goes the short way: halfway between 170 and -170 is 180, not 0.
    const BvhMotion across = read_text_as_bvh(tmp.path(), take({"0 0 0 170 0 0 0 0 0", "0 0 0 -170 0 0 0 0 0"}));
    const Eigen::AngleAxisd half(global_rotation(resample_bvh(across, 20), 1, 0));
    EXPECT_NEAR(std::abs(half.angle()), M_PI, 1e-9);

    EXPECT_THROW(resample_bvh(two, 0), Error);
}

TEST(ImportBvh, WritesMeshesLabelsAndTrackThatScenesReadBack) {
    test::TempDir tmp;
    const fs::path bvh = test::source_dir() / "data/cmu/19_01.bvh";
    const fs::path out = tmp.path() / "b";
    auto result = test::run_amhv(fmt::format("import-bvh '{}' --fps 30 --frames 20:40 --out '{}'", bvh.string(), out.string()));
    ASSERT_EQ(result.exit_code, 0) << result.output;

    const BvhMotion motion = load_bvh(bvh, {TPose::Auto, 30});
    const SkeletonBodyOptions options;
    const auto track = skeleton_track(motion, options);
    std::ifstream csv(out / "track.csv");
    std::string line;
    std::getline(csv, line);
    EXPECT_EQ(line[0], '#');
    for (int f = 20; f <= 40; ++f) {
        const fs::path ply = out / fmt::format("meshes/frame_{:04d}.ply", f);
        const TriangleMesh expected = skeleton_body(motion, f, options);
        const TriangleMesh read = read_mesh(ply, UnitsAndAxes{1.0, UpAxis::Z});
        ASSERT_EQ(read.vertices.size(), expected.vertices.size()) << ply;
        EXPECT_EQ(read.triangles, expected.triangles) << ply;
        double worst = 0;
        for (std::size_t v = 0; v < read.vertices.size(); ++v) worst = std::max(worst, (read.vertices[v] - expected.vertices[v]).norm());
        EXPECT_LT(worst, 1e-6) << ply;  // float storage

        std::ifstream labels(out / fmt::format("labels/frame_{:04d}.txt", f));
        std::vector<std::string> names;
        for (std::string name; labels >> name;) names.push_back(name);
        std::vector<std::string> expected_names;
        for (const BodyPart& part : skeleton_body_parts(motion, f, options))
            expected_names.insert(expected_names.end(), part.mesh.vertices.size(), part.name);
        EXPECT_EQ(names, expected_names);

        ASSERT_TRUE(std::getline(csv, line));
        std::replace(line.begin(), line.end(), ',', ' ');
        std::istringstream fields(line);
        int frame = -1;
        Vec3 eye, gaze;
        fields >> frame >> eye.x() >> eye.y() >> eye.z() >> gaze.x() >> gaze.y() >> gaze.z();
        EXPECT_EQ(frame, f);
        EXPECT_LT((eye - track[std::size_t(f)].eye).norm(), 1e-8);
        EXPECT_LT((gaze - track[std::size_t(f)].gaze).norm(), 1e-8);
    }
    EXPECT_FALSE(std::getline(csv, line));

    // object.toml, pasted into a scene, makes an object with the BVH body's parts and track.
    std::string object = test::read_text(out / "object.toml");
    for (const char* key : {"meshes = \"", "labels = \"", "track = \""}) object.replace(object.find(key), std::string(key).size(), std::string(key) + "b/");
    const fs::path scene_file = tmp.path() / "scene.toml";
    std::ofstream(scene_file) << fmt::format(
        "[sampling]\nvoxel = 0.04\nangle_step_deg = 30\n\n[objects.A]\nbvh = '{}'\n\n[objects.B]\n{}\n"
        "[[segments]]\na = [100, 140]\nb = [25, 35]\ntype = \"0&0a\"\n"
        "interest = {{ A = {{ parts = [\"right_hand\"] }}, B = {{ parts = [\"right_hand\"] }} }}\n",
        (test::source_dir() / "data/cmu/18_01.bvh").string(), object);
    const Scene scene = load_scene(scene_file);
    EXPECT_EQ(scene.b.frame_first, 20);
    EXPECT_EQ(scene.b.frame_last, 40);
    EXPECT_EQ(scene.b.fps, 30.0);
    EXPECT_EQ(scene.a.tpose, TPose::Skip);
    ObjectSource imported(scene.b);
    std::vector<std::string> parts;
    for (const BodyPart& part : imported.frame_parts(30)) parts.push_back(part.name);
    std::vector<std::string> expected_parts;
    for (const BodyPart& part : skeleton_body_parts(motion, 30, options)) expected_parts.push_back(part.name);
    EXPECT_EQ(parts, expected_parts);
    ASSERT_TRUE(imported.track(30).has_value());
    EXPECT_LT((imported.track(30)->eye - track[30].eye).norm(), 1e-8);
}

TEST(ImportBvh, BadRequestsAreOneLineErrorsWithNoOutput) {
    test::TempDir tmp;
    const std::string bvh = (test::source_dir() / "data/cmu/19_01.bvh").string();
    const std::string out = (tmp.path() / "o").string();
    std::ofstream(tmp.path() / "broken.bvh") << take({"0 0 0 0 0 0 0 0 0", "1 2 3"});
    for (const auto& [arguments, expected] : std::vector<std::pair<std::string, std::string>>{
             {fmt::format("import-bvh '{}/none.bvh' --out '{}'", tmp.path().string(), out), "none.bvh: cannot open BVH file"},
             {fmt::format("import-bvh '{}/broken.bvh' --out '{}'", tmp.path().string(), out), "broken.bvh:20: motion block is truncated"},
             {fmt::format("import-bvh '{}' --frames 0:10 --out '{}'", bvh, out), "starts before frame 1, the first after the converter's T-pose"},
             {fmt::format("import-bvh '{}' --frames 300:400 --out '{}'", bvh, out), "goes beyond the take's 304 frames"},
             {fmt::format("import-bvh '{}' --tpose maybe --out '{}'", bvh, out), "--tpose: 'maybe' is not auto, skip or keep"},
             {fmt::format("import-bvh '{}' --fps -3 --out '{}'", bvh, out), "--fps: -3 is not a frame rate"},
             {fmt::format("import-bvh '{}' --unit furlong --out '{}'", bvh, out), "--unit: unit 'furlong'"},
         }) {
        auto result = test::run_amhv(arguments);
        EXPECT_NE(result.exit_code, 0) << result.output;
        EXPECT_EQ(test::one_line_error(result), 1) << result.output;
        EXPECT_EQ(std::count(result.output.begin(), result.output.end(), '\n'), 1) << result.output;  // nothing else either
        EXPECT_NE(result.output.find(expected), std::string::npos) << result.output;
        EXPECT_FALSE(fs::exists(out));
    }
}

// The scene position of the joint playing `role` at `frame`.
Vec3 joint_at(const BvhMotion& motion, int frame, const char* role, const UnitsAndAxes& units) {
    const auto roles = role_names(motion);
    const std::size_t j = std::size_t(std::find(roles.begin(), roles.end(), role) - roles.begin());
    return to_scene_point(motion.global_transforms(frame)[j].translation(), units);
}

// The capsule body's shoulders: each side's collar bone, from the base of the neck to the shoulder
// joint, as its own part; the skinned body keeps them in its torso. Either way the body is the
// same union (the parts only regroup capsules).
TEST(SkeletonBody, ShouldersAreTheCollarBonesOfTheCapsuleBody) {
    const BvhMotion motion = load_bvh((test::source_dir() / "data/cmu/18_01.bvh").string(), {});
    const std::vector<std::string> capsules = body_part_names(motion), skinned = body_part_names(motion, true);
    for (const char* side : {"left_shoulder", "right_shoulder"}) {
        EXPECT_NE(std::find(capsules.begin(), capsules.end(), side), capsules.end()) << side;
        EXPECT_EQ(std::find(skinned.begin(), skinned.end(), side), skinned.end()) << side;
    }
    const int f = 120;
    const SkeletonBodyOptions options;
    auto joint = [&](const char* role) { return joint_at(motion, f, role, options.units); };
    std::size_t vertices = 0;
    for (const BodyPart& part : skeleton_body_parts(motion, f, options)) {
        vertices += part.mesh.vertices.size();
        if (part.name != "right_shoulder") continue;
        // Every vertex within the capsule's radius of the segment from the neck's base to the shoulder.
        const Vec3 a = joint("RightShoulder"), b = joint("RightArm");
        ASSERT_FALSE(part.mesh.vertices.empty());
        for (const Vec3& v : part.mesh.vertices) {
            const double s = std::clamp((v - a).dot(b - a) / (b - a).squaredNorm(), 0.0, 1.0);
            EXPECT_NEAR((v - (a + s * (b - a))).norm(), bone_radius("RightShoulder", "RightArm"), 1e-6);
        }
    }
    EXPECT_EQ(vertices, skeleton_body(motion, f, options).vertices.size());
}

// A tapered capsule is the hull of its two spheres: its volume is the two spherical caps beyond
// the tangent cone plus the cone's frustum; its vertices lie on the spheres, none beyond the cone.
TEST(SkeletonBody, ATaperedCapsuleIsTheHullOfItsTwoSpheres) {
    const double ra = 0.038, rb = 0.026, length = 0.25;
    const double c = (ra - rb) / length, s = std::sqrt(1 - c * c);
    auto cap = [](double r, double h) { return std::numbers::pi * h * h * (3 * r - h) / 3; };
    const double frustum_height = length * (1 - c * c);
    const double expected = cap(ra, ra * (1 + c)) + cap(rb, rb * (1 - c)) +
                            std::numbers::pi * frustum_height * (ra * s * ra * s + ra * s * rb * s + rb * s * rb * s) / 3;
    const Vec3 a(0.1, -0.2, 0.9), b = a + length * Vec3(0.6, 0.0, 0.8);
    const TriangleMesh mesh = shapes::tapered_capsule(a, b, ra, rb, 48, 256);
    EXPECT_NEAR(shapes::signed_volume(mesh) / expected, 1.0, 2e-3);
    const Vec3 u = (b - a) / length;
    for (const Vec3& v : mesh.vertices) {
        // Every vertex on one of the spheres, and none beyond the tangent cone (whose outward
        // normal in (along, across) is (c, s), at distance ra from A's centre).
        EXPECT_LT(std::min(std::abs((v - a).norm() - ra), std::abs((v - b).norm() - rb)), 1e-9) << v.transpose();
        const double along = (v - a).dot(u), across = (v - a - along * u).norm();
        EXPECT_LT(across * s + along * c - ra, 1e-9) << v.transpose();
    }
    // One sphere inside the other: the larger sphere.
    EXPECT_NEAR(shapes::signed_volume(shapes::tapered_capsule(a, a + Vec3(0.01, 0, 0), 0.05, 0.02, 24, 96)) / (4 * std::numbers::pi * 0.05 * 0.05 * 0.05 / 3), 1.0, 5e-3);
}

// The capsule body's forearm narrows from its radius at the elbow to an adult's wrist.
TEST(SkeletonBody, TheForearmNarrowsToTheWrist) {
    const BvhMotion motion = load_bvh((test::source_dir() / "data/cmu/18_01.bvh").string(), {});
    const SkeletonBodyOptions options;
    const Vec3 elbow = joint_at(motion, 120, "RightForeArm", options.units), wrist = joint_at(motion, 120, "RightHand", options.units);
    for (const BodyPart& part : skeleton_body_parts(motion, 120, options)) {
        if (part.name != "right_forearm") continue;
        double near_wrist = 0, near_elbow = 0;
        for (const Vec3& v : part.mesh.vertices) {
            const double s = (v - elbow).dot(wrist - elbow) / (wrist - elbow).squaredNorm();
            const double across = (v - (elbow + s * (wrist - elbow))).norm();
            if (std::abs(s - 1) < 0.02) near_wrist = std::max(near_wrist, across);
            if (std::abs(s) < 0.02) near_elbow = std::max(near_elbow, across);
        }
        EXPECT_NEAR(near_wrist, kWristRadius, 0.002);
        EXPECT_NEAR(near_elbow, bone_radius("RightForeArm", "RightHand"), 0.002);
    }
}

// Joints by role: the 18/19 skeleton keeps its names, the 20/21 one (LeftCollar, LeftShoulder =
// upper arm, LeftElbow, LeftWrist, lhand, LeftHip, LeftKnee, lowerback, Chest2) maps onto them, and
// a skeleton that lacks a role says which.
TEST(SkeletonRoles, MapJointsByRoleAndNameWhatIsMissing) {
    const BvhMotion cmu18 = load_bvh((test::source_dir() / "data/cmu/18_01.bvh").string(), {});
    const std::vector<std::string> same = role_names(cmu18);
    for (std::size_t j = 0; j < cmu18.joints.size(); ++j) EXPECT_EQ(same[j], cmu18.joints[j].name) << j;

    const BvhMotion cmu20 = load_bvh((test::source_dir() / "data/cmu/20_11.bvh").string(), {});
    EXPECT_EQ(cmu20.first_frame, 0);
    const std::vector<std::string> roles = role_names(cmu20);
    auto role = [&](const char* name) { return roles[std::size_t(cmu20.joint_index(name))]; };
    const std::vector<std::pair<const char*, const char*>> expected{
        {"Hips", "Hips"},         {"LHipJoint", "LHipJoint"},   {"LeftHip", "LeftUpLeg"},     {"LeftKnee", "LeftLeg"},
        {"LeftAnkle", "LeftFoot"}, {"LeftToe", "LeftToeBase"},   {"RightKnee", "RightLeg"},    {"lowerback", "LowerBack"},
        {"Chest", "Spine"},       {"Chest2", "Spine1"},         {"lowerneck", "Neck"},        {"Neck", "Neck1"},
        {"Head", "Head"},         {"LeftCollar", "LeftShoulder"}, {"LeftShoulder", "LeftArm"}, {"LeftElbow", "LeftForeArm"},
        {"LeftWrist", "LeftHand"}, {"lhand", "LeftFinger"},     {"LFingers", "LFingers"},     {"LThumb", "LThumb"},
        {"RightShoulder", "RightArm"}, {"RightWrist", "RightHand"}, {"rhand", "RightFinger"}};
    for (const auto& [name, expected_role] : expected) EXPECT_EQ(role(name), expected_role) << name;
    EXPECT_EQ(body_part_names(cmu20), body_part_names());

    // Without an elbow on the left arm (renamed), and without a side in the names of a leg.
    test::TempDir dir;
    std::string text = test::read_text(test::source_dir() / "data/cmu/20_11.bvh");
    auto renamed = [&](const std::string& from, const std::string& to) {
        std::string t = text;
        for (std::size_t at = t.find(from); at != std::string::npos; at = t.find(from, at + to.size())) t.replace(at, from.size(), to);
        std::ofstream(dir.path() / "x.bvh", std::ios::binary) << t;
        return load_bvh((dir.path() / "x.bvh").string(), {});
    };
    try {
        role_names(renamed("JOINT LeftElbow", "JOINT LeftBend"));
        ADD_FAILURE() << "no error";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("x.bvh: no joint plays the role of the left elbow (a joint named like LeftElbow or LeftForeArm)"),
                  std::string::npos)
            << e.what();
    }
    try {
        role_names(renamed("JOINT Head", "JOINT Top"));
        ADD_FAILURE() << "no error";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("no joint plays the role of the head"), std::string::npos) << e.what();
    }
    try {
        BvhMotion m = renamed("JOINT RHipJoint", "JOINT HipJoint2");
        for (auto& j : m.joints)
            if (j.name.rfind("Right", 0) == 0 && (j.name.find("Hip") != std::string::npos || j.name.find("Knee") != std::string::npos ||
                                                   j.name.find("Ankle") != std::string::npos || j.name.find("Toe") != std::string::npos))
                j.name = "Joint" + j.name.substr(5);
        role_names(m);
        ADD_FAILURE() << "no error";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("does not say whether it is left or right"), std::string::npos) << e.what();
    }
}

}  // namespace
}  // namespace amhv
