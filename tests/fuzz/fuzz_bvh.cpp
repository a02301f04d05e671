// Fuzz target: one BVH take through read_bvh and load_bvh (resampling to 25 fps, the T-pose test).
#include "src/io/bvh.hpp"
#include "tests/fuzz/fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace amhv;
    const auto path = fuzz::write_input("take.bvh", data, size);
    return fuzz::refusals_only([&] {
        read_bvh(path);
        load_bvh(path, BvhLoadOptions{TPose::Auto, 25.0});
    });
}
