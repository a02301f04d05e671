// Fuzz target: one PLY frame through read_mesh (the structural pre-checks, OpenMesh and
// the conversion).
#include "src/io/mesh_sequence.hpp"
#include "tests/fuzz/fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace amhv;
    const auto path = fuzz::write_input("frame.ply", data, size);
    return fuzz::refusals_only([&] { read_mesh(path, UnitsAndAxes{}); });
}
