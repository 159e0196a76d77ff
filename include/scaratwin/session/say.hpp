// Where a session's messages go. The session library formats what a procedure has to say, one
// line at a time; each front end decides where it goes: the command line prints it, Python
// collects it or passes it to a callback, the panel shows it.
#pragma once

#include <functional>
#include <string>

namespace scaratwin::session {

// Receives one line of text, without its newline.
using Say = std::function<void(const std::string& line)>;

// Prints each line on stdout, flushed at once (the command line's progress).
Say say_on_stdout();

// Says nothing.
Say say_nothing();

}  // namespace scaratwin::session
