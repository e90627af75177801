#pragma once
// Running gnuplot for the viewers' figures (side_view.cpp, knee_figure.cpp); not installed.

#include <filesystem>
#include <string>

namespace wj::viz::detail {

/// Writes `text` to `script`; throws std::runtime_error if the file cannot be written.
void writeScript(const std::filesystem::path& script, const std::string& text);
/// Runs gnuplot on `script`; throws std::runtime_error if it fails or `out` is not there
/// afterwards (an old `out` is removed first).
void runGnuplot(const std::filesystem::path& script, const std::filesystem::path& out);
/// Text as a gnuplot double-quoted string (noenhanced mode): "\n" breaks the line.
std::string quoted(const std::string& text);

}  // namespace wj::viz::detail
