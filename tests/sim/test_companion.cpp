// The paper's companion TCP dialect: the framer and decoder, then a real client on loopback
// (a plain POSIX socket, as MATLAB's tcpclient is one) moving the virtual robot, spawning,
// grasping and reading the camera's PNG; bad frames are logged with their reason, change
// nothing, and the connection keeps working.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "scaratwin/config/robot_config.hpp"
#include "scaratwin/kinematics/kinematics.hpp"
#include "scaratwin/sim/companion.hpp"
#include "scaratwin/sim/world.hpp"

namespace scaratwin::sim {
namespace {

constexpr double kDeg = M_PI / 180.0;

std::string frame(const std::string& payload) {
  return std::string(1, static_cast<char>(payload.size())) + payload;
}

RobotModel robot() {
  auto m = load_robot_config(SCARATWIN_CONFIG_FILE);
  EXPECT_TRUE(m.ok());
  return *m;
}

TEST(CompanionFramer, AnyChunkingGivesTheSameFrames) {
  const std::string stream = frame("Name:Matlab") + std::string(1, '\0') + frame("ModGrab:1") +
                             frame(std::string(255, 'x'));
  auto run = [&](std::size_t chunk) {
    CompanionFramer f;
    std::vector<std::string> frames, errors;
    for (std::size_t i = 0; i < stream.size(); i += chunk) {
      f.feed(
          std::string_view(stream).substr(i, chunk),
          [&](std::string_view p) { frames.emplace_back(p); },
          [&](const std::string& e) { errors.push_back(e); });
    }
    EXPECT_EQ(f.pending(), 0u);
    return std::make_pair(frames, errors);
  };
  const auto whole = run(stream.size());
  ASSERT_EQ(whole.first.size(), 3u);
  EXPECT_EQ(whole.first[0], "Name:Matlab");
  EXPECT_EQ(whole.first[1], "ModGrab:1");
  EXPECT_EQ(whole.first[2], std::string(255, 'x'));
  ASSERT_EQ(whole.second.size(), 1u);
  EXPECT_EQ(whole.second[0], "length byte 0 (a frame holds 1..255 bytes): skipped");
  for (std::size_t chunk : {1u, 2u, 7u, 64u}) EXPECT_EQ(run(chunk), whole) << "chunk " << chunk;
}

TEST(CompanionDecode, ModRobotTakesMetresAndDegreesAndIgnoresTrailingFields) {
  const RobotModel m = robot();
  // the companion scripts' own line: sprintf("ModRobot:%f,%f,%f,%f,d%", ...)
  auto c = parse_companion("ModRobot:0.089046,-20.500000,110.250000,45.000000,d%", m);
  ASSERT_TRUE(c.ok()) << c.error().message;
  EXPECT_EQ(c->kind, CompanionCommand::Kind::kModRobot);
  EXPECT_DOUBLE_EQ(c->q[0], 0.089046);
  EXPECT_NEAR(c->q[1], -20.5 * kDeg, 1e-15);
  EXPECT_NEAR(c->q[2], 110.25 * kDeg, 1e-15);
  EXPECT_NEAR(c->q[3], 45.0 * kDeg, 1e-15);
  // the limits themselves are inside; exponent and '+' are the invariant culture's too
  auto edge = parse_companion("ModRobot:0.12,115,-75,+1.8e2", m);
  ASSERT_TRUE(edge.ok()) << edge.error().message;
  EXPECT_NEAR(edge->q[3], M_PI, 1e-15);
}

TEST(CompanionDecode, EachBadFrameIsNamed) {
  const RobotModel m = robot();
  const std::pair<const char*, const char*> cases[] = {
      {"ModRobot", "no ':' (expected Command:arg,arg,..., e.g. ModGrab:1)"},
      {"Move:1", "unknown command 'Move' (known: Name, ModRobot, ModGrab, NewObj, Camera)"},
      {"ModRobot:0.1,2,3",
       "ModRobot takes at least 4 fields, got 3 (expected ModRobot:d1_m,q2_deg,q3_deg,q4_deg)"},
      {"ModRobot:0.1,NaN,0,0",
       "ModRobot field 2 (q2) 'NaN' is not a number (expected e.g. 0.12 or -30.5: digits, '.' "
       "decimals, no spaces)"},
      {"ModRobot:0.1,0,0,inf",
       "ModRobot field 4 (q4) 'inf' is not a number (expected e.g. 0.12 or -30.5: digits, '.' "
       "decimals, no spaces)"},
      {"ModRobot:0.1,2.5.1,0,0",
       "ModRobot field 2 (q2) '2.5.1' is not a number (expected e.g. 0.12 or -30.5: digits, '.' "
       "decimals, no spaces)"},
      {"ModRobot:0.1, 5,0,0",
       "ModRobot field 2 (q2) ' 5' is not a number (expected e.g. 0.12 or -30.5: digits, '.' "
       "decimals, no spaces)"},
      {"ModRobot:0.13,0,0,0", "ModRobot d1 0.13 m is outside the joint limits 0.01..0.12 m"},
      {"ModRobot:0.1,116,0,0", "ModRobot q2 116 deg is outside the joint limits -105..115 deg"},
      {"ModRobot:0.1,0,-76,0", "ModRobot q3 -76 deg is outside the joint limits -75..205 deg"},
      {"ModRobot:0.1,0,0,-0.5", "ModRobot q4 -0.5 deg is outside the joint limits 0..180 deg"},
      {"ModGrab:2", "ModGrab '2': expected 1 (grasp) or 0 (release)"},
      {"ModGrab:1,0", "ModGrab takes 1 field, got 2 (expected ModGrab:1 or ModGrab:0)"},
      {"NewObj:4", "NewObj '4': expected 1 (red), 2 (green) or 3 (blue)"},
      {"Camera:Center,img",
       "Camera takes 3 fields, got 2 (expected Camera:<camera>,<path>,<name>)"},
      {"Name:a\tb", "byte 0x09 is not printable ASCII (a frame is text: Command:arg,arg,...)"},
  };
  for (const auto& [payload, message] : cases) {
    auto c = parse_companion(payload, m);
    ASSERT_FALSE(c.ok()) << payload;
    EXPECT_EQ(c.error().message, message) << payload;
  }
}

// A blocking loopback client, as the companion scripts' tcpclient.
class Client {
 public:
  explicit Client(std::uint16_t port) {
    fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(port);
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    connected_ = ::connect(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0;
  }
  ~Client() { ::close(fd_); }
  bool connected() const { return connected_; }
  void send(const std::string& bytes) {
    ASSERT_EQ(::send(fd_, bytes.data(), bytes.size(), MSG_NOSIGNAL),
              static_cast<ssize_t>(bytes.size()));
  }
  // Reads until nothing more arrives for `quiet_ms` (after the first byte, waiting up to
  // `first_ms` for it): "until no bytes are left", as the companion scripts read an image.
  std::string read_all(int first_ms, int quiet_ms) {
    std::string out;
    int wait = first_ms;
    char buf[65536];
    for (;;) {
      pollfd p{fd_, POLLIN, 0};
      if (::poll(&p, 1, wait) <= 0) break;
      const ssize_t n = ::recv(fd_, buf, sizeof buf, 0);
      if (n <= 0) break;
      out.append(buf, static_cast<std::size_t>(n));
      wait = quiet_ms;
    }
    return out;
  }

 private:
  int fd_ = -1;
  bool connected_ = false;
};

class CompanionServerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    model_ = robot();
    auto w = World::create(model_);
    ASSERT_TRUE(w.ok()) << w.error().message;
    world_ = std::move(*w);
    world_->start();
    CompanionOptions o;
    o.port = 0;
    o.log = [this](const std::string& line) {
      std::lock_guard lock(log_mutex_);
      log_.push_back(line);
    };
    auto s = CompanionServer::create(*world_, o);
    ASSERT_TRUE(s.ok()) << s.error().message;
    server_ = std::move(*s);
  }
  void TearDown() override {
    server_.reset();
    if (world_) world_->stop();
  }

  // Waits until the server has handled `n` frames in all (the dialect sends no replies).
  bool handled(std::uint64_t n) {
    const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    while (server_->counters().frames < n) {
      if (std::chrono::steady_clock::now() > until) return false;
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    return true;
  }
  std::vector<std::string> log() {
    std::lock_guard lock(log_mutex_);
    return log_;
  }
  JointVector joints() {
    return world_->with_simulation([](Simulation& s) { return s.joints(); });
  }
  std::vector<CubeState> cubes() {
    return world_->with_simulation([](Simulation& s) { return s.cubes(); });
  }

  RobotModel model_;
  std::unique_ptr<World> world_;
  std::unique_ptr<CompanionServer> server_;
  std::mutex log_mutex_;
  std::vector<std::string> log_;
};

TEST_F(CompanionServerTest, ModRobotMovesTheVirtualRobotInPaperUnits) {
  Client c(server_->port());
  ASSERT_TRUE(c.connected());
  c.send(frame("Name:Matlab") + frame("ModRobot:0.080000,30.000000,-45.000000,10.000000,d%"));
  ASSERT_TRUE(handled(2));
  const JointVector q = joints();
  EXPECT_NEAR(q[0], 0.08, 1e-9);
  EXPECT_NEAR(q[1], 30.0 * kDeg, 1e-9);
  EXPECT_NEAR(q[2], -45.0 * kDeg, 1e-9);
  EXPECT_NEAR(q[3], 10.0 * kDeg, 1e-9);
  const auto l = log();
  ASSERT_GE(l.size(), 2u);
  EXPECT_NE(l[1].find("is named 'Matlab'"), std::string::npos) << l[1];
  EXPECT_EQ(server_->counters().applied, 2u);
}

TEST_F(CompanionServerTest, BadFramesAreLoggedChangeNothingAndTheConnectionStaysUp) {
  Client c(server_->port());
  ASSERT_TRUE(c.connected());
  c.send(frame("ModRobot:0.1,20,30,40"));
  ASSERT_TRUE(handled(1));
  const JointVector before = joints();
  c.send(std::string(1, '\0') + frame("Jump:1") + frame("ModRobot:0.1,20,30") +
         frame("ModRobot:0.1,nan,30,40") + frame("ModRobot:0.1,20,206,40") + frame("ModGrab:yes") +
         frame("NewObj:0"));
  ASSERT_TRUE(handled(8));
  EXPECT_EQ(joints(), before);
  EXPECT_TRUE(cubes().empty());
  EXPECT_FALSE(world_->with_simulation([](Simulation& s) { return s.gripper_closed(); }));
  EXPECT_EQ(server_->counters().refused, 7u);
  const auto l = log();
  const char* reasons[] = {"length byte 0",
                           "unknown command 'Jump'",
                           "ModRobot takes at least 4 fields, got 3",
                           "'nan' is not a number",
                           "q3 206 deg is outside the joint limits",
                           "ModGrab 'yes'",
                           "NewObj '0'"};
  for (const char* r : reasons) {
    bool found = false;
    for (const auto& line : l) found |= line.find(r) != std::string::npos;
    EXPECT_TRUE(found) << "no log line says: " << r;
  }
  // the same connection still works
  c.send(frame("ModRobot:0.05,-10,20,0"));
  ASSERT_TRUE(handled(9));
  EXPECT_NEAR(joints()[0], 0.05, 1e-9);
  EXPECT_NEAR(joints()[1], -10.0 * kDeg, 1e-9);
}

TEST_F(CompanionServerTest, NewObjSpawnsAndModGrabCarriesTheCube) {
  Client c(server_->port());
  ASSERT_TRUE(c.connected());
  c.send(frame("NewObj:3"));
  ASSERT_TRUE(handled(1));
  auto cs = cubes();
  ASSERT_EQ(cs.size(), 1u);
  EXPECT_EQ(cs[0].color, CubeColor::kBlue);
  // the tool over the cube at grasp height (the paper's convention: d1 in m, degrees)
  ToolPose pick;
  pick.x_m = cs[0].pos_m[0];
  pick.y_m = cs[0].pos_m[1];
  pick.z_m = model_.scene.grasp_z_m;
  // a cube looks the same every 90 deg: the first heading the wrist reaches
  Result<JointVector> q = Error{IkError::kBeyondReach, "unreachable"};
  for (double yaw : {0.0, 90.0, 180.0, -90.0}) {
    pick.yaw_rad = yaw * kDeg;
    q = inverse(model_, pick, model_.home);
    if (q.ok()) break;
  }
  ASSERT_TRUE(q.ok()) << q.error().message;
  auto mod = [](const JointVector& j) {
    char buf[128];
    std::snprintf(buf, sizeof buf, "ModRobot:%f,%f,%f,%f,d%%", j[0], j[1] / kDeg, j[2] / kDeg,
                  j[3] / kDeg);
    return frame(buf);
  };
  c.send(mod(*q) + frame("ModGrab:1"));
  ASSERT_TRUE(handled(3));
  EXPECT_EQ(world_->with_simulation([](Simulation& s) { return s.held_cube(); }), cs[0].id);
  // where the cube was grasped (it may have settled on the table since it was spawned)
  const auto grasped = cubes();
  ASSERT_EQ(grasped.size(), 1u);
  // lift by 3 cm: the cube goes with the tool
  JointVector up = *q;
  up[0] += 0.03;
  c.send(mod(up));
  ASSERT_TRUE(handled(4));
  // the held cube follows over the world's next steps (an event, not a time: wait until it has
  // risen and then rests, 0.01 mm or less between two looks 20 ms apart)
  std::vector<CubeState> lifted;
  double last_z = -1.0;
  for (int i = 0; i < 500; ++i) {
    lifted = cubes();
    if (lifted.size() != 1) break;
    const double z = lifted[0].pos_m[2];
    if (z - grasped[0].pos_m[2] > 0.02 && std::abs(z - last_z) < 1e-5) break;
    last_z = z;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  ASSERT_EQ(lifted.size(), 1u);
  EXPECT_NEAR(lifted[0].pos_m[2] - grasped[0].pos_m[2], 0.03, 0.003);
  c.send(frame("ModGrab:0"));
  ASSERT_TRUE(handled(5));
  EXPECT_EQ(world_->with_simulation([](Simulation& s) { return s.held_cube(); }), -1);
}

TEST_F(CompanionServerTest, CameraAnswersWithTheRawPngOfTheDescriptionsSize) {
  Client c(server_->port());
  ASSERT_TRUE(c.connected());
  c.send(frame("Camera:Center,C:/images,image"));
  const std::string png = c.read_all(10000, 500);
  ASSERT_GT(png.size(), 1000u);
  // PNG signature, IHDR width and height (big endian), and the IEND chunk last: the whole file
  EXPECT_EQ(png.substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8));
  auto be32 = [&](std::size_t at) {
    return (static_cast<std::uint32_t>(static_cast<unsigned char>(png[at])) << 24) |
           (static_cast<std::uint32_t>(static_cast<unsigned char>(png[at + 1])) << 16) |
           (static_cast<std::uint32_t>(static_cast<unsigned char>(png[at + 2])) << 8) |
           static_cast<std::uint32_t>(static_cast<unsigned char>(png[at + 3]));
  };
  EXPECT_EQ(png.substr(12, 4), "IHDR");
  EXPECT_EQ(be32(16), static_cast<std::uint32_t>(model_.scene.camera.width_px));
  EXPECT_EQ(be32(20), static_cast<std::uint32_t>(model_.scene.camera.height_px));
  EXPECT_EQ(png.substr(png.size() - 8, 4), "IEND");
  EXPECT_EQ(server_->counters().images_sent, 1u);
  // nothing else is ever sent: a ModRobot after it gets no reply
  c.send(frame("ModRobot:0.1,0,0,0"));
  ASSERT_TRUE(handled(2));
  EXPECT_TRUE(c.read_all(200, 50).empty());
}

TEST_F(CompanionServerTest, TwoClientsAtOnce) {
  Client a(server_->port()), b(server_->port());
  ASSERT_TRUE(a.connected() && b.connected());
  a.send(frame("Name:first"));
  b.send(frame("NewObj:1"));
  ASSERT_TRUE(handled(2));
  EXPECT_EQ(cubes().size(), 1u);
  EXPECT_EQ(server_->counters().clients, 2u);
}

}  // namespace
}  // namespace scaratwin::sim
