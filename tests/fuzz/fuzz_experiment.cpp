// libFuzzer target for the experiment-config loader (harness/src/config/experiment.cpp): the input is
// parsed as JSON the way load_experiment parses a file (comments allowed), then validated by
// parse_experiment against the real registries of algorithms, metrics, datasets and scanner
// presets. A config may only load or throw a scanbench::Error (ParamError, IoError,
// UnknownNameError: the CLI's exit 2); any other exception (a nlohmann type_error from an unchecked
// get<>, say), crash, leak or sanitizer report is a bug.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "scanbench/core/errors.h"
#include "scanbench/harness/experiment.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  const scanbench::Json j = scanbench::Json::parse(text, nullptr, /*allow_exceptions=*/false,
                                                   /*ignore_comments=*/true);
  if (j.is_discarded()) return 0;  // load_experiment's "not valid JSON" error
  try {
    (void)scanbench::harness::parse_experiment(j, "fuzz.json");
  } catch (const scanbench::Error&) {
    // The expected outcome for an invalid config.
  }
  return 0;
}
