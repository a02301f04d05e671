// Fuzz target: one character file through read_character (assimp, in its contained child) and
// build_character_body (the rig by role, the surface closed and cut), then one frame posed. A
// glTF binary (its "glTF" magic) is written as c.glb, anything else as c.gltf (JSON).
//
// assimp's own crashes and hangs end the child and come back as amhv::Error (a refusal): the
// target finds what amhv does with what assimp hands it. A sanitizer's report in the child
// (it exits with status 1) is made a finding here.
#include <cstdlib>
#include <cstring>
#include <memory>

#include "src/body/character_body.hpp"
#include "tests/fuzz/fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace amhv;
    const bool binary = size >= 4 && std::memcmp(data, "glTF", 4) == 0;
    const auto path = fuzz::write_input(binary ? "c.glb" : "c.gltf", data, size);
    try {
        auto file = std::make_shared<const CharacterFile>(read_character(path, std::nullopt, 30.0));
        const auto body = build_character_body(file);
        character_body_parts(*body, 0, UnitsAndAxes{1.0, UpAxis::Y});
    } catch (const Error& e) {
        if (std::strstr(e.what(), "without an answer (exit status 1)")) std::abort();  // a sanitizer's report in the child
    }
    return 0;
}
