// Test peers that speak the protocol through the protocol codec over real file descriptors:
// a device on the master side of a pty (the firmware's part) and a simulator on a listening
// TCP socket. Each runs one thread; they are small on purpose but honour the protocol's
// reply rules, the device's 8-slot trajectory queue and its 64-byte receive window.
#pragma once

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <pty.h>
#include <sys/socket.h>
#include <termios.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <deque>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "scaratwin/protocol/codec.hpp"

namespace scaratwin::transport::testing {

inline void write_fd(int fd, std::string_view bytes) {
  while (!bytes.empty()) {
    ssize_t n = ::write(fd, bytes.data(), bytes.size());
    if (n <= 0) return;
    bytes.remove_prefix(static_cast<std::size_t>(n));
  }
}

// For sockets: a peer that went away is EPIPE, not SIGPIPE.
inline void send_fd(int fd, std::string_view bytes) {
  while (!bytes.empty()) {
    ssize_t n = ::send(fd, bytes.data(), bytes.size(), MSG_NOSIGNAL);
    if (n <= 0) return;
    bytes.remove_prefix(static_cast<std::size_t>(n));
  }
}

inline std::uint32_t now_us32() {
  return static_cast<std::uint32_t>(std::chrono::duration_cast<std::chrono::microseconds>(
                                        std::chrono::steady_clock::now().time_since_epoch())
                                        .count());
}

class DevicePeer {
 public:
  static constexpr int kSlots = 8;

  DevicePeer() {
    termios raw{};
    ::cfmakeraw(&raw);
    char name[128] = {};
    if (::openpty(&master_, &slave_, name, &raw, nullptr) == 0) path_ = name;
    thread_ = std::thread([this] { loop(); });
  }
  ~DevicePeer() {
    stop_ = true;
    thread_.join();
    ::close(slave_);
    ::close(master_);
  }
  const std::string& path() const { return path_; }

  std::mutex m;
  protocol::MotorSteps steps{1000, -500, 300};
  double wrist_rad = 0.5;
  std::vector<protocol::TrajectoryPoint> received;  // TP in arrival order
  std::vector<double> grip_commands;
  int overflows = 0;               // TP refused for lack of slots
  std::size_t max_unanswered = 0;  // largest unanswered input seen (window check)
  std::atomic<bool> ignore_queries{false};
  std::atomic<int> seq_step{1};  // ST sequence increment (2 = every other one "lost")

  void send(std::string_view bytes) { write_fd(master_, bytes); }

 private:
  void reply(const protocol::SerialFromDevice& msg) {
    auto bytes = protocol::encode(msg);
    if (bytes) write_fd(master_, *bytes);
  }

  void loop() {
    protocol::SerialToDeviceDecoder decoder;
    std::deque<protocol::TrajectoryPoint> queue;
    std::size_t carry = 0;  // bytes of a partial line
    auto last_step = std::chrono::steady_clock::now();
    while (!stop_) {
      pollfd p{master_, POLLIN, 0};
      if (::poll(&p, 1, 1) > 0 && (p.revents & POLLIN)) {
        char buf[512];
        ssize_t n = ::read(master_, buf, sizeof buf);
        if (n > 0) {
          std::string_view chunk(buf, static_cast<std::size_t>(n));
          std::size_t realtime = 0;
          for (char c : chunk) realtime += (c == '!' || c == '#' || c == '~');
          {
            std::lock_guard lock(m);
            max_unanswered = std::max(max_unanswered, carry + chunk.size() - realtime);
          }
          auto nl = chunk.rfind('\n');
          carry = nl == std::string_view::npos ? carry + chunk.size() : chunk.size() - nl - 1;
          decoder.feed(chunk, [&](protocol::Decoded<protocol::SerialToDevice>&& d) {
            handle(std::move(d), queue);
          });
        }
      }
      // execute one queued point every 2 ms
      if (std::chrono::steady_clock::now() - last_step > std::chrono::milliseconds(2)) {
        last_step = std::chrono::steady_clock::now();
        std::lock_guard lock(m);
        if (!queue.empty()) {
          steps = queue.front().steps;
          queue.pop_front();
        }
      }
    }
  }

  void handle(protocol::Decoded<protocol::SerialToDevice>&& d,
              std::deque<protocol::TrajectoryPoint>& queue) {
    using namespace protocol;
    if (auto* err = std::get_if<DecodeError>(&d)) {
      reply(ErrorReply{err->code, err->detail});
      return;
    }
    auto& msg = std::get<SerialToDevice>(d);
    std::lock_guard lock(m);
    const auto free_slots = static_cast<std::int32_t>(kSlots - queue.size());
    if (std::get_if<Hello>(&msg)) {
      reply(PeerHello{1, "test-uno", "0.0.1", {}});
    } else if (std::get_if<QueryState>(&msg)) {
      if (ignore_queries) return;
      DeviceState st;
      st.seq = seq_;
      seq_ = static_cast<std::uint16_t>(seq_ + seq_step.load());
      st.t_us = now_us32();
      st.steps = steps;
      st.wrist_rad = wrist_rad;
      st.queue_free = free_slots;
      reply(st);
    } else if (auto* tb = std::get_if<TrajectoryBegin>(&msg)) {
      queue.clear();
      (void)tb;
      reply(Ack{"TB", kSlots});
    } else if (auto* tp = std::get_if<TrajectoryPoint>(&msg)) {
      if (queue.size() >= static_cast<std::size_t>(kSlots)) {
        ++overflows;
        reply(ErrorReply{core::kErrQueueFull, 0});
        return;
      }
      queue.push_back(*tp);
      received.push_back(*tp);
      reply(Ack{"TP", free_slots - 1});
    } else if (auto* gr = std::get_if<SetGripper>(&msg)) {
      grip_commands.push_back(gr->angle_rad);
      reply(Ack{"GR", static_cast<std::int32_t>(
                          std::lround(gr->angle_rad * 18000.0 / 3.14159265358979))});
    } else if (std::get_if<RealtimeCommand>(&msg)) {
      // no reply
    } else {
      reply(Ack{encode(msg)->substr(0, 2), std::nullopt});
    }
  }

  int master_ = -1;
  int slave_ = -1;
  std::string path_;
  std::atomic<bool> stop_{false};
  std::uint16_t seq_ = 100;
  std::thread thread_;
};

class SimPeer {
 public:
  SimPeer() {
    listen_ = ::socket(AF_INET, SOCK_STREAM, 0);
    int one = 1;
    ::setsockopt(listen_, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    ::bind(listen_, reinterpret_cast<sockaddr*>(&a), sizeof a);
    ::listen(listen_, 4);
    socklen_t len = sizeof a;
    ::getsockname(listen_, reinterpret_cast<sockaddr*>(&a), &len);
    port_ = ntohs(a.sin_port);
    thread_ = std::thread([this] { loop(); });
  }
  ~SimPeer() {
    stop_ = true;
    thread_.join();
    if (conn_ >= 0) ::close(conn_);
    ::close(listen_);
  }
  std::uint16_t port() const { return port_; }
  // Drops the current connection (the simulator crashed).
  void drop() { drop_ = true; }

  std::mutex m;
  std::vector<protocol::ObjectPose> objects;
  std::vector<std::uint8_t> png;
  std::vector<protocol::JointData> joints;  // JD received
  std::atomic<bool> ignore_pings{false};
  // Hangs like a stopped process: reads, answers and accepts nothing, its connection open
  // (the kernel still completes new connections into the listen backlog).
  std::atomic<bool> hang{false};
  // A camera shot takes this long to answer (the loop blocked, as a render blocks it).
  std::atomic<int> camera_ms{0};

 private:
  void reply(const protocol::TcpFromSim& msg) {
    auto bytes = protocol::encode(msg);
    if (bytes) send_fd(conn_, *bytes);
  }

  void loop() {
    auto decoder = std::make_unique<protocol::TcpToSimDecoder>();
    while (!stop_) {
      if (hang) {
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
        continue;
      }
      if (drop_ && conn_ >= 0) {
        ::close(conn_);
        conn_ = -1;
        drop_ = false;
      }
      int fd = conn_ >= 0 ? conn_ : listen_;
      pollfd p{fd, POLLIN, 0};
      if (::poll(&p, 1, 2) <= 0) continue;
      if (conn_ < 0) {
        conn_ = ::accept(listen_, nullptr, nullptr);
        decoder = std::make_unique<protocol::TcpToSimDecoder>();
        continue;
      }
      char buf[4096];
      ssize_t n = ::read(conn_, buf, sizeof buf);
      if (n <= 0) {
        ::close(conn_);
        conn_ = -1;
        continue;
      }
      decoder->feed(std::string_view(buf, static_cast<std::size_t>(n)),
                    [&](protocol::Decoded<protocol::TcpToSim>&& d) { handle(std::move(d)); });
    }
  }

  void handle(protocol::Decoded<protocol::TcpToSim>&& d) {
    using namespace protocol;
    if (auto* err = std::get_if<DecodeError>(&d)) {
      reply(ErrorReply{err->code, err->detail});
      return;
    }
    auto& msg = std::get<TcpToSim>(d);
    std::lock_guard lock(m);
    if (std::get_if<Hello>(&msg)) {
      reply(PeerHello{1, "test-sim", "0.0.1", {}});
    } else if (auto* ping = std::get_if<Ping>(&msg)) {
      if (!ignore_pings) reply(Ack{"PI", ping->token});
    } else if (auto* jd = std::get_if<JointData>(&msg)) {
      joints.push_back(*jd);
      reply(JointApplied{jd->seq, now_us32()});
    } else if (auto* gr = std::get_if<Grasp>(&msg)) {
      reply(GripperState{gr->close, gr->close ? 7 : -1});
    } else if (auto* cs = std::get_if<CameraShoot>(&msg)) {
      std::this_thread::sleep_for(std::chrono::milliseconds(camera_ms.load()));
      if (cs->width_px == 1) {
        reply(ErrorReply{core::kErrInternal, 0});
      } else {
        reply(Image{png});
      }
    } else if (auto* op = std::get_if<QueryObjects>(&msg)) {
      std::int32_t count = 0;
      std::string out;
      for (const auto& o : objects) {
        if (!op->id || *op->id == o.id) {
          (void)append(out, TcpFromSim(o));
          ++count;
        }
      }
      (void)append(out, TcpFromSim(Ack{"OP", count}));
      send_fd(conn_, out);
    } else {
      reply(Ack{encode(msg)->substr(0, 2), std::nullopt});
    }
  }

  int listen_ = -1;
  int conn_ = -1;
  std::uint16_t port_ = 0;
  std::atomic<bool> stop_{false};
  std::atomic<bool> drop_{false};
  std::thread thread_;
};

}  // namespace scaratwin::transport::testing
