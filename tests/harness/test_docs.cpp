// The options tables of the docs pages against the registries of the real binary: each family
// page of docs/algorithms/ and docs/metrics.md holds, between the markers below, one Markdown
// table per registered entry, rendered from `scanbench list --json` by render_entry(). The test
// fails naming the page and the entry when a table disagrees, and when a registered algorithm or
// metric is on no page or on more than one. SCANBENCH_UPDATE_DOCS=1 rewrites the blocks first.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "cli_test_util.h"

namespace scanbench::docs_test {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

constexpr const char* kBegin = "<!-- options:begin -->";
constexpr const char* kEnd = "<!-- options:end -->";

/// docs/ beside tests/: SCANBENCH_TEST_DATA is <root>/tests/data.
fs::path docs_dir() {
  return fs::path(SCANBENCH_TEST_DATA).parent_path().parent_path() / "docs";
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

/// stdout of `scanbench list --json` (test-only algorithms off, as a user sees the registry).
Json list_json() {
  const auto r = test::sh("env -u SCANBENCH_TEST_ALGORITHMS '" + test::sb() + "' list --json",
                          /*merge_stderr=*/false);
  if (r.code != 0)
    throw std::runtime_error("scanbench list --json exited " + std::to_string(r.code));
  return Json::parse(r.out);
}

/// A table cell: no line breaks, '|' escaped.
std::string cell(const std::string& s) {
  std::string out;
  for (const char c : s) {
    if (c == '|') {
      out += "\\|";
    } else if (c == '\n') {
      out += ' ';
    } else {
      out += c;
    }
  }
  return out;
}

std::string value_cell(const Json& v) {
  if (v.is_null()) return "";
  if (v.is_string()) return cell("`" + v.get<std::string>() + "`");
  return cell("`" + v.dump() + "`");
}

/// One entry's section: heading, doc, and the table of its parameters.
std::string render_entry(const Json& e) {
  std::string s = "### `" + e.at("name").get<std::string>() + "`\n\n";
  s += cell(e.at("doc").get<std::string>()) + "\n\n";
  const Json& params = e.at("params");
  if (params.empty()) return s + "No parameters.\n";
  s += "| name | type | default | min | max | unit | doc |\n";
  s += "|---|---|---|---|---|---|---|\n";
  for (const Json& p : params) {
    std::string doc = p.value("doc", "");
    if (p.contains("choices")) {
      std::string c;
      for (const Json& x : p["choices"])
        c += (c.empty() ? "" : ", ") + x.get<std::string>();
      doc += " (one of: " + c + ")";
    }
    std::string min = value_cell(p.value("min", Json()));
    std::string max = value_cell(p.value("max", Json()));
    if (!min.empty() && p.value("min_exclusive", false)) min += " (excl.)";
    if (!max.empty() && p.value("max_exclusive", false)) max += " (excl.)";
    s += "| `" + p.at("name").get<std::string>() + "` | " + p.value("type", "") + " | " +
         value_cell(p.value("default", Json())) + " | " + min + " | " + max + " | " +
         cell(p.value("unit", "")) + " | " + cell(doc) + " |\n";
  }
  return s;
}

/// The expected blocks: page -> (entry name, rendered section) in registry order.
using Pages = std::map<std::string, std::vector<std::pair<std::string, std::string>>>;

Pages expected_pages(const Json& list, std::vector<std::string>& unplaced) {
  Pages pages;
  for (const Json& e : list.at("algorithms")) {
    const std::string name = e.at("name").get<std::string>();
    // The page its family declares (algorithms/src/registry.cpp), in `scanbench list --json`.
    const std::string page = e.value("page", "");
    if (page.empty()) {
      unplaced.push_back(name);
    } else {
      pages[page].emplace_back(name, render_entry(e));
    }
  }
  for (const Json& e : list.at("metrics"))
    pages["metrics.md"].emplace_back(e.at("name").get<std::string>(), render_entry(e));
  return pages;
}

std::string join_block(const std::vector<std::pair<std::string, std::string>>& entries) {
  std::string s = "\n";
  for (const auto& [name, text] : entries)
    s += text + "\n";
  return s;
}

/// The text between the markers of a page, and its offsets; false when the markers are missing.
bool find_block(const std::string& text, size_t& from, size_t& to) {
  const size_t b = text.find(kBegin);
  if (b == std::string::npos) return false;
  from = b + std::string(kBegin).size();
  to = text.find(kEnd, from);
  return to != std::string::npos;
}

/// The sections of a block keyed by entry name (split at "### `").
std::map<std::string, std::string> sections(const std::string& block) {
  std::map<std::string, std::string> out;
  const std::string h = "### `";
  size_t at = block.find(h);
  while (at != std::string::npos) {
    const size_t next = block.find("\n" + h, at);
    const size_t name_end = block.find('`', at + h.size());
    const std::string name = block.substr(at + h.size(), name_end - at - h.size());
    const size_t stop = next == std::string::npos ? block.size() : next + 1;
    out[name] = block.substr(at, stop - at);
    at = next == std::string::npos ? std::string::npos : next + 1;
  }
  return out;
}

std::string trim_trailing(std::string s) {
  while (!s.empty() && (s.back() == '\n' || s.back() == ' '))
    s.pop_back();
  return s;
}

TEST(Docs, OptionsTablesMatchTheRegistry) {
  const Json list = list_json();
  std::vector<std::string> unplaced;
  const Pages pages = expected_pages(list, unplaced);
  for (const auto& name : unplaced)
    ADD_FAILURE() << "algorithm " << name << " has no docs page: add it through its family "
                  << "(algorithms/src/registry.cpp)";
  const bool update = std::getenv("SCANBENCH_UPDATE_DOCS") != nullptr &&
                      std::string(std::getenv("SCANBENCH_UPDATE_DOCS")) == "1";
  for (const auto& [page, entries] : pages) {
    const fs::path path = docs_dir() / page;
    std::string text = slurp(path);
    size_t from = 0;
    size_t to = 0;
    if (!find_block(text, from, to)) {
      ADD_FAILURE() << "docs/" << page << ": no " << kBegin << " ... " << kEnd << " block";
      continue;
    }
    const std::string want = join_block(entries);
    if (update) {  // rewrite, then check the page as written like any other
      text.replace(from, to - from, want);
      std::ofstream(path, std::ios::binary) << text;
      text = slurp(path);
      if (!find_block(text, from, to)) {
        ADD_FAILURE() << "docs/" << page << ": the rewritten page lost its block";
        continue;
      }
    }
    const std::string have = text.substr(from, to - from);
    if (have == want) continue;
    const auto have_sections = sections(have);
    bool named = false;
    for (const auto& [name, section] : entries) {
      const auto it = have_sections.find(name);
      if (it == have_sections.end()) {
        ADD_FAILURE() << "docs/" << page << ": no options table for " << name;
        named = true;
      } else if (trim_trailing(it->second) != trim_trailing(section)) {
        ADD_FAILURE() << "docs/" << page << ": the options table of " << name
                      << " disagrees with `scanbench list --json`\n--- page:\n"
                      << it->second << "\n--- registry:\n"
                      << section;
        named = true;
      }
    }
    for (const auto& [name, section] : have_sections) {
      bool known = false;
      for (const auto& e : entries)
        known = known || e.first == name;
      if (!known) {
        ADD_FAILURE() << "docs/" << page << ": table for " << name
                      << ", which is not registered for this page";
        named = true;
      }
    }
    if (!named) ADD_FAILURE() << "docs/" << page << ": the options block differs in layout";
  }
}

TEST(Docs, EveryEntryIsOnExactlyOnePage) {
  const Json list = list_json();
  std::map<std::string, std::vector<std::string>> found;  // entry -> pages holding its table
  for (const auto& d : fs::recursive_directory_iterator(docs_dir())) {
    if (d.path().extension() != ".md") continue;
    const std::string text = slurp(d.path());
    size_t from = 0;
    size_t to = 0;
    if (!find_block(text, from, to)) continue;
    for (const auto& [name, section] : sections(text.substr(from, to - from)))
      found[name].push_back(fs::relative(d.path(), docs_dir()).string());
  }
  for (const char* kind : {"algorithms", "metrics"}) {
    for (const Json& e : list.at(kind)) {
      const std::string name = e.at("name").get<std::string>();
      const auto it = found.find(name);
      const size_t n = it == found.end() ? 0 : it->second.size();
      std::string where;
      if (it != found.end())
        for (const auto& p : it->second)
          where += " docs/" + p;
      EXPECT_EQ(n, 1u) << kind << " entry " << name << " has an options table on " << n
                       << " pages (" << where << " ), expected exactly one";
    }
  }
}

}  // namespace
}  // namespace scanbench::docs_test
