#pragma once
// Private to the harness: the value helpers of parameter protocols (config/protocol.cpp) that the
// tuning (results/tuning.cpp) shares.
#include <string>
#include <vector>

#include "scanbench/harness/config/protocol.h"

namespace scanbench::harness::detail {

/// Whether two protocol values are the same: numbers within 1e-9 x max(1, |b|) (so 1 == 1.0),
/// anything else by JSON equality.
bool protocol_same_value(const Json& a, const Json& b);
/// The protocol parameters of `variant` that have a range (tuned or swept), in protocol order.
std::vector<const ProtocolParam*> ranged_params(const Protocol& p, const std::string& variant);

}  // namespace scanbench::harness::detail
