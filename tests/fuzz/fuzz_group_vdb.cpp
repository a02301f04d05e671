// Fuzz target: one group.vdb through read_group_lattice, then read_group_vdb on the lattice it
// claims (what `amhv solutions` and `amhv view` do with a folder they are given).
#include "src/results/group_vdb.hpp"
#include "tests/fuzz/fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace amhv;
    const auto path = fuzz::write_input("group.vdb", data, size);
    return fuzz::refusals_only([&] {
        const results::GroupLattice lattice = results::read_group_lattice(path);
        results::read_group_vdb(path, lattice);
    });
}
