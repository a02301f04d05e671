// Fuzz target: one OBJ frame through read_mesh (the structural pre-checks, OpenMesh and
// the conversion, and the appearance with its material libraries).
#include "src/io/mesh_sequence.hpp"
#include "tests/fuzz/fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace amhv;
    const auto path = fuzz::write_input("frame.obj", data, size);
    return fuzz::refusals_only([&] { read_mesh(path, UnitsAndAxes{}); });
}
