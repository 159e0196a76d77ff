#include <utility>  // before Boost.Asio (Boost 1.74 misses it)

#include "scaratwin/transport/io_thread.hpp"

#include <pthread.h>

#include <atomic>
#include <boost/asio/executor_work_guard.hpp>
#include <boost/asio/io_context.hpp>
#include <cstdio>
#include <exception>
#include <optional>

namespace scaratwin::transport {

struct IoThread::Impl {
  boost::asio::io_context context{1};
  std::optional<boost::asio::executor_work_guard<boost::asio::io_context::executor_type>> guard;
  std::thread thread;
  std::atomic<unsigned long> escaped{0};
};

IoThread::IoThread(std::string name) : impl_(std::make_unique<Impl>()) {
  impl_->guard.emplace(impl_->context.get_executor());
  impl_->thread = std::thread([impl = impl_.get(), name = std::move(name)] {
    pthread_setname_np(pthread_self(), name.substr(0, 15).c_str());
    for (;;) {
      try {
        impl->context.run();
        return;
      } catch (const std::exception& e) {
        // no exception may end the event loop: log, count, keep running
        impl->escaped.fetch_add(1);
        std::fprintf(stderr, "scaratwin io thread: handler threw: %s\n", e.what());
      }
    }
  });
}

IoThread::~IoThread() {
  impl_->guard.reset();
  impl_->context.stop();
  if (!impl_->thread.joinable()) return;
  if (impl_->thread.get_id() == std::this_thread::get_id()) {
    // the last owner let go from a handler on this very thread (a link whose last reference
    // a completing handler held): it cannot join itself (std::system_error, EDEADLK, seen
    // under ThreadSanitizer's timing). The loop returns once this handler does; a helper
    // joins it, then frees the context it was running.
    std::thread([impl = std::move(impl_)] { impl->thread.join(); }).detach();
    return;
  }
  impl_->thread.join();
}

boost::asio::io_context& IoThread::context() { return impl_->context; }

bool IoThread::in_io_thread() const { return impl_->thread.get_id() == std::this_thread::get_id(); }

unsigned long IoThread::escaped_exceptions() const { return impl_->escaped.load(); }

}  // namespace scaratwin::transport
