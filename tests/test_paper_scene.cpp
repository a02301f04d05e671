// The paper-scale scene (tools/make_paper_scene.cpp, docs/benchmarks.md B3): `amhv edit` leaves no
// transitional frame with the two performers inside each other, asserted from the output files
// alone (both whole bodies re-voxelised per frame from transforms.json by the CPU reference,
// independent of the edit's own check), with the key segments' groups as the sweep found them.
#include <filesystem>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "host/reference/voxelise_reference.hpp"
#include "src/scene/scene.hpp"
#include "src/scene/segment.hpp"
#include "support.hpp"

namespace amhv {
namespace {

namespace fs = std::filesystem;

TEST(PaperScene, NoTransitionalFrameHasThePerformersInsideEachOther) {
    test::TempDir tmp;
    auto made = test::run_shell(fmt::format("'{}' '{}'", AMHV_PAPER_SCENE_TOOL, (tmp.path() / "scene").string()));
    ASSERT_EQ(made.exit_code, 0) << made.output;
    const fs::path out = tmp.path() / "edit";
    auto run = test::run_amhv(fmt::format("edit '{}' --no-frames --no-glb --no-timings --out '{}'", (tmp.path() / "scene/scene.toml").string(), out.string()));
    ASSERT_EQ(run.exit_code, 0) << run.output;
    const auto result = nlohmann::json::parse(test::read_text(out / "result.json"));
    int separated = 0;
    for (const auto& t : result.at("transitions")) {
        EXPECT_EQ(t.at("frames_overlapping").get<int>(), 0) << t.dump();
        separated += t.at("before_separation").at("frames_overlapping").get<int>() > 0;
    }
    EXPECT_GE(separated, 1);  // the paper's paths collide in the last transition
    for (const auto& s : result.at("segments")) EXPECT_GT(s.at("solutions").get<int>(), 0);

    const double voxel = load_scene(tmp.path() / "scene/scene.toml").sampling.voxel;
    EXPECT_EQ(test::overlapping_transitional_frames(tmp.path() / "scene/scene.toml", out / "transforms.json", voxel), std::vector<int>{});
    EXPECT_EQ(result.at("transitions").size(), 10u);  // 200 transitional frames, every one checked above
}

}  // namespace
}  // namespace amhv
