// Fuzz target: one scene file through load_scene (every key, its type and range, the objects'
// files), in a folder with a small BVH take (take.bvh) and a tetrahedron mesh sequence
// (m/0000.obj .. m/0003.obj) for the scene to name.
#include "src/scene/scene.hpp"
#include "tests/fuzz/fuzz_support.hpp"

namespace {

const std::string kTake =
    "HIERARCHY\nROOT Hips\n{\n OFFSET 0 0 0\n CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n"
    " JOINT Chest\n {\n  OFFSET 0 10 0\n  CHANNELS 3 Zrotation Xrotation Yrotation\n  End Site\n  {\n   OFFSET 0 10 0\n  }\n }\n}\n"
    "MOTION\nFrames: 4\nFrame Time: 0.04\n0 30 0 0 0 0 0 0 0\n0 30 0 0 0 0 0 0 0\n0 30 0 0 0 0 0 0 0\n0 30 0 0 0 0 0 0 0\n";
const std::string kTetra = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 2 3 4\nf 1 4 3\n";

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace amhv;
    static const bool files = [] {
        fuzz::write_input("scene/take.bvh", reinterpret_cast<const std::uint8_t*>(kTake.data()), kTake.size());
        for (int f = 0; f < 4; ++f)
            fuzz::write_input("scene/m/000" + std::to_string(f) + ".obj", reinterpret_cast<const std::uint8_t*>(kTetra.data()), kTetra.size());
        return true;
    }();
    (void)files;
    const auto path = fuzz::write_input("scene/scene.toml", data, size);
    return fuzz::refusals_only([&] { load_scene(path); });
}
