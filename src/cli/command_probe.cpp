// `amhv probe`: why a pose is (not) a solution of a key segment, constraint by constraint.
#include <charconv>
#include <iostream>
#include <vector>

#include "src/cli/backend.hpp"
#include "src/cli/commands.hpp"
#include "src/core/error.hpp"
#include "src/pipeline/probe_stage.hpp"

namespace amhv::cli {

namespace {

struct ProbeArguments {
    std::string scene, pose, backend = "vulkan";
    int device = -1;
    bool json = false;
    pipeline::ProbeRequest request;
};

// "X,Y,THETA" or "X,Y,THETA,Z": metres and degrees.
std::array<double, 4> parse_pose(const std::string& text) {
    std::vector<std::string> items{""};
    for (char c : text) {
        if (c == ',') items.emplace_back();
        else items.back() += c;
    }
    std::array<double, 4> out{0, 0, 0, 0};
    bool ok = items.size() == 3 || items.size() == 4;
    for (std::size_t n = 0; n < items.size() && ok; ++n) {
        const std::string& item = items[n];
        const auto [end, error] = std::from_chars(item.data(), item.data() + item.size(), out[n]);
        ok = error == std::errc() && end == item.data() + item.size() && !item.empty();
    }
    if (!ok) fail("--pose", "'{}' is not X,Y,THETA or X,Y,THETA,Z (metres, degrees)", text);
    return out;
}

void run_probe(ProbeArguments args) {
    if (args.pose.empty() == !args.request.truth) fail("probe", "give exactly one of --pose X,Y,THETA[,Z] and --truth");
    if (!args.pose.empty()) args.request.pose = parse_pose(args.pose);
    const Scene scene = load_two_object_scene(args.scene, "probe");
    Backend backend(args.backend, args.device);
    const pipeline::ProbeAnswer answer = pipeline::probe_scene(scene, args.request, backend.voxeliser());
    if (args.json) std::cout << pipeline::probe_json(answer).dump(2) << '\n';
    else std::cout << pipeline::probe_table(answer, int(answer.probe.fidelity_voxels.size()));
}

}  // namespace

void add_probe_command(CLI::App& app) {
    auto args = std::make_shared<ProbeArguments>();
    auto* probe = app.add_subcommand("probe", "Why one pose of a key segment is or is not a solution: every constraint, frame by frame");
    probe->add_option("scene", args->scene, "Scene file (TOML)")->required();
    probe->add_option("--segment", args->request.segment, "Key segment N (1-based; 1)");
    probe->add_option("--pose", args->pose, "X,Y,THETA[,Z]: B's root offset from A's root (metres), its turn (degrees), its raise (metres)");
    probe->add_flag("--truth", args->request.truth, "Probe the pose the scene's [truth] gives");
    probe->add_flag("--json", args->json, "Print JSON instead of a table");
    add_backend_options(*probe, args->backend, args->device);
    probe->callback([args] { run_probe(*args); });
}

}  // namespace amhv::cli
