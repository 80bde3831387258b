// libFuzzer target for the experiment-config loader (harness/src/config/experiment.cpp): the
// input is parsed by parse_json_text the way load_experiment parses a file (core/json_text.h),
// then validated by parse_experiment against the real registries of algorithms, metrics,
// datasets and scanner presets. A config may only load or throw a scanbench::Error (ParamError,
// IoError, UnknownNameError: the CLI's exit 2); any other exception (a nlohmann type_error from an
// unchecked get<>, say), crash, leak or sanitizer report is a bug.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "scanbench/core/errors.h"
#include "scanbench/core/json_text.h"
#include "scanbench/harness/config/experiment.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  try {
    // As load_experiment reads a file: comments allowed, duplicate keys and nesting deeper than
    // kJsonMaxDepth refused before a value is built.
    scanbench::JsonTextOptions options;
    options.ignore_comments = true;
    options.reject_duplicate_keys = true;
    const scanbench::Json j = scanbench::parse_json_text(text, "fuzz.json", options);
    (void)scanbench::harness::parse_experiment(j, "fuzz.json");
  } catch (const scanbench::Error&) {
    // The expected outcome for an invalid config.
  }
  return 0;
}
