#pragma once
// external.points / external.mesh: any program as a step. The step's input points are written
// as a binary PLY (core/io.h: x y z, nx ny nz when present, weight, scan_id, further float
// properties) to {in}; the program must write its output to {out} (`extension` .ply or .off): a
// point cloud (external.points: a PLY point cloud or point-only OFF) or a triangle mesh
// (external.mesh: PLY or OFF faces, polygons fan-triangulated), which becomes the step's product.
//
// `command` is a template run by /bin/sh -c in a private temporary directory (the working
// directory: give programs by absolute path or PATH), with placeholders replaced by their
// shell-quoted values:
//   {in}, {out}   the input and output files,
//   {name}        the value of `name` in `vars`, whitespace-separated name=value pairs (e.g.
//                 "depth=7 samples=1.5"; sweep them as one string),
//   {{ and }}     literal braces.
// A placeholder that is neither {in}, {out} nor a name of `vars`, an unused name of `vars`, and a
// command without {out} are ParamErrors (before anything runs): a typo must not silently drop
// an argument. The output kind cannot be a parameter, because a step's stage data kinds are
// declared per registry entry and type-checked when a config loads; hence two entries.
//
// Failures are Errors naming the step and ending with the program's last log lines: not found
// (sh's exit code 127), a non-zero exit code, a signal, the timeout (`timeout_s`, the process
// group is killed), and exit code 0 with no or an empty output file, or an unreadable one.
// Parameters are recorded like any algorithm's. Timer: "external".
#include <string>

#include "scanbench/core/params.h"
#include "scanbench/core/run_context.h"
#include "scanbench/core/stage_data.h"

namespace scanbench::algorithms {

struct ExternalParams {
  std::string command;
  std::string vars;
  std::string extension = ".ply";
  double timeout_s = 600.0;

  static void declare(ParamDeclarer<ExternalParams>& d) {
    d.text("command", &ExternalParams::command,
           "shell command template with {in} (input PLY), {out} (output file) and {name} "
           "placeholders for `vars`; run by /bin/sh -c in a private temporary directory");
    d.text("vars", &ExternalParams::vars,
           "whitespace-separated name=value pairs, each substituted (shell-quoted) for {name} in "
           "the command; unknown or unused names are errors");
    d.choice("extension", &ExternalParams::extension, {".ply", ".off"},
             "extension of the output file {out}");
    d.real("timeout_s", &ExternalParams::timeout_s, Range::open_min(0.0, 1e6), "s",
           "wall seconds before the program's process group is killed");
  }
};

/// The command with every placeholder replaced (values shell-quoted). Throws ParamError
/// ("<stage>.command: ...") for an unknown placeholder, an unused var, a malformed var, an
/// unbalanced brace or a command without {out}.
std::string expand_command(const ExternalParams& p, const std::string& in, const std::string& out,
                           std::string_view stage);

/// external.points: the program's output read as a point cloud.
PointCloud external_points(const StageData& in, const ExternalParams& p, RunContext& ctx);
/// external.mesh: the program's output read as a triangle mesh.
StageData external_mesh(const StageData& in, const ExternalParams& p, RunContext& ctx);

}  // namespace scanbench::algorithms
