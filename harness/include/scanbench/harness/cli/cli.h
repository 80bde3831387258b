#pragma once
// The `scanbench` command line. Exit codes: 0 success, 1 a regression found by compare/nightly,
// 2 bad input or usage (one line on stderr naming the file and field), 3 an internal error.
namespace scanbench::harness {

int run_cli(int argc, char** argv);

}  // namespace scanbench::harness
