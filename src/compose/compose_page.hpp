#pragma once
// index.html of `amhv compose`: a strip per take with every frame's action, and for a query the
// composed take as a timeline of its clips and splices. One static file, no scripts.
#include <optional>
#include <string>

#include "src/compose/compose_files.hpp"

namespace amhv::compose {

std::string compose_page(const Library& library, const Recognition& recognition, const MotionGraph& graph, const std::optional<Composed>& composed);

// Text with &, <, >, " and ' replaced by their entities (names come from input files).
std::string html_text(const std::string& text);

}  // namespace amhv::compose
