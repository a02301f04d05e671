#pragma once
// What every fuzz target shares (libFuzzer; docs/design.md, "Fuzzing"): a private folder for the
// input's file, a small memory budget (so that a file that asks for gigabytes is refused by the
// budget, as on a small machine, instead of tripping the fuzzer's RSS limit), and the rule that a
// reader may refuse an input only with amhv::Error: any other exception, crash, leak or hang is
// a finding.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <unistd.h>

#include "src/core/budget.hpp"
#include "src/core/error.hpp"

namespace amhv::fuzz {

// A folder of this process's own, made once.
inline const std::filesystem::path& folder() {
    static const std::filesystem::path dir = [] {
        const std::filesystem::path d = std::filesystem::temp_directory_path() / ("amhv-fuzz-" + std::to_string(::getpid()));
        std::filesystem::create_directories(d);
        budget::set_memory_limit(std::uint64_t(512) << 20);
        return d;
    }();
    return dir;
}

// Writes the input as `name` in the folder and returns its path.
inline std::filesystem::path write_input(const std::string& name, const std::uint8_t* data, std::size_t size) {
    const std::filesystem::path path = folder() / name;
    std::filesystem::create_directories(path.parent_path());
    std::ofstream(path, std::ios::binary | std::ios::trunc).write(reinterpret_cast<const char*>(data), std::streamsize(size));
    return path;
}

// Runs `read`; amhv::Error is a refusal, everything else propagates (and the fuzzer reports it).
template <typename Read>
int refusals_only(Read&& read) {
    try {
        read();
    } catch (const Error&) {
    }
    return 0;
}

}  // namespace amhv::fuzz
