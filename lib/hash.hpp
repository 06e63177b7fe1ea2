// Content fingerprints stored in results files so that --resume can check what it resumes.
// FNV-1a, 64 bits: it detects accidental changes (an edited .geo, another mesh), not tampering.
#pragma once

#include <cstdint>
#include <cstdio>
#include <string>

namespace ltl {

class Fingerprint {
 public:
  Fingerprint& add(const void* data, std::size_t bytes) {
    const auto* p = static_cast<const unsigned char*>(data);
    for (std::size_t i = 0; i < bytes; ++i) h_ = (h_ ^ p[i]) * 1099511628211ull;
    return *this;
  }
  Fingerprint& add(const std::string& s) { return add(s.data(), s.size()); }
  std::string hex() const {
    char b[17];
    std::snprintf(b, sizeof b, "%016llx", static_cast<unsigned long long>(h_));
    return b;
  }

 private:
  std::uint64_t h_ = 14695981039346656037ull;
};

inline std::string fingerprint(const std::string& text) {
  return Fingerprint().add(text).hex();
}

}  // namespace ltl
