// A fixture of the wing check: exec includes config, downward, which is allowed.
#include "scanbench/harness/config/experiment.h"
