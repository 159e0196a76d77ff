#include "scaratwin/session/hub_service.hpp"

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <future>
#include <memory>
#include <mutex>
#include <optional>

#include <fmt/format.h>

#include "scaratwin/fleet/hub_state.hpp"
#include "scaratwin/fleet/mqtt_bridge.hpp"

namespace scaratwin::session {
namespace {

// A command to run on the hub: from the fleet's topic or from a local client of the port's
// owner (a statement or a script); `done` gets how it ended.
struct Job {
  fleet::Command command;  // its id (as JSON) and its statement, for the log and the status
  std::function<Result<std::string>(Hub&)> run;
  std::function<void(const Result<std::string>&)> done;
};

// The commands that arrived and the one being run. The bridge's and the local clients'
// threads add; the hub's thread takes and runs.
class Jobs {
 public:
  explicit Jobs(std::size_t capacity) : capacity_(capacity) {}

  // false: the queue is full (the command is refused).
  bool add(Job j) {
    std::lock_guard<std::mutex> lock(mu_);
    if (closed_ || queue_.size() >= capacity_) return false;
    queue_.push_back(std::move(j));
    cv_.notify_all();
    return true;
  }
  // `stop` goes before everything that waits; whatever runs is interrupted by the caller.
  void add_stop(Job j) {
    std::lock_guard<std::mutex> lock(mu_);
    queue_.push_front(std::move(j));
    stop_pending_ = true;
    cv_.notify_all();
  }
  bool busy() const {
    std::lock_guard<std::mutex> lock(mu_);
    return status_.running;
  }
  // Whether the job with this id runs now; if so the caller's interrupt is taken as a stop
  // of it alone (serving goes on).
  bool cancel_if_running(const std::string& id_json) {
    std::lock_guard<std::mutex> lock(mu_);
    if (!status_.running || status_.id_json != id_json) return false;
    stop_pending_ = true;
    return true;
  }
  // The next command, or nothing after `wait`.
  std::optional<Job> take(std::chrono::milliseconds wait) {
    std::unique_lock<std::mutex> lock(mu_);
    if (!cv_.wait_for(lock, wait, [this] { return !queue_.empty(); })) return std::nullopt;
    Job j = std::move(queue_.front());
    queue_.pop_front();
    status_.id_json = j.command.id_json;
    status_.statement = j.command.statement;
    status_.running = true;
    status_.elapsed_s = 0.0;
    started_ = std::chrono::steady_clock::now();
    return j;
  }
  void finished(bool ok) {
    std::lock_guard<std::mutex> lock(mu_);
    status_.running = false;
    status_.elapsed_s = seconds_since_start();
    ++(ok ? status_.done : status_.failed);
  }
  // A stop was asked for (the hub was interrupted on its behalf): true once.
  bool take_stop_pending() {
    std::lock_guard<std::mutex> lock(mu_);
    return std::exchange(stop_pending_, false);
  }
  fleet::JobStatus status() const {
    std::lock_guard<std::mutex> lock(mu_);
    fleet::JobStatus s = status_;
    s.queued = queue_.size();
    if (s.running) s.elapsed_s = seconds_since_start();
    return s;
  }
  // The hub stops serving: every command still waiting is told so, and no more are taken.
  void close() {
    std::deque<Job> left;
    {
      std::lock_guard<std::mutex> lock(mu_);
      closed_ = true;
      left.swap(queue_);
    }
    for (Job& j : left) {
      if (j.done) j.done(Error{HubError::kInterrupted, "the hub stopped before it ran this"});
    }
  }

 private:
  double seconds_since_start() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - started_).count();
  }

  std::size_t capacity_;
  mutable std::mutex mu_;
  std::condition_variable cv_;
  std::deque<Job> queue_;
  fleet::JobStatus status_;
  std::chrono::steady_clock::time_point started_{};
  bool stop_pending_ = false;
  bool closed_ = false;
};

bool is_stop(const std::string& statement) {
  const size_t b = statement.find_first_not_of(" \t");
  if (b == std::string::npos) return false;
  const size_t e = statement.find_first_of(" \t", b);
  return statement.substr(b, e == std::string::npos ? e : e - b) == "stop";
}

// A local client's request (a statement or a script, session/port_owner.hpp) as a job, run on
// the hub's thread in its turn; the client's thread waits for it, and a client that goes away
// stops it (as Ctrl-C stops a statement that holds the port itself).
Status run_for_client(Hub& hub, Jobs& jobs, const OwnerRequest& request, const Say& say,
                      const std::function<bool()>& gone) {
  static std::atomic<unsigned> next{1};
  Job job;
  job.command.id_json = fmt::format("\"local-{}\"", next++);
  job.command.statement = request.statement.empty() ? "run " + request.name : request.statement;
  auto result = std::make_shared<std::promise<Result<std::string>>>();
  auto ended = result->get_future();
  job.run = [request, say](Hub& h) -> Result<std::string> {
    if (Status s = run_request(h, request, say); !s) return s.error();
    return std::string("ok");
  };
  job.done = [result](const Result<std::string>& r) { result->set_value(r); };
  const std::string id = job.command.id_json;
  if (is_stop(request.statement)) {
    jobs.add_stop(std::move(job));
    if (jobs.busy()) hub.interrupt();
  } else if (!jobs.add(std::move(job))) {
    return Error{fleet::kBusy,
                 "the hub is busy or stopping: too many commands already wait (its "
                 "--queue); nothing was done"};
  }
  bool cancelled = false;
  while (ended.wait_for(std::chrono::milliseconds(50)) != std::future_status::ready) {
    if (!cancelled && gone()) {
      cancelled = true;
      if (jobs.cancel_if_running(id)) hub.interrupt();
    }
  }
  Result<std::string> r = ended.get();
  if (!r) return r.error();
  return Ok{};
}

}  // namespace

Status serve_hub(Hub& hub, const HubServiceOptions& a, PortOwner* owner, const Say& say) {
  const std::optional<fleet::BrokerAddress>& broker = a.broker;
  Jobs jobs(static_cast<std::size_t>(a.queue));
  std::unique_ptr<fleet::MqttBridge> bridge;
  if (broker) {
    fleet::BridgeOptions bo;
    bo.broker = *broker;
    bo.robot = a.name;
    auto handler = [&hub, &jobs, &a, &bridge](const fleet::Command& c) -> Status {
      Job job{c, [c](Hub& h) { return fleet::run_statement_text(h, c.statement); },
              [&bridge, id = c.id_json](const Result<std::string>& r) {
                if (bridge)
                  bridge->reply(r ? fleet::reply_ok(id, *r) : fleet::reply_error(id, r.error()));
              }};
      if (is_stop(c.statement)) {
        // stop acts at once, as `scaratwin stop` does beside a running hub: the command in
        // progress is interrupted (and fails), then the stop runs
        jobs.add_stop(std::move(job));
        if (jobs.busy()) hub.interrupt();
        return Ok{};
      }
      if (!jobs.add(std::move(job))) {
        return Error{fleet::kBusy, fmt::format("robot '{}' is busy: {} commands already wait "
                                               "(--queue); nothing was done",
                                               a.name, a.queue)};
      }
      return Ok{};
    };
    auto b = fleet::MqttBridge::start(bo, handler, say);
    if (!b) return b.error();
    bridge = std::move(*b);
  }
  std::optional<fleet::StatePublisher> publisher;
  if (bridge) {
    publisher.emplace(*bridge, hub, a.name, a.state_hz, [&jobs] { return jobs.status(); });
  }
  if (owner != nullptr) {
    owner->serve(
        [&hub, &jobs](const OwnerRequest& r, const Say& s, const std::function<bool()>& gone) {
          return run_for_client(hub, jobs, r, s, gone);
        });
  }
  // when serving ends: the commands still waiting are refused, the local clients answered
  struct Closer {
    Jobs& jobs;
    PortOwner* owner;
    ~Closer() {
      jobs.close();
      if (owner != nullptr) owner->stop();
    }
  } closer{jobs, owner};
  say(fmt::format("scaratwin hub: robot '{}' ready{}{}; Ctrl-C to stop", a.name,
                  broker ? fmt::format(", fleet on mqtt://{}:{} under {}/{}/", broker->host,
                                       broker->port, fleet::kTopicPrefix, a.name)
                         : std::string(),
                  owner != nullptr
                      ? fmt::format(", its port's statements at {}", owner->socket_path().string())
                      : std::string()));
  for (;;) {
    if (hub.interrupted() && !jobs.take_stop_pending()) {
      return Error{HubError::kInterrupted, "interrupted"};
    }
    auto job = jobs.take(std::chrono::milliseconds(100));
    if (!job) continue;
    const fleet::Command& c = job->command;
    if (is_stop(c.statement)) {
      (void)jobs.take_stop_pending();
      hub.clear_interrupt();
    }
    auto r = job->run(hub);
    jobs.finished(r.ok());
    // a stop that arrived during this command, or its client that went away, interrupted it:
    // serving goes on
    if (hub.interrupted() && jobs.take_stop_pending()) hub.clear_interrupt();
    say(fmt::format("{}command {} '{}': {}", a.log_prefix, c.id_json, c.statement,
                    r ? *r : "refused: " + r.error().message));
    if (job->done) job->done(r);
  }
}

}  // namespace scaratwin::session
