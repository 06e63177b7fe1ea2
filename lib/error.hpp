// One exception type for every user-facing error: what is wrong and where.
#pragma once

#include <sstream>
#include <stdexcept>
#include <string>

namespace ltl {

/// A clear, user-facing error (bad input, failed factorization, divergence). Drivers print
/// `what()` and exit non-zero.
class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& message) : std::runtime_error(message) {}
};

/// An error about one configuration key (dotted path, e.g. "algorithm.R"), so that the
/// configuration reader can point at the file and line where the key was given.
class KeyError : public Error {
 public:
  KeyError(const std::string& key, const std::string& message)
      : Error(key + ": " + message), key_(key), message_(message) {}
  const std::string& key() const { return key_; }
  const std::string& message() const { return message_; }

 private:
  std::string key_, message_;
};

/// Builds a message from any streamable parts: `throw Error(cat("key ", k, ": must be > 0"))`.
template <class... Parts>
std::string cat(const Parts&... parts) {
  std::ostringstream s;
  (s << ... << parts);
  return s.str();
}

}  // namespace ltl
