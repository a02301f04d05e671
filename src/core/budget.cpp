#include "src/core/budget.hpp"

#include <atomic>
#include <cmath>
#include <fstream>
#include <sstream>
#include <utility>

#include "src/core/error.hpp"

namespace amhv::budget {

namespace {

std::atomic<std::uint64_t> g_limit{0};  // 0: the machine's
std::atomic<std::uint64_t> g_held{0};   // all Reservations together

std::uint64_t available_memory() {
    std::ifstream in("/proc/meminfo");
    std::string line;
    while (std::getline(in, line)) {
        std::istringstream words(line);
        std::string key;
        std::uint64_t kib = 0;
        if (words >> key >> kib && key == "MemAvailable:") return kib * 1024;
    }
    return std::uint64_t(1) << 62;  // unknown: no limit of ours
}

std::string gigabytes(std::uint64_t bytes) { return fmt::format("{:.1f} GB", double(bytes) / 1e9); }

// The limit reservations are held to: --max-memory, or what was available when the first one was made.
std::uint64_t reservation_limit() {
    if (const std::uint64_t set = g_limit.load()) return set;
    static const std::uint64_t at_start = available_memory();
    return at_start;
}

// "WHAT needs ~N GB of memory[ beside the H GB the run already holds], more than the M GB ...; HINT".
[[noreturn]] void too_much_memory(const std::string& what, std::uint64_t bytes, std::uint64_t held, std::uint64_t limit, const char* source,
                                  const std::string& hint) {
    const std::string others = held > 0 ? fmt::format(" beside the {} the run already holds", gigabytes(held)) : "";
    throw Error(fmt::format("{} needs ~{} of memory{}, more than the {} {}; {}", what, gigabytes(bytes), others, gigabytes(limit),
                            g_limit.load() ? "--max-memory allows" : source, hint));
}

}  // namespace

std::uint64_t memory_limit() {
    const std::uint64_t set = g_limit.load();
    return set ? set : available_memory();
}

void set_memory_limit(std::uint64_t bytes) { g_limit.store(bytes); }

void require_memory(std::uint64_t bytes, const std::string& what, const std::string& hint) {
    const std::uint64_t limit = memory_limit();
    if (bytes > limit) too_much_memory(what, bytes, 0, limit, "this machine has available", hint);
}

void require_disk(const std::filesystem::path& where, std::uint64_t bytes, const std::string& what, const std::string& hint) {
    std::error_code ec;
    const auto space = std::filesystem::space(where, ec);
    if (ec || bytes <= space.available) return;
    throw Error(fmt::format("{} needs ~{} of disk, more than the {} free at {}; {}", what, gigabytes(bytes), gigabytes(space.available),
                            where.string(), hint));
}

Reservation::Reservation(std::uint64_t bytes, const std::string& what, const std::string& hint) {
    const std::uint64_t limit = reservation_limit(), held = g_held.fetch_add(bytes) + bytes;
    if (held > limit) {
        g_held.fetch_sub(bytes);
        too_much_memory(what, bytes, held - bytes, limit, "this machine had available", hint);
    }
    bytes_ = bytes;
}

Reservation::Reservation(const Reservation& other) : bytes_(other.bytes_) { g_held.fetch_add(bytes_); }
Reservation::Reservation(Reservation&& other) noexcept : bytes_(std::exchange(other.bytes_, 0)) {}
Reservation& Reservation::operator=(Reservation other) noexcept {
    std::swap(bytes_, other.bytes_);
    return *this;
}
Reservation::~Reservation() { g_held.fetch_sub(bytes_); }

double voxel_that_fits(double voxel, std::uint64_t bytes, std::uint64_t limit) {
    const double scale = std::cbrt(double(bytes) / double(std::max<std::uint64_t>(limit, 1)));
    return std::ceil(voxel * scale * 1000.0 * 1.05) / 1000.0;
}

}  // namespace amhv::budget
