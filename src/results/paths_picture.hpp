#pragma once
// paths.svg and paths.png: every performer's root path seen from above, for a reader who has not
// read the code: a legend names each performer by its colour, says captured (dashed, at the
// editor's placement) and edited (solid), shows how key segments (thick, numbered) and facings
// (ticks every 10 output frames) look; axes in metres with a grid and a 1 m scale bar. The PNG is
// the same drawing as the SVG, its text drawn from one font file (src/results/picture.hpp).
#include <array>
#include <filesystem>
#include <string>
#include <vector>

#include "src/edit/edit.hpp"

namespace amhv {

// One object of a paths picture: its frames and its key segments (index, first output frame,
// length), drawn thick on its edited path and numbered.
struct PathsObject {
    std::string name;
    const std::vector<ObjectFrameEdit>* frames = nullptr;
    std::vector<std::array<int, 3>> keys;
};

// Any number of objects, over their output frames, which every object has the same number of (the
// two-object picture is this with A and B sharing every key segment).
void write_paths_picture(const std::filesystem::path& svg, const std::filesystem::path& png, const std::vector<PathsObject>& objects);

}  // namespace amhv
