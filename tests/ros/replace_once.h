// Shared helper of the ROS layer's unit tests that edit a known-good text (a URDF,
// a robot spec) into a bad one.
#pragma once

#include <gtest/gtest.h>

#include <string>

namespace msspr::testing_util {

// s with the first occurrence of `from` replaced by `to`; a test failure when s has none.
inline std::string ReplaceOnce(std::string s, const std::string& from, const std::string& to) {
  const size_t at = s.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) s.replace(at, from.size(), to);
  return s;
}

}  // namespace msspr::testing_util
