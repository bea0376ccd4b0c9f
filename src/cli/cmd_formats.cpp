// `spikems formats`: the event formats this build reads and writes.
#include <cstdio>

#include "cli/command.h"
#include "core/events/io.h"

namespace {

void add(CLI::App& app) {
  auto* cmd = app.add_subcommand("formats", "List the event file formats spikems reads and writes");
  cmd->footer(
      "Example:\n"
      "  spikems formats   (then: spikems convert recording.raw recording.h5)\n"
      "Details of each format: docs/formats.md.");
  cmd->callback([] {
    std::printf("%-12s %-5s %-6s %-24s %s\n", "name", "read", "write", "extensions", "description");
    for (const auto& f : spikems::formats()) {
      std::string ext;
      for (const auto& e : f.extensions) ext += (ext.empty() ? "" : " ") + e;
      std::printf("%-12s %-5s %-6s %-24s %s\n", f.name.c_str(), "yes", f.open_writer ? "yes" : "no",
                  ext.c_str(), f.description.c_str());
    }
  });
}

}  // namespace

SPIKEMS_COMMAND(formats, 90, add);
