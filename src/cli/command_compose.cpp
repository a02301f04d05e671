// `amhv compose`: a performer's take composed from a library of captured clips: actions recognised
// from a few labelled examples, a motion graph of splice points, and the cheapest path through it
// that performs the requested actions in order.
#include <iostream>
#include <optional>

#include <fmt/format.h>

#include "src/cli/commands.hpp"
#include "src/compose/compose_files.hpp"
#include "src/io/output_dir.hpp"

namespace amhv::cli {

namespace {

struct ComposeArguments {
    std::string library, actions, out;
};

void run_compose(const ComposeArguments& args) {
    using namespace amhv::compose;
    const Library library = read_library(args.library);
    std::optional<std::vector<ActionQuery>> query;
    if (!args.actions.empty()) query = parse_actions(args.actions, library);
    std::vector<std::filesystem::path> inputs{library.file};
    for (const LibraryTake& take : library.takes) inputs.push_back(take.file);
    StagedOutput out(args.out, inputs);
    const Recognition recognition = recognise(library, library_features(library));
    const MotionGraph graph = build_graph(library, recognition);
    std::optional<Composed> composed;
    if (query) {
        Composed c;
        c.query = *query;
        c.path = cheapest_path(library, graph, c.query);
        c.spliced = splice(library, c.path.clips);
        c.quality = splice_quality(library, c.spliced, c.path.clips);
        composed = std::move(c);
    }
    write_compose_files(out.dir(), library, recognition, graph, composed);
    out.commit();
    std::cout << fmt::format("{} takes, {} actions: {} nodes, {} splices\n", library.takes.size(), library.actions.size(), graph.nodes.size(),
                             graph.edges.size());
    if (composed) {
        for (std::size_t k = 0; k < composed->path.clips.size(); ++k) {
            const Clip& clip = composed->path.clips[k];
            std::cout << fmt::format("  {:<14} take {} frames {}..{}\n", composed->query[k].action, library.takes[std::size_t(clip.take)].name, clip.first, clip.last);
        }
        std::cout << fmt::format("wrote {}/: take.bvh ({} frames at {} fps), compose.json, index.html, labels.json, graph.json\n", out.target().string(),
                                 composed->spliced.motion.frame_count, library.fps);
    } else {
        std::cout << fmt::format("wrote {}/: index.html, labels.json, graph.json (give --actions to compose a take)\n", out.target().string());
    }
}

}  // namespace

void add_compose_command(CLI::App& app) {
    auto args = std::make_shared<ComposeArguments>();
    auto* command = app.add_subcommand("compose", "Compose a take from a library of clips: recognise actions from examples, splice along a motion graph");
    command->add_option("library", args->library, "Library file (TOML: [[takes]] and [[examples]])")->required();
    command->add_option("--actions", args->actions, "Actions in order, as \"walk, shake_hands:1-2, walk\" (durations in seconds)");
    command->add_option("--out", args->out, "Output folder (replaced as a whole when the run succeeds)")->required();
    command->callback([args] { run_compose(*args); });
}

}  // namespace amhv::cli
