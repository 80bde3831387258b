// A fixture of the wing check (tests/CMakeLists.txt): the config wing reaching up into exec.
#include "scanbench/harness/config/experiment.h"
#include "scanbench/harness/exec/runner.h"
