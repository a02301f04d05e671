// Fuzz target: one MTL file through read_mtl and mtl_references, confined to the input's folder
// (a texture it names that exists: textures/skin.png).
#include "src/io/obj_appearance.hpp"
#include "tests/fuzz/fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace amhv;
    static const auto texture = fuzz::write_input("mtl/textures/skin.png", reinterpret_cast<const std::uint8_t*>("png"), 3);
    const auto path = fuzz::write_input("mtl/body.mtl", data, size);
    return fuzz::refusals_only([&] {
        read_mtl(path, path.parent_path());
        mtl_references(path, path.parent_path());
    });
}
