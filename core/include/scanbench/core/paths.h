#pragma once
// Where scanbench finds its configs and extracted data. The source folder is compiled in, so the
// binary works from any working directory; SCANBENCH_ROOT (configs/) and SCANBENCH_DATA (data/)
// override it at run time.
#include <filesystem>

namespace scanbench {

/// The project folder (holds configs/); SCANBENCH_ROOT or the compiled-in source folder.
std::filesystem::path project_root();
/// <project_root>/configs
std::filesystem::path config_root();
/// SCANBENCH_DATA or <project_root>/data (filled by scripts/setup.sh; never committed).
std::filesystem::path data_root();

}  // namespace scanbench
