#pragma once
// Declared parameters. A parameter struct holds its defaults in member
// initialisers and lists every parameter once in a static `declare` function:
//
//   struct LopParams {
//     double h = 0.04;
//     int iterations = 10;
//     static void declare(ParamDeclarer<LopParams>& d) {
//       d.real("h", &LopParams::h, {1e-4, 1.0}, "diag", "kernel support radius ...");
//       d.integer("iterations", &LopParams::iterations, {1, 1000}, "", "projection iterations");
//     }
//   };
//
// From that one list come: the schema (names, types, defaults, ranges, units, docs) shown by
// `scanbench list`, JSON parsing that rejects unknown keys, wrong types and out-of-range values
// with the JSON path in the message, the record of effective parameters, and the per-value
// validation used by sweep expansion.
#include <functional>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "scanbench/core/errors.h"

namespace scanbench {

/// Insertion-ordered JSON, so records and schemas keep declaration order.
using Json = nlohmann::ordered_json;

enum class ParamType { Bool, Int, Real, String, Choice };
const char* to_string(ParamType t);

/// A closed or open interval for numeric parameters.
struct Range {
  double min = -std::numeric_limits<double>::infinity();
  double max = std::numeric_limits<double>::infinity();
  bool min_open = false;  ///< true: min itself is not allowed
  bool max_open = false;  ///< true: max itself is not allowed
  static Range closed(double a, double b) { return {a, b, false, false}; }
  static Range half_open(double a, double b) { return {a, b, false, true}; }  ///< [a, b)
  static Range open_min(double a, double b) { return {a, b, true, false}; }   ///< (a, b]
  static Range at_least(double a) { return {a, std::numeric_limits<double>::infinity()}; }
  static Range above(double a) { return {a, std::numeric_limits<double>::infinity(), true}; }
  bool contains(double v) const;
  /// "[0, 0.5)" style text.
  std::string to_string() const;
};

/// One declared parameter.
struct ParamInfo {
  std::string name;
  ParamType type = ParamType::Real;
  Json default_value;
  Range range;                       ///< numeric types only
  std::vector<std::string> choices;  ///< Choice only
  std::string unit;                  ///< "diag" (fraction of bbox diagonal), "deg", "" ...
  std::string doc;

  /// Checks one value against type and range; throws ParamError("<path>: expected ..., got ...").
  /// Returns the value normalised (an integral Real stays a number; nothing is coerced silently).
  Json check(const Json& value, const std::string& path) const;
  /// {"name","type","default","min","max","unit","doc"[, "choices"]}; min/max null when unbounded.
  Json to_json() const;
};

/// The declared parameters of one struct, in declaration order.
class ParamSchema {
 public:
  ParamSchema() = default;
  explicit ParamSchema(std::vector<ParamInfo> params) : params_(std::move(params)) {}
  const std::vector<ParamInfo>& params() const { return params_; }
  const ParamInfo* find(std::string_view name) const;
  /// Throws ParamError naming the key and listing the known ones.
  const ParamInfo& at(std::string_view name, const std::string& path) const;
  bool empty() const { return params_.empty(); }

  /// Validates a JSON object against the schema: unknown keys, wrong types and out-of-range
  /// values throw ParamError with "<path>.<key>" in the message. Returns the complete effective
  /// parameters (defaults filled in), in declaration order of the schema.
  Json validate(const Json& object, const std::string& path) const;
  /// Every default as one JSON object.
  Json defaults() const;
  /// Array of ParamInfo::to_json().
  Json to_json() const;

 private:
  std::vector<ParamInfo> params_;
};

/// Collects a struct's declarations (see the example at the top of this file).
template <class T>
class ParamDeclarer {
 public:
  struct Field {
    ParamInfo info;
    std::function<void(T&, const Json&)> set;
    std::function<Json(const T&)> get;
  };

  void real(std::string name, double T::*m, Range r, std::string unit, std::string doc) {
    add(
        std::move(name), ParamType::Real, r, {}, std::move(unit), std::move(doc),
        [m](T& t, const Json& v) { t.*m = v.get<double>(); },
        [m](const T& t) { return Json(t.*m); });
  }
  void integer(std::string name, int T::*m, Range r, std::string unit, std::string doc) {
    add(
        std::move(name), ParamType::Int, r, {}, std::move(unit), std::move(doc),
        [m](T& t, const Json& v) { t.*m = v.get<int>(); }, [m](const T& t) { return Json(t.*m); });
  }
  void integer(std::string name, std::int64_t T::*m, Range r, std::string unit, std::string doc) {
    add(
        std::move(name), ParamType::Int, r, {}, std::move(unit), std::move(doc),
        [m](T& t, const Json& v) { t.*m = v.get<std::int64_t>(); },
        [m](const T& t) { return Json(t.*m); });
  }
  void flag(std::string name, bool T::*m, std::string doc) {
    add(
        std::move(name), ParamType::Bool, {}, {}, "", std::move(doc),
        [m](T& t, const Json& v) { t.*m = v.get<bool>(); }, [m](const T& t) { return Json(t.*m); });
  }
  void text(std::string name, std::string T::*m, std::string doc) {
    add(
        std::move(name), ParamType::String, {}, {}, "", std::move(doc),
        [m](T& t, const Json& v) { t.*m = v.get<std::string>(); },
        [m](const T& t) { return Json(t.*m); });
  }
  void choice(std::string name, std::string T::*m, std::vector<std::string> choices,
              std::string doc) {
    add(
        std::move(name), ParamType::Choice, {}, std::move(choices), "", std::move(doc),
        [m](T& t, const Json& v) { t.*m = v.get<std::string>(); },
        [m](const T& t) { return Json(t.*m); });
  }

  const std::vector<Field>& fields() const { return fields_; }

 private:
  template <class Set, class Get>
  void add(std::string name, ParamType type, Range r, std::vector<std::string> choices,
           std::string unit, std::string doc, Set set, Get get) {
    ParamInfo info;
    info.name = std::move(name);
    info.type = type;
    info.range = r;
    info.choices = std::move(choices);
    info.unit = std::move(unit);
    info.doc = std::move(doc);
    info.default_value = get(T{});
    fields_.push_back({std::move(info), set, get});
  }
  std::vector<Field> fields_;
};

/// The declared fields of T (built once).
template <class T>
const ParamDeclarer<T>& declared_fields() {
  static const ParamDeclarer<T> d = [] {
    ParamDeclarer<T> decl;
    T::declare(decl);
    return decl;
  }();
  return d;
}

/// The schema of T.
template <class T>
const ParamSchema& schema_of() {
  static const ParamSchema s = [] {
    std::vector<ParamInfo> infos;
    for (const auto& f : declared_fields<T>().fields())
      infos.push_back(f.info);
    return ParamSchema(std::move(infos));
  }();
  return s;
}

/// Parses and validates T from a JSON object (missing keys keep their defaults).
/// `path` names where the object came from, e.g. "config.json: /algorithms/0/params".
template <class T>
T params_from_json(const Json& object, const std::string& path) {
  const Json effective = schema_of<T>().validate(object, path);
  T t{};
  for (const auto& f : declared_fields<T>().fields())
    f.set(t, effective.at(f.info.name));
  return t;
}

/// The effective parameters of t as a JSON object, in declaration order.
template <class T>
Json params_to_json(const T& t) {
  Json j = Json::object();
  for (const auto& f : declared_fields<T>().fields())
    j[f.info.name] = f.get(t);
  return j;
}

/// Parses "key=value" (value as JSON when it parses, else as a string) into obj[key].
/// Dotted keys ("scanner.noise_sigma") create nested objects. Throws ParamError on a missing '='.
void apply_assignment(Json& obj, std::string_view assignment);

}  // namespace scanbench
