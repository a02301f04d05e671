#pragma once
// result.json (docs/method.md section 10): written by `amhv sweep` and `amhv edit`, read back by
// `amhv edit --from-sweep`. This module alone knows its layout: the header (program, scene,
// backend, device, parameters), one entry per key segment (the sweep's counts, range, roots,
// parts, files and truth; after an edit the chosen pose and the rigid move), and the edit's dp,
// paths, outputs and timings.
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "src/edit/edit.hpp"
#include "src/edit/natural_terms.hpp"
#include "src/scene/scene.hpp"
#include "src/scene/segment.hpp"
#include "src/sweep/problem.hpp"

namespace amhv::results {

using Json = nlohmann::ordered_json;

// A solution's descriptors: x, y, z, theta_deg, L, thetaA_deg, thetaB_deg.
Json solution_json(const Solution& s);
// The natural choice's terms (docs/method.md section 7b) and their cost: null where a term does not apply.
Json natural_terms_json(const NaturalTerms& t);

// program, scene, backend, device and the resolved sampling and weights.
Json result_header(const Scene& scene, const std::string& backend, const std::string& device);

// What one key segment's sweep wrote, for its entry.
struct SegmentFiles {
    bool maps = false;         // feasibility maps written
    int feasibility_files = 0;
    std::uint64_t group_bytes = 0;  // segment_N/group.vdb
    bool csv = false;               // segment_N/solutions.csv written (--csv)
};

// One key segment's entry after its sweep (`group` within the intent's limits, `limited` the
// solutions of the sweep outside them); `timings` (mhv, sweep, output, stages) when not null.
Json sweep_segment_json(const Scene& scene, const KeySegment& segment, const SweepProblem& problem, const SweepResult& result,
                        const SolutionGroup& group, std::uint64_t limited, const SegmentFiles& files, const Json& timings);

// What the edit wrote beside result.json.
struct EditFiles {
    bool frames = false;
    int mesh_files = 0;
    int obj_files = 0;  // frames/A_NNNN.obj, B_NNNN.obj: OBJ input with its appearance
    bool glb = false;  // scene.glb
    std::vector<std::string> bvh;  // A.bvh, B.bvh: the edited takes
    std::vector<std::string> characters;  // A.glb, B.glb: the edited characters
    std::uint64_t glb_bytes = 0;
    double glb_fps = 0;  // the frame rate scene.glb plays at
    Json views = Json::array();  // views/key_N.png: the output frame each shows, its camera
};

// Adds the edit to a result: per key segment the chosen pose, its error from the truth and the
// rigid move; then dp, paths and outputs.
void add_edit(Json& json, const EditResult& edit, const EditFiles& files);

// The key segments' sweeps as `amhv sweep` (or `amhv edit`) wrote them into `dir`, for the scene
// they must match: result.json's entries and each segment_N/group.vdb.
struct SweepRecord {
    std::vector<KeySweep> sweeps;
    Json segments = Json::array();  // result.json's "segments"
};
// Throws amhv::Error naming the file when the folder does not match `scene`.
SweepRecord read_sweep_folder(const std::filesystem::path& dir, const Scene& scene);

// Writes `json` (indented by 2) to `path`, checking the stream; throws amhv::Error naming the file.
void write_json_file(const std::filesystem::path& path, const Json& json);

}  // namespace amhv::results
