// For tests of the GL backend (vehicle/gl_camera.h): whether an OpenGL ES context can be made
// here, and the rule when it cannot. Such a test is skipped with the reason, except under
// CI=true: CI installs Mesa with the project's own script, so there a missing context is a
// failure, not a skip that would hide a broken backend.
#pragma once

#include <gtest/gtest.h>

#include <cstdlib>
#include <string>

#include "vehicle/gl_camera.h"

namespace autonomsim::vehicle::testing {

// Empty where a context can be made; else why not. Tried once per test program.
inline const std::string& GlUnavailableReason() {
  static const std::string reason = [] {
    try {
      GlContext::Create();
      return std::string();
    } catch (const GlUnavailable& e) {
      return std::string(e.what()).empty() ? std::string("unknown") : std::string(e.what());
    }
  }();
  return reason;
}

inline bool InCi() {
  const char* ci = std::getenv("CI");
  return ci != nullptr && std::string(ci) == "true";
}

}  // namespace autonomsim::vehicle::testing

// At the top of a test body: skips it (fails it under CI=true) where no context can be made.
#define AUTONOMSIM_REQUIRE_GL()                                                 \
  do {                                                                          \
    const std::string& autonomsim_gl_reason =                                   \
        ::autonomsim::vehicle::testing::GlUnavailableReason();                  \
    if (!autonomsim_gl_reason.empty()) {                                        \
      if (::autonomsim::vehicle::testing::InCi()) {                             \
        FAIL() << "CI=true and no OpenGL ES context: " << autonomsim_gl_reason; \
      }                                                                         \
      GTEST_SKIP() << "no OpenGL ES context here: " << autonomsim_gl_reason;    \
    }                                                                           \
  } while (false)
