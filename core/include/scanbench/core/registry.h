#pragma once
// Registries: algorithms, metrics, scanner presets and datasets are registered by dotted name in
// one explicit list per module (no static initialisers). A Registry<Fn> is a
// vector of entries with lookup by name; each module defines its Fn and fills its list in one
// function (e.g. algorithms::registry()).
#include <algorithm>
#include <string>
#include <string_view>
#include <vector>

#include "scanbench/core/errors.h"
#include "scanbench/core/params.h"

namespace scanbench {

template <class Fn>
struct RegistryEntry {
  std::string name;    ///< dotted name, e.g. "resample.clop"
  std::string doc;     ///< one paragraph: what it is, which paper and equations
  ParamSchema params;  ///< declared parameters
  Fn fn;               ///< what the module runs for this entry
  /// The page under docs/ that documents the entry (its family's, e.g. "algorithms/gpf.md"); ""
  /// for entries without one (plugins may leave it empty).
  std::string page = {};

  /// {"name","doc","params":[...]} plus "page" when set and whatever Fn::describe adds.
  Json to_json() const {
    Json j = Json::object();
    j["name"] = name;
    j["doc"] = doc;
    j["params"] = params.to_json();
    if (!page.empty()) j["page"] = page;
    if constexpr (requires(const Fn& f, Json& out) { f.describe(out); }) fn.describe(j);
    return j;
  }
};

template <class Fn>
class Registry {
 public:
  using Entry = RegistryEntry<Fn>;
  explicit Registry(std::string kind) : kind_(std::move(kind)) {}

  /// Adds an entry; throws Error on a duplicate name (a programming error caught by tests).
  void add(Entry e) {
    if (find(e.name)) throw Error(kind_ + " registry: duplicate name '" + e.name + "'");
    entries_.push_back(std::move(e));
  }
  const Entry* find(std::string_view name) const {
    auto it = std::find_if(entries_.begin(), entries_.end(),
                           [&](const Entry& e) { return e.name == name; });
    return it == entries_.end() ? nullptr : &*it;
  }
  /// Throws UnknownNameError("unknown <kind> 'x' (known: a, b, ...)").
  const Entry& at(std::string_view name) const {
    if (const Entry* e = find(name)) return *e;
    std::string known;
    for (const auto& e : entries_)
      known += (known.empty() ? "" : ", ") + e.name;
    throw UnknownNameError("unknown " + kind_ + " '" + std::string(name) + "' (known: " + known +
                           ")");
  }
  const std::vector<Entry>& entries() const { return entries_; }
  const std::string& kind() const { return kind_; }

 private:
  std::string kind_;
  std::vector<Entry> entries_;
};

}  // namespace scanbench
