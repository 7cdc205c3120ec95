// SHA-256 (OpenSSL's libcrypto: a well-kept implementation, no reason to write our own).
#pragma once

#include <string>
#include <string_view>

namespace autonomsim::sim {

// Incremental SHA-256; Hex() finishes it and returns 64 lowercase hex digits.
class Sha256 {
 public:
  Sha256();
  ~Sha256();
  Sha256(const Sha256&) = delete;
  Sha256& operator=(const Sha256&) = delete;
  void Update(std::string_view bytes);
  std::string Hex();

 private:
  void* context_;  // EVP_MD_CTX, kept opaque so OpenSSL's headers stay out of ours
};

std::string Sha256Hex(std::string_view bytes);

}  // namespace autonomsim::sim
