#include "scanbench/core/allocator.h"
#include "scanbench/harness/cli/cli.h"

int main(int argc, char** argv) {
  // One allocator policy for every command (scanbench/core/allocator.h), so that `bench`
  // measures what `scan` and `run` do.
  scanbench::apply_allocator_policy();
  return scanbench::harness::run_cli(argc, argv);
}
