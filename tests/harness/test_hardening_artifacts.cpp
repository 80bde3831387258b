// Issue 48, "no half-written artifact", through the real binary: a full disk (a small tmpfs,
// mounted by the test: the tests run as root) gives exit 2 and one line with the path and the
// reason, leaves no truncated file under a final name and no temp behind; a damaged cache entry
// is built again, not used; an output path that is a symlink is replaced, its target unchanged.
#include <gtest/gtest.h>
#include <sys/mount.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "cli_test_util.h"
#include "scanbench/core/errors.h"
#include "scanbench/core/files.h"
#include "scanbench/core/params.h"
#include "scanbench/metrics/distance_field.h"

namespace fs = std::filesystem;
using scanbench::Json;
using namespace scanbench::test;  // NOLINT(google-build-using-namespace): test helpers

namespace {

/// The lines of the output that start with "scanbench:" (the CLI's error lines).
std::vector<std::string> error_lines(const std::string& out) {
  std::vector<std::string> lines;
  std::istringstream in(out);
  for (std::string line; std::getline(in, line);)
    if (line.rfind("scanbench:", 0) == 0) lines.push_back(line);
  return lines;
}

/// Exit 2 and exactly one error line naming `file` and the full disk.
void expect_disk_full(const Result& r, const std::string& file) {
  EXPECT_EQ(r.code, 2) << r.out;
  const auto lines = error_lines(r.out);
  ASSERT_EQ(lines.size(), 1u) << r.out;
  EXPECT_NE(lines[0].find("No space left on device"), std::string::npos) << lines[0];
  EXPECT_NE(lines[0].find(file), std::string::npos) << lines[0];
}

/// Every regular file under `dir`, relative to it (temps included: their names start with '.').
std::set<std::string> files_under(const fs::path& dir) {
  std::set<std::string> out;
  for (const auto& e : fs::recursive_directory_iterator(dir)) {
    if (!e.is_directory()) out.insert(fs::relative(e.path(), dir).string());
  }
  return out;
}

/// No name under `dir` is a temp (".<name>.tmp.<pid>.<n>", a scan's ".<hash>.<host>.<pid>.ply").
void expect_no_temp(const fs::path& dir) {
  for (const auto& f : files_under(dir))
    EXPECT_NE(fs::path(f).filename().string().front(), '.') << "temp left behind: " << f;
}

/// Each file under `dir` is whole: the same bytes as the file of that name under `ref` (a run of
/// the same command on a disk with room); a .vdb (whose header holds a random UUID) has the same
/// size and reads back.
void expect_whole(const fs::path& dir, const fs::path& ref) {
  for (const auto& f : files_under(dir)) {
    ASSERT_TRUE(fs::exists(ref / f)) << f << " has no reference";
    if (fs::path(f).extension() == ".vdb") {
      EXPECT_EQ(fs::file_size(dir / f), fs::file_size(ref / f)) << f;
      EXPECT_NO_THROW(scanbench::metrics::read_vdb_info(dir / f)) << f;
    } else {
      EXPECT_EQ(slurp(dir / f), slurp(ref / f)) << f << " is not whole";
    }
  }
}

/// A test with a scratch folder and, on demand, a tmpfs of a given size in it (unmounted and
/// removed in TearDown).
class ArtifactsTest : public ::testing::Test {
 protected:
  void SetUp() override { root_ = make_temp_dir("artifacts"); }
  void TearDown() override {
    if (mounted_) ::umount2(disk().c_str(), MNT_DETACH);
    std::error_code ec;
    fs::remove_all(root_, ec);
  }
  fs::path disk() const { return root_ / "disk"; }
  /// Mounts a tmpfs of `size` ("4m", "8k") at disk().
  void mount_disk(const std::string& size) {
    fs::create_directories(disk());
    const std::string opts = "size=" + size + ",mode=0755";
    ASSERT_EQ(::mount("tmpfs", disk().c_str(), "tmpfs", 0, opts.c_str()), 0)
        << "mount tmpfs (the tests run as root): " << std::strerror(errno);
    mounted_ = true;
  }
  /// Remounts disk() with another size, or read-only.
  void resize_disk(const std::string& size, unsigned long flags = 0) {
    const std::string opts = "size=" + size + ",mode=0755";
    ASSERT_EQ(::mount("tmpfs", disk().c_str(), "tmpfs", MS_REMOUNT | flags, opts.c_str()), 0)
        << std::strerror(errno);
  }
  /// A scan of the sphere (3.6 MB, 112,299 points) on the normal disk, the input of eval and algo.
  fs::path sphere_scan() {
    const fs::path ply = root_ / "scan.ply";
    if (!fs::exists(ply)) {
      const auto r = sh(sb() + " scan --dataset sphere --seed 1 -o " + ply.string());
      EXPECT_EQ(r.code, 0) << r.out;
    }
    return ply;
  }
  fs::path root_;
  bool mounted_ = false;
};

using ArtifactsDiskFull = ArtifactsTest;
using ArtifactsSymlink = ArtifactsTest;
using ArtifactsCache = ArtifactsTest;

/// The id of the job of variant `label` in a results folder's plan.
std::string job_id(const fs::path& out, const std::string& label) {
  const Json plan = Json::parse(slurp(out / "plan.json"));
  for (const Json& j : plan["jobs"])
    if (j["variant"]["label"] == label) return j["id"].get<std::string>();
  return "";
}

std::string eval_cmd(const fs::path& scan, const std::string& extra) {
  return sb() + " eval --dataset sphere --points " + scan.string() + " --seed 2 " + extra;
}

}  // namespace

// The distance field (11 MB) does not fit on a 4 MB disk, the five PNGs do: exit 2 naming the
// .vdb and the reason; the PNGs written before are whole, the field is absent, no temp is left.
// Before: exit 0, the .vdb truncated under its final name.
TEST_F(ArtifactsDiskFull, EvalFieldOnAFullDisk) {
  const fs::path scan = sphere_scan();
  const fs::path ref = root_ / "ref";
  const auto ok = sh(eval_cmd(scan, "--vdb " + (ref / "v").string() + " --heatmap " +
                                        (ref / "h").string() + " -o " + (ref / "m.json").string()));
  ASSERT_EQ(ok.code, 0) << ok.out;
  mount_disk("4m");
  const auto r =
      sh(eval_cmd(scan, "--vdb " + (disk() / "v").string() + " --heatmap " +
                            (disk() / "h").string() + " -o " + (disk() / "m.json").string()));
  expect_disk_full(r, (disk() / "v" / "ground_truth.vdb").string());
  EXPECT_FALSE(fs::exists(disk() / "v" / "ground_truth.vdb"));
  EXPECT_FALSE(fs::exists(disk() / "m.json"));
  EXPECT_TRUE(fs::exists(disk() / "h" / "heatmap_p2plane.png"));
  expect_no_temp(disk());
  expect_whole(disk(), ref);
}

// The heatmap (17 kB) does not fit on an 8 kB disk. Before: exit 0 and a 0-byte PNG.
TEST_F(ArtifactsDiskFull, EvalHeatmapOnAFullDisk) {
  const fs::path scan = sphere_scan();
  mount_disk("8k");
  const auto r = sh(eval_cmd(
      scan, "--heatmap " + (disk() / "h").string() + " -o " + (root_ / "m.json").string()));
  expect_disk_full(r, (disk() / "h" / "heatmap_p2plane.png").string());
  EXPECT_TRUE(files_under(disk()).empty()) << r.out;
}

// `scan -o` and `algo -o` on a 1 MB disk: nothing is left, neither the PLY nor its record.
TEST_F(ArtifactsDiskFull, ScanAndAlgoOutputsOnAFullDisk) {
  const fs::path scan = sphere_scan();
  mount_disk("1m");
  const auto s = sh(sb() + " scan --dataset sphere --seed 1 -o " + (disk() / "s.ply").string());
  expect_disk_full(s, (disk() / "s.ply").string());
  EXPECT_TRUE(files_under(disk()).empty()) << s.out;
  const auto a =
      sh(sb() + " algo normals.pca -i " + scan.string() + " -o " + (disk() / "a.ply").string());
  expect_disk_full(a, (disk() / "a.ply").string());
  EXPECT_TRUE(files_under(disk()).empty()) << a.out;
}

// A run whose distance field does not fit: its jobs fail with the path and the reason, no field
// is left truncated (the run before this change linked a 3 of 11 MB field and resumed with it),
// and after the disk grows, --resume --retry-failed gives the metrics of a run that had room.
TEST_F(ArtifactsDiskFull, RunResumesToTheSameMetricsAfterAFullDisk) {
  const fs::path cfg = root_ / "c.json";
  write(cfg, R"({"scanbench_experiment": 1, "name": "full", "seed": 3, "save_outputs": true,
    "datasets": [{"name": "sphere"}],
    "scanners": [{"preset": "clean", "params": {"views": 2, "resolution": 40}}],
    "variants": [
      {"label": "sub2", "algorithm": "test.subsample", "params": {"stride": 2}},
      {"label": "sub3", "algorithm": "test.subsample", "params": {"stride": 3}}],
    "metrics": ["accuracy.p2plane"]})");
  const auto ref = sh(sb() + " run " + cfg.string() + " -q -o " + (root_ / "ref").string());
  ASSERT_EQ(ref.code, 0) << ref.out;
  mount_disk("8m");
  const fs::path out = disk() / "out";
  const auto r = sh(sb() + " run " + cfg.string() + " -q -o " + out.string());
  EXPECT_NE(r.code, 0) << r.out;
  for (const Json& rec : read_jsonl(out / "runs.jsonl")) {
    EXPECT_EQ(rec["status"], "error") << rec.dump();
    const std::string err = rec.value("error", "");
    EXPECT_NE(err.find("No space left on device"), std::string::npos) << err;
    EXPECT_NE(err.find("fields/"), std::string::npos) << err;
  }
  for (const auto& f : files_under(out)) {
    EXPECT_NE(fs::path(f).extension(), ".vdb") << f;  // none, rather than a truncated one
    EXPECT_EQ(f.find("/."), std::string::npos) << "temp left behind: " << f;
  }
  resize_disk("64m");
  const auto again =
      sh(sb() + " run " + cfg.string() + " -q --resume --retry-failed -o " + out.string());
  ASSERT_EQ(again.code, 0) << again.out;
  std::map<std::string, Json> want, got;
  for (const auto& [label, rec] : by_variant(read_jsonl(root_ / "ref" / "runs.jsonl")))
    want[label] = rec["metrics"];
  for (const auto& [label, rec] : by_variant(read_jsonl(out / "runs.jsonl"))) {
    EXPECT_EQ(rec["status"], "ok") << rec.dump();
    got[label] = rec["metrics"];
  }
  EXPECT_EQ(got, want);
  ASSERT_EQ(want.size(), 2u);
}

// A truncated field and a truncated scan in the caches of a results folder: the next job that
// needs them builds them again (a line in its log each), and never reads the damaged bytes.
// Before: the cache checked only that the files existed.
TEST_F(ArtifactsCache, DamagedFieldAndScanAreBuiltAgain) {
  const fs::path cfg = root_ / "c.json";
  write(cfg, R"({"scanbench_experiment": 1, "name": "cache", "seed": 3, "save_outputs": true,
    "datasets": [{"name": "sphere"}],
    "scanners": [{"preset": "clean", "params": {"views": 2, "resolution": 40}}],
    "variants": [
      {"label": "sub2", "algorithm": "test.subsample", "params": {"stride": 2}},
      {"label": "sub3", "algorithm": "test.subsample", "params": {"stride": 3}}],
    "metrics": ["accuracy.p2plane"]})");
  const fs::path out = root_ / "out";
  const auto first = sh(sb() + " run " + cfg.string() + " -q --filter sub2 -o " + out.string());
  ASSERT_EQ(first.code, 0) << first.out;
  std::vector<fs::path> vdbs, plys;
  for (const auto& e : fs::directory_iterator(out / "fields"))
    if (e.path().extension() == ".vdb") vdbs.push_back(e.path());
  for (const auto& e : fs::directory_iterator(out / "scans"))
    if (e.path().extension() == ".ply") plys.push_back(e.path());
  ASSERT_EQ(vdbs.size(), 1u);
  ASSERT_EQ(plys.size(), 1u);
  const auto field_size = fs::file_size(vdbs[0]);
  const auto voxels = scanbench::metrics::read_vdb_info(vdbs[0]).active_voxels;
  const std::string scan_bytes = slurp(plys[0]);
  fs::resize_file(vdbs[0], field_size / 4);
  fs::resize_file(plys[0], scan_bytes.size() / 2);

  const auto second = sh(sb() + " run " + cfg.string() + " -q --resume -o " + out.string());
  ASSERT_EQ(second.code, 0) << second.out;
  const std::string sub3_id = job_id(out, "sub3");
  const std::string log = slurp(out / "logs" / (sub3_id + ".log"));
  EXPECT_NE(log.find(vdbs[0].string() + ": cache entry fails its check"), std::string::npos) << log;
  EXPECT_NE(log.find(plys[0].string() + ": cache entry fails its check"), std::string::npos) << log;
  EXPECT_EQ(fs::file_size(vdbs[0]), field_size);
  EXPECT_EQ(scanbench::metrics::read_vdb_info(vdbs[0]).active_voxels, voxels);
  EXPECT_EQ(slurp(plys[0]), scan_bytes);  // scanned again, the same bytes
  const auto recs = by_variant(read_jsonl(out / "runs.jsonl"));
  ASSERT_EQ(recs.count("sub3"), 1u);
  EXPECT_EQ(recs.at("sub3")["status"], "ok") << recs.at("sub3").dump();
  EXPECT_EQ(recs.at("sub3")["timing"]["scan_cached"], false);  // not the damaged one
}

// `scan -o LINK` and `algo -o LINK`: the link is replaced by the file, its target is unchanged.
TEST_F(ArtifactsSymlink, ScanAndAlgoReplaceALinkAtTheOutput) {
  const fs::path scan = sphere_scan();
  const fs::path target = root_ / "target.txt";
  write(target, "keep");
  for (const char* name : {"s.ply", "a.ply"}) {
    const fs::path link = root_ / name;
    fs::create_symlink(target, link);
    const std::string cmd =
        std::string(name) == "s.ply"
            ? sb() + " scan --dataset sphere --seed 1 -o " + link.string()
            : sb() + " algo normals.pca -i " + scan.string() + " -o " + link.string();
    const auto r = sh(cmd);
    ASSERT_EQ(r.code, 0) << r.out;
    EXPECT_EQ(slurp(target), "keep") << name;
    EXPECT_FALSE(fs::is_symlink(link)) << name;
    EXPECT_TRUE(fs::is_regular_file(link)) << name;
  }
}

// outputs/<id>.ply a symlink to a file outside the results folder: the job's output replaces
// the link; the target is unchanged. Before: the target was overwritten.
TEST_F(ArtifactsSymlink, OutputsEntryLinkTargetUnchanged) {
  const fs::path cfg = root_ / "c.json";
  write(cfg, R"({"scanbench_experiment": 1, "name": "links", "seed": 3, "save_outputs": true,
    "datasets": [{"name": "sphere"}],
    "scanners": [{"preset": "clean", "params": {"views": 2, "resolution": 40}}],
    "variants": [
      {"label": "sub2", "algorithm": "test.subsample", "params": {"stride": 2}},
      {"label": "sub3", "algorithm": "test.subsample", "params": {"stride": 3}}],
    "metrics": ["accuracy.p2plane"]})");
  const fs::path out = root_ / "out";
  const auto first = sh(sb() + " run " + cfg.string() + " -q --filter sub2 -o " + out.string());
  ASSERT_EQ(first.code, 0) << first.out;
  const std::string sub3_id = job_id(out, "sub3");
  ASSERT_FALSE(sub3_id.empty());
  const fs::path target = root_ / "target.ply";
  write(target, "keep");
  const fs::path link = out / "outputs" / (sub3_id + ".ply");
  fs::create_symlink(target, link);
  const auto second = sh(sb() + " run " + cfg.string() + " -q --resume -o " + out.string());
  ASSERT_EQ(second.code, 0) << second.out;
  EXPECT_EQ(slurp(target), "keep");
  EXPECT_FALSE(fs::is_symlink(link));
  EXPECT_TRUE(fs::is_regular_file(link));
}

// The writer itself (core files.h), on the reasons a user meets: each message names the final
// path and the kernel's reason; the final name keeps its old bytes and no temp is left.
TEST_F(ArtifactsDiskFull, WriterNamesTheReason) {
  const fs::path long_name = root_ / std::string(300, 'x');
  try {
    scanbench::write_file_atomic(long_name, "a");
    ADD_FAILURE() << "no error for a 300-byte name";
  } catch (const scanbench::IoError& e) {
    EXPECT_NE(std::string(e.what()).find("File name too long"), std::string::npos) << e.what();
  }
  mount_disk("8k");
  const fs::path f = disk() / "f.txt";
  scanbench::write_file_atomic(f, "old");
  try {
    scanbench::write_file_atomic(f, std::string(64 * 1024, 'n'));
    ADD_FAILURE() << "no error on a full disk";
  } catch (const scanbench::IoError& e) {
    EXPECT_EQ(std::string(e.what()), f.string() + ": cannot write: No space left on device");
  }
  EXPECT_EQ(slurp(f), "old");
  resize_disk("8k", MS_RDONLY);
  try {
    scanbench::write_file_atomic(f, "new");
    ADD_FAILURE() << "no error on a read-only file system";
  } catch (const scanbench::IoError& e) {
    EXPECT_EQ(std::string(e.what()), f.string() + ": cannot write: Read-only file system");
  }
  EXPECT_EQ(slurp(f), "old");
  EXPECT_EQ(files_under(disk()), std::set<std::string>{"f.txt"});
}

// write_via_temp (a writer that can only write to a path): a failing writer's temp is removed
// and its message names the final path; an empty result is refused; a link at the final name
// is replaced, its target unchanged.
TEST_F(ArtifactsSymlink, WriteViaTempChecksAndReplacesTheLink) {
  const fs::path target = root_ / "target.txt";
  write(target, "keep");
  const fs::path out = root_ / "out.bin";
  fs::create_symlink(target, out);
  fs::path seen;
  try {
    scanbench::write_via_temp(out, [&](const fs::path& tmp) {
      seen = tmp;
      write(tmp, "part");
      throw scanbench::IoError(tmp.string() + ": cannot encode");
    });
    ADD_FAILURE() << "the writer's error was lost";
  } catch (const scanbench::IoError& e) {
    EXPECT_EQ(std::string(e.what()), out.string() + ": cannot encode");
  }
  EXPECT_EQ(seen.parent_path(), root_);
  EXPECT_TRUE(scanbench::is_temp_name(seen.filename().string())) << seen;
  EXPECT_FALSE(fs::exists(seen));
  EXPECT_THROW(scanbench::write_via_temp(out, [](const fs::path&) {}), scanbench::IoError);
  EXPECT_TRUE(fs::is_symlink(out));  // both failures left the old entry
  scanbench::write_via_temp(out, [](const fs::path& tmp) { write(tmp, "whole"); });
  EXPECT_FALSE(fs::is_symlink(out));
  EXPECT_EQ(slurp(out), "whole");
  EXPECT_EQ(slurp(target), "keep");
  EXPECT_EQ(files_under(root_), (std::set<std::string>{"out.bin", "target.txt"}));
}
