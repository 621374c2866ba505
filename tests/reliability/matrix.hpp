#pragma once
// The bad-input matrix: a table of cases, each with the answer written down before it runs.
//   throws(name, "arg", f)      f must throw std::invalid_argument whose message names 'arg'
//   throws_io(name, "text", f)  a tools reader: std::runtime_error whose message contains "text"
//   gives(name, "status", f)    f returns Outcome{status, outputs}; the status must match and every
//                               output must be finite (no NaN or inf leaking)
// Anything else (another exception, a different status, a non-finite output, no throw) fails.
#include <cmath>
#include <functional>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace binpick::reliability {

struct Outcome {
  std::string status = "ok";
  std::vector<double> outputs;  // every number the call produced that a caller would use

  Outcome& add(double v) {
    outputs.push_back(v);
    return *this;
  }
  template <typename Derived>
  Outcome& add(const Eigen::MatrixBase<Derived>& m) {
    for (Eigen::Index i = 0; i < m.size(); ++i) outputs.push_back(double(m.derived().data()[i]));
    return *this;
  }
  template <typename T>
  Outcome& add_all(const std::vector<T>& values) {
    for (const T& v : values) outputs.push_back(double(v));
    return *this;
  }
};

enum class Expect { invalid_argument, runtime_error, status };

struct Case {
  std::string name;
  Expect expect;
  std::string expected;  // the argument name, message fragment or status
  std::function<Outcome()> run;
};

class Matrix {
 public:
  explicit Matrix(std::string prefix = "") : prefix_(std::move(prefix)) {}
  void throws(const std::string& name, const std::string& argument, std::function<Outcome()> f) {
    cases_.push_back({prefix_ + name, Expect::invalid_argument, argument, std::move(f)});
  }
  void throws_io(const std::string& name, const std::string& fragment, std::function<Outcome()> f) {
    cases_.push_back({prefix_ + name, Expect::runtime_error, fragment, std::move(f)});
  }
  void gives(const std::string& name, const std::string& status, std::function<Outcome()> f) {
    cases_.push_back({prefix_ + name, Expect::status, status, std::move(f)});
  }
  std::vector<Case>& cases() { return cases_; }

 private:
  std::string prefix_;
  std::vector<Case> cases_;
};

/// Runs one case; returns an empty string when it gave its written-down answer, else what happened.
inline std::string check(const Case& c) {
  try {
    const Outcome out = c.run();
    if (c.expect != Expect::status) return "returned (status '" + out.status + "') instead of throwing";
    if (out.status != c.expected) return "status '" + out.status + "', expected '" + c.expected + "'";
    for (std::size_t i = 0; i < out.outputs.size(); ++i)
      if (!std::isfinite(out.outputs[i])) return "output #" + std::to_string(i) + " is not finite";
    return "";
  } catch (const std::invalid_argument& e) {
    const std::string msg = e.what();
    if (c.expect != Expect::invalid_argument) return std::string("threw invalid_argument: ") + msg;
    if (msg.find("argument '" + c.expected + "'") == std::string::npos)
      return "invalid_argument does not name '" + c.expected + "': " + msg;
    return "";
  } catch (const std::runtime_error& e) {
    const std::string msg = e.what();
    if (c.expect != Expect::runtime_error) return std::string("threw runtime_error: ") + msg;
    if (msg.find(c.expected) == std::string::npos) return "runtime_error without '" + c.expected + "': " + msg;
    return "";
  } catch (const std::exception& e) {
    return std::string("threw an unexpected exception: ") + e.what();
  } catch (...) {
    return "threw a non-standard exception";
  }
}

/// The hostile values of the matrix for a scalar type.
template <typename Scalar>
struct Bad {
  static Scalar nan() { return std::numeric_limits<Scalar>::quiet_NaN(); }
  static Scalar inf() { return std::numeric_limits<Scalar>::infinity(); }
  static Scalar denormal() { return std::numeric_limits<Scalar>::denorm_min(); }
  static Scalar huge() { return Scalar(1e30); }
  /// Non-finite values (each must be refused where finiteness is a precondition).
  static std::vector<std::pair<std::string, Scalar>> non_finite() {
    return {{"nan", nan()}, {"+inf", inf()}, {"-inf", -inf()}};
  }
  /// Values that are not > 0 or not finite (refused where "finite and > 0" is a precondition).
  static std::vector<std::pair<std::string, Scalar>> non_positive() {
    return {{"0", Scalar(0)}, {"-1", Scalar(-1)}, {"-denormal", -denormal()}, {"nan", nan()}, {"+inf", inf()},
            {"-inf", -inf()}};
  }
  /// Depth samples that are no measurement or extreme but valid.
  static std::vector<std::pair<std::string, Scalar>> depths() {
    return {{"nan", nan()},       {"+inf", inf()},   {"-inf", -inf()},
            {"-1", Scalar(-1)},   {"0", Scalar(0)},  {"denormal", denormal()},
            {"1e30", huge()},     {"max", std::numeric_limits<Scalar>::max()}};
  }
};

template <typename Scalar>
const char* scalar_name() {
  return sizeof(Scalar) == 4 ? "float" : "double";
}

}  // namespace binpick::reliability
