#include "scanbench/algorithms/registry.h"

#include "scanbench/algorithms/clop.h"
#include "scanbench/algorithms/hem.h"

namespace scanbench::algorithms {

const AlgorithmRegistry& registry() {
  static const AlgorithmRegistry r = [] {
    AlgorithmRegistry reg("algorithm");
    // One explicit list; every entry has a create-by-name test (tests/algorithms).
    reg.add(make_entry<HemParams>(
        "mixture.hem",
        "Geometrically regularised hierarchical EM (CLOP paper sec. 5, 7, 9.2, Algorithm 1): "
        "eq. 12 initial covariances, WLOP density weights (eq. 26), random parents (p = 1/3), "
        "KL constraint D_KL < alpha^2/2 (eq. 11), log-domain responsibilities (eq. 9), M-step "
        "eq. 10 and wrapped normal axes eq. 29-30, orphans carried; stops after `levels` or when "
        "a level removes < min_reduction. Output points = component means (normals = axes, "
        "weights = mixture weights); the mixture is written as a PLY.",
        hem));
    reg.add(make_entry<ClopParams>(
        "resample.clop",
        "Continuous LOP (CLOP paper sec. 6-8): weighted HEM mixture, continuous L2 initial "
        "iteration (eq. 24), continuous attraction with the three-Gaussian fit of theta(r)/r "
        "(eq. 19-22), WLOP repulsion cut at repulsion_cutoff*h and interleaved (sec. 8); "
        "theta(r) = exp(-16 r^2/h^2), h a fraction of the bbox diagonal; particles may exceed "
        "the input (upsampling). Phases init, hem, attraction, repulsion.",
        clop));
    return reg;
  }();
  return r;
}

}  // namespace scanbench::algorithms
