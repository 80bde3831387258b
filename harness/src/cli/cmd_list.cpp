// scanbench list [algorithms|metrics|datasets|scanners] [--json]
#include <fmt/format.h>

#include <iostream>

#include "cli/commands.h"
#include "scanbench/harness/pipelines/registries.h"

namespace scanbench::harness {

namespace {

// `kind` "algorithm" or "metric" marks each entry's source (built in or a plugin).
void print_text(const std::string& title, const Json& entries) {
  fmt::print("{} ({})\n", title, entries.size());
  for (const auto& e : entries) {
    std::string status;
    if (e.contains("available") && !e["available"].get<bool>()) {
      status = "  [file missing: run scripts/setup.sh]";
    }
    if (e.contains("plugin")) status += "  [plugin " + e["plugin"]["path"].get<std::string>() + "]";
    fmt::print("  {}{}\n      {}\n", e["name"].get<std::string>(), status,
               e["doc"].get<std::string>());
    for (const auto& p : e["params"]) {
      std::string range;
      if (!p["min"].is_null() || !p["max"].is_null()) {
        range = fmt::format(" {}{}, {}{}", p.value("min_exclusive", false) ? "(" : "[",
                            p["min"].is_null() ? "-inf" : p["min"].dump(),
                            p["max"].is_null() ? "inf" : p["max"].dump(),
                            p.value("max_exclusive", false) ? ")" : "]");
      }
      if (p.contains("choices")) {
        std::string c;
        for (const auto& x : p["choices"]) {
          if (!c.empty()) c += '|';
          c += x.get<std::string>();
        }
        range = fmt::format(" {{{}}}", c);
      }
      const std::string unit = p["unit"].get<std::string>();
      fmt::print("      {:<22} {:<7} default {}{}{}  {}\n", p["name"].get<std::string>(),
                 p["type"].get<std::string>(), p["default"].dump(), range,
                 unit.empty() ? "" : " " + unit, p["doc"].get<std::string>());
    }
  }
  fmt::print("\n");
}

}  // namespace

void add_list_command(Cli& cli) {
  struct Opts {
    std::string kind;
    bool json = false;
  };
  auto opts = std::make_shared<Opts>();
  CLI::App* sub = cli.app.add_subcommand(
      "list",
      "List registered algorithms, metrics, datasets and scanner presets with their "
      "parameters (defaults, ranges, units, docs)");
  sub->add_option("kind", opts->kind, "Only this kind")
      ->check(CLI::IsMember({"algorithms", "metrics", "datasets", "scanners"}));
  sub->add_flag("--json", opts->json,
                "One JSON object with arrays algorithms, metrics, datasets, scanners");
  sub->callback([&cli, opts] {
    cli.action = [opts] {
      const Json all = registries_json(opts->kind);
      if (opts->json) {
        std::cout << all.dump(2) << "\n";
      } else {
        for (const auto& [k, v] : all.items())
          print_text(k, v);
      }
      return 0;
    };
  });
}

}  // namespace scanbench::harness
