// Writes the paper-scale benchmark scene (docs/benchmarks.md, B3), deterministically: two
// performers captured apart, each a BVH skeleton holding a sword (a "RightSword" joint), 9 key
// segment pairs of sword play between walks, B's takes longer and shifted in time, 425 output
// frames after normalisation, sampled at 10 mm / 2 degrees.
//
//   amhv_make_paper_scene OUT_DIR   ->  OUT_DIR/a.bvh, OUT_DIR/b.bvh, OUT_DIR/scene.toml
#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <numbers>
#include <string>
#include <vector>

#include <fmt/format.h>

namespace fs = std::filesystem;

namespace {

constexpr int kKeys = 9;
constexpr int kKeyLength = 25;         // A's key segments; the normalised length
constexpr int kTransitionLength = 20;  // A's transitions; the normalised length

const char* kHierarchy = R"(HIERARCHY
ROOT Hips
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT LeftUpLeg
  {
    OFFSET 0.1 0 0
    CHANNELS 3 Zrotation Xrotation Yrotation
    JOINT LeftLeg
    {
      OFFSET 0 -0.45 0
      CHANNELS 3 Zrotation Xrotation Yrotation
      JOINT LeftFoot
      {
        OFFSET 0 -0.42 0
        CHANNELS 3 Zrotation Xrotation Yrotation
        End Site
        {
          OFFSET 0 -0.05 0.14
        }
      }
    }
  }
  JOINT RightUpLeg
  {
    OFFSET -0.1 0 0
    CHANNELS 3 Zrotation Xrotation Yrotation
    JOINT RightLeg
    {
      OFFSET 0 -0.45 0
      CHANNELS 3 Zrotation Xrotation Yrotation
      JOINT RightFoot
      {
        OFFSET 0 -0.42 0
        CHANNELS 3 Zrotation Xrotation Yrotation
        End Site
        {
          OFFSET 0 -0.05 0.14
        }
      }
    }
  }
  JOINT Spine
  {
    OFFSET 0 0.1 0
    CHANNELS 3 Zrotation Xrotation Yrotation
    JOINT Spine1
    {
      OFFSET 0 0.25 0
      CHANNELS 3 Zrotation Xrotation Yrotation
      JOINT Neck
      {
        OFFSET 0 0.2 0
        CHANNELS 3 Zrotation Xrotation Yrotation
        JOINT Head
        {
          OFFSET 0 0.1 0
          CHANNELS 3 Zrotation Xrotation Yrotation
          End Site
          {
            OFFSET 0 0.2 0
          }
        }
      }
      JOINT LeftShoulder
      {
        OFFSET 0.04 0.17 0
        CHANNELS 3 Zrotation Xrotation Yrotation
        JOINT LeftArm
        {
          OFFSET 0.15 0 0
          CHANNELS 3 Zrotation Xrotation Yrotation
          JOINT LeftForeArm
          {
            OFFSET 0.28 0 0
            CHANNELS 3 Zrotation Xrotation Yrotation
            JOINT LeftHand
            {
              OFFSET 0.25 0 0
              CHANNELS 3 Zrotation Xrotation Yrotation
              End Site
              {
                OFFSET 0.17 0 0
              }
            }
          }
        }
      }
      JOINT RightShoulder
      {
        OFFSET -0.04 0.17 0
        CHANNELS 3 Zrotation Xrotation Yrotation
        JOINT RightArm
        {
          OFFSET -0.15 0 0
          CHANNELS 3 Zrotation Xrotation Yrotation
          JOINT RightForeArm
          {
            OFFSET -0.28 0 0
            CHANNELS 3 Zrotation Xrotation Yrotation
            JOINT RightHand
            {
              OFFSET -0.25 0 0
              CHANNELS 3 Zrotation Xrotation Yrotation
              JOINT RightSword
              {
                OFFSET -0.1 0 0
                CHANNELS 3 Zrotation Xrotation Yrotation
                End Site
                {
                  OFFSET -0.7 0 0
                }
              }
            }
          }
        }
      }
    }
  }
}
)";

// Joints with rotation channels, in file order (after the root).
enum Joint { LeftUpLeg, LeftLeg, LeftFoot, RightUpLeg, RightLeg, RightFoot, Spine, Spine1, Neck, Head, LeftShoulder, LeftArm,
             LeftForeArm, LeftHand, RightShoulder, RightArm, RightForeArm, RightHand, RightSword, JointCount };

struct Pose {
    double x = 0, z = 0, heading_deg = 0;  // root on the floor (BVH: y up), heading about y
    double phase = 0;                      // gait phase, radians
    double swing_deg = -20;                // sword arm about the vertical: -20 beside the body, +90 straight ahead
};

std::string frame_line(const Pose& p) {
    std::array<std::array<double, 3>, JointCount> r{};  // Z X Y per joint, degrees
    r[LeftUpLeg][1] = 25 * std::sin(p.phase);
    r[RightUpLeg][1] = -25 * std::sin(p.phase);
    r[LeftLeg][1] = 30 * std::max(0.0, std::sin(p.phase + 1.2));
    r[RightLeg][1] = 30 * std::max(0.0, -std::sin(p.phase + 1.2));
    r[LeftArm][0] = -80;  // the free arm hangs down
    r[LeftArm][1] = -10 * std::sin(p.phase);
    r[RightArm][2] = p.swing_deg;  // the sword arm is held out level and swings about the vertical
    std::string line = fmt::format("{:.5f} 0.93000 {:.5f} 0 0 {:.5f}", p.x, p.z, p.heading_deg);
    for (const auto& j : r) line += fmt::format(" {:.4f} {:.4f} {:.4f}", j[0], j[1], j[2]);
    return line;
}

// One performer: a walk (`transitions[i]` frames, turning by `turns_deg[i]` in all) before each key
// segment (`keys[i]` frames of a sword swing from `from_deg` to `to_deg`), and a last walk.
std::vector<Pose> performance(const std::vector<int>& transitions, const std::vector<int>& keys, const std::vector<double>& turns_deg,
                              double from_deg, double to_deg, double start_heading_deg, std::vector<std::array<int, 2>>& key_frames) {
    std::vector<Pose> frames;
    Pose p;
    p.heading_deg = start_heading_deg;
    auto walk = [&](int count, double turn_deg) {
        for (int f = 0; f < count; ++f) {
            p.heading_deg += turn_deg / count;
            const double h = p.heading_deg * std::numbers::pi / 180;
            p.x += 0.045 * std::sin(h);  // BVH forward is +z; heading turns it about y
            p.z += 0.045 * std::cos(h);
            p.phase += 0.45;
            p.swing_deg = -20;
            frames.push_back(p);
        }
    };
    for (std::size_t i = 0; i < keys.size(); ++i) {
        walk(transitions[i], turns_deg[i]);
        const int first = int(frames.size());
        for (int f = 0; f < keys[i]; ++f) {
            const double s = keys[i] > 1 ? double(f) / (keys[i] - 1) : 1.0;
            p.swing_deg = from_deg + (to_deg - from_deg) * (0.5 - 0.5 * std::cos(std::numbers::pi * s));
            frames.push_back(p);
        }
        key_frames.push_back({first, int(frames.size()) - 1});
    }
    walk(transitions.back(), turns_deg.back());
    return frames;
}

void write_bvh(const fs::path& path, const std::vector<Pose>& frames) {
    std::ofstream out(path);
    out << kHierarchy << "MOTION\nFrames: " << frames.size() << "\nFrame Time: 0.04\n";
    for (const Pose& p : frames) out << frame_line(p) << '\n';
    if (!out) throw std::runtime_error("cannot write " + path.string());
}

}  // namespace

int main(int argc, char** argv) {
    try {
        if (argc != 2) {
            std::cerr << "usage: amhv_make_paper_scene OUT_DIR\n";
            return 2;
        }
        const fs::path dir = argv[1];
        fs::create_directories(dir);
        // A: 10 walks of 20 frames and 9 key segments of 25 (425 frames). B: longer, shifted takes.
        std::vector<int> a_walks(kKeys + 1, kTransitionLength), a_keys(kKeys, kKeyLength), b_walks, b_keys;
        std::vector<double> a_turns, b_turns;
        for (int i = 0; i <= kKeys; ++i) {
            b_walks.push_back(kTransitionLength + (i * 7) % 5);
            a_turns.push_back(i % 2 ? 40.0 : -30.0);
            b_turns.push_back(i % 3 ? -35.0 : 50.0);
        }
        for (int i = 0; i < kKeys; ++i) b_keys.push_back(kKeyLength + 3 * (i % 3));
        std::vector<std::array<int, 2>> a_frames, b_frames;
        write_bvh(dir / "a.bvh", performance(a_walks, a_keys, a_turns, -20, 70, 0, a_frames));
        write_bvh(dir / "b.bvh", performance(b_walks, b_keys, b_turns, -20, 50, 90, b_frames));

        const std::array<const char*, kKeys> types{"+&+", "0&0b", "+&0", "0&+", "+&+", "0&0b", "0&0c", "0&0b", "+&+"};
        std::ofstream scene(dir / "scene.toml");
        scene << "# The paper-scale benchmark scene written by amhv_make_paper_scene: 425 output frames, 9 key segment pairs.\n"
                 "[sampling]\nvoxel = 0.01\nangle_step_deg = 2.0\n\n"
                 "[objects.A]\nbvh = \"a.bvh\"\nunit = \"m\"\nup = \"y\"\n\n"
                 "[objects.B]\nbvh = \"b.bvh\"\nunit = \"m\"\nup = \"y\"\nplacement = { x = 6.0, y = -2.0, yaw_deg = 150.0 }\n";
        for (int i = 0; i < kKeys; ++i) {
            scene << fmt::format("\n[[segments]]\na = [{}, {}]\nb = [{}, {}]\ntype = \"{}\"\n", a_frames[std::size_t(i)][0], a_frames[std::size_t(i)][1],
                                 b_frames[std::size_t(i)][0], b_frames[std::size_t(i)][1], types[std::size_t(i)]);
            scene << "interest = { A = { parts = [\"sword\"] }, B = { parts = [\"sword\"] } }\n";
            if (i % 3 == 1) scene << "visibility = { enabled = true, half_angle_deg = 45.0 }\n";
        }
        if (!scene) throw std::runtime_error("cannot write " + (dir / "scene.toml").string());
        std::cout << "wrote " << (dir / "scene.toml").string() << " (a.bvh, b.bvh beside it)\n";
        return 0;
    } catch (const std::exception& e) {
        std::cerr << "amhv_make_paper_scene: error: " << e.what() << '\n';
        return 1;
    }
}
