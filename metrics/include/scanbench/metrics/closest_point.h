#pragma once
// The closest-point routine is core's (scanbench/core/closest_point.h: the photogrammetric scanner
// flags outliers with it too); the metrics use it under their old names.
#include "scanbench/core/closest_point.h"

namespace scanbench::metrics {
using scanbench::closest_point_on_triangle;
using scanbench::PreparedTriangle;
}  // namespace scanbench::metrics
