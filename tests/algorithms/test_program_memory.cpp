// The peak RSS of an external program a step runs (programs::run_program ->
// RunContext::program_peak_rss_kb, the harness's timing.step_program_peak_rss_mb and the program
// part of step_work_mb): the program's own peak, not this process's. The kernel's ru_maxrss of a
// posix_spawn child includes the caller's peak RSS at the spawn (execve folds the old memory's
// high-water mark in), so a small program run by a big process must still read small, and a
// program that allocates a known buffer must read that buffer's size.
#include <gtest/gtest.h>

#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include "scanbench/algorithms/lop/pca_normals.h"
#include "scanbench/algorithms/reconstruction/poisson.h"
#include "scanbench/core/rng.h"
#include "scanbench/core/run_program.h"

namespace scanbench::algorithms {
namespace {

constexpr long kMiB = 1024;  // kB

// `mib` MiB of resident memory in this process (every page written).
std::vector<char> resident(long mib) {
  std::vector<char> v(static_cast<std::size_t>(mib) << 20);
  std::memset(v.data(), 1, v.size());
  return v;
}

long run_and_measure(const std::vector<std::string>& argv) {
  RunContext ctx(1);
  EXPECT_EQ(ctx.program_peak_rss_kb(), -1);
  const programs::TempDir dir("program-memory");
  programs::run_program(argv, dir.path(), 60.0, "test", ctx);
  return ctx.program_peak_rss_kb();
}

TEST(ProgramMemory, ASmallProgramRunByABigProcessReadsSmall) {
  const std::vector<char> big = resident(384);
  // A shell that lives long enough to be sampled; it needs a few MB, this process > 384 MB.
  const long kb = run_and_measure({"/bin/sh", "-c", "sleep 0.3"});
  EXPECT_GT(kb, 0);
  EXPECT_LT(kb, 64 * kMiB) << "the parent's " << big.size() / (1 << 20) << " MB leaked in";
}

TEST(ProgramMemory, AProgramThatAllocatesABufferReadsItsSize) {
  // This process's peak back to its current RSS (an earlier test held 384 MB): the program's peak
  // then exceeds it and its ru_maxrss is exact (a shorter program than the sampling interval
  // below the caller's peak would be under-read, see run_program.h).
  std::ofstream("/proc/self/clear_refs") << "5";
  // dd reads 160 MiB of zeros into one buffer: a resident peak of 160 MiB plus dd itself.
  const long kb = run_and_measure({"dd", "if=/dev/zero", "of=/dev/null", "bs=160M", "count=1",
                                   "iflag=fullblock", "status=none"});
  EXPECT_GE(kb, 160 * kMiB);
  EXPECT_LT(kb, 176 * kMiB);
}

TEST(ProgramMemory, PoissonOnATinyInputReadsBelowTheCallersMemory) {
  const std::vector<char> big = resident(512);
  Rng rng(7);
  PointCloud c;
  c.positions.resize(3, 2000);
  for (Eigen::Index i = 0; i < c.size(); ++i) {
    Eigen::Vector3f d(static_cast<float>(rng.normal()), static_cast<float>(rng.normal()),
                      static_cast<float>(rng.normal()));
    c.positions.col(i) = d.normalized();
  }
  RunContext ctx(1);
  const StageData in(pca_normals(c, PcaNormalsParams{}, ctx));
  PoissonParams p;
  p.depth = 5;
  (void)poisson(in, p, ctx);
  const long kb = ctx.program_peak_rss_kb();
  EXPECT_GT(kb, 1 * kMiB);
  EXPECT_LT(kb, 384 * kMiB) << "the caller holds " << big.size() / (1 << 20) << " MB";
  RecordProperty("colmap_peak_rss_kb", std::to_string(kb));
}

}  // namespace
}  // namespace scanbench::algorithms
