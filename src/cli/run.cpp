#include <csignal>
#include <exception>
#include <filesystem>
#include <new>
#include <iostream>

#include <fmt/format.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include "src/cli/commands.hpp"
#include "src/core/budget.hpp"
#include "src/core/error.hpp"

namespace amhv::cli {

int run(int argc, char** argv, const char* commit) {
    // Past a file size limit (ulimit -f) a write then fails with EFBIG, which the checked writes
    // report, instead of the signal killing the run without a word.
    std::signal(SIGXFSZ, SIG_IGN);
    auto logger = spdlog::stderr_color_mt("amhv");
    logger->set_pattern("amhv: %^%l%$: %v");
    spdlog::set_default_logger(logger);

    CLI::App app{"amhv: spatiotemporal editing of two separately captured performances with augmented Motion History Volumes"};
    app.set_version_flag("--version", fmt::format("amhv {} (commit {})", AMHV_VERSION, commit));
    app.require_subcommand(1);
    app.fallthrough();  // --max-memory, -q, -v also after the subcommand
    bool quiet = false, verbose = false;
    app.add_flag("-q,--quiet", quiet, "Only errors");
    app.add_flag("-v,--verbose", verbose, "More detail");
    double max_memory_gb = 0;
    app.add_option("--max-memory", max_memory_gb, "Memory a run may use, in GB (default: what the machine has available)")
        ->check(CLI::PositiveNumber);
    app.parse_complete_callback([&] {
        if (max_memory_gb > 0) budget::set_memory_limit(std::uint64_t(max_memory_gb * 1e9));
        spdlog::set_level(quiet ? spdlog::level::err : verbose ? spdlog::level::debug : spdlog::level::info);
    });
    add_devices_command(app);
    add_mhv_command(app);
    add_import_bvh_command(app);
    add_compose_command(app);
    add_scene_commands(app);
    add_edit_command(app);
    add_probe_command(app);
    add_propose_command(app);
    add_view_command(app);
    add_shard_commands(app);
    try {
        app.parse(argc, argv);
    } catch (const CLI::CallForHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForAllHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForVersion& e) {
        return app.exit(e);
    } catch (const CLI::ParseError& e) {
        std::cerr << "amhv: error: " << e.what() << " (see --help)\n";
        return e.get_exit_code() ? e.get_exit_code() : 2;
    } catch (const Error& e) {
        std::cerr << "amhv: error: " << escape_controls(e.what()) << '\n';
        return 1;
    } catch (const std::bad_alloc&) {
        const std::string file = ReadingFile::current();
        if (!file.empty())
            std::cerr << "amhv: error: " << escape_controls(file)
                      << ": out of memory while reading it: the file needs more memory than this machine has (is it what it claims to be?)\n";
        else
            std::cerr << "amhv: error: out of memory: use a larger voxel, a narrower x/y range or fewer frames (--max-memory sets the budget)\n";
        return 1;
    } catch (const std::filesystem::filesystem_error& e) {
        std::cerr << "amhv: error: " << escape_controls(e.path1().string()) << ": " << e.code().message() << '\n';
        return 1;
    } catch (const std::exception& e) {
        std::cerr << "amhv: error: internal failure (please report it): " << printable(e.what(), 200) << '\n';
        return 1;
    }
    return 0;
}

}  // namespace amhv::cli
