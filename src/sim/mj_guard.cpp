#include "mj_guard.hpp"

#include <csetjmp>
#include <cstring>
#include <mutex>

#include <fmt/format.h>
#include <mujoco/mujoco.h>

namespace scaratwin::sim::detail {
namespace {

struct GuardFrame {
  std::jmp_buf env;
  char message[512];
  GuardFrame* outer;
};

thread_local GuardFrame* t_frame = nullptr;
std::mutex g_warn_mutex;
std::string g_warnings;

extern "C" void on_mujoco_error(const char* msg) {
  GuardFrame* f = t_frame;
  if (f == nullptr) {
    // an error outside any guard is a bug of ours: every entry point is guarded
    std::fprintf(stderr, "scaratwin-sim: MuJoCo error outside a guarded call: %s\n", msg);
    std::abort();
  }
  std::snprintf(f->message, sizeof f->message, "%s", msg);
  std::longjmp(f->env, 1);
}

extern "C" void on_mujoco_warning(const char* msg) {
  std::lock_guard lock(g_warn_mutex);
  if (g_warnings.size() < 4096) {
    g_warnings += msg;
    g_warnings += '\n';
  }
}

// Kept apart so that setjmp's frame holds no C++ object.
int run_frame(GuardFrame* frame, void (*fn)(void*), void* arg) {
  if (setjmp(frame->env) != 0) return 1;
  fn(arg);
  return 0;
}

}  // namespace

void install_mujoco_handlers() {
  static std::once_flag once;
  std::call_once(once, [] {
    mju_user_error = on_mujoco_error;
    mju_user_warning = on_mujoco_warning;
  });
}

Status mj_guarded(int code, const char* what, void (*fn)(void*), void* arg) {
  install_mujoco_handlers();
  GuardFrame frame;
  frame.message[0] = '\0';
  frame.outer = t_frame;
  t_frame = &frame;
  const int failed = run_frame(&frame, fn, arg);
  t_frame = frame.outer;
  if (failed) return Error{code, fmt::format("{}: MuJoCo error: {}", what, frame.message)};
  return Ok{};
}

std::string take_mujoco_warnings() {
  std::lock_guard lock(g_warn_mutex);
  return std::exchange(g_warnings, {});
}

}  // namespace scaratwin::sim::detail
