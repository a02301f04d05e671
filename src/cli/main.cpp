#include "src/cli/commands.hpp"
#include "src/core/process.hpp"

int main(int argc, char** argv) {
    amhv::keep_freed_memory();
    return amhv::cli::run(argc, argv);
}
