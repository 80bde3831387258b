#pragma once
// The few typed exceptions of scanbench. Library code never terminates the
// process: it throws one of these with a one-line message that starts with the stage or file
// ("scan: ...", "bunny.ply: vertex 12: ..."), and the CLI or the harness reports it.
#include <stdexcept>
#include <string>

namespace scanbench {

/// Base of every scanbench error. what() is one line, prefixed with where it happened.
class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// A file could not be read or written, or is malformed. Message: "<path>: <what>".
class IoError : public Error {
 public:
  using Error::Error;
};

/// A parameter or config value is unknown, of the wrong type or out of range.
/// Message: "<where>.<key>: expected ..., got ...".
class ParamError : public Error {
 public:
  using Error::Error;
};

/// Input data that an algorithm cannot work with (empty, NaN coordinates, degenerate mesh).
class InputError : public Error {
 public:
  using Error::Error;
};

/// A name that is not in a registry (algorithm, metric, dataset, scanner preset).
class UnknownNameError : public Error {
 public:
  using Error::Error;
};

/// Thrown by RunContext::check_cancelled() once cancellation was requested.
class Cancelled : public Error {
 public:
  using Error::Error;
};

}  // namespace scanbench
