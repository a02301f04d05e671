#pragma once
// The surface of an object's part at one frame, as a key segment names it (interest or fidelity:
// labelled parts, parts but some, a separate mesh sequence, a box, or the whole body), in the
// object's capture frame: for pictures and measures that look at the parts themselves rather than
// their voxels (the key views' camera, contact measures).
#include <vector>

#include "src/core/geometry.hpp"
#include "src/scene/scene.hpp"
#include "src/scene/segment.hpp"

namespace amhv {

// The triangles of `spec` at source frame `number` of `source` (capture frame, metres, z up). A box
// keeps the whole body's triangles whose centroid lies in it; WholeMinusInterest gives nothing.
TriangleMesh part_surface(ObjectSource& source, const PartSpec& spec, int number);

// For each triangle of the whole body at frame `number` (its parts in order, as placed_mesh joins
// them): whether it belongs to `spec`'s part. A part given as its own mesh sequence marks none.
std::vector<bool> part_triangles(ObjectSource& source, const PartSpec& spec, int number);

// Every part name the key segments give (interest and fidelity, parts and parts_except) is one of
// its object's parts (`sources[o]` for scene.objects[o]; a labelled mesh sequence's names from the
// first frame of each key segment): else one line naming the scene's line, the object and the
// part, with the parts the object has.
void check_part_names(const Scene& scene, const std::vector<ObjectSource*>& sources);

}  // namespace amhv
