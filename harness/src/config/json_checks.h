#pragma once
// Private to the harness: the key check shared by the readers of claim files (claim_file.cpp) and
// of compare tolerances (compare.cpp). The experiment loader has its own, with JSON-pointer
// locations (experiment.cpp).
#include <initializer_list>
#include <string>

#include "scanbench/core/params.h"

namespace scanbench::harness {

/// Throws ParamError "<where>: expected an object, got <type>" when `j` is not an object, and
/// "<where>/<key>: unknown key (expected one of: a, b, ...)" for a key not in `allowed`.
void check_keys(const Json& j, const std::string& where,
                std::initializer_list<const char*> allowed);

}  // namespace scanbench::harness
