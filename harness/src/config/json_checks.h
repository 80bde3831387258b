#pragma once
// Private to the harness: the key check shared by the readers of claim files (claim_file.cpp), of
// protocols (protocol.cpp) and of compare tolerances (compare_options.cpp), and the "did you
// mean" suggestion of every unknown-name message. The experiment loader has its own, with JSON-pointer
// locations (experiment.cpp).
#include <initializer_list>
#include <string>
#include <vector>

#include "scanbench/core/params.h"

namespace scanbench::harness {

/// Throws ParamError "<where>: expected an object, got <type>" when `j` is not an object, and
/// "<where>/<key>: unknown key (expected one of: a, b, ...)" for a key not in `allowed`.
void check_keys(const Json& j, const std::string& where,
                std::initializer_list<const char*> allowed);

/// " (did you mean 'x'?)" for the candidate closest to `name` by edit distance (or that `name`
/// is a prefix or part of), else " (known: a, b, ...)" listing up to 12 candidates; "" when there
/// are none.
std::string did_you_mean(const std::string& name, const std::vector<std::string>& candidates);

}  // namespace scanbench::harness
