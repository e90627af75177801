#pragma once
// Edits of a shipped configuration's text for the strict readers' tests.

#include <gtest/gtest.h>

#include <string>

namespace wj::test {

/// `text` with the first `from` replaced by `to`; a `from` that is not there fails the test
/// (the edit would silently test the unedited file) and returns the text unchanged.
inline std::string replaceFirst(std::string text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

}  // namespace wj::test
