#pragma once
// Structural checks of a mesh file made before OpenMesh reads it. OpenMesh trusts a file's
// header: counts that promise more data than the file holds make it allocate without bound, and
// some malformed headers crash it. Every check here is bounded by the file's size.
#include <filesystem>

namespace amhv {

// Refuses (amhv::Error naming the file and line) a mesh file whose structure OpenMesh must not
// see: counts beyond the file's size, indices beyond its vertices, non-finite coordinates, binary
// PLY rows whose lists run past the file, header forms amhv does not read (binary or 4D OFF). An OBJ's
// appearance (materials, under `files_root`) is checked too, so that a missing library is named.
void precheck_mesh_file(const std::filesystem::path& path, const std::filesystem::path& files_root);

}  // namespace amhv
