// The process's memory (core/process.hpp): large blocks from the replaced operator new and from the
// volumes' zeroed allocator carry the huge-page advice, seen as "hg" in the VmFlags of their
// mapping in /proc/self/smaps (set whether or not the kernel then finds huge pages for it).
#include <csignal>
#include <cstdint>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "src/core/amhv.hpp"
#include "src/core/contained.hpp"
#include "src/core/error.hpp"
#include "src/core/sanitizers.hpp"
#include "src/core/process.hpp"
#include "support.hpp"

namespace amhv {
namespace {

// The VmFlags of the mapping holding `address`, or "" when no mapping holds it.
std::string vm_flags_at(const void* address) {
    const auto at = reinterpret_cast<std::uintptr_t>(address);
    std::ifstream smaps("/proc/self/smaps");
    std::string line;
    bool inside = false;
    while (std::getline(smaps, line)) {
        std::uintptr_t start = 0, end = 0;
        char dash = 0;
        std::istringstream header(line);
        if (header >> std::hex >> start >> dash >> end && dash == '-') {
            inside = start <= at && at < end;
            continue;
        }
        if (inside && line.rfind("VmFlags:", 0) == 0) return line;
    }
    return "";
}

// An address inside the block's 2 MiB-aligned part, the part the advice covers.
const void* aligned_inside(const void* block) {
    const auto start = reinterpret_cast<std::uintptr_t>(block);
    return reinterpret_cast<const void*>((start + kHugePageBytes - 1) & ~std::uintptr_t(kHugePageBytes - 1));
}

bool advised(const std::string& flags) { return flags.find(" hg") != std::string::npos; }

#if defined(AMHV_ASAN)
constexpr bool kSanitized = true;  // the sanitizer's runtime keeps its own allocator
#else
constexpr bool kSanitized = false;
#endif

TEST(Process, LargeBlocksFromOperatorNewAreAdvisedHugePages) {
    if (kSanitized) GTEST_SKIP() << "operator new is the sanitizer's";
    const std::size_t bytes = 8 * kHugePageBytes;
    const auto block = std::make_unique<std::uint8_t[]>(bytes);
    const std::string flags = vm_flags_at(aligned_inside(block.get()));
    ASSERT_FALSE(flags.empty()) << "no mapping holds the block";
    EXPECT_TRUE(advised(flags)) << flags;
    std::vector<std::uint32_t> words(bytes / 4, 1u);
    EXPECT_TRUE(advised(vm_flags_at(aligned_inside(words.data())))) << "a standard container's block";
}

TEST(Process, ZeroedVolumeBlocksAreAdvisedHugePagesAndZero) {
    if (kSanitized) GTEST_SKIP() << "calloc is the sanitizer's";
    release_recycled_volume();  // a fresh block from calloc, not the one kept
    std::vector<std::uint32_t, ZeroedAllocator<std::uint32_t>> mask;
    mask.resize(8 * kHugePageBytes / 4);
    EXPECT_TRUE(advised(vm_flags_at(aligned_inside(mask.data()))));
    for (std::size_t w = 0; w < mask.size(); w += 4093) ASSERT_EQ(mask[w], 0u) << "word " << w;
}

// Work run contained (core/contained.hpp): its answer comes back whole, its amhv::Error as itself,
// and a crash, a hang or an exception from a library as one line naming the file; amhv goes on.
TEST(Contained, AnswersErrorsAndCrashesComeBackAsOneLine) {
    std::string big(3 << 20, 'x');  // past a pipe's buffer: the parent reads while the child writes
    big[12345] = 'y';
    EXPECT_EQ(run_contained("f.glb", [&] { return big; }), big);
    auto message = [](const std::function<std::string()>& work, ContainLimits limits = {}) {
        try {
            run_contained("f.glb", work, limits);
        } catch (const Error& e) {
            return std::string(e.what());
        }
        return std::string("(no error)");
    };
    EXPECT_EQ(message([]() -> std::string { fail("f.glb", "holds no animation"); }), "f.glb: holds no animation");
    EXPECT_EQ(message([]() -> std::string { throw std::runtime_error("DeadlyImportError: secret text"); }),
              "f.glb: cannot be read: the reader failed on it");
    const std::string crash = message([]() -> std::string {
        std::raise(SIGSEGV);
        return "";
    });
    // (Under AddressSanitizer its handler reports the fault and exits instead.)
    EXPECT_EQ(crash.rfind(test::kAddressSanitizer ? "f.glb: cannot be read: the reader (assimp) "
                                            : "f.glb: cannot be read: the reader (assimp) crashed on it with a segmentation fault (SIGSEGV)",
                          0),
              0u)
        << crash;
    const std::string hang = message(
        []() -> std::string {
            for (;;) std::this_thread::sleep_for(std::chrono::milliseconds(10));
        },
        ContainLimits{1});
    EXPECT_EQ(hang, "f.glb: its reader took over 1 s and was stopped");
}

}  // namespace
}  // namespace amhv
