#pragma once
/// @file What a call that must refuse its input says: the tests of every settings parser and
/// request check that bad input is refused with a message naming the field and its range. The
/// message is compared with gmock's HasSubstr, so that a failure prints the whole message.
#include <gmock/gmock.h>

#include <exception>
#include <string>
#include <utility>

namespace wj::test {

/// The message of the exception of type E (or derived) that `call()` throws, or "accepted" if it
/// returns. Another exception type propagates, so that the test fails on it.
template <class E = std::exception, class Call>
std::string errorOf(Call&& call) {
  try {
    static_cast<void>(std::forward<Call>(call)());
  } catch (const E& e) {
    return e.what();
  }
  return "accepted";
}

using ::testing::HasSubstr;

}  // namespace wj::test
