#include "scanbench/scanner/registry.h"

namespace scanbench::scanner {

const ScannerRegistry& presets() {
  static const ScannerRegistry r = [] {
    ScannerRegistry reg("scanner preset");
    return reg;
  }();
  return r;
}

}  // namespace scanbench::scanner
