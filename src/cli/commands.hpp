#pragma once
// The `amhv` command line: one function per subcommand, all registered on one CLI11 app.
#include <CLI/CLI.hpp>

namespace amhv::cli {

// Registers the subcommands; the returned callbacks run after parsing.
void add_devices_command(CLI::App& app);
void add_mhv_command(CLI::App& app);
void add_import_bvh_command(CLI::App& app);
void add_compose_command(CLI::App& app);
void add_scene_commands(CLI::App& app);  // check, sweep
void add_edit_command(CLI::App& app);  // edit, demo
void add_probe_command(CLI::App& app);
void add_propose_command(CLI::App& app);
void add_view_command(CLI::App& app);  // view
void add_shard_commands(CLI::App& app);  // merge, plan

// Runs the whole program; returns the exit code. Every failure becomes one "amhv: error: ..." line.
// `commit` is the commit the program was built from (`amhv --version`).
int run(int argc, char** argv, const char* commit);

}  // namespace amhv::cli
