#include "src/cli/commands.hpp"
#include "src/core/process.hpp"
#include "src/io/output_dir.hpp"

namespace amhv {
const char* build_commit();  // written at build time (tools/version.cmake)
}

int main(int argc, char** argv) {
    amhv::watch_interrupts();  // first: every thread started later inherits the blocked signals
    amhv::keep_freed_memory();
    return amhv::cli::run(argc, argv, amhv::build_commit());
}
