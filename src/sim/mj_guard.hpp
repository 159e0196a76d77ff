// MuJoCo's own errors as our errors. mju_error normally prints, writes MUJOCO_LOG.TXT and exits
// the process; we install mju_user_error and mju_user_warning once, and run every MuJoCo call
// that can fail inside mj_guarded(), which turns an error into an Error value. The handler
// leaves MuJoCo with longjmp (MuJoCo is C, so no destructor is skipped inside it); the guarded
// callable must therefore not own objects with destructors itself.
#pragma once

#include <string>

#include "scaratwin/core/result.hpp"

namespace scaratwin::sim::detail {

// Installs the handlers (idempotent, thread-safe).
void install_mujoco_handlers();

// Runs fn() and returns an Error (code `code`, message "what: <MuJoCo's message>") when MuJoCo
// raised mju_error inside it. Nests and works per thread.
Status mj_guarded(int code, const char* what, void (*fn)(void*), void* arg);

template <typename F>
Status mj_guarded(int code, const char* what, F& f) {
  return mj_guarded(
      code, what, [](void* p) { (*static_cast<F*>(p))(); }, &f);
}

// The last warnings MuJoCo printed through mju_warning (for logs), cleared by the call.
std::string take_mujoco_warnings();

}  // namespace scaratwin::sim::detail
