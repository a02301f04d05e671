#include "src/cli/commands.hpp"

int main(int argc, char** argv) { return amhv::cli::run(argc, argv); }
