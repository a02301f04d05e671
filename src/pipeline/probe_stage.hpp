#pragma once
// `amhv probe`: one pose of one key segment, constraint by constraint (docs/method.md section 5),
// with the CPU reference's mapping so the verdict is the sweep's; and result.json's near misses.
#include <optional>
#include <string>

#include "host/reference/pose_probe.hpp"
#include "src/results/result_json.hpp"
#include "src/scene/scene.hpp"
#include "src/scene/segment.hpp"

namespace amhv::pipeline {

// The pose asked for: metres and degrees (snapped to the sweep's lattice), or the scene's truth.
struct ProbeRequest {
    int segment = 1;
    std::optional<std::array<double, 4>> pose;  // x, y, theta_deg, z
    bool truth = false;
};

struct ProbeAnswer {
    KeySegment segment;
    PoseProbe probe;
    bool in_range = true;  // within the poses the sweep tests
    std::string snapped;   // a note when the pose asked for was moved onto the lattice ("" otherwise)
    // When the pose fails: its lattice neighbours (one voxel in x, y and z within the range, one
    // angle step) that are solutions, in (l, k, j, i) order. A pose just off the group is then told
    // from one far from it.
    std::vector<Solution> neighbours_in_group;
};

ProbeAnswer probe_scene(const Scene& scene, const ProbeRequest& request, Voxeliser& voxeliser);

// The answer as a readable table, and as JSON.
std::string probe_table(const ProbeAnswer& answer, int frames);
results::Json probe_json(const ProbeAnswer& answer);

// Up to 10 poses that fail the fewest frames, far apart from each other (at least 10 cm or 10
// degrees or one height step), among the non-solutions that got furthest through the tests; a
// deterministic sample of at most 400 is probed. For result.json's "near_misses".
results::Json near_misses(const SweepProblem& problem, const SweepResult& result);

}  // namespace amhv::pipeline
