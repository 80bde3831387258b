#include "scanbench/harness/cli.h"

int main(int argc, char** argv) {
  return scanbench::harness::run_cli(argc, argv);
}
