// scanbench list [algorithms|metrics|datasets|scanners] [--json]
#include <fmt/format.h>

#include <iostream>

#include "cli/commands.h"
#include "scanbench/algorithms/registry.h"
#include "scanbench/core/datasets.h"
#include "scanbench/harness/config/plugins.h"
#include "scanbench/metrics/registry.h"
#include "scanbench/scanner/registry.h"

namespace scanbench::harness {

namespace {

// `kind` "algorithm" or "metric" marks each entry's source (built in or a plugin).
template <class R>
Json entries_json(const R& reg, std::string_view kind = "") {
  Json a = Json::array();
  for (const auto& e : reg.entries()) {
    a.push_back(e.to_json());
    if (!kind.empty()) mark_source(a.back(), kind);
  }
  return a;
}

Json datasets_json() {
  Json a = Json::array();
  for (const auto& e : datasets().entries()) {
    Json j = e.to_json();
    j["procedural"] = e.fn.file.empty();
    j["file"] = e.fn.file.empty() ? Json(nullptr) : Json(e.fn.file.string());
    j["available"] = e.fn.available();
    a.push_back(std::move(j));
  }
  return a;
}

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
      Json all = Json::object();
      auto want = [&](const char* k) { return opts->kind.empty() || opts->kind == k; };
      if (want("algorithms")) all["algorithms"] = entries_json(algorithms::registry(), "algorithm");
      if (want("metrics")) all["metrics"] = entries_json(metrics::registry(), "metric");
      if (want("datasets")) all["datasets"] = datasets_json();
      if (want("scanners")) all["scanners"] = entries_json(scanner::presets());
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
