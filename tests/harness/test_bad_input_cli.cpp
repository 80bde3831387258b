// The bad-input corpus replayed through the real command-line binary, as a user would meet it:
// every file of tests/data/malformed (reader-level damage: truncation, NaN/inf, huge counts, bad
// indices...) and of tests/data/bad_input (every reader and the experiment config: wrong types,
// unknown keys, NaN, out-of-range values, duplicate labels and keys, non-SPD covariances,
// degenerate and non-manifold meshes, empty/one-point/identical clouds, coordinates near 1e7;
// COLMAP models and dense workspaces as folders colmap_*: truncated, huge counts, dangling ids).
//
// Each file either fails with exit 2 and exactly one line on stderr naming the file and the field
// (tests/data/bad_input/EXPECTED.tsv gives the field for each), or gives the documented result
// (exit 0, a finite output that reads back). No file may crash, hang (timeout 120 s) or exit 3.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>

#include "scanbench/core/io.h"

namespace scanbench {
namespace {

namespace fs = std::filesystem;

struct Outcome {
  int exit_code = -1;
  std::string err;
};

std::string read_text(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

class BadInputCli : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("scanbench_bad_input_" +
            std::to_string(::testing::UnitTest::GetInstance()->random_seed()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  /// The command that reads `file` as its kind (by the file-name prefix of bad_input; the
  /// malformed corpus goes through `algo normals.pca`, which reads any stage file).
  std::string command_for(const fs::path& file) const {
    const std::string name = file.filename().string();
    const std::string in = "'" + file.string() + "'";
    const std::string out = "'" + (dir_ / "out.ply").string() + "'";
    auto starts = [&](const char* p) { return name.rfind(p, 0) == 0; };
    if (starts("colmap_")) return "import colmap " + in + " -o " + out;
    if (starts("config_")) return "run " + in + " -q -o '" + (dir_ / "results").string() + "'";
    if (starts("mesh_")) return "algo subdivide.loop -i " + in + " -o " + out;
    if (starts("covmesh_")) return "algo subdivide.gp_loop -i " + in + " -o " + out;
    if (starts("mixture_")) return "algo triangulate.bhattacharyya -i " + in + " -o " + out;
    return "algo normals.pca -i " + in + " -o " + out;
  }

  Outcome run(const fs::path& file) const {
    const fs::path err = dir_ / "stderr.txt";
    const std::string cmd = "timeout 120 '" + std::string(SCANBENCH_BINARY) + "' " +
                            command_for(file) + " >/dev/null 2>'" + err.string() + "'";
    const int status = std::system(cmd.c_str());
    Outcome o;
    o.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    o.err = read_text(err);
    return o;
  }

  /// Exit 2, one line on stderr, naming the file and containing `field`.
  void expect_one_line_error(const fs::path& file, const std::string& field) const {
    const Outcome o = run(file);
    EXPECT_EQ(o.exit_code, 2) << o.err;
    const auto newlines = std::count(o.err.begin(), o.err.end(), '\n');
    EXPECT_EQ(newlines, 1) << "expected exactly one line on stderr:\n" << o.err;
    EXPECT_NE(o.err.find(file.filename().string()), std::string::npos)
        << "error does not name the file: " << o.err;
    if (!field.empty()) {
      EXPECT_NE(o.err.find(field), std::string::npos)
          << "error does not name '" << field << "': " << o.err;
    }
  }

  /// Exit 0 and a finite output that reads back.
  void expect_documented_result(const fs::path& file) const {
    const Outcome o = run(file);
    ASSERT_EQ(o.exit_code, 0) << o.err;
    const StageData out = read_stage_file(dir_ / "out.ply");
    if (out.covariance_mesh) {
      EXPECT_TRUE(out.covariance_mesh->means.allFinite());
      EXPECT_GT(out.covariance_mesh->num_faces(), 0);
    } else if (out.mesh) {
      EXPECT_TRUE(out.mesh->vertices.allFinite());
      EXPECT_GT(out.mesh->num_faces(), 0);
    } else {
      ASSERT_GT(out.points.size(), 0);
      EXPECT_TRUE(out.points.positions.allFinite());
      if (out.points.has_normals()) {
        EXPECT_TRUE(out.points.normals.allFinite());
      }
    }
  }

  fs::path dir_;
};

// Reader-level damage: every file is an error naming it (no_faces.off is a valid point set).
TEST_F(BadInputCli, MalformedCorpusThroughTheCli) {
  const fs::path corpus = fs::path(SCANBENCH_TEST_DATA) / "malformed";
  int n = 0;
  for (const auto& entry : fs::directory_iterator(corpus)) {
    if (!entry.is_regular_file()) continue;
    SCOPED_TRACE(entry.path().filename().string());
    ++n;
    if (entry.path().filename() == "no_faces.off") {
      expect_documented_result(entry.path());
    } else {
      expect_one_line_error(entry.path(), "");
    }
  }
  EXPECT_GE(n, 70);
}

// Every reader and the config, each file with its expected field or documented result.
TEST_F(BadInputCli, EveryReaderAndTheConfig) {
  const fs::path corpus = fs::path(SCANBENCH_TEST_DATA) / "bad_input";
  std::ifstream manifest(corpus / "EXPECTED.tsv");
  ASSERT_TRUE(manifest) << corpus / "EXPECTED.tsv";
  std::map<std::string, std::pair<int, std::string>> expected;
  std::string line;
  while (std::getline(manifest, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream s(line);
    std::string file, code, field;
    std::getline(s, file, '\t');
    std::getline(s, code, '\t');
    std::getline(s, field, '\t');
    expected[file] = {std::stoi(code), field};
  }
  int n = 0;
  for (const auto& entry : fs::directory_iterator(corpus)) {
    const std::string name = entry.path().filename().string();
    if (name == "EXPECTED.tsv") continue;
    SCOPED_TRACE(name);
    const auto it = expected.find(name);
    ASSERT_NE(it, expected.end()) << "no line in EXPECTED.tsv";
    ++n;
    if (it->second.first == 0) {
      expect_documented_result(entry.path());
    } else {
      ASSERT_EQ(it->second.first, 2);
      expect_one_line_error(entry.path(), it->second.second);
    }
  }
  EXPECT_EQ(n, static_cast<int>(expected.size())) << "EXPECTED.tsv names files that do not exist";
  EXPECT_GE(n, 60);
}

}  // namespace
}  // namespace scanbench
