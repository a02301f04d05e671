// Output folders never lose a user's files (docs/scenes.md, "Output folders"): unsafe targets are
// refused before anything is written, a replaced output is swapped in atomically (a kill -9 at any
// moment leaves the old output or the new one, whole), two runs into one folder do not both
// write, and a failed write (a full disk, a file size limit) is an error with no output left.
#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <thread>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "src/body/shapes.hpp"
#include "src/io/output_dir.hpp"
#include "support.hpp"

namespace amhv {
namespace {

namespace fs = std::filesystem;

// A ball over `frames` frames as OBJ files (centimetres, y up), and the mhv arguments reading them.
std::string ball_sequence(const fs::path& folder, int frames = 6) {
    fs::create_directories(folder);
    for (int f = 0; f < frames; ++f)
        test::write_obj(folder / fmt::format("frame_{:04d}.obj", f), shapes::sphere(Vec3(2.0 * f, 30.0, 0.0), 15.0, 16, 24));
    return fmt::format("mhv --meshes '{}/frame_%04d.obj' --unit cm --up y --backend cpu", folder.string());
}

void write_user_file(const fs::path& path, const std::string& text) {
    fs::create_directories(path.parent_path());
    std::ofstream(path) << text;
}

TEST(Output, RefusesTheWorkingFolderAndItsParents) {
    test::TempDir tmp;
    const std::string mhv = ball_sequence(tmp.path() / "ball");
    write_user_file(tmp.path() / "work" / "notes.txt", "mine");
    for (const char* out : {".", "..", "./"}) {
        auto result = test::run_shell(fmt::format("cd '{}' && {} {} --out {}", (tmp.path() / "work").string(), test::amhv_command(), mhv, out));
        EXPECT_EQ(result.exit_code, 1) << result.output;
        EXPECT_EQ(test::one_line_error(result), 1) << result.output;
        EXPECT_NE(result.output.find("working folder"), std::string::npos) << result.output;
    }
    EXPECT_EQ(test::read_text(tmp.path() / "work" / "notes.txt"), "mine");
    EXPECT_TRUE(fs::exists(tmp.path() / "ball" / "frame_0000.obj"));
}

TEST(Output, RefusesAnOutputThatIsOrHoldsAnInput) {
    test::TempDir tmp;
    const std::string mhv = ball_sequence(tmp.path() / "data" / "ball");
    for (const fs::path& out : {tmp.path() / "data" / "ball", tmp.path() / "data"}) {
        auto result = test::run_amhv(fmt::format("{} --out '{}'", mhv, out.string()));
        EXPECT_EQ(result.exit_code, 1) << result.output;
        EXPECT_NE(result.output.find("is or contains the input"), std::string::npos) << result.output;
    }
    EXPECT_EQ(std::distance(fs::directory_iterator(tmp.path() / "data" / "ball"), fs::directory_iterator()), 6);

    // A scene's own folder, and edit --from-sweep X --out X.
    const fs::path scenes = tmp.path() / "scenes";
    fs::create_directories(scenes);
    fs::copy(test::source_dir() / "data" / "scenes" / "demo.toml", scenes / "demo.toml");
    fs::copy(test::source_dir() / "data" / "cmu", tmp.path() / "cmu");
    auto sweep = test::run_amhv(fmt::format("sweep '{}' --out '{}'", (scenes / "demo.toml").string(), scenes.string()));
    EXPECT_EQ(sweep.exit_code, 1) << sweep.output;
    EXPECT_NE(sweep.output.find("is or contains the input"), std::string::npos) << sweep.output;
    auto bvh = test::run_amhv(fmt::format("sweep '{}' --out '{}'", (scenes / "demo.toml").string(), (tmp.path() / "cmu").string()));
    EXPECT_NE(bvh.output.find("is or contains the input"), std::string::npos) << bvh.output;
    write_user_file(tmp.path() / "sweep" / "result.json", "{\"program\": \"amhv 0.1.0\"}");
    auto edit = test::run_amhv(fmt::format("edit '{}' --from-sweep '{}' --out '{}'", (scenes / "demo.toml").string(),
                                           (tmp.path() / "sweep").string(), (tmp.path() / "sweep").string()));
    EXPECT_EQ(edit.exit_code, 1) << edit.output;
    EXPECT_NE(edit.output.find("is or contains the input"), std::string::npos) << edit.output;
    EXPECT_TRUE(fs::exists(scenes / "demo.toml"));
    EXPECT_TRUE(fs::exists(tmp.path() / "sweep" / "result.json"));
}

TEST(Output, NeverReplacesAFolderAmhvDidNotWrite) {
    test::TempDir tmp;
    const std::string mhv = ball_sequence(tmp.path() / "ball");
    write_user_file(tmp.path() / "photos" / "holiday.jpg", "not ours");
    auto refused = test::run_amhv(fmt::format("{} --out '{}'", mhv, (tmp.path() / "photos").string()));
    EXPECT_EQ(refused.exit_code, 1) << refused.output;
    EXPECT_EQ(test::one_line_error(refused), 1) << refused.output;
    EXPECT_NE(refused.output.find("did not write"), std::string::npos) << refused.output;
    EXPECT_EQ(test::read_text(tmp.path() / "photos" / "holiday.jpg"), "not ours");

    // A file is no folder; an empty folder and amhv's own output are fine.
    write_user_file(tmp.path() / "file.txt", "x");
    EXPECT_EQ(test::run_amhv(fmt::format("{} --out '{}'", mhv, (tmp.path() / "file.txt").string())).exit_code, 1);
    fs::create_directories(tmp.path() / "empty");
    EXPECT_EQ(test::run_amhv(fmt::format("{} --out '{}'", mhv, (tmp.path() / "empty").string())).exit_code, 0);
    auto again = test::run_amhv(fmt::format("{} --voxel 0.03 --out '{}'", mhv, (tmp.path() / "empty").string()));
    EXPECT_EQ(again.exit_code, 0) << again.output;
    EXPECT_TRUE(fs::exists(tmp.path() / "empty" / StagedOutput::kMarker));
    EXPECT_EQ(nlohmann::json::parse(test::read_text(tmp.path() / "empty" / "mhv.json"))["voxel_size_m"], 0.03);
}

TEST(Output, ASecondRunIntoTheSameFolderIsRefusedWhileTheFirstWrites) {
    test::TempDir tmp;
    const std::string mhv = ball_sequence(tmp.path() / "ball");
    const fs::path out = tmp.path() / "out";
    // This test holds the lock as a running amhv would.
    const int fd = ::open((tmp.path() / ".out.lock").c_str(), O_RDWR | O_CREAT, 0644);
    ASSERT_GE(fd, 0);
    ASSERT_EQ(::flock(fd, LOCK_EX | LOCK_NB), 0);
    ASSERT_EQ(::write(fd, "4242", 4), 4);
    auto result = test::run_amhv(fmt::format("{} --out '{}'", mhv, out.string()));
    EXPECT_EQ(result.exit_code, 1) << result.output;
    EXPECT_NE(result.output.find("another amhv run (pid 4242)"), std::string::npos) << result.output;
    EXPECT_FALSE(fs::exists(out));
    ::close(fd);
    // Released: the next run writes, and removes the staging folder a dead run left (its name and
    // its marker carry the same run, whose process is gone), and nothing that merely looks like one.
    const std::string dead = "999999-0123456789abcdef";
    write_user_file(tmp.path() / (".out.partial-" + dead) / StagedOutput::kMarker, "{\"amhv_output\": 2, \"staging\": \"" + dead + "\"}\n");
    write_user_file(tmp.path() / (".out.partial-" + dead) / "half.json", "{");
    write_user_file(tmp.path() / ".out.partial-999998-0123456789abcdef" / "mine.txt", "a user's folder with a staging name");
    write_user_file(tmp.path() / ".out.partial-anything" / "mine.txt", "a user's folder");
    const std::string alive = fmt::format("{}-0123456789abcdef", ::getpid());  // this test is alive
    write_user_file(tmp.path() / (".out.partial-" + alive) / StagedOutput::kMarker, "{\"amhv_output\": 2, \"staging\": \"" + alive + "\"}\n");
    fs::create_directories(tmp.path() / ".other.partial-999999");
    // A run killed before its marker was whole: an empty staging folder, or one holding only a
    // partial marker.
    fs::create_directories(tmp.path() / ".out.partial-999997-0123456789abcdef");
    write_user_file(tmp.path() / ".out.partial-999996-0123456789abcdef" / StagedOutput::kMarker, "{\"amhv_out");
    // Killed while writing a marker: markers are written under a temporary name and renamed, so the
    // folder holds its staging marker and the temporary file (never a partial marker among outputs).
    const std::string writing = "999995-0123456789abcdef";
    write_user_file(tmp.path() / (".out.partial-" + writing) / StagedOutput::kMarker, "{\"amhv_output\": 2, \"staging\": \"" + writing + "\"}\n");
    write_user_file(tmp.path() / (".out.partial-" + writing) / "mhv.json", "{}");
    write_user_file(tmp.path() / (".out.partial-" + writing) / (std::string(StagedOutput::kMarker) + ".writing"), "{\"amhv_output\": 2, \"fol");
    write_user_file(tmp.path() / ".out.partial-999994-0123456789abcdef" / (std::string(StagedOutput::kMarker) + ".writing"), "{\"amh");
    // Killed while removing an old output it had swapped out: its marker goes last, so what is
    // left is a subset of what the marker lists.
    const std::string swapped = ".out.partial-999993-0123456789abcdef";
    write_user_file(tmp.path() / swapped / StagedOutput::kMarker,
                    "{\"amhv_output\": 2, \"folders\": [\"frames\"], \"files\": [[\"frames/a.json\", 2], [\"mhv.json\", 2]]}\n");
    write_user_file(tmp.path() / swapped / "frames" / "a.json", "{}");
    auto next = test::run_amhv(fmt::format("{} --out '{}'", mhv, out.string()));
    EXPECT_EQ(next.exit_code, 0) << next.output;
    EXPECT_FALSE(fs::exists(tmp.path() / (".out.partial-" + dead)));
    EXPECT_FALSE(fs::exists(tmp.path() / ".out.partial-999997-0123456789abcdef"));
    EXPECT_FALSE(fs::exists(tmp.path() / ".out.partial-999996-0123456789abcdef"));
    EXPECT_FALSE(fs::exists(tmp.path() / (".out.partial-" + writing)));
    EXPECT_FALSE(fs::exists(tmp.path() / ".out.partial-999994-0123456789abcdef"));
    EXPECT_FALSE(fs::exists(tmp.path() / swapped));
    EXPECT_TRUE(fs::exists(tmp.path() / ".out.partial-999998-0123456789abcdef" / "mine.txt"));
    EXPECT_TRUE(fs::exists(tmp.path() / ".out.partial-anything" / "mine.txt"));
    EXPECT_TRUE(fs::exists(tmp.path() / (".out.partial-" + alive)));
    EXPECT_TRUE(fs::exists(tmp.path() / ".other.partial-999999"));  // another target's: not ours to judge
    EXPECT_FALSE(fs::exists(tmp.path() / ".out.lock"));
    for (const char* left : {".out.partial-999998-0123456789abcdef", ".out.partial-anything"}) fs::remove_all(tmp.path() / left);
    fs::remove_all(tmp.path() / (".out.partial-" + alive));

    // Two real runs at once: each either writes a whole output or is refused; never both fail.
    std::string both = fmt::format("{0} {1} --out '{2}' > '{3}/first.log' 2>&1 & {0} {1} --voxel 0.03 --out '{2}' > '{3}/second.log' 2>&1; wait",
                                   test::amhv_command(), mhv, out.string(), tmp.path().string());
    test::run_shell(both);
    const std::string logs = test::read_text(tmp.path() / "first.log") + test::read_text(tmp.path() / "second.log");
    EXPECT_TRUE(fs::exists(out / "mhv.json")) << logs;
    EXPECT_EQ(logs.find("partial"), std::string::npos) << logs;
}

TEST(Output, AKillDuringTheReplacementLeavesTheOldOutputOrTheNewOneWhole) {
    test::TempDir tmp;
    const std::string mhv = ball_sequence(tmp.path() / "ball", 12);
    const fs::path out = tmp.path() / "out";
    ASSERT_EQ(test::run_amhv(fmt::format("{} --voxel 0.02 --out '{}'", mhv, out.string())).exit_code, 0);
    int old_seen = 0, new_seen = 0;
    for (int attempt = 0; attempt < 14; ++attempt) {
        // Killed after 0 .. 650 ms: before, during and after the swap.
        const std::string run = fmt::format("{} {} --voxel {} --out '{}' > /dev/null 2>&1 & pid=$!; sleep {}; kill -9 $pid 2>/dev/null; wait $pid",
                                            test::amhv_command(), mhv, attempt % 2 ? 0.02 : 0.025, out.string(), 0.05 * attempt);
        test::run_shell(run);
        ASSERT_TRUE(fs::exists(out / "mhv.json")) << "attempt " << attempt << ": no output at all";
        ASSERT_TRUE(fs::exists(out / "mhv.amhv")) << "attempt " << attempt;
        const auto json = nlohmann::json::parse(test::read_text(out / "mhv.json"));
        const double voxel = json["voxel_size_m"];
        (voxel == 0.025 ? new_seen : old_seen) += 1;
        EXPECT_TRUE(voxel == 0.02 || voxel == 0.025);
    }
    EXPECT_GT(old_seen + new_seen, 0);
    // Whatever the kills left beside it is cleaned by the next run.
    ASSERT_EQ(test::run_amhv(fmt::format("{} --out '{}'", mhv, out.string())).exit_code, 0);
    for (const auto& entry : fs::directory_iterator(tmp.path()))
        EXPECT_EQ(entry.path().filename().string().find(".out."), std::string::npos) << entry.path();
}

TEST(Output, AFailedWriteIsAnErrorAndLeavesNoOutput) {
    test::TempDir tmp;
    const std::string mhv = ball_sequence(tmp.path() / "ball");
    const fs::path out = tmp.path() / "out";
    // ulimit -f: at most 16 blocks of 512 bytes per file, far less than the volume file needs.
    auto result = test::run_shell(fmt::format("ulimit -f 16; {} {} --voxel 0.005 --no-exr --out '{}'", test::amhv_command(), mhv, out.string()));
    EXPECT_EQ(result.exit_code, 1) << result.output;
    EXPECT_EQ(test::one_line_error(result), 1) << result.output;
    EXPECT_NE(result.output.find("could not be written in full"), std::string::npos) << result.output;
    EXPECT_FALSE(fs::exists(out));
    for (const auto& entry : fs::directory_iterator(tmp.path())) EXPECT_EQ(entry.path().filename().string().find(".out."), std::string::npos);
}

TEST(Output, IsWithinComparesWholeComponents) {
    EXPECT_TRUE(is_within("/a/b/c", "/a/b"));
    EXPECT_TRUE(is_within("/a/b", "/a/b"));
    EXPECT_TRUE(is_within("/a/b/", "/a/b"));
    EXPECT_FALSE(is_within("/a/bc", "/a/b"));
    EXPECT_FALSE(is_within("/a", "/a/b"));
}

}  // namespace
}  // namespace amhv
