#include "support.hpp"

#include "host/reference/voxelise_reference.hpp"
#include "src/io/bvh.hpp"
#include "src/io/mesh_sequence.hpp"
#include "src/scene/scene.hpp"

#include <Eigen/Geometry>
#include <fmt/format.h>
#include <numbers>

#include "src/voxelise/voxelise.hpp"

#include <cstdlib>

#include <array>
#include <cstdio>
#include <fstream>
#include <memory>
#include <random>
#include <sstream>

namespace amhv::test {

gpu::Context& context() {
    // Validation on unless AMHV_VALIDATION=0 (the sanitizer job: the layers' own leaks at exit
    // cannot be told apart once the loader has unloaded them; the main job runs them).
    const char* setting = std::getenv("AMHV_VALIDATION");
    static gpu::Context instance(gpu::ContextOptions{.validation = !(setting && std::string(setting) == "0")});
    return instance;
}

// NAME.bvh of each object re-imported: one frame per output frame at the take's rate; every
// joint (the root and the head) where transforms.json puts the source frame's joint in the scene;
// every channel but the root's as captured.
void expect_edited_takes(const std::filesystem::path& out, const std::vector<std::pair<std::string, const SceneObject*>>& objects,
                         const nlohmann::json& transforms) {
    for (const auto& [name, spec] : objects) {
        ObjectSource source(*spec);
        const BvhMotion& captured = *source.motion();
        const BvhMotion edited = read_bvh(out / (name + ".bvh"));
        ASSERT_EQ(edited.frame_count, transforms.at("frames").get<int>()) << name;
        EXPECT_NEAR(edited.frame_time, captured.frame_time, 1e-8);
        const int head = captured.joint_index("Head");
        ASSERT_GE(head, 0);
        const BvhJoint& root = captured.joints[0];
        for (int k : {0, 60, 120, 200, edited.frame_count - 1}) {
            const auto& t = transforms.at("output").at(std::size_t(k)).at(name);
            const int from = t.at("source").get<int>();
            const Eigen::Rotation2Dd yaw(t.at("yaw_deg").get<double>() * std::numbers::pi / 180);
            const auto now = edited.global_transforms(k), then = captured.global_transforms(from);
            for (int j : {0, head}) {
                const Vec3 p = to_scene_point(then[std::size_t(j)].translation(), spec->units);
                const Eigen::Vector2d xy = yaw * Eigen::Vector2d(p.x(), p.y()) + Eigen::Vector2d(t.at("x").get<double>(), t.at("y").get<double>());
                const Vec3 expected(xy.x(), xy.y(), p.z() + t.at("z").get<double>());
                EXPECT_LT((to_scene_point(now[std::size_t(j)].translation(), spec->units) - expected).norm(), 1e-4) << name << " frame " << k << " joint " << j;
            }
            for (int c = 0; c < captured.channel_count; ++c) {
                if (c >= root.first_channel && c < root.first_channel + int(root.channels.size())) continue;
                EXPECT_NEAR(edited.values[std::size_t(k * edited.channel_count + c)], captured.values[std::size_t(from * captured.channel_count + c)], 1e-6);
            }
        }
    }
}

gpu::Context& staged_context() {
    const char* setting = std::getenv("AMHV_VALIDATION");
    static gpu::Context instance(gpu::ContextOptions{.validation = !(setting && std::string(setting) == "0"), .staged_transfers = true});
    return instance;
}

void expect_no_validation_messages() {
    static std::size_t seen = 0;
    auto messages = context().validation_messages();
    for (std::size_t i = seen; i < messages.size(); ++i) ADD_FAILURE() << "Vulkan validation: " << messages[i];
    seen = messages.size();
}

TempDir::TempDir() {
    static std::mt19937_64 rng(std::random_device{}());
    path_ = std::filesystem::temp_directory_path() / ("amhv-test-" + std::to_string(rng()));
    std::filesystem::create_directories(path_);
}

TempDir::~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
}

std::filesystem::path source_dir() { return AMHV_SOURCE_DIR; }

CommandResult run_shell(const std::string& command_line) {
    const std::string command = command_line + " 2>&1";
    std::unique_ptr<FILE, int (*)(FILE*)> pipe(popen(command.c_str(), "r"), pclose);
    CommandResult result{-1, {}};
    if (!pipe) return result;
    std::array<char, 4096> buffer{};
    while (std::size_t n = std::fread(buffer.data(), 1, buffer.size(), pipe.get())) result.output.append(buffer.data(), n);
    int status = pclose(pipe.release());
    result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    return result;
}

std::string amhv_command() { return std::string("'") + AMHV_BINARY + "'"; }

CommandResult run_amhv(const std::string& arguments) { return run_shell(amhv_command() + " " + arguments); }

CommandResult validate_gltf(const std::filesystem::path& file) {
    return run_shell("node '" + (source_dir() / "tools" / "validate_gltf.cjs").string() + "' '" + file.string() + "'");
}

void write_obj(const std::filesystem::path& path, const TriangleMesh& mesh) {
    std::ofstream out(path);
    out.precision(9);
    for (const auto& v : mesh.vertices) out << "v " << v.x() << ' ' << v.y() << ' ' << v.z() << '\n';
    for (const auto& t : mesh.triangles) out << "f " << t[0] + 1 << ' ' << t[1] + 1 << ' ' << t[2] + 1 << '\n';
}

std::string read_text(const std::filesystem::path& path) {
    std::ifstream in(path, std::ios::binary);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
}

void replace_in_file(const std::filesystem::path& path, const std::string& from, const std::string& to) {
    std::string text = read_text(path);
    const std::size_t at = text.find(from);
    ASSERT_NE(at, std::string::npos) << from << " is not in " << path;
    text.replace(at, from.size(), to);
    std::ofstream(path, std::ios::binary) << text;
}

void write_labelled_obj(const std::filesystem::path& obj, const std::filesystem::path& labels,
                        const std::vector<std::pair<std::string, TriangleMesh>>& parts) {
    TriangleMesh all;
    std::ofstream out(labels);
    for (const auto& [name, mesh] : parts) {
        all.append(mesh);
        for (std::size_t v = 0; v < mesh.vertices.size(); ++v) out << name << '\n';
    }
    write_obj(obj, all);
}

int one_line_error(const CommandResult& result) {
    std::istringstream lines(result.output);
    std::string line;
    int errors = 0;
    while (std::getline(lines, line)) errors += line.rfind("amhv: error: ", 0) == 0;
    return errors;
}

// The union of the parts of `source`'s frame `number` selected by `keep`, moved into the scene.
MeshFrame moved_parts(ObjectSource& source, const nlohmann::json& transform, bool (*keep)(const std::string&)) {
    MeshFrame out;
    for (const BodyPart& part : source.frame_parts(transform.at("source").get<int>()))
        if (keep(part.name)) out.mesh.append(part.mesh);
    const Eigen::Vector2d shift(transform.at("x").get<double>(), transform.at("y").get<double>());
    out.mesh = moved_into_scene(std::move(out.mesh), transform.at("yaw_deg").get<double>() * std::numbers::pi / 180, shift, transform.value("z", 0.0));
    out.source = fmt::format("source frame {}", transform.at("source").get<int>());
    return out;
}


// Voxels (edge h, on the scene lattice) whose centre lies inside `a` and, within `reach` voxels
// (26-neighbourhood steps), inside `b`.
std::size_t shared_voxels(const MeshFrame& a, const MeshFrame& b, double h, Voxeliser& voxeliser, int reach) {
    const Box3 box_a = a.mesh.bounds(), box_b = b.mesh.bounds();
    if ((box_a.min.array() > box_b.max.array()).any() || (box_b.min.array() > box_a.max.array()).any()) return 0;
    Box3 both = box_a;
    both.extend(box_b);
    const Amhv volume = voxelise(prepare_voxelisation({&a, &b}, grid_covering(both, h, "overlap")), voxeliser);
    const VoxelGrid& g = volume.grid();
    std::size_t shared = 0;
    for (int z = 0; z < g.dims[2]; ++z)
        for (int y = 0; y < g.dims[1]; ++y)
            for (int x = 0; x < g.dims[0]; ++x) {
                if (!(volume.word(0, g.index(x, y, z)) & 1u)) continue;
                bool near = false;
                for (int dz = -reach; dz <= reach && !near; ++dz)
                    for (int dy = -reach; dy <= reach && !near; ++dy)
                        for (int dx = -reach; dx <= reach && !near; ++dx) {
                            const int u = x + dx, w = y + dy, q = z + dz;
                            near = u >= 0 && w >= 0 && q >= 0 && u < g.dims[0] && w < g.dims[1] && q < g.dims[2] &&
                                   (volume.word(0, g.index(u, w, q)) & 2u);
                        }
                shared += near;
            }
    return shared;
}

std::vector<int> overlapping_transitional_frames(const std::filesystem::path& scene_file, const std::filesystem::path& transforms_file, double h) {
    const Scene scene = load_scene(scene_file);
    ObjectSource a(scene.a), b(scene.b);
    ReferenceVoxeliser voxeliser;
    auto whole = [](const std::string&) { return true; };
    const auto transforms = nlohmann::json::parse(read_text(transforms_file));
    std::vector<int> overlapping;
    for (const auto& frame : transforms.at("output")) {
        if (frame.at("segment").get<std::string>().rfind("transition", 0) != 0) continue;
        if (shared_voxels(moved_parts(a, frame.at("A"), whole), moved_parts(b, frame.at("B"), whole), h, voxeliser) > 0)
            overlapping.push_back(frame.at("frame").get<int>());
    }
    return overlapping;
}

}  // namespace amhv::test
