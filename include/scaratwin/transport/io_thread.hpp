// The io thread: one Boost.Asio io_context run by one dedicated thread. Every link does its
// I/O there, so link handlers never run concurrently with each other. Several links may share
// one IoThread (pass it to their constructors); a link created without one makes its own.
// The hub may run its own Asio work (a web server) on the same context.
#pragma once

#include <memory>
#include <string>
#include <thread>

namespace boost::asio {
class io_context;
}

namespace scaratwin::transport {

class IoThread {
 public:
  explicit IoThread(std::string name = "scaratwin-io");
  ~IoThread();  // stops the context and joins the thread
  IoThread(const IoThread&) = delete;
  IoThread& operator=(const IoThread&) = delete;

  boost::asio::io_context& context();
  // True when called from the io thread itself.
  bool in_io_thread() const;
  // Number of exceptions that escaped a handler (caught; the loop keeps running).
  unsigned long escaped_exceptions() const;

  static std::shared_ptr<IoThread> create(std::string name = "scaratwin-io") {
    return std::make_shared<IoThread>(std::move(name));
  }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace scaratwin::transport
