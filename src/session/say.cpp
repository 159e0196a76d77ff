#include "scaratwin/session/say.hpp"

#include <cstdio>

namespace scaratwin::session {

Say say_on_stdout() {
  return [](const std::string& line) {
    std::fwrite(line.data(), 1, line.size(), stdout);
    std::fputc('\n', stdout);
    std::fflush(stdout);
  };
}

Say say_nothing() {
  return [](const std::string&) {};
}

}  // namespace scaratwin::session
