#pragma once
/// @file Golden digest files of the tests that pin results bit for bit (the planner's plans, the
/// service's answers): 64-bit FNV-1a digests, one "name hex" line each, and the comparison that
/// says which one changed. A test regenerates its file when its environment variable is "1".
#include <gtest/gtest.h>

#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>
#include <string>

namespace wj::test {

using Digests = std::map<std::string, std::string>;  ///< name -> hex digest

/// FNV-1a over raw bytes: any change of any bit changes the digest.
class Fnv1a {
 public:
  void add(const void* data, std::size_t n) {
    const auto* p = static_cast<const unsigned char*>(data);
    for (std::size_t i = 0; i < n; ++i) h_ = (h_ ^ p[i]) * 0x100000001b3ULL;
  }
  std::string hex() const {
    std::ostringstream o;
    o << std::hex << h_;
    return o.str();
  }

 private:
  std::uint64_t h_ = 0xcbf29ce484222325ULL;
};

inline Digests readGoldenDigests(const std::string& path) {
  Digests golden;
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ls(line);
    std::string name, hex;
    ls >> name >> hex;
    golden[name] = hex;
  }
  return golden;
}

/// True when `update_env` is "1": the caller then writes `now` with writeGoldenDigests and skips.
inline bool updateRequested(const char* update_env) {
  const char* u = std::getenv(update_env);
  return u != nullptr && u[0] == '1' && u[1] == '\0';
}

inline void writeGoldenDigests(const std::string& path, const std::string& header,
                               const Digests& now) {
  std::ofstream out(path);
  out << "# " << header << '\n';
  for (const auto& [name, hex] : now) out << name << ' ' << hex << '\n';
}

/// Every digest of `now` has a golden one in `path` and equals it.
inline void expectGoldenDigests(const std::string& path, const Digests& now,
                                const char* update_env) {
  const Digests golden = readGoldenDigests(path);
  ASSERT_FALSE(golden.empty()) << "no digests in " << path;
  for (const auto& [name, hex] : now) {
    const auto it = golden.find(name);
    ASSERT_NE(it, golden.end()) << "no golden digest for " << name << " in " << path;
    EXPECT_EQ(hex, it->second) << name << " changed; if on purpose, regenerate with " << update_env
                               << "=1 and say why in the commit";
  }
}

}  // namespace wj::test
