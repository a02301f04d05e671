// Attacks and careless use (docs/scenes.md, "What amhv refuses"): the page server serves only its
// folder's own files and survives any request and any client; no file an input names outside what
// the user gave is read or copied; no output folder, lock or staging name can make amhv delete or
// overwrite what it did not create; crafted groups, takes and meshes are refused before they cost
// anything; a run that is interrupted leaves nothing behind.
#include <bit>
#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <fstream>
#include <random>
#include <thread>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <openvdb/openvdb.h>

#include "src/body/shapes.hpp"
#include "src/core/error.hpp"
#include "src/io/mesh_precheck.hpp"
#include "src/io/mesh_sequence.hpp"
#include "src/io/output_dir.hpp"
#include "src/pipeline/page_server.hpp"
#include "src/results/group_vdb.hpp"
#include "src/sweep/solution_group.hpp"
#include "support.hpp"

namespace amhv {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

void write_obj_in(const fs::path& path, const TriangleMesh& mesh) {
    fs::create_directories(path.parent_path());
    test::write_obj(path, mesh);
}

void write_text(const fs::path& path, const std::string& text) {
    fs::create_directories(path.parent_path());
    std::ofstream(path, std::ios::binary) << text;
}

// A folder with a page, a subfolder, amhv's hidden marker, a FIFO, a link out to a secret beside
// the folder and a link to a folder outside.
struct PageFolder {
    test::TempDir tmp;
    fs::path dir = tmp.path() / "page";
    PageFolder() {
        write_text(dir / "index.html", "<html>page</html>");
        write_text(dir / "view" / "data.js", "window.X = 1;");
        write_text(dir / ".amhv-output", "{}");
        write_text(tmp.path() / "secret.txt", "the secret");
        write_text(tmp.path() / "outside" / "also.txt", "the secret too");
        fs::create_symlink("../secret.txt", dir / "link.txt");
        fs::create_symlink(tmp.path() / "outside", dir / "view" / "out");
        ::mkfifo((dir / "fifo").c_str(), 0600);
    }
};

TEST(Security, TheServerAnswersOnlyWithTheFoldersOwnFiles) {
    PageFolder page;
    const pipeline::ServedFolder folder(page.dir);
    auto get = [&](const std::string& path, const std::string& host = "127.0.0.1:8123", const std::string& method = "GET") {
        return pipeline::answer_request(folder, method, path, host, 8123);
    };
    EXPECT_EQ(get("/").body, "<html>page</html>");
    EXPECT_EQ(get("/view/data.js").status, 200);
    EXPECT_EQ(get("/view/data.js").content_type, "text/javascript; charset=utf-8");
    EXPECT_EQ(get("/index.html", "", "HEAD").status, 200);
    const std::string secret = (page.tmp.path() / "secret.txt").string();
    for (const std::string& path : std::vector<std::string>{"//" + secret.substr(1), "/" + secret, "//etc/passwd", "/../secret.txt", "/view/../index.html", "/./index.html",
                                    "/link.txt", "/view/out/also.txt", "/.amhv-output", "/fifo", "/view", "", "?a", "index.html", "/view//data.js",
                                    "/view\\data.js", std::string("/index.html\0x", 13), "/" + std::string(2000, 'a')}) {
        const Clock::time_point start = Clock::now();
        const pipeline::ServeAnswer answer = get(path);
        EXPECT_EQ(answer.status, 404) << path;
        EXPECT_EQ(answer.body.find("secret"), std::string::npos) << path;
        EXPECT_LT(Clock::now() - start, std::chrono::seconds(1)) << path;  // the FIFO is never waited on
    }
    for (const std::string& method : std::vector<std::string>{"POST", "PUT", "DELETE", "OPTIONS", "PATCH", "CONNECT", ""}) EXPECT_EQ(get("/", "127.0.0.1", method).status, 405) << method;
    for (const std::string& host : std::vector<std::string>{"localhost", "LOCALHOST:8123", "127.0.0.1", "[::1]:8123", ""}) EXPECT_EQ(get("/", host).status, 200) << host;
    for (const std::string& host : std::vector<std::string>{"evil.example", "evil.example:8123", "127.0.0.1:9999", "127.0.0.1.evil.example", "localhost.", "0.0.0.0"})
        EXPECT_EQ(get("/", host).status, 403) << host;
}

// One request on a fresh connection to 127.0.0.1:`port`; the answer, or "" when none came within
// `seconds`.
std::string exchange(int port, const std::string& request, int seconds = 5) {
    const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_port = htons(std::uint16_t(port));
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    timeval timeout{seconds, 0};
    ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof(timeout));
    std::string answer;
    if (::connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof(address)) == 0) {
        for (std::size_t sent = 0; sent < request.size();) {
            const ssize_t n = ::send(fd, request.data() + sent, request.size() - sent, MSG_NOSIGNAL);
            if (n <= 0) break;
            sent += std::size_t(n);
        }
        char buffer[4096];
        for (ssize_t n; (n = ::recv(fd, buffer, sizeof(buffer), 0)) > 0;) answer.append(buffer, std::size_t(n));
    }
    ::close(fd);
    return answer;
}

// A connection that sends nothing, held open until the object goes.
struct StalledClient {
    int fd = ::socket(AF_INET, SOCK_STREAM, 0);
    explicit StalledClient(int port) {
        sockaddr_in address{};
        address.sin_family = AF_INET;
        address.sin_port = htons(std::uint16_t(port));
        address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
        ::connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof(address));
    }
    ~StalledClient() { ::close(fd); }
};

TEST(Security, TheServerSurvivesHostileRequestsAndStalledClients) {
    PageFolder page;
    const int port = 20000 + int(std::random_device()() % 30000);
    std::thread([dir = page.dir, port] {
        try {
            pipeline::serve_folder(dir, port);
        } catch (...) {
        }
    }).detach();  // the test's process ends with it
    std::string first;
    for (int attempt = 0; attempt < 50 && first.empty(); ++attempt) {
        std::this_thread::sleep_for(std::chrono::milliseconds(100));
        first = exchange(port, "GET / HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n");
    }
    ASSERT_NE(first.find("200 OK"), std::string::npos) << first;
    const std::string ok = "GET / HTTP/1.1\r\nHost: localhost\r\nConnection: close\r\n\r\n";
    std::vector<std::unique_ptr<StalledClient>> stalled;
    for (int c = 0; c < 4; ++c) stalled.push_back(std::make_unique<StalledClient>(port));
    const std::string secret = (page.tmp.path() / "secret.txt").string();
    const std::vector<std::string> hostile{
        "GET ?a HTTP/1.1\r\n\r\n", "GET  HTTP/1.1\r\n\r\n", "GET //proc/self/mem HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n",
        "GET /" + secret + " HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n", "GET /%2e%2e/secret.txt HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n",
        "GET /link.txt HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n", "GET / HTTP/1.1\r\nHost: evil.example\r\n\r\n",
        "DELETE / HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n", "\x01\x02\x03\r\n\r\n",
        "GET / HTTP/1.1\r\nHost: 127.0.0.1\r\nX: " + std::string(1 << 20, 'a') + "\r\n\r\n", "GET /fifo HTTP/1.1\r\n\r\n"};
    // All at once, beside the stalled clients: each is answered without the secret, or dropped.
    std::vector<std::string> answers(hostile.size());
    std::vector<std::thread> clients;
    for (std::size_t h = 0; h < hostile.size(); ++h) clients.emplace_back([&, h] { answers[h] = exchange(port, hostile[h]); });
    for (auto& c : clients) c.join();
    for (std::size_t h = 0; h < hostile.size(); ++h) {
        EXPECT_EQ(answers[h].find("the secret"), std::string::npos) << hostile[h].substr(0, 60);
        EXPECT_EQ(answers[h].find(" 200 "), std::string::npos) << hostile[h].substr(0, 60) << " -> " << answers[h].substr(0, 80);
    }
    // The server is still there, and answers the next client at once despite the stalled ones.
    const Clock::time_point start = Clock::now();
    EXPECT_NE(exchange(port, ok).find("<html>page</html>"), std::string::npos);
    EXPECT_LT(Clock::now() - start, std::chrono::seconds(2));
    EXPECT_NE(answers[6].find("403"), std::string::npos) << answers[6];
    EXPECT_NE(answers[7].find("405"), std::string::npos) << answers[7];
}

// A ball frame with a material library whose lines name files outside the frames' folder.
TEST(Security, FilesAMaterialNamesOutsideItsFolderAreNeitherReadNorCopied) {
    test::TempDir tmp;
    const fs::path d = tmp.path();
    write_text(d / "secret.txt", "the secret");
    std::ostringstream ball;
    const TriangleMesh mesh = shapes::sphere(Vec3(0, 0, 0.3), 0.2, 12, 16);
    for (const Vec3& v : mesh.vertices) ball << fmt::format("v {} {} {}\n", v.x(), v.y(), v.z());
    for (const auto& t : mesh.triangles) ball << fmt::format("f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1);
    for (const std::string& reference : std::vector<std::string>{(d / "secret.txt").string(), std::string("../secret.txt"), std::string("../../x"), std::string("link.png")}) {
        fs::remove_all(d / "m");
        write_text(d / "m" / "f_0000.obj", "mtllib a.mtl\nusemtl skin\n" + ball.str());
        write_text(d / "m" / "f_0001.obj", "mtllib a.mtl\nusemtl skin\n" + ball.str());
        write_text(d / "m" / "a.mtl", "newmtl skin\nKd 1 0 0\nmap_Ks " + reference + "\n");
        fs::create_symlink(d / "secret.txt", d / "m" / "link.png");
        auto run = test::run_amhv(fmt::format("mhv --meshes '{0}/m/f_%04d.obj' --out '{0}/o' --backend cpu", d.string()));
        EXPECT_EQ(run.exit_code, 1) << reference << ": " << run.output;
        EXPECT_EQ(test::one_line_error(run), 1) << run.output;
        EXPECT_NE(run.output.find("a.mtl:3: file '"), std::string::npos) << run.output;
        EXPECT_FALSE(fs::exists(d / "o"));
    }
    // An mtllib out of the folder, likewise.
    write_text(d / "m" / "f_0000.obj", "mtllib ../secret.txt\n" + ball.str());
    auto run = test::run_amhv(fmt::format("mhv --meshes '{0}/m/f_%04d.obj' --out '{0}/o' --backend cpu", d.string()));
    EXPECT_NE(run.output.find("f_0000.obj:1: material library '../secret.txt' lies outside"), std::string::npos) << run.output;
}

// The shipped handshake with its first and last transitions one frame long: the path of a single
// frame is fixed by its one end (it crashed in the sparse QR of an empty system).
TEST(Security, OneFrameTransitionsAreSolved) {
    test::TempDir tmp;
    std::string scene = test::read_text(test::source_dir() / "data/scenes/handshake.toml");
    for (const std::string& cmu : std::vector<std::string>{"18_01.bvh", "19_01.bvh"}) {
        const std::size_t at = scene.find("\"../cmu/" + cmu + "\"");
        ASSERT_NE(at, std::string::npos);
        scene.replace(at, cmu.size() + 10, fmt::format("'{}'\nframes = [107, 148]", (test::source_dir() / "data/cmu" / cmu).string()));
    }
    scene.replace(scene.find("voxel = 0.01"), 12, "voxel = 0.04");
    scene.replace(scene.find("angle_step_deg = 2.0"), 20, "angle_step_deg = 10.0");
    write_text(tmp.path() / "scene.toml", scene);
    auto run = test::run_amhv(fmt::format("edit '{0}/scene.toml' --out '{0}/e' --no-page --no-glb --no-frames --backend cpu", tmp.path().string()));
    EXPECT_EQ(run.exit_code, 0) << run.output;
    EXPECT_TRUE(fs::exists(tmp.path() / "e" / "transforms.json"));
    for (const auto& entry : fs::directory_iterator(tmp.path())) EXPECT_EQ(entry.path().filename().string().rfind(".e.", 0), std::string::npos) << entry.path();
}

TEST(Security, TheLockNeverFollowsALinkNorTouchesAnotherFile) {
    test::TempDir tmp;
    const fs::path d = tmp.path();
    write_text(d / "victim.txt", "keep me");
    write_obj_in(d / "m" / "f_0000.obj", shapes::sphere(Vec3(0, 0, 0.3), 0.2, 8, 12));
    write_obj_in(d / "m" / "f_0001.obj", shapes::sphere(Vec3(0, 0, 0.3), 0.2, 8, 12));
    const std::string mhv = fmt::format("mhv --meshes '{0}/m/f_%04d.obj' --backend cpu --out '{0}/t'", d.string());
    fs::create_symlink(d / "victim.txt", d / ".t.lock");
    auto linked = test::run_amhv(mhv);
    EXPECT_EQ(linked.exit_code, 1) << linked.output;
    EXPECT_NE(linked.output.find(".t.lock"), std::string::npos) << linked.output;
    EXPECT_EQ(test::read_text(d / "victim.txt"), "keep me");
    EXPECT_TRUE(fs::is_symlink(d / ".t.lock"));
    fs::remove(d / ".t.lock");
    fs::create_hard_link(d / "victim.txt", d / ".t.lock");
    auto hard = test::run_amhv(mhv);
    EXPECT_EQ(hard.exit_code, 1) << hard.output;
    EXPECT_EQ(test::read_text(d / "victim.txt"), "keep me");
    fs::remove(d / ".t.lock");
    EXPECT_EQ(test::run_amhv(mhv).exit_code, 0);
    EXPECT_FALSE(fs::exists(fs::symlink_status(d / ".t.lock")));
}

TEST(Security, OnlyAFolderAmhvWroteAndNothingElseIsReplaced) {
    test::TempDir tmp;
    const fs::path d = tmp.path();
    write_obj_in(d / "m" / "f_0000.obj", shapes::sphere(Vec3(0, 0, 0.3), 0.2, 8, 12));
    write_obj_in(d / "m" / "f_0001.obj", shapes::sphere(Vec3(0, 0, 0.3), 0.2, 8, 12));
    auto mhv = [&](const std::string& out) { return test::run_amhv(fmt::format("mhv --meshes '{0}/m/f_%04d.obj' --backend cpu --out '{1}'", d.string(), out)); };
    // A user folder holding a report copied from amhv (or any JSON that starts like one).
    write_text(d / "keep" / "result.json", "{\"program\": \"amhv 0.4.0\", \"segments\": []}\n");
    write_text(d / "keep" / "photo.jpg", "mine");
    EXPECT_EQ(mhv((d / "keep").string()).exit_code, 1);
    EXPECT_EQ(test::read_text(d / "keep" / "photo.jpg"), "mine");
    // A real output's marker copied into a user folder does not make it amhv's: the marker lists
    // what the run wrote, and photo.jpg is not on the list.
    ASSERT_EQ(mhv((d / "real").string()).exit_code, 0);
    fs::copy_file(d / "real" / StagedOutput::kMarker, d / "keep" / StagedOutput::kMarker);
    auto copied = mhv((d / "keep").string());
    EXPECT_EQ(copied.exit_code, 1);
    EXPECT_NE(copied.output.find("holds files that amhv did not write"), std::string::npos) << copied.output;
    EXPECT_EQ(test::read_text(d / "keep" / "photo.jpg"), "mine");
    // A file added to amhv's own output, likewise; and a user folder named like a staging folder
    // beside the target is left alone.
    write_text(d / "real" / "notes.txt", "my notes");
    EXPECT_EQ(mhv((d / "real").string()).exit_code, 1);
    EXPECT_EQ(test::read_text(d / "real" / "notes.txt"), "my notes");
    fs::remove(d / "real" / "notes.txt");
    write_text(d / ".real.partial-anything" / "mine.txt", "mine");
    EXPECT_EQ(mhv((d / "real").string()).exit_code, 0);
    EXPECT_EQ(test::read_text(d / ".real.partial-anything" / "mine.txt"), "mine");
    // A FIFO in the output's place of a report is never opened (a read would hang the run).
    ::mkfifo((d / "real" / "result.json").c_str(), 0600);
    const Clock::time_point start = Clock::now();
    EXPECT_EQ(mhv((d / "real").string()).exit_code, 1);
    EXPECT_LT(Clock::now() - start, std::chrono::seconds(20));
    // A dangling link as --out is refused before any work.
    fs::create_symlink(d / "nowhere", d / "dangling");
    auto dangling = mhv((d / "dangling").string());
    EXPECT_EQ(dangling.exit_code, 1);
    EXPECT_NE(dangling.output.find("is a symbolic link"), std::string::npos) << dangling.output;
    EXPECT_FALSE(fs::exists(d / "nowhere"));
}

// A group.vdb written as amhv writes one, with the given active voxels and tiles.
void write_crafted_group(const fs::path& dir, const std::function<void(openvdb::BoolGrid&)>& fill, int angles, double voxel) {
    openvdb::initialize();
    fs::create_directories(dir / "segment_1");
    auto grid = openvdb::BoolGrid::create(false);
    grid->setName("solutions");
    grid->insertMeta("voxel_m", openvdb::DoubleMetadata(voxel));
    grid->insertMeta("angle_step_deg", openvdb::DoubleMetadata(360.0 / angles));
    grid->insertMeta("angles", openvdb::Int32Metadata(angles));
    grid->insertMeta("segment", openvdb::Int32Metadata(1));
    grid->insertMeta("z_voxels", openvdb::Int32Metadata(0));
    grid->insertMeta("scene_hash", openvdb::StringMetadata("0000000000000000"));
    fill(*grid);
    openvdb::io::File((dir / "segment_1" / "group.vdb").string()).write({grid});
    write_text(dir / "result.json", R"({"segments": [{"index": 1, "facing": {"A": [1, 0], "B": [1, 0]}}]})");
}

TEST(Security, CraftedGroupsAreRefusedBeforeTheyCostAnything) {
    test::TempDir tmp;
    const fs::path far = tmp.path() / "far", tile = tmp.path() / "tile";
    write_crafted_group(far, [](openvdb::BoolGrid& g) { g.tree().setValueOn(openvdb::Coord(std::numeric_limits<int>::max() - 8, 0, 0), true); }, 180, 0.01);
    // One tile at the root: 4096^3 poses, 6.9e10 members on a 36000-angle lattice.
    write_crafted_group(tile, [](openvdb::BoolGrid& g) { g.fill(openvdb::CoordBBox(openvdb::Coord(0), openvdb::Coord(4095)), true, true); }, 36000, 0.01);
    for (const std::string& command : std::vector<std::string>{"solutions '" + far.string() + "'", "solutions '" + far.string() + "' --csv '" + tmp.path().string() + "/far.csv'",
                                       "solutions '" + tile.string() + "' --csv '" + tmp.path().string() + "/tile.csv'"}) {
        const Clock::time_point start = Clock::now();
        auto run = test::run_amhv(command);
        EXPECT_EQ(run.exit_code, 1) << command << ": " << run.output;
        EXPECT_EQ(test::one_line_error(run), 1) << run.output;
        EXPECT_LT(Clock::now() - start, std::chrono::seconds(30)) << command;
    }
    EXPECT_FALSE(fs::exists(tmp.path() / "far.csv"));
    EXPECT_FALSE(fs::exists(tmp.path() / "tile.csv"));
    EXPECT_FALSE(fs::exists(tmp.path() / ".partial-tile.csv"));
}

// OpenVDB trusts every length and count in a file; check_vdb_layout reads them first. A group
// amhv wrote passes; one whose metadata type a reader would size by itself (a "mat4d" stated as 8
// bytes), one compressed with Blosc, and one cut short are refused in one line, before OpenVDB
// allocates what they claim.
TEST(Security, GroupFilesAreCheckedBeforeOpenVdbTrustsThem) {
    test::TempDir tmp;
    SolutionGroup group;
    group.add_run({0, 3, 7, -2, 40});
    group.add_run({0, 5, -9, 0, 3});
    const results::GroupLattice lattice{0.01, 2.0, 180, 1, 0, 0, "0123456789abcdef"};
    const fs::path good = tmp.path() / "good.vdb";
    results::write_group_vdb(good, group, lattice);
    EXPECT_EQ(results::read_group_vdb(good, results::read_group_lattice(good)), group);
    const std::string bytes = test::read_text(good);
    auto refused = [&](std::string changed, const std::string& expected) {
        write_text(tmp.path() / "bad.vdb", changed);
        try {
            results::read_group_lattice(tmp.path() / "bad.vdb");
            ADD_FAILURE() << "accepted; expected " << expected;
        } catch (const amhv::Error& e) {
            EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
        }
    };
    std::string mat4d = bytes;
    const std::size_t int64_at = mat4d.find("int64");
    ASSERT_NE(int64_at, std::string::npos);
    mat4d.replace(int64_at, 5, "mat4d");
    refused(mat4d, "metadata of another type or size than amhv writes");
    std::string blosc = bytes;
    const std::size_t solutions = blosc.find("Tree_bool_5_4_3");
    ASSERT_NE(solutions, std::string::npos);
    std::uint32_t flags = 0;
    const std::size_t flags_at = solutions + 15 + 4 + 24;  // the grid type, an empty parent name, three offsets
    std::memcpy(&flags, blosc.data() + flags_at, 4);
    ASSERT_EQ(flags, 2u);  // amhv writes the active-mask flag alone
    flags = 6;
    std::memcpy(blosc.data() + flags_at, &flags, 4);
    refused(blosc, "compressed with Blosc or zip");
    refused(bytes.substr(0, bytes.size() - 100), "is not a readable OpenVDB file");
}

// A tetrahedron with one more face, the reverse of one of its own: OpenMesh cannot take it into its
// half-edge structure (non-manifold), and it is left out, as the warning says, so the frame is the
// solid tetrahedron and not a hollow shell.
TEST(Security, NonManifoldFacesAreLeftOutAsTheWarningSays) {
    test::TempDir tmp;
    const std::string tetra = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 2 3 4\nf 1 4 3\n";
    write_text(tmp.path() / "plain.obj", tetra);
    write_text(tmp.path() / "extra.obj", tetra + "f 1 2 3\n");
    write_text(tmp.path() / "seq" / "extra_0000.obj", tetra + "f 1 2 3\n");
    const TriangleMesh plain = read_mesh(tmp.path() / "plain.obj", UnitsAndAxes{});
    const TriangleMesh extra = read_mesh(tmp.path() / "extra.obj", UnitsAndAxes{});
    EXPECT_EQ(extra.triangles.size(), plain.triangles.size());
    EXPECT_TRUE(extra.is_closed());
    auto run = test::run_amhv(fmt::format("mhv --meshes '{0}/seq' --voxel 0.02 --backend cpu --no-exr --out '{0}/o'", tmp.path().string()));
    EXPECT_NE(run.output.find("1 face shared an edge"), std::string::npos) << run.output;
}

// The forms of OFF and PLY whose headers are now checked before OpenMesh reads them still read as
// the plain form does: COFF with colours, PLY in both byte orders with an extra vertex property.
TEST(Security, CheckedMeshFormsStillRead) {
    test::TempDir tmp;
    auto ply = [](bool big, const std::string& count_type) {
        std::string out = fmt::format("ply\nformat {} 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
                                      "property uchar red\nelement face 4\nproperty list {} int vertex_indices\nend_header\n",
                                      big ? "binary_big_endian" : "binary_little_endian", count_type);
        auto put = [&](std::uint32_t v, int bytes) {
            for (int k = 0; k < bytes; ++k) out.push_back(char((v >> (8 * (big ? bytes - 1 - k : k))) & 0xff));
        };
        const float xyz[4][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
        for (const auto& v : xyz) {
            for (float f : v) put(std::bit_cast<std::uint32_t>(f), 4);
            put(200, 1);
        }
        for (const auto& f : {std::array<std::uint32_t, 3>{0, 2, 1}, {0, 1, 3}, {1, 2, 3}, {0, 3, 2}}) {
            put(3, count_type == "uchar" ? 1 : 4);
            for (auto i : f) put(i, 4);
        }
        return out;
    };
    write_text(tmp.path() / "plain.off", "OFF\n4 4 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 1 2 3\n3 0 3 2\n");
    write_text(tmp.path() / "coloured.off",
               "COFF\n4 4 0\n0 0 0 255 0 0 255\n1 0 0 0 255 0 255\n0 1 0 0 0 255 255\n0 0 1 9 9 9 255\n3 0 2 1\n3 0 1 3\n3 1 2 3\n3 0 3 2\n");
    write_text(tmp.path() / "little.ply", ply(false, "uchar"));
    write_text(tmp.path() / "big.ply", ply(true, "uchar"));
    write_text(tmp.path() / "wide.ply", ply(false, "int"));
    const TriangleMesh plain = read_mesh(tmp.path() / "plain.off", UnitsAndAxes{});
    ASSERT_EQ(plain.triangles.size(), 4u);
    for (const char* name : {"coloured.off", "little.ply", "big.ply", "wide.ply"}) {
        const TriangleMesh other = read_mesh(tmp.path() / name, UnitsAndAxes{});
        EXPECT_EQ(other.vertices, plain.vertices) << name;
        EXPECT_EQ(other.triangles, plain.triangles) << name;
    }
}

// A mesh file removed between read_mesh's checks and the precheck's size: one line naming it.
TEST(Security, AMeshFileThatGoesBeforeItsCheckIsNamed) {
    test::TempDir tmp;
    const fs::path gone = tmp.path() / "gone.ply";
    try {
        precheck_mesh_file(gone, tmp.path());
        FAIL() << "no error";
    } catch (const amhv::Error& e) {
        EXPECT_NE(std::string(e.what()).find("gone.ply: cannot read the file"), std::string::npos) << e.what();
    }
}

TEST(Security, SmallMistakesInInputsAreNamed) {
    test::TempDir tmp;
    const fs::path d = tmp.path();
    // A pattern names only what printf would write: f_%04d.obj is f_0001.obj, never f_1.obj.
    write_obj_in(d / "m" / "f_0000.obj", shapes::sphere(Vec3(0, 0, 0.3), 0.2, 8, 12));
    write_obj_in(d / "m" / "f_1.obj", shapes::sphere(Vec3(0, 0, 0.3), 0.2, 8, 12));
    auto pattern = test::run_amhv(fmt::format("mhv --meshes '{0}/m/f_%04d.obj' --frames 0:1 --backend cpu --out '{0}/o'", d.string()));
    EXPECT_EQ(pattern.exit_code, 1);
    EXPECT_NE(pattern.output.find("frame 1 of --frames 0:1 is missing"), std::string::npos) << pattern.output;
    // A shard.json of the wrong shape: amhv's words, not the JSON library's.
    write_text(d / "shard" / "shard.json", R"({"kind": "amhv sweep shard", "program": 3})");
    auto shard = test::run_amhv(fmt::format("merge '{0}/shard' --out '{0}/merged'", d.string()));
    EXPECT_EQ(shard.exit_code, 1) << shard.output;
    EXPECT_NE(shard.output.find("a value has the wrong type"), std::string::npos) << shard.output;
    EXPECT_EQ(shard.output.find("json."), std::string::npos) << shard.output;
    // A count that is a number but no integer the count can hold (the JSON library would cast it).
    write_text(d / "shard" / "shard.json", R"({"kind": "amhv sweep shard", "program": "amhv", "scene": "s.toml", "scene_hash": "0", "inputs": "0",
                                            "sampling": {"voxel_m": 0.04, "angle_step_deg": 30, "angles": 1e300}})");
    auto huge = test::run_amhv(fmt::format("merge '{0}/shard' --out '{0}/merged'", d.string()));
    EXPECT_EQ(huge.exit_code, 1) << huge.output;
    EXPECT_NE(huge.output.find("shard.json: is not a shard's manifest (a value has the wrong type)"), std::string::npos) << huge.output;
    // A take that promises ten million frames and holds two reserves no more than it can hold.
    const std::string take = "HIERARCHY\nROOT Hips\n{\n OFFSET 0 0 0\n CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n"
                             " End Site\n {\n  OFFSET 0 10 0\n }\n}\nMOTION\nFrames: 10000000\nFrame Time: 0.04\n0 0 0 0 0 0\n0 0 0 0 0 0\n";
    write_text(d / "t.bvh", take);
    // (Under AddressSanitizer, whose shadow memory reserves terabytes of address space, without the
    // address-space limit: the main job runs it with one.)
    const std::string limit = test::kAddressSanitizer ? "" : "ulimit -v 2000000; ";
    auto bvh = test::run_shell(fmt::format("{}{} mhv --bvh '{}/t.bvh' --out '{}/b' 2>&1", limit, test::amhv_command(), d.string(), d.string()));
    EXPECT_EQ(bvh.exit_code, 1);
    EXPECT_NE(bvh.output.find("motion block is truncated: 2 of 10000000 frames"), std::string::npos) << bvh.output;
}

TEST(Security, AnInterruptedRunLeavesNoStagingAndNoLock) {
    test::TempDir tmp;
    const fs::path d = tmp.path();
    for (int f = 0; f < 40; ++f) write_obj_in(d / "m" / fmt::format("f_{:04d}.obj", f), shapes::sphere(Vec3(0.01 * f, 0, 0.5), 0.4, 48, 64));
    for (const int signal : {SIGINT, SIGTERM}) {
        const std::string run = fmt::format("{} mhv --meshes '{}/m/f_%04d.obj' --voxel 0.002 --backend cpu --out '{}/o' > '{}/log' 2>&1 & pid=$!; "
                                            "sleep 1.5; kill -{} $pid; wait $pid; echo $?",
                                            test::amhv_command(), d.string(), d.string(), d.string(), signal);
        const auto result = test::run_shell(run);
        EXPECT_EQ(std::stoi(result.output), 128 + signal) << result.output << test::read_text(d / "log");
        EXPECT_NE(test::read_text(d / "log").find("interrupted"), std::string::npos) << test::read_text(d / "log");
        for (const auto& entry : fs::directory_iterator(d)) EXPECT_EQ(entry.path().filename().string().rfind(".o.", 0), std::string::npos) << entry.path();
        EXPECT_FALSE(fs::exists(d / "o"));
    }
}

}  // namespace
}  // namespace amhv
