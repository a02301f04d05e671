// Scale-out: the shard plan covers every key segment angle once, in balanced contiguous shards;
// shards merged equal the one-machine sweep byte for byte (whichever backend swept each shard);
// shard runs are idempotent; Slurm's array variables name the shard; and merge refuses every kind
// of bad shard set with one line and writes nothing. (tests/slurm_cluster.sh runs it all on a real
// one-node Slurm.)
#include <algorithm>
#include <cstdlib>
#include <fstream>
#include <map>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "src/core/error.hpp"
#include "src/pipeline/shard_stage.hpp"
#include "tests/support.hpp"

namespace amhv {
namespace {

namespace fs = std::filesystem;
using test::read_text;
using test::run_amhv;

// The handshake (0&0 (a) with visibility) and a later '+&+' with B's heights, at 4 cm / 10 deg:
// 3 shards cut it so that shard 2 spans both key segments.
std::string two_segment_scene() {
    const std::string cmu = (test::source_dir() / "data/cmu").string();
    return fmt::format(R"([sampling]
voxel = 0.04
angle_step_deg = 10.0

[objects.A]
bvh = "{0}/18_01.bvh"

[objects.B]
bvh = "{0}/19_01.bvh"

[[segments]]
a = [108, 147]
b = [108, 147]
type = "0&0a"
interest = {{ A = {{ parts = ["right_hand"] }}, B = {{ parts = ["right_hand"] }} }}
fidelity = {{ A = {{ parts_except = ["right_upper_arm", "right_forearm", "right_hand"] }}, B = {{ parts_except = ["right_upper_arm", "right_forearm", "right_hand"] }} }}
visibility = {{ enabled = true, half_angle_deg = 30.0 }}

[[segments]]
a = [160, 175]
b = [160, 175]
type = "+&+"
interest = {{ A = {{ parts = ["right_hand"] }}, B = {{ parts = ["right_hand"] }} }}
z_range = [-0.04, 0.04]
)",
                       cmu);
}

std::string q(const fs::path& p) { return fmt::format("'{}'", p.string()); }

// Every file under `root` by its relative name, with its bytes.
std::map<std::string, std::string> folder_files(const fs::path& root) {
    std::map<std::string, std::string> files;
    for (const auto& entry : fs::recursive_directory_iterator(root))
        if (entry.is_regular_file()) files[fs::relative(entry.path(), root).string()] = read_text(entry.path());
    return files;
}

// Every file under `a` equals the one of the same name under `b`, and they hold the same names.
void expect_same_folder(const fs::path& a, const fs::path& b) {
    const std::map<std::string, std::string> files_a = folder_files(a), files_b = folder_files(b);
    ASSERT_GE(files_a.size(), 3u);
    EXPECT_EQ(files_a.size(), files_b.size());
    for (const auto& [name, bytes] : files_a) {
        ASSERT_TRUE(files_b.count(name)) << name << " is missing from " << b;
        EXPECT_TRUE(bytes == files_b.at(name)) << name << " differs";
    }
}

// One scene, swept on one machine and in 3 shards (once per test binary: every test reads them).
class Shards : public ::testing::Test {
protected:
    static void SetUpTestSuite() {
        dir_ = new test::TempDir;
        std::ofstream(scene()) << two_segment_scene();
        ASSERT_EQ(run_amhv(fmt::format("sweep {} --out {} --no-timings --csv", q(scene()), q(path("one")))).exit_code, 0);
        for (int k = 1; k <= 3; ++k) {
            const auto r = run_amhv(fmt::format("sweep {} --shard {}/3 --no-timings --out {}", q(scene()), k, q(shard(k))));
            ASSERT_EQ(r.exit_code, 0) << r.output;
        }
    }
    static void TearDownTestSuite() { delete dir_; }
    static fs::path path(const std::string& name) { return dir_->path() / name; }
    static fs::path scene() { return path("scene.toml"); }
    static fs::path shard(int k) { return path(fmt::format("shard_{}", k)); }
    static std::string shards(const std::vector<int>& ks) {
        std::string out;
        for (int k : ks) out += q(shard(k)) + " ";
        return out;
    }
    static test::TempDir* dir_;
};
test::TempDir* Shards::dir_ = nullptr;

TEST(ShardPlan, EveryAngleOnceInContiguousShardsOfAboutEqualCost) {
    test::TempDir tmp;
    std::ofstream(tmp.path() / "scene.toml") << two_segment_scene();
    const Scene scene = load_scene(tmp.path() / "scene.toml");
    const int angles = scene.sampling.angles();
    const std::uint64_t unit[2] = {pipeline::angle_cost(scene, scene.segments[0]), pipeline::angle_cost(scene, scene.segments[1])};
    EXPECT_EQ(unit[0], 40u * 2);  // 40 frames, visibility
    EXPECT_EQ(unit[1], 16u * 3);  // 16 frames, 3 heights
    const std::uint64_t total = (unit[0] + unit[1]) * std::uint64_t(angles);
    for (int count : {1, 2, 3, 5, 7, 16, 71, 72}) {
        const auto plan = pipeline::plan_shards(scene, count);
        ASSERT_EQ(plan.size(), std::size_t(count));
        std::vector<std::pair<int, int>> order;  // (segment, angle) in shard order
        for (const auto& work : plan) {
            std::uint64_t cost = 0;
            for (const results::ShardPiece& p : work) {
                ASSERT_GE(p.angle_count, 1);
                for (int k = p.first_angle; k < p.first_angle + p.angle_count; ++k) order.emplace_back(p.segment, k);
                cost += unit[p.segment - 1] * std::uint64_t(p.angle_count);
            }
            // Within one angle's cost of an equal share.
            EXPECT_LE(cost, total / std::uint64_t(count) + std::max(unit[0], unit[1])) << count << " shards";
            EXPECT_EQ(work, pipeline::plan_shards(scene, count)[std::size_t(&work - plan.data())]);
        }
        ASSERT_EQ(order.size(), std::size_t(2 * angles)) << count << " shards";
        for (int n = 0; n < 2 * angles; ++n) EXPECT_EQ(order[std::size_t(n)], std::make_pair(1 + n / angles, n % angles));
    }
    EXPECT_THROW(pipeline::plan_shards(scene, 0), Error);
    EXPECT_THROW(pipeline::plan_shards(scene, 2 * angles + 1), Error);
}

TEST_F(Shards, MergedEqualsTheOneMachineSweepByteForByte) {
    const auto plan = nlohmann::json::parse(read_text(shard(2) / "shard.json"));
    ASSERT_EQ(plan["pieces"].size(), 2u) << "shard 2 should span both key segments";
    const auto r = run_amhv(fmt::format("merge {} --out {} --no-timings --csv", shards({3, 1, 2}), q(path("merged"))));
    ASSERT_EQ(r.exit_code, 0) << r.output;
    expect_same_folder(path("one"), path("merged"));
    // And the edit takes the merged folder.
    const auto edit = run_amhv(fmt::format("edit {} --from-sweep {} --no-frames --no-glb --out {}", q(scene()), q(path("merged")), q(path("edit"))));
    EXPECT_EQ(edit.exit_code, 0) << edit.output;
}

TEST_F(Shards, AShardOfTheOtherBackendMergesToTheSameGroups) {
    ASSERT_EQ(run_amhv(fmt::format("sweep {} --shard 2/3 --backend cpu --no-timings --out {}", q(scene()), q(path("cpu_2")))).exit_code, 0);
    const auto r = run_amhv(fmt::format("merge {} {} {} --out {} --no-timings --csv", q(shard(1)), q(path("cpu_2")), q(shard(3)), q(path("mixed"))));
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const auto one = nlohmann::json::parse(read_text(path("one/result.json")));
    const auto mixed = nlohmann::json::parse(read_text(path("mixed/result.json")));
    EXPECT_EQ(one["segments"], mixed["segments"]);
    EXPECT_EQ(mixed["backend"], "vulkan, cpu");
    for (const char* file : {"segment_1/group.vdb", "segment_2/group.vdb", "segment_2/solutions.csv", "segment_1/feasibility/angle_000.png"})
        EXPECT_TRUE(read_text(path("one") / file) == read_text(path("mixed") / file)) << file;
}

TEST_F(Shards, ARerunShardIsTheSameBytesAndTimedShardsAreSummed) {
    ASSERT_EQ(run_amhv(fmt::format("sweep {} --shard 2/3 --no-timings --out {}", q(scene()), q(path("again_2")))).exit_code, 0);
    expect_same_folder(shard(2), path("again_2"));
    // A rerun into the same folder replaces it with the same bytes.
    ASSERT_EQ(run_amhv(fmt::format("sweep {} --shard 2/3 --no-timings --out {}", q(scene()), q(path("again_2")))).exit_code, 0);
    expect_same_folder(shard(2), path("again_2"));

    for (int k = 1; k <= 3; ++k)
        ASSERT_EQ(run_amhv(fmt::format("sweep {} --shard {}/3 --out {}", q(scene()), k, q(path(fmt::format("timed_{}", k))))).exit_code, 0);
    const auto r = run_amhv(fmt::format("merge {} {} {} --out {}", q(path("timed_1")), q(path("timed_2")), q(path("timed_3")), q(path("timed"))));
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const auto json = nlohmann::json::parse(read_text(path("timed/result.json")));
    const auto& shards = json["timings_s"]["shards"];
    ASSERT_EQ(shards["count"], 3);
    double sum = 0;
    for (int k = 1; k <= 3; ++k) {
        const auto manifest = nlohmann::json::parse(read_text(path(fmt::format("timed_{}/shard.json", k))));
        EXPECT_GT(manifest["timings_s"]["peak_memory_mb"].get<double>(), 10.0);
        EXPECT_EQ(shards["per_shard"][std::size_t(k - 1)]["total"], manifest["timings_s"]["total"]);
        sum += manifest["timings_s"]["total"].get<double>();
    }
    EXPECT_DOUBLE_EQ(shards["seconds"].get<double>(), sum);
}

TEST_F(Shards, MergeTakesTheSceneWhereThisMachineMountsIt) {
    // A project folder (scene and takes, relative paths) swept in shards, then merged where it was
    // copied to: the same scene, found by --scene.
    const fs::path project = path("project"), moved = path("moved");
    fs::create_directories(project);
    for (const char* take : {"18_01.bvh", "19_01.bvh"}) fs::copy_file(test::source_dir() / "data/cmu" / take, project / take);
    std::string text = two_segment_scene();
    const std::string cmu = (test::source_dir() / "data/cmu/").string();
    for (std::size_t at = text.find(cmu); at != std::string::npos; at = text.find(cmu)) text.erase(at, cmu.size());
    std::ofstream(project / "scene.toml") << text;
    std::string folders;
    for (int k = 1; k <= 3; ++k) {
        const fs::path folder = path(fmt::format("project_shard_{}", k));
        ASSERT_EQ(run_amhv(fmt::format("sweep {} --shard {}/3 --no-timings --out {}", q(project / "scene.toml"), k, q(folder))).exit_code, 0);
        folders += q(folder) + " ";
    }
    fs::copy(project, moved, fs::copy_options::recursive);
    const auto r = run_amhv(fmt::format("merge {} --scene {} --out {} --no-timings --csv", folders, q(moved / "scene.toml"), q(path("merged_moved"))));
    ASSERT_EQ(r.exit_code, 0) << r.output;
    ASSERT_EQ(run_amhv(fmt::format("merge {} --out {} --no-timings --csv", folders, q(path("merged_project")))).exit_code, 0);
    for (const char* file : {"segment_1/solutions.csv", "segment_2/solutions.csv"})
        EXPECT_TRUE(read_text(path("one") / file) == read_text(path("merged_moved") / file)) << file;
    for (const char* file : {"segment_1/group.vdb", "segment_2/group.vdb"})  // they name the scene by its hash
        EXPECT_TRUE(read_text(path("merged_project") / file) == read_text(path("merged_moved") / file)) << file;
    // Another scene there is refused.
    std::ofstream(moved / "scene.toml", std::ios::app) << "\n[weights]\nlambda = 3.0\n";
    const auto refused = run_amhv(fmt::format("merge {} --scene {} --out {}", folders, q(moved / "scene.toml"), q(path("refused"))));
    EXPECT_EQ(test::one_line_error(refused), 1) << refused.output;
    EXPECT_NE(refused.output.find("has changed since the shards were swept"), std::string::npos) << refused.output;
    EXPECT_FALSE(fs::exists(path("refused")));
}

TEST_F(Shards, SlurmArrayVariablesNameTheShard) {
    // An array counted from 4: task 5 is shard 2.
    const auto r = test::run_shell(fmt::format("SLURM_ARRAY_TASK_ID=5 SLURM_ARRAY_TASK_MIN=4 SLURM_ARRAY_TASK_COUNT=3 {} sweep {} --shard --no-timings --out {}",
                                               test::amhv_command(), q(scene()), q(path("from_slurm"))));
    ASSERT_EQ(r.exit_code, 0) << r.output;
    expect_same_folder(shard(2), path("from_slurm"));
    const std::string out = q(path("refused"));
    for (const std::string& bad : {std::string("env -u SLURM_ARRAY_TASK_ID -u SLURM_ARRAY_TASK_COUNT ") + test::amhv_command() + " sweep " + q(scene()) + " --shard --out " + out,
                                   test::amhv_command() + " sweep " + q(scene()) + " --shard 4/3 --out " + out,
                                   test::amhv_command() + " sweep " + q(scene()) + " --shard 0/3 --out " + out,
                                   test::amhv_command() + " sweep " + q(scene()) + " --shard three --out " + out,
                                   test::amhv_command() + " sweep " + q(scene()) + " --shard 1/100 --out " + out,
                                   test::amhv_command() + " sweep " + q(scene()) + " --shard 1/3 --csv --out " + out}) {
        const auto refused = test::run_shell(bad);
        EXPECT_NE(refused.exit_code, 0) << bad;
        EXPECT_EQ(test::one_line_error(refused), 1) << refused.output;
        EXPECT_FALSE(fs::exists(path("refused"))) << bad;
    }
}

// One bad shard set: how to make it, and what the error line must name.
struct BadShards {
    const char* name;
    std::string (*prepare)(const fs::path& dir);  // copies of the good shards changed; returns the merge's folders
    const char* says;
};

void copy_shards(const fs::path& from, const fs::path& dir) {
    for (int k = 1; k <= 3; ++k) fs::copy(from / fmt::format("shard_{}", k), dir / fmt::format("s{}", k), fs::copy_options::recursive);
}
std::string three(const fs::path& dir) { return q(dir / "s1") + " " + q(dir / "s2") + " " + q(dir / "s3"); }
fs::path outcome_file(const fs::path& shard) {
    for (const auto& entry : fs::directory_iterator(shard))
        if (entry.path().extension() == ".outcomes") return entry.path();
    return {};
}
void flip_byte(const fs::path& file, std::size_t at) {
    std::string bytes = read_text(file);
    bytes[at] = char(bytes[at] ^ 0x5a);
    std::ofstream(file, std::ios::binary) << bytes;
}

// Shards s1..s3 of `scene` (written to d/own.toml), in place of the copies.
void sweep_own_shards(const fs::path& d, const std::string& scene) {
    std::ofstream(d / "own.toml") << scene;
    for (int k = 1; k <= 3; ++k) {
        fs::remove_all(d / fmt::format("s{}", k));
        run_amhv(fmt::format("sweep {} --shard {}/3 --no-timings --out {}", q(d / "own.toml"), k, q(d / fmt::format("s{}", k))));
    }
}

class ShardsRefused : public Shards, public ::testing::WithParamInterface<BadShards> {};

TEST_P(ShardsRefused, OneLineNamingTheProblemAndNoOutput) {
    test::TempDir tmp;
    copy_shards(dir_->path(), tmp.path());
    const std::string folders = GetParam().prepare(tmp.path());
    const auto r = run_amhv(fmt::format("merge {} --out {}", folders, q(tmp.path() / "merged")));
    EXPECT_NE(r.exit_code, 0);
    EXPECT_EQ(test::one_line_error(r), 1) << r.output;
    EXPECT_NE(r.output.find(GetParam().says), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(tmp.path() / "merged"));
}

INSTANTIATE_TEST_SUITE_P(
    Cases, ShardsRefused,
    ::testing::Values(
        BadShards{"missing", [](const fs::path& d) { return q(d / "s1") + " " + q(d / "s3"); }, "shard 2 of 3 is missing"},
        BadShards{"duplicate", [](const fs::path& d) { return three(d) + " " + q(d / "s2"); }, "is shard 2 of 3 again"},
        BadShards{"not_a_shard", [](const fs::path& d) { return three(d) + " " + q(d); }, "is not a shard folder"},
        BadShards{"other_scene",
                  [](const fs::path& d) {
                      std::ofstream(d / "other.toml") << two_segment_scene() + "\n[weights]\nlambda = 2.0\n";
                      fs::remove_all(d / "s3");
                      run_amhv(fmt::format("sweep {} --shard 3/3 --no-timings --out {}", q(d / "other.toml"), q(d / "s3")));
                      return three(d);
                  },
                  "merge the shards of one scene"},
        BadShards{"other_plan",
                  [](const fs::path& d) {
                      const auto manifest = nlohmann::json::parse(read_text(d / "s1/shard.json"));
                      fs::remove_all(d / "s2");
                      run_amhv(fmt::format("sweep {} --shard 2/4 --no-timings --out {}", q(manifest["scene"].get<std::string>()), q(d / "s2")));
                      return three(d);
                  },
                  "merge the shards of one plan"},
        BadShards{"other_version",
                  [](const fs::path& d) {
                      test::replace_in_file(d / "s2/shard.json", "\"program\": \"amhv ", "\"program\": \"amhv 0.0.1-old ");
                      return three(d);
                  },
                  "was written by amhv 0.0.1-old"},
        BadShards{"corrupt_outcomes", [](const fs::path& d) { flip_byte(outcome_file(d / "s1"), 40); return three(d); }, "the file is damaged"},
        BadShards{"truncated_outcomes",
                  [](const fs::path& d) {
                      const fs::path f = outcome_file(d / "s3");
                      fs::resize_file(f, fs::file_size(f) / 2);
                      return three(d);
                  },
                  "the file is damaged"},
        BadShards{"missing_outcomes", [](const fs::path& d) { fs::remove(outcome_file(d / "s2")); return three(d); }, "is missing: the shard is not whole"},
        BadShards{"garbled_manifest",
                  [](const fs::path& d) {
                      std::ofstream(d / "s2/shard.json") << "{\"kind\": \"amhv sweep shard\", \"program\": ";
                      return three(d);
                  },
                  "is not valid JSON"},
        BadShards{"scene_changed_since",
                  [](const fs::path& d) {
                      sweep_own_shards(d, two_segment_scene());
                      std::ofstream(d / "own.toml", std::ios::app) << "\n[truth]\nx = 0.0\ny = 0.0\nyaw_deg = 0.0\n";
                      return three(d);
                  },
                  "has changed since the shards were swept"},
        BadShards{"take_changed_since",
                  [](const fs::path& d) {
                      fs::copy(test::source_dir() / "data/cmu/19_01.bvh", d / "19_01.bvh");
                      std::string scene = two_segment_scene();
                      const std::string take = (test::source_dir() / "data/cmu/19_01.bvh").string();
                      scene.replace(scene.find(take), take.size(), (d / "19_01.bvh").string());
                      sweep_own_shards(d, scene);
                      std::ofstream(d / "19_01.bvh", std::ios::app) << "\n";
                      return three(d);
                  },
                  "input files (takes, meshes, labels, tracks) have changed"}),
    [](const ::testing::TestParamInfo<BadShards>& param) { return std::string(param.param.name); });

}  // namespace
}  // namespace amhv
