#include "config/json_checks.h"

#include <fmt/format.h>

#include <algorithm>

#include "scanbench/core/errors.h"

namespace scanbench::harness {

namespace {

/// Levenshtein distance (a dozen lines; no library among the dependencies offers one).
std::size_t edit_distance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> prev(b.size() + 1), cur(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j)
    prev[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    cur[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t sub = prev[j - 1] + (a[i - 1] == b[j - 1] ? 0 : 1);
      cur[j] = std::min({prev[j] + 1, cur[j - 1] + 1, sub});
    }
    std::swap(prev, cur);
  }
  return prev[b.size()];
}

}  // namespace

void check_keys(const Json& j, const std::string& where,
                std::initializer_list<const char*> allowed) {
  if (!j.is_object()) {
    throw ParamError(fmt::format("{}: expected an object, got {}", where, j.type_name()));
  }
  for (const auto& item : j.items()) {
    const std::string& key = item.key();
    if (std::none_of(allowed.begin(), allowed.end(), [&](const char* a) { return key == a; })) {
      std::string list;
      for (const char* a : allowed)
        list += (list.empty() ? "" : ", ") + std::string(a);
      throw ParamError(fmt::format("{}/{}: unknown key (expected one of: {})", where, key, list));
    }
  }
}

std::string did_you_mean(const std::string& name, const std::vector<std::string>& candidates) {
  if (candidates.empty()) return "";
  std::string best;
  std::size_t best_d = std::string::npos;
  for (const auto& c : candidates) {
    std::size_t d = edit_distance(name, c);
    // A short name against a dotted key's last part ("stride" of "test.subsample.stride").
    const auto dot = c.rfind('.');
    if (name.find('.') == std::string::npos && dot != std::string::npos)
      d = std::min(d, edit_distance(name, c.substr(dot + 1)));
    // A prefix or a part of a longer name ("p2plane_mean" of "p2plane_mean_rel") is close.
    if (!name.empty() && c.find(name) != std::string::npos) d = std::min<std::size_t>(d, 1);
    if (d < best_d) {
      best_d = d;
      best = c;
    }
  }
  if (best_d <= std::max<std::size_t>(2, name.size() / 3)) {
    return fmt::format(" (did you mean '{}'?)", best);
  }
  std::string known;
  for (std::size_t i = 0; i < candidates.size() && i < 12; ++i)
    known += (known.empty() ? "" : ", ") + candidates[i];
  if (candidates.size() > 12) known += fmt::format(", ... {} in all", candidates.size());
  return " (known: " + known + ")";
}

}  // namespace scanbench::harness
