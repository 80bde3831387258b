#include "scanbench/core/params.h"

#include <fmt/format.h>

#include <cmath>
#include <cstdint>

#include "scanbench/core/json_text.h"

namespace scanbench {

const char* to_string(ParamType t) {
  switch (t) {
    case ParamType::Bool:
      return "bool";
    case ParamType::Int:
      return "int";
    case ParamType::Real:
      return "real";
    case ParamType::String:
      return "string";
    case ParamType::Choice:
      return "choice";
  }
  return "?";
}

bool Range::contains(double v) const {
  if (std::isnan(v)) return false;
  if (min_open ? !(v > min) : !(v >= min)) return false;
  if (max_open ? !(v < max) : !(v <= max)) return false;
  return true;
}

std::string Range::to_string() const {
  auto num = [](double v) {
    return std::isinf(v) ? std::string(v < 0 ? "-inf" : "inf") : fmt::format("{}", v);
  };
  return fmt::format("{}{}, {}{}", min_open || std::isinf(min) ? "(" : "[", num(min), num(max),
                     max_open || std::isinf(max) ? ")" : "]");
}

namespace {
std::string describe_json(const Json& v) {
  std::string s = v.dump();
  if (s.size() > 40) s = s.substr(0, 37) + "...";
  return fmt::format("{} {}", v.type_name(), s);
}
}  // namespace

Json ParamInfo::check(const Json& value, const std::string& path) const {
  switch (type) {
    case ParamType::Bool:
      if (!value.is_boolean()) {
        throw ParamError(fmt::format("{}: expected a boolean, got {}", path, describe_json(value)));
      }
      return value;
    case ParamType::Int: {
      // JSON integers only: 2.5 or "2" are errors, never rounded or parsed.
      if (!value.is_number_integer()) {
        throw ParamError(fmt::format("{}: expected an integer in {}, got {}", path,
                                     range.to_string(), describe_json(value)));
      }
      const double d = value.get<double>();
      if (!range.contains(d)) {
        throw ParamError(fmt::format("{}: expected an integer in {}, got {}", path,
                                     range.to_string(), value.dump()));
      }
      return value;
    }
    case ParamType::Real: {
      if (!value.is_number()) {
        throw ParamError(fmt::format("{}: expected a number in {}, got {}", path, range.to_string(),
                                     describe_json(value)));
      }
      const double d = value.get<double>();
      if (!std::isfinite(d) || !range.contains(d)) {
        throw ParamError(fmt::format("{}: expected a number in {}, got {}", path, range.to_string(),
                                     value.dump()));
      }
      return Json(d);
    }
    case ParamType::String:
      if (!value.is_string()) {
        throw ParamError(fmt::format("{}: expected a string, got {}", path, describe_json(value)));
      }
      return value;
    case ParamType::Choice: {
      std::string list;
      for (const auto& c : choices)
        list += (list.empty() ? "" : "|") + c;
      if (!value.is_string()) {
        throw ParamError(
            fmt::format("{}: expected one of {}, got {}", path, list, describe_json(value)));
      }
      for (const auto& c : choices) {
        if (value.get<std::string>() == c) return value;
      }
      throw ParamError(fmt::format("{}: expected one of {}, got {}", path, list, value.dump()));
    }
  }
  return value;
}

Json ParamInfo::to_json() const {
  Json j = Json::object();
  j["name"] = name;
  j["type"] = scanbench::to_string(type);
  j["default"] = default_value;
  const bool numeric = type == ParamType::Int || type == ParamType::Real;
  // Integer parameters show integer bounds (1, not 1.0).
  auto bound = [&](double v) {
    if (!numeric || !std::isfinite(v)) return Json(nullptr);
    return type == ParamType::Int ? Json(static_cast<std::int64_t>(v)) : Json(v);
  };
  j["min"] = bound(range.min);
  j["max"] = bound(range.max);
  if (numeric) {
    j["min_exclusive"] = range.min_open;
    j["max_exclusive"] = range.max_open;
  }
  if (type == ParamType::Choice) j["choices"] = choices;
  j["unit"] = unit;
  j["doc"] = doc;
  return j;
}

const ParamInfo* ParamSchema::find(std::string_view name) const {
  for (const auto& p : params_) {
    if (p.name == name) return &p;
  }
  return nullptr;
}

const ParamInfo& ParamSchema::at(std::string_view name, const std::string& path) const {
  if (const ParamInfo* p = find(name)) return *p;
  std::string known;
  for (const auto& p : params_)
    known += (known.empty() ? "" : ", ") + p.name;
  throw ParamError(fmt::format("{}.{}: unknown parameter (known: {})", path, name,
                               known.empty() ? "none" : known));
}

Json ParamSchema::validate(const Json& object, const std::string& path) const {
  if (object.is_null()) return defaults();
  if (!object.is_object()) {
    throw ParamError(
        fmt::format("{}: expected an object of parameters, got {}", path, describe_json(object)));
  }
  for (const auto& [key, value] : object.items())
    at(key, path);  // unknown keys first
  Json out = Json::object();
  for (const auto& p : params_) {
    auto it = object.find(p.name);
    out[p.name] = it == object.end() ? p.default_value : p.check(*it, path + "." + p.name);
  }
  return out;
}

Json ParamSchema::defaults() const {
  Json out = Json::object();
  for (const auto& p : params_)
    out[p.name] = p.default_value;
  return out;
}

Json ParamSchema::to_json() const {
  Json a = Json::array();
  for (const auto& p : params_)
    a.push_back(p.to_json());
  return a;
}

void apply_assignment(Json& obj, std::string_view assignment) {
  const auto eq = assignment.find('=');
  if (eq == std::string_view::npos || eq == 0) {
    throw ParamError(fmt::format("--set {}: expected key=value", assignment));
  }
  const std::string key(assignment.substr(0, eq));
  const std::string text(assignment.substr(eq + 1));
  const Json value = parse_assigned_value(text, fmt::format("--set {}", key));
  Json* target = &obj;
  std::size_t start = 0;
  while (true) {
    const auto dot = key.find('.', start);
    const std::string part =
        key.substr(start, dot == std::string::npos ? std::string::npos : dot - start);
    if (part.empty()) throw ParamError(fmt::format("--set {}: empty key component", assignment));
    if (dot == std::string::npos) {
      (*target)[part] = value;
      return;
    }
    Json& next = (*target)[part];
    if (next.is_null()) next = Json::object();
    if (!next.is_object()) {
      throw ParamError(fmt::format("--set {}: '{}' is not an object", assignment, part));
    }
    target = &next;
    start = dot + 1;
  }
}

}  // namespace scanbench
