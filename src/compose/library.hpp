#pragma once
// A composing library (`amhv compose`): BVH takes of one skeleton, and a few example clips per
// action labelled by the user. Every take is brought to one clock (the library's frames per second)
// so that frame numbers, windows and the composed take share it.
#include <filesystem>
#include <string>
#include <vector>

#include "src/io/bvh.hpp"
#include "src/io/mesh_sequence.hpp"

namespace amhv::compose {

struct LibraryTake {
    std::string name;
    std::filesystem::path file;
    BvhMotion motion;                 // at the library's clock
    double file_fps = 0;              // the file's own rate
    int first = 0, last = 0;          // the frames of `motion` the library uses (inclusive)
    int frames() const { return last - first + 1; }
};

struct ActionExample {
    int take = 0;                     // index into takes
    int first = 0, last = 0;          // at the library's clock, inclusive
    std::string action;
};

struct Library {
    std::filesystem::path file;
    UnitsAndAxes units{0.0564444, UpAxis::Y};  // CMU defaults, as scenes
    double fps = 0;
    std::vector<LibraryTake> takes;
    std::vector<ActionExample> examples;
    std::vector<std::string> actions;  // in the order the examples first name them
    std::vector<std::string> roles;    // per joint, its role (src/body/skeleton_roles.hpp)

    int action_index(const std::string& name) const;  // -1 when no example names it
};

// Reads a library file:
//   unit = "0.0564444"  up = "y"  fps = 30          (optional; defaults: CMU units, y up, the first take's rate)
//   [[takes]]     name = "a"  bvh = "a.bvh"  frames = [1, 303]  (frames optional)  tpose = "auto"
//   [[examples]]  take = "a"  frames = [1, 90]  action = "walk"  (frames in the file's own numbering)
// Paths are relative to the library file. Every take must map joint by joint onto the first
// (same joints in the same order and hierarchy, same roles and channels, three rotation channels
// per joint); a take that does not, an unknown take in an example, an example outside its take,
// or an example shorter than `min_example_s` is refused in one line naming the file and line.
Library read_library(const std::filesystem::path& file);

// The shortest example the library accepts, seconds: the recognition window (recognise.hpp).
inline constexpr double kMinExampleSeconds = 0.25;

}  // namespace amhv::compose
