#pragma once
// `--backend vulkan|cpu` and `--device N`, shared by the subcommands: the Vulkan context with the
// GPU voxeliser, sweeper and skinner, or the plain CPU references. Each stage's pipeline is only built when
// a subcommand first asks for it.
#include <memory>

#include <CLI/CLI.hpp>
#include <string>

#include "src/body/skinning.hpp"
#include "src/voxelise/voxelise.hpp"
#include "src/gpu/context.hpp"
#include "src/pipeline/sweep_stage.hpp"
#include "src/sweep/problem.hpp"

namespace amhv::cli {

// Registers --backend and --device on `command`.
void add_backend_options(CLI::App& command, std::string& backend, int& device);

class Backend {
public:
    // Throws amhv::Error for an unknown backend name; `device` < 0 lets the context choose.
    Backend(const std::string& name, int device);

    Voxeliser& voxeliser();
    Sweeper& sweeper();
    Skinner& skinner();
    const std::string& device() const { return device_; }  // "name (type, driver)", or "cpu"
    // The stages' view of it: voxeliser, sweeper, skinner, and how result.json names them.
    pipeline::Backends backends();

private:
    std::unique_ptr<gpu::Context> context_;  // null for cpu
    std::unique_ptr<Voxeliser> voxeliser_;
    std::unique_ptr<Sweeper> sweeper_;
    std::unique_ptr<Skinner> skinner_;
    std::string name_;
    std::string device_ = "cpu";
};

}  // namespace amhv::cli
