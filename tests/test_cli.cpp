// The command line on real files: outputs, EXR contents, volume round trip, determinism and every
// kind of bad input (one-line error, non-zero exit, no partial output).
#include <fstream>
#include <set>
#include <sstream>

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfMultiPartInputFile.h>
#include <OpenEXR/ImfStringAttribute.h>
#include <gtest/gtest.h>
#include <tiny_gltf.h>
#include <nlohmann/json.hpp>

#include "src/body/shapes.hpp"
#include "src/core/error.hpp"
#include "src/io/amhv_file.hpp"
#include "src/io/bvh.hpp"
#include "src/io/exr_slices.hpp"
#include "support.hpp"

namespace amhv {
namespace {

namespace fs = std::filesystem;

using test::read_text;
using test::write_obj;

// A ball rolling over 12 frames, written as frame_0000.obj ... with y up in centimetres.
fs::path make_sequence(const fs::path& folder, int frames = 12) {
    fs::create_directories(folder);
    for (int f = 0; f < frames; ++f) {
        auto mesh = shapes::sphere(Vec3(2.0 * f, 30.0, 0.0), 15.0, 16, 24);  // cm, y up: centre 30 cm above the floor
        write_obj(folder / fmt::format("frame_{:04d}.obj", f), mesh);
    }
    return folder;
}

TEST(Cli, MhvWritesVolumeJsonAndExrSlices) {
    test::TempDir tmp;
    make_sequence(tmp.path() / "ball");
    auto out = tmp.path() / "out";
    auto result = test::run_amhv(fmt::format("mhv --meshes '{}/ball/frame_%04d.obj' --frames 2:9 --unit cm --up y --voxel 0.02 --out '{}'",
                                             tmp.path().string(), out.string()));
    ASSERT_EQ(result.exit_code, 0) << result.output;
    auto json = nlohmann::json::parse(read_text(out / "mhv.json"));
    EXPECT_EQ(json["frames"], 8);
    EXPECT_GT(json["occupied_voxels"].get<int>(), 100);
    EXPECT_EQ(json["gap_voxels"], 0);
    EXPECT_NEAR(json["root_m"][2].get<double>(), 0.30, 0.02);  // y-up input became z-up
    EXPECT_TRUE(json.contains("timings_s"));
    EXPECT_NE(json["device"], "cpu");  // the default backend is vulkan: the device is named

    Amhv volume = read_amhv(out / "mhv.amhv");
    EXPECT_EQ(volume.frames(), 8);
    EXPECT_EQ(summarise(volume).occupied_voxels, json["occupied_voxels"].get<std::size_t>());

    // One slice through the ball's centre: channels, attributes and values.
    int k = int((0.30 - volume.grid().origin.z()) / 0.02);
    auto slice = out / "slices" / fmt::format("z_{:04d}.exr", k);
    ASSERT_TRUE(fs::exists(slice));
    Imf::InputFile file(slice.c_str());
    const auto& header = file.header();
    for (const char* channel : {"R", "G", "B", "t_start", "t_end", "frames", "label"})
        EXPECT_NE(header.channels().findChannel(channel), nullptr) << channel;
    ASSERT_NE(header.findTypedAttribute<Imf::StringAttribute>("amhv:voxel_size_m"), nullptr);
    EXPECT_EQ(header.findTypedAttribute<Imf::StringAttribute>("amhv:voxel_size_m")->value(), "0.02");
    auto dw = header.dataWindow();
    int width = dw.max.x - dw.min.x + 1, height = dw.max.y - dw.min.y + 1;
    EXPECT_EQ(width, volume.grid().dims[0]);
    std::vector<float> t_start(std::size_t(width * height)), frames(std::size_t(width * height));
    Imf::FrameBuffer buffer;
    buffer.insert("t_start", Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(t_start.data()), 4, 4 * std::size_t(width)));
    buffer.insert("frames", Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(frames.data()), 4, 4 * std::size_t(width)));
    file.setFrameBuffer(buffer);
    file.readPixels(dw.min.y, dw.max.y);
    int matched = 0;
    for (int row = 0; row < height; ++row)
        for (int col = 0; col < width; ++col) {
            std::size_t v = volume.grid().index(col, height - 1 - row, k);
            float s = t_start[std::size_t(row * width + col)];
            if (volume.any(v)) {
                EXPECT_EQ(s, float(volume.t_start(v)));
                EXPECT_EQ(frames[std::size_t(row * width + col)], float(volume.frame_count(v)));
                ++matched;
            } else {
                EXPECT_TRUE(std::isnan(s));
            }
        }
    EXPECT_GT(matched, 50);
}

TEST(Cli, BackendsAgreeAndRerunsAreByteIdentical) {
    test::TempDir tmp;
    make_sequence(tmp.path() / "ball");
    std::string common = fmt::format("mhv --meshes '{}/ball' --unit cm --up y --voxel 0.01 --no-timings --axis x", tmp.path().string());
    for (const char* run : {"gpu1", "gpu2"})
        ASSERT_EQ(test::run_amhv(common + " --out '" + (tmp.path() / run).string() + "'").exit_code, 0);
    ASSERT_EQ(test::run_amhv(common + " --backend cpu --out '" + (tmp.path() / "cpu").string() + "'").exit_code, 0);
    EXPECT_EQ(read_text(tmp.path() / "gpu1/mhv.json"), read_text(tmp.path() / "gpu2/mhv.json"));
    EXPECT_EQ(read_text(tmp.path() / "gpu1/mhv.amhv"), read_text(tmp.path() / "gpu2/mhv.amhv"));
    EXPECT_EQ(read_text(tmp.path() / "gpu1/mhv.amhv"), read_text(tmp.path() / "cpu/mhv.amhv"));
    for (const auto& entry : fs::directory_iterator(tmp.path() / "gpu1/slices"))
        EXPECT_EQ(read_text(entry.path()), read_text(tmp.path() / "gpu2/slices" / entry.path().filename())) << entry.path();
    EXPECT_TRUE(fs::exists(tmp.path() / "gpu1/slices/x_0000.exr"));
}

TEST(Cli, MultipartExrHasOnePartPerSlice) {
    test::TempDir tmp;
    make_sequence(tmp.path() / "ball", 4);
    auto out = tmp.path() / "out";
    auto result = test::run_amhv(fmt::format("mhv --meshes '{}/ball' --unit cm --up y --voxel 0.02 --exr-multipart --axis y --out '{}'",
                                             tmp.path().string(), out.string()));
    ASSERT_EQ(result.exit_code, 0) << result.output;
    Amhv volume = read_amhv(out / "mhv.amhv");
    Imf::MultiPartInputFile file((out / "slices/slices_y.exr").c_str());
    EXPECT_EQ(file.parts(), volume.grid().dims[1]);
    EXPECT_EQ(file.header(0).name(), "y_0000");
}

// A volume file whose voxel is occupied in a frame past its last one (a bit the writer never sets)
// is refused with the file and the frame named: later stages index frames by bit.
TEST(VolumeFile, OccupancyPastTheLastFrameIsRefused) {
    test::TempDir tmp;
    VoxelGrid grid;
    grid.dims = {4, 3, 2};
    grid.voxel = 0.01;
    Amhv volume(grid, 8);
    volume.plane(0)[grid.index(1, 2, 1)] = 0b1010u;
    const auto path = tmp.path() / "volume.amhv";
    write_amhv(volume, path);
    EXPECT_EQ(read_amhv(path).word(0, grid.index(1, 2, 1)), 0b1010u);
    {  // the file ends in the last record's last word: its top byte 0x10 is frame 28
        std::fstream file(path, std::ios::in | std::ios::out | std::ios::binary);
        file.seekp(-1, std::ios::end);
        file.put(char(0x10));
    }
    try {
        read_amhv(path);
        ADD_FAILURE() << "expected an error";
    } catch (const Error& e) {
        const std::string message = e.what();
        EXPECT_NE(message.find(path.string()), std::string::npos) << message;
        EXPECT_NE(message.find("occupied in frame 28, past the last frame 7"), std::string::npos) << message;
    }
}

// mhv --glb: the occupied voxels' outer faces (each face between an occupied voxel and an empty one,
// counted here from mhv.amhv), two triangles each, coloured by the voxel's t_end; the validator
// accepts it.
TEST(Cli, MhvGlbIsTheVolumesSurfaceColouredByTEnd) {
    test::TempDir tmp;
    make_sequence(tmp.path() / "ball");
    const auto out = tmp.path() / "out";
    auto result = test::run_amhv(fmt::format("mhv --meshes '{}/ball/frame_%04d.obj' --frames 2:9 --unit cm --up y --voxel 0.02 --no-exr --glb --out '{}'",
                                             tmp.path().string(), out.string()));
    ASSERT_EQ(result.exit_code, 0) << result.output;
    EXPECT_EQ(nlohmann::json::parse(read_text(out / "mhv.json"))["files"]["glb"], "mhv.glb");
    const auto valid = test::validate_gltf(out / "mhv.glb");
    EXPECT_EQ(valid.exit_code, 0) << valid.output;
    EXPECT_NE(valid.output.find(": 0 errors, 0 warnings"), std::string::npos) << valid.output;

    const Amhv volume = read_amhv(out / "mhv.amhv");
    const auto& d = volume.grid().dims;
    auto occupied = [&](int x, int y, int z) {
        return x >= 0 && y >= 0 && z >= 0 && x < d[0] && y < d[1] && z < d[2] && volume.t_end(volume.grid().index(x, y, z)) >= 0;
    };
    std::size_t faces = 0;
    int latest = -1;
    for (int z = 0; z < d[2]; ++z)
        for (int y = 0; y < d[1]; ++y)
            for (int x = 0; x < d[0]; ++x)
                if (occupied(x, y, z)) {
                    latest = std::max(latest, volume.t_end(volume.grid().index(x, y, z)));
                    faces += !occupied(x - 1, y, z) + !occupied(x + 1, y, z) + !occupied(x, y - 1, z) + !occupied(x, y + 1, z) +
                             !occupied(x, y, z - 1) + !occupied(x, y, z + 1);
                }
    ASSERT_GT(faces, 100u);
    tinygltf::Model model;
    tinygltf::TinyGLTF loader;
    std::string error, warning;
    ASSERT_TRUE(loader.LoadBinaryFromFile(&model, &error, &warning, (out / "mhv.glb").string())) << error;
    const tinygltf::Primitive& p = model.meshes.at(0).primitives.at(0);
    EXPECT_EQ(model.accessors[std::size_t(p.indices)].count, 6 * faces);
    EXPECT_EQ(model.accessors[std::size_t(p.attributes.at("POSITION"))].count, 4 * faces);
    // Every colour is the EXR slices' colour of some t_end, and the last frame's is there (the ball
    // is still in the volume at the segment's end).
    const tinygltf::Accessor& colours = model.accessors[std::size_t(p.attributes.at("COLOR_0"))];
    const auto* c = reinterpret_cast<const float*>(model.buffers[0].data.data() + model.bufferViews[std::size_t(colours.bufferView)].byteOffset);
    std::set<std::array<float, 3>> expected, seen;
    for (int t = 0; t <= 7; ++t) expected.insert(time_colour(t / 7.0));
    for (std::size_t i = 0; i < colours.count; ++i) seen.insert({c[3 * i], c[3 * i + 1], c[3 * i + 2]});
    for (const auto& colour : seen) EXPECT_TRUE(expected.count(colour)) << colour[0] << " " << colour[1] << " " << colour[2];
    EXPECT_EQ(latest, 7);
    EXPECT_TRUE(seen.count(time_colour(1.0)));
}

TEST(Cli, BvhBodyAndVdb) {
    test::TempDir tmp;
    auto out = tmp.path() / "out";
    auto result = test::run_amhv(fmt::format("mhv --bvh '{}' --frames 100:111 --voxel 0.02 --vdb --no-exr --out '{}'",
                                             (test::source_dir() / "data/cmu/19_01.bvh").string(), out.string()));
    ASSERT_EQ(result.exit_code, 0) << result.output;
    EXPECT_TRUE(fs::exists(out / "mhv.vdb"));
    EXPECT_GT(fs::file_size(out / "mhv.vdb"), 1000u);
    EXPECT_FALSE(fs::exists(out / "slices"));
}

TEST(Cli, OpenMeshGetsSurfaceVoxelisationAndAWarning) {
    test::TempDir tmp;
    auto folder = tmp.path() / "open";
    fs::create_directories(folder);
    TriangleMesh mesh = shapes::box({0, 0, 0}, {0.3, 0.3, 0.3});
    mesh.triangles.pop_back();  // a hole
    write_obj(folder / "a.obj", mesh);
    write_obj(folder / "b.obj", shapes::box({0, 0, 0}, {0.3, 0.3, 0.3}));
    auto result = test::run_amhv(fmt::format("mhv --meshes '{}' --voxel 0.02 --no-exr --out '{}/out'", folder.string(), tmp.path().string()));
    ASSERT_EQ(result.exit_code, 0) << result.output;
    EXPECT_NE(result.output.find("a.obj: mesh is not closed"), std::string::npos) << result.output;
    auto json = nlohmann::json::parse(read_text(tmp.path() / "out/mhv.json"));
    EXPECT_EQ(json["open_frames"], nlohmann::json::array({0}));
    EXPECT_GT(json["occupied_per_frame"][0].get<int>(), 0);
}

struct BadInput {
    const char* name;
    std::string file_content;  // written as bad/frame_0000.obj ("" = no file)
    std::string extra;         // extra arguments
    const char* expected;      // substring of the error line
};

class CliBadInput : public ::testing::TestWithParam<BadInput> {};

TEST_P(CliBadInput, OneLineErrorAndNoOutput) {
    const BadInput& bad = GetParam();
    test::TempDir tmp;
    auto folder = tmp.path() / "bad";
    fs::create_directories(folder);
    make_sequence(folder, 3);  // frames 0..2 are good
    if (!bad.file_content.empty()) {
        std::ofstream(folder / "frame_0001.obj") << bad.file_content;
    }
    auto out = tmp.path() / "out";
    std::string unit = bad.extra.find("--unit") == std::string::npos ? "--unit cm" : "";
    auto result = test::run_amhv(fmt::format("mhv --meshes '{}/frame_%04d.obj' {} --out '{}' {}", folder.string(), unit, out.string(), bad.extra));
    EXPECT_NE(result.exit_code, 0) << result.output;
    EXPECT_EQ(test::one_line_error(result), 1) << result.output;
    EXPECT_NE(result.output.find(bad.expected), std::string::npos) << result.output;
    EXPECT_FALSE(fs::exists(out));
    for (const auto& entry : fs::directory_iterator(tmp.path())) EXPECT_EQ(entry.path().filename().string().find(".out.partial"), std::string::npos);
}

INSTANTIATE_TEST_SUITE_P(
    Robustness, CliBadInput,
    ::testing::Values(
        BadInput{"nan_vertex", "v 0 0 0\nv 1 0 0\nv nan 1 0\nf 1 2 3\n", "", "frame_0001.obj:3: vertex 2 has a non-finite coordinate"},
        BadInput{"inf_vertex", "v 0 0 0\nv 1 0 0\nv 0 inf 0\nf 1 2 3\n", "", "non-finite coordinate"},
        BadInput{"empty_frame", "# nothing here\n", "", "frame_0001.obj: empty frame"},
        BadInput{"only_vertices", "v 0 0 0\nv 1 0 0\n", "", "frame_0001.obj: empty frame"},
        BadInput{"missing_frame", "", "--frames 0:5", "frame 3 of --frames 0:5 is missing"},
        BadInput{"bad_range", "", "--frames 5:2", "--frames: frame range '5:2' is empty"},
        BadInput{"bad_unit", "", "--unit furlong", "--unit: unit 'furlong'"},
        BadInput{"bad_voxel", "", "--voxel -1", "voxel size must be a positive number"},
        BadInput{"huge_grid", "", "--voxel 0.00001", "voxels along"},
        BadInput{"bad_backend", "", "--backend cuda", "--backend: 'cuda' is not vulkan or cpu"},
        BadInput{"bad_axis", "", "--axis w", "--axis: 'w' is not x, y or z"},
        BadInput{"bad_device", "", "--device 7", "--device 7: there are only"}),
    [](const auto& param_info) { return std::string(param_info.param.name); });

TEST(Cli, UnreadableAndMissingInputs) {
    test::TempDir tmp;
    auto folder = tmp.path() / "binary";
    fs::create_directories(folder);
    const std::string ply_header =
        "ply\nformat binary_little_endian 1.0\nelement vertex 99\nproperty float x\nproperty float y\nproperty float z\n"
        "element face 5\nproperty list uchar int vertex_indices\nend_header\n";
    std::ofstream(folder / "truncated.ply", std::ios::binary) << ply_header << "0123456789";
    auto no_header = tmp.path() / "no_header";
    fs::create_directories(no_header);
    std::ofstream(no_header / "a.ply", std::ios::binary) << std::string("ply\nformat binary_little_endian 1.0\nelement vertex 99\n\x01\x02");
    auto bad_stl = tmp.path() / "bad_stl";
    fs::create_directories(bad_stl);
    std::ofstream(bad_stl / "a.stl", std::ios::binary) << std::string(80, 'x') << std::string("\xff\xff\x00\x00", 4) << "short";
    for (const auto& [arguments, expected] : std::vector<std::pair<std::string, std::string>>{
             {fmt::format("mhv --meshes '{}' --out '{}/o'", folder.string(), tmp.path().string()), "truncated.ply: malformed PLY: 99 vertices"},
             {fmt::format("mhv --meshes '{}' --out '{}/o'", no_header.string(), tmp.path().string()), "a.ply:4: malformed PLY header"},
             {fmt::format("mhv --meshes '{}' --out '{}/o'", bad_stl.string(), tmp.path().string()), "a.stl: malformed binary STL"},
             {fmt::format("mhv --meshes '{}/nothing' --out '{}/o'", tmp.path().string(), tmp.path().string()), "is neither a folder"},
             {fmt::format("mhv --bvh '{}/none.bvh' --out '{}/o'", tmp.path().string(), tmp.path().string()), "cannot open BVH file"},
         }) {
        auto result = test::run_amhv(arguments);
        EXPECT_NE(result.exit_code, 0);
        EXPECT_EQ(test::one_line_error(result), 1) << result.output;
        EXPECT_NE(result.output.find(expected), std::string::npos) << result.output;
        EXPECT_FALSE(fs::exists(tmp.path() / "o"));
    }
}

TEST(Bvh, ReadsCmuAndReportsMalformedFilesWithLineNumbers) {
    BvhMotion motion = read_bvh(test::source_dir() / "data/cmu/18_01.bvh");
    EXPECT_EQ(motion.frame_count, 304);
    EXPECT_NEAR(motion.frame_time, 0.0083333, 1e-9);
    EXPECT_EQ(motion.channel_count, 6 + 30 * 3);
    EXPECT_GE(motion.joint_index("RightHand"), 0);

    test::TempDir tmp;
    const std::string header = "HIERARCHY\r\nROOT Hips\n{\n OFFSET 0 0 0\n CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n"
                               " End Site\n {\n  OFFSET 0 1 0\n }\n}\nMOTION\nFrames: 2\nFrame Time: 0.04\n";
    for (const auto& [content, expected] : std::vector<std::pair<std::string, std::string>>{
             {header + "0 0 0 0 0 0\n1 2 3 4 5 6\n", ""},
             {header + "0 0 0 0 0 0\n1 2 3\n", ":15: motion block is truncated: frame 1 of 2 has 3 of 6 values"},
             {header + "0 0 0 0 0 0\n1 2 x 4 5 6\n", ":15: motion value 'x' is not a finite number"},
             {header + "0 0 0 0 0 0\n1 2 3 4 5 6 7\n", ":15: frame 1 has 7 values but the hierarchy declares 6 channels"},
             {"HIERARCHY\nROOT Hips\n{\n OFFSET 0 0 0\n CHANNELS 2 Xposition Wrotation\n}\n", ":5: unknown channel 'Wrotation'"},
             {"HIERARCHY\nROOT Hips\n{\n OFFSET 0 0\n", ":5: file ends where offset was expected"},
             {header.substr(0, header.find("Frames")) + "Frames: 99999999999\nFrame Time: 0.04\n", "frame count"},
         }) {
        auto path = tmp.path() / "test.bvh";
        std::ofstream(path, std::ios::binary) << content;
        if (expected.empty()) {
            BvhMotion ok = read_bvh(path);
            EXPECT_EQ(ok.frame_count, 2);
            auto transforms = ok.global_transforms(1);
            EXPECT_NEAR(transforms[0].translation().x(), 1.0, 1e-12);
        } else {
            try {
                read_bvh(path);
                ADD_FAILURE() << "no error for " << expected;
            } catch (const Error& e) {
                EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
            }
        }
    }
}

TEST(Cli, DevicesListsLavapipeAndMarksTheChosenOne) {
    auto result = test::run_amhv("devices");
    ASSERT_EQ(result.exit_code, 0) << result.output;
    EXPECT_NE(result.output.find("* [0]"), std::string::npos) << result.output;
    EXPECT_NE(result.output.find("max storage buffer range"), std::string::npos);
    EXPECT_NE(result.output.find("subgroup size"), std::string::npos);
    // The sweep's buffers follow the chosen device: read in place where it works in host memory
    // (lavapipe here, an integrated GPU), moved by transfers on a discrete GPU (the GPU machines).
    const std::size_t chosen = result.output.find("* [");
    const std::string chosen_line = chosen == std::string::npos ? "" : result.output.substr(chosen, result.output.find('\n', chosen) - chosen);
    const bool discrete = chosen_line.find("(discrete)") != std::string::npos;
    EXPECT_NE(result.output.find(discrete ? "the sweep's buffers: device-local memory, moved by transfers (a discrete GPU)"
                                          : "the sweep's buffers: host memory, read by the device in place"),
              std::string::npos) << result.output;
    auto missing = test::run_amhv("devices --device 42");
    EXPECT_NE(missing.exit_code, 0);
    EXPECT_EQ(test::one_line_error(missing), 1) << missing.output;
}

TEST(Cli, NoVulkanDriverSaysWhatToInstall) {
    test::TempDir tmp;
    auto result = test::run_amhv(fmt::format("devices 2>&1; VK_ICD_FILENAMES='{}/none.json' VK_DRIVER_FILES='{}/none.json' '{}' devices",
                                             tmp.path().string(), tmp.path().string(), AMHV_BINARY));
    EXPECT_NE(result.exit_code, 0);
    EXPECT_NE(result.output.find("mesa-vulkan-drivers"), std::string::npos) << result.output;
}

}  // namespace
}  // namespace amhv
