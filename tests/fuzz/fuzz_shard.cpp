// Fuzz target: one shard folder's shard.json through read_shard_manifest.
#include "src/results/shard_files.hpp"
#include "tests/fuzz/fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace amhv;
    const auto path = fuzz::write_input("shard/shard.json", data, size);
    return fuzz::refusals_only([&] { results::read_shard_manifest(path.parent_path()); });
}
