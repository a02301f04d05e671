#pragma once
// Tolerance that still touches (docs/method.md section 7c): with `contact_tolerance` the group
// holds poses whose parts only come within the tolerance, and the DP may choose one where they
// hover. Each such key's choice is then moved to the nearest member of its group, at the same turn
// and height, where the parts meet without the tolerance (the CPU reference decides, on the key
// built again without it), or kept, with the reason, when no member within the tolerance does.
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "host/choose/chain_dp.hpp"
#include "src/edit/edit.hpp"

namespace amhv {

class PoseProber;
struct SegmentBuild;

// The key segments built again without their tolerance, each once across the edit's retries of
// the chain (a retry moves the choice, not the keys).
class ExactKeys {
public:
    ExactKeys();
    ~ExactKeys();
    const PoseProber& prober(const Scene& scene, std::size_t key, ObjectSource& a, ObjectSource& b, Voxeliser& voxeliser);

private:
    std::map<std::size_t, std::pair<std::unique_ptr<SegmentBuild>, std::unique_ptr<PoseProber>>> built_;
};

// Moves `choice` in place; one entry per key segment with a contact tolerance (0&0 (a) and (b)).
std::vector<TouchUp> touch_up_choice(const Scene& scene, const std::vector<KeySweep>& sweeps, ObjectSource& a, ObjectSource& b,
                                     Voxeliser& voxeliser, const std::vector<bool>& captured, ExactKeys& exact, ChainChoice& choice);

}  // namespace amhv
