// `amhv view DIR [--serve PORT]`: the page of an edited scene (index.html and view/) for an
// existing output folder of `amhv edit`, and, with --serve, a web server for it on 127.0.0.1.
#include <filesystem>
#include <iostream>
#include <unistd.h>

#include "src/io/files.hpp"
#include "src/cli/commands.hpp"
#include "src/core/error.hpp"
#include "src/io/output_dir.hpp"
#include "src/pipeline/page_server.hpp"
#include "src/pipeline/view_page.hpp"

namespace amhv::cli {

namespace {

namespace fs = std::filesystem;

struct ViewArguments {
    std::string dir;
    int port = 0;
};

// The page is written beside the folder's files in a staging folder of its own, then moved into
// place: a failed run leaves the folder as it was. Only folders amhv wrote are touched.
void write_page_into(const fs::path& dir) {
    if (!is_amhv_output(dir))
        fail(dir.string(), "is not an output folder of amhv as it wrote it (no {} listing everything in it): amhv writes its page only "
                           "into folders it made",
             StagedOutput::kMarker);
    const fs::path staging = dir / fmt::format(".view.partial-{}", ::getpid());
    fs::remove_all(staging);
    fs::create_directories(staging);
    try {
        const pipeline::PageReport report = pipeline::write_view_page(dir, staging);
        fs::remove_all(dir / "view");
        fs::rename(staging / "view", dir / "view");
        fs::rename(staging / "index.html", dir / "index.html");
        fs::remove_all(staging);
        write_output_marker(dir);  // the folder's list now holds the page
        std::cout << fmt::format("wrote {}/index.html and view/ ({:.1f} MB): open it in a web browser\n", dir.string(), double(report.bytes) / 1e6);
    } catch (...) {
        fs::remove_all(staging);
        throw;
    }
}

void run_view(const ViewArguments& args) {
    const fs::path dir = args.dir;
    if (!is_folder(dir)) fail(dir.string(), "is not a folder");
    write_page_into(dir);
    if (args.port) pipeline::serve_folder(dir, args.port);
}

}  // namespace

void add_view_command(CLI::App& app) {
    auto args = std::make_shared<ViewArguments>();
    auto* view = app.add_subcommand("view", "Write the page of an edited scene (index.html: the scene playing, each solution group plotted)");
    view->add_option("dir", args->dir, "Output folder of `amhv edit`")->required();
    view->add_option("--serve", args->port, "Then serve the folder on 127.0.0.1:PORT (this machine only) until stopped");
    view->callback([args] { run_view(*args); });
}

}  // namespace amhv::cli
