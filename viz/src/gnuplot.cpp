#include "gnuplot.h"

#include <cstdlib>
#include <fstream>
#include <stdexcept>

namespace wj::viz::detail {

void writeScript(const std::filesystem::path& script, const std::string& text) {
  std::ofstream f(script);
  if (!f) throw std::runtime_error("cannot write " + script.string());
  f << text;
}

void runGnuplot(const std::filesystem::path& script, const std::filesystem::path& out) {
  std::error_code ec;
  std::filesystem::remove(out, ec);
  const std::string cmd = "gnuplot '" + script.string() + "'";
  if (std::system(cmd.c_str()) != 0)
    throw std::runtime_error("gnuplot failed on " + script.string());
  if (!std::filesystem::exists(out) || std::filesystem::file_size(out) == 0)
    throw std::runtime_error("gnuplot wrote no " + out.string());
}

std::string quoted(const std::string& text) {
  std::string s = "\"";
  for (const char c : text) {
    if (c == '"' || c == '\\') s += '\\';
    s += c == '\n' ? std::string("\\n") : std::string(1, c);
  }
  return s + "\"";
}

}  // namespace wj::viz::detail
