#include "scanbench/algorithms/peers/external.h"

#include <fmt/format.h>

#include <cctype>
#include <map>
#include <set>
#include <sstream>

#include "input_checks.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/io.h"
#include "scanbench/core/run_program.h"

namespace scanbench::algorithms {

namespace {

std::string shell_quote(std::string_view s) {
  std::string q = "'";
  for (const char c : s) {
    if (c == '\'') {
      q += "'\\''";
    } else {
      q += c;
    }
  }
  return q + "'";
}

bool valid_name(std::string_view n) {
  if (n.empty()) return false;
  for (const char c : n) {
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_')) return false;
  }
  return true;
}

// Writes the input, runs the command, checks the output file; returns its path.
template <class Read>
auto run_external(const StageData& in, const ExternalParams& p, RunContext& ctx,
                  std::string_view stage, std::string_view what, Read read) {
  detail::check_points(in.points, stage);
  const programs::TempDir dir("external");
  const auto input = dir.path() / "input.ply";
  const auto output = dir.path() / ("output" + p.extension);
  const std::string command = expand_command(p, input.string(), output.string(), stage);
  write_point_cloud(in.points, input);
  {
    auto timer = ctx.phase("external");
    programs::run_program({"/bin/sh", "-c", command}, dir.path(), p.timeout_s, stage, ctx);
  }
  programs::require_output(output, dir.path(), p.command, what, stage);
  try {
    return read(output);
  } catch (const IoError& e) {
    throw Error(fmt::format("{}: '{}' exited with code 0 but its output is not a valid {}: {}",
                            stage, p.command, what, e.what()));
  }
}

}  // namespace

std::string expand_command(const ExternalParams& p, const std::string& in, const std::string& out,
                           std::string_view stage) {
  const std::string where = fmt::format("{}.command", stage);
  std::map<std::string, std::string, std::less<>> vars;
  {
    std::istringstream s(p.vars);
    std::string pair;
    while (s >> pair) {
      const std::size_t eq = pair.find('=');
      const std::string name = pair.substr(0, eq);
      if (eq == std::string::npos || !valid_name(name)) {
        throw ParamError(
            fmt::format("{}.vars: '{}' is not name=value (name: letters, digits, _)", stage, pair));
      }
      if (name == "in" || name == "out" || !vars.emplace(name, pair.substr(eq + 1)).second) {
        throw ParamError(fmt::format("{}.vars: '{}' is reserved or repeated", stage, name));
      }
    }
  }
  if (p.command.empty()) throw ParamError(fmt::format("{}: empty (required)", where));
  std::string result;
  std::set<std::string, std::less<>> used;
  const std::string& c = p.command;
  for (std::size_t i = 0; i < c.size(); ++i) {
    if (c[i] == '{' && i + 1 < c.size() && c[i + 1] == '{') {
      result += '{';
      ++i;
    } else if (c[i] == '}' && i + 1 < c.size() && c[i + 1] == '}') {
      result += '}';
      ++i;
    } else if (c[i] == '{') {
      const std::size_t end = c.find('}', i);
      if (end == std::string::npos) throw ParamError(fmt::format("{}: unclosed '{{'", where));
      const std::string name = c.substr(i + 1, end - i - 1);
      if (name == "in") {
        result += shell_quote(in);
      } else if (name == "out") {
        result += shell_quote(out);
      } else if (auto it = vars.find(name); it != vars.end()) {
        result += shell_quote(it->second);
      } else {
        throw ParamError(fmt::format(
            "{}: unknown placeholder {{{}}} (known: {{in}}, {{out}} and the names of vars)", where,
            name));
      }
      used.insert(name);
      i = end;
    } else if (c[i] == '}') {
      throw ParamError(fmt::format("{}: unmatched '}}' (write }}}} for a literal brace)", where));
    } else {
      result += c[i];
    }
  }
  if (!used.count("out")) throw ParamError(fmt::format("{}: has no {{out}}", where));
  for (const auto& v : vars) {
    if (!used.count(v.first)) {
      throw ParamError(fmt::format("{}.vars: '{}' is not used by the command (no {{{}}})", stage,
                                   v.first, v.first));
    }
  }
  return result;
}

PointCloud external_points(const StageData& in, const ExternalParams& p, RunContext& ctx) {
  constexpr const char* stage = "external.points";
  return run_external(in, p, ctx, stage, "point cloud",
                      [](const std::filesystem::path& f) { return read_point_cloud(f); });
}

StageData external_mesh(const StageData& in, const ExternalParams& p, RunContext& ctx) {
  constexpr const char* stage = "external.mesh";
  StageData out;
  out.mesh = run_external(in, p, ctx, stage, "mesh",
                          [](const std::filesystem::path& f) { return read_mesh(f); });
  return out;
}

}  // namespace scanbench::algorithms
