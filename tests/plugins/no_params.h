#pragma once
// What the test plugins share: an algorithm without parameters, and a copy to register under a
// name (each plugin's SCANBENCH_PLUGIN body is its own case).
#include "scanbench/plugin.h"

namespace test_plugin {

struct NoParams {
  static void declare(scanbench::ParamDeclarer<NoParams>&) {}
};

inline scanbench::PointCloud copy(const scanbench::PointCloud& in, const NoParams&,
                                  scanbench::RunContext&) {
  return in;
}

}  // namespace test_plugin
