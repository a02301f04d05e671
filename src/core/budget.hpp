#pragma once
// Budgets before work: every stage that allocates in proportion to its input (a voxel grid, the
// sweep's poses and maps, the DP's grid, resampling, EXR slices, frames) states what it will need
// before it allocates, and a need beyond the machine gets one clear line naming the knob to turn
// instead of an allocation that the kernel kills half way.
#include <cstdint>
#include <filesystem>
#include <string>

namespace amhv::budget {

// The memory a run may use: --max-memory when given, else what the machine has available now
// (MemAvailable in /proc/meminfo).
std::uint64_t memory_limit();
void set_memory_limit(std::uint64_t bytes);

// Throws amhv::Error "WHAT needs ~N GB of memory, more than the M GB available; HINT".
void require_memory(std::uint64_t bytes, const std::string& what, const std::string& hint);
// The same for disk space in the file system holding `where`.
void require_disk(const std::filesystem::path& where, std::uint64_t bytes, const std::string& what, const std::string& hint);

// Memory held for the life of an object (an aMHV): the run's reservations together must stay
// within memory_limit() as it was when the run first asked. Copies reserve again.
class Reservation {
public:
    Reservation() = default;
    // Throws amhv::Error (require_memory's message) when the bytes do not fit beside the others.
    Reservation(std::uint64_t bytes, const std::string& what, const std::string& hint);
    Reservation(const Reservation& other);
    Reservation(Reservation&& other) noexcept;
    Reservation& operator=(Reservation other) noexcept;
    ~Reservation();
    std::uint64_t bytes() const { return bytes_; }

private:
    std::uint64_t bytes_ = 0;
};

// A voxel edge (metres) at which a volume of `bytes` at `voxel` would fit in `limit`, rounded up to
// a whole millimetre: the bytes of a voxel grid go with the inverse cube of the edge.
double voxel_that_fits(double voxel, std::uint64_t bytes, std::uint64_t limit);

}  // namespace amhv::budget
