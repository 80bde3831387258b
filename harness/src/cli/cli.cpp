#include "scanbench/harness/cli/cli.h"

#include <fmt/format.h>

#include <cstdio>
#include <filesystem>
#include <string_view>

#include "cli/commands.h"
#include "config/json_checks.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/run_program.h"
#include "scanbench/core/simd.h"
#include "scanbench/core/version.h"
#include "scanbench/harness/config/plugins.h"
#include "scanbench/harness/exec/runner.h"

namespace scanbench::harness {

namespace {

/// An environment failure (a read-only folder, a file where a folder should be, a name too long)
/// as one line: the path, what failed and the reason, without the library's prefix.
std::string filesystem_line(const std::filesystem::filesystem_error& e) {
  std::string what = e.what();
  constexpr std::string_view prefix = "filesystem error: ";
  if (what.rfind(prefix, 0) == 0) what.erase(0, prefix.size());
  if (const auto at = what.find(" ["); at != std::string::npos) what.erase(at);
  return e.path1().empty() ? what : fmt::format("{}: {}", e.path1().string(), what);
}

/// Handles what CLI11 reports as "A subcommand is required": no arguments (the help, exit 2),
/// `help` and `help CMD` (the help, exit 0), and a first argument that names no command (one line
/// with a suggestion, exit 2). Returns -1 for everything else, which CLI11 parses.
int help_or_unknown(const CLI::App& app, int argc, char** argv) {
  std::vector<std::string> names;
  for (const CLI::App* sub : app.get_subcommands([](const CLI::App* a) {
         return !a->get_group().empty();  // the hidden ones (job, slurm-task) are not offered
       })) {
    names.push_back(sub->get_name());
  }
  auto unknown = [&](const std::string& name) {
    std::fprintf(stderr, "scanbench: unknown command '%s'%s; `scanbench help` lists the commands\n",
                 name.c_str(), did_you_mean(name, names).c_str());
    return 2;
  };
  if (argc < 2) {
    std::fputs(app.help().c_str(), stdout);
    return 2;
  }
  const std::string first = argv[1];
  if (first == "help") {
    if (argc == 2) {
      std::fputs(app.help().c_str(), stdout);
      return 0;
    }
    const std::string name = argv[2];
    for (const CLI::App* sub : app.get_subcommands({})) {
      if (sub->get_name() == name) {
        std::fputs(sub->help().c_str(), stdout);
        return 0;
      }
    }
    return unknown(name);
  }
  if (first.empty() || first.front() == '-') return -1;  // options (--version, --plugin F)
  for (const CLI::App* sub : app.get_subcommands({}))
    if (sub->get_name() == first) return -1;
  return unknown(first);
}

}  // namespace

int run_cli(int argc, char** argv) {
  // Every process a step starts is this process's to end (run_program.h): orphans come here.
  programs::become_subreaper();
  Cli cli;
  // The SIMD path (SCANBENCH_ISA is checked here, once, for every command: an ISA this binary or
  // CPU lacks is a one-line error).
  std::string isa;
  try {
    isa = simd::describe();
  } catch (const Error& e) {
    std::fprintf(stderr, "scanbench: %s\n", e.what());
    return 2;
  }
  cli.app.set_version_flag("--version", fmt::format("scanbench {} (commit {})\nsimd: {}",
                                                    version_string(), git_commit(), isa));
  cli.app.require_subcommand(1);
  // Plugins (docs/plugins.md), loaded before any command runs: SCANBENCH_PLUGIN_PATH, then these.
  std::vector<std::string> plugin_files;
  cli.app
      .add_option("--plugin", plugin_files,
                  "Load a plugin (a shared library of algorithms and metrics, "
                  "scanbench/plugin.h) before the command; repeatable")
      ->type_name("FILE");

  // One explicit list of subcommands.
  add_list_command(cli);
  add_scan_command(cli);
  add_import_command(cli);
  add_algo_command(cli);
  add_bench_command(cli);
  add_eval_command(cli);
  add_run_command(cli);
  add_job_command(cli);
  add_table_command(cli);
  add_compare_command(cli);
  add_report_command(cli);
  add_figure_command(cli);
  add_nightly_command(cli);
  add_status_command(cli);
  add_merge_command(cli);
  add_slurm_task_command(cli);
  add_claims_command(cli);
  add_history_command(cli);

  // `scanbench help [CMD]`, no command at all, and an unknown command named as such.
  if (const int code = help_or_unknown(cli.app, argc, argv); code >= 0) return code;
  try {
    cli.app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = cli.app.exit(e);
    return code == 0 ? 0 : 2;
  }
  try {
    load_plugins_from_env();
    for (const auto& f : plugin_files)
      load_plugin(f, "--plugin");
  } catch (const Error& e) {
    std::fprintf(stderr, "scanbench: %s\n", e.what());
    return 2;
  }
  try {
    return cli.action ? cli.action() : 0;
  } catch (const Interrupted& e) {
    std::fprintf(stderr, "scanbench: %s\n", e.what());
    return 130;  // the shell's code for a process stopped by SIGINT
  } catch (const Error& e) {
    std::fprintf(stderr, "scanbench: %s\n", e.what());
    return 2;
  } catch (const std::filesystem::filesystem_error& e) {
    // The environment, not scanbench: exit 2 like bad input (3 is for scanbench's own faults).
    std::fprintf(stderr, "scanbench: %s\n", filesystem_line(e).c_str());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "scanbench: internal error: %s\n", e.what());
    return 3;
  }
}

}  // namespace scanbench::harness
