// The web server's HTTP side over real loopback sockets: static files from the web root only,
// the JSON endpoints, refusals. (The WebSocket feed is exercised by the browser test.)
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>

#include "scaratwin/config/robot_config.hpp"
#include "scaratwin/web/feed.hpp"
#include "scaratwin/web/web_server.hpp"

namespace scaratwin::web {
namespace {

// One HTTP/1.1 request on a fresh connection; returns the whole response.
std::string request(std::uint16_t port, const std::string& text) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  EXPECT_GE(fd, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(port);
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
    ::close(fd);
    return "connect failed";
  }
  timeval tv{5, 0};
  ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
  EXPECT_EQ(::send(fd, text.data(), text.size(), 0), static_cast<ssize_t>(text.size()));
  std::string out;
  char buf[4096];
  for (;;) {
    const ssize_t n = ::recv(fd, buf, sizeof buf, 0);
    if (n <= 0) break;
    out.append(buf, static_cast<std::size_t>(n));
  }
  ::close(fd);
  return out;
}

std::string get(std::uint16_t port, const std::string& target) {
  return request(port, "GET " + target + " HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n");
}

std::string body_of(const std::string& response) {
  const auto p = response.find("\r\n\r\n");
  return p == std::string::npos ? std::string() : response.substr(p + 4);
}

class HttpTest : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ =
        std::filesystem::temp_directory_path() / ("scaratwin-web-" + std::to_string(::getpid()));
    std::filesystem::create_directories(root_ / "js");
    std::ofstream(root_ / "index.html") << "<!doctype html><title>twin</title>";
    std::ofstream(root_ / "js" / "app.js") << "export const x = 1;";
    std::ofstream(root_.parent_path() / "secret.txt") << "TOP-SECRET-CONTENT";
    auto robot = load_robot_config_or_default("");
    ASSERT_TRUE(robot.ok());
    sim::WorldOptions wo;
    wo.camera = false;
    auto world = sim::World::create(*robot, {}, wo);
    ASSERT_TRUE(world.ok());
    world_ = std::move(*world);
    WebOptions o;
    o.port = 0;
    o.root_dir = root_.string();
    auto server = WebServer::create(*world_, o);
    ASSERT_TRUE(server.ok()) << server.error().message;
    server_ = std::move(*server);
  }
  void TearDown() override {
    server_.reset();
    std::filesystem::remove_all(root_);
    std::filesystem::remove(root_.parent_path() / "secret.txt");
  }
  std::filesystem::path root_;
  std::unique_ptr<sim::World> world_;
  std::unique_ptr<WebServer> server_;
};

TEST_F(HttpTest, ServesThePageAndItsAssetsWithTheirTypes) {
  const std::string index = get(server_->port(), "/");
  EXPECT_EQ(index.rfind("HTTP/1.1 200", 0), 0U) << index;
  EXPECT_NE(index.find("text/html"), std::string::npos);
  EXPECT_EQ(body_of(index), "<!doctype html><title>twin</title>");
  const std::string js = get(server_->port(), "/js/app.js?v=2");
  EXPECT_EQ(js.rfind("HTTP/1.1 200", 0), 0U);
  EXPECT_NE(js.find("text/javascript"), std::string::npos);
  const std::string head =
      request(server_->port(), "HEAD /js/app.js HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n");
  EXPECT_EQ(head.rfind("HTTP/1.1 200", 0), 0U);
  EXPECT_TRUE(body_of(head).empty());
}

TEST_F(HttpTest, NeverServesOutsideTheRoot) {
  for (const char* target : {"/../secret.txt", "/js/../../secret.txt", "/%2e%2e/secret.txt",
                             "//etc/passwd", "/js\\..\\..\\secret.txt"}) {
    const std::string r = get(server_->port(), target);
    EXPECT_EQ(r.find("TOP-SECRET-CONTENT"), std::string::npos) << target << ": " << r;
    EXPECT_TRUE(r.rfind("HTTP/1.1 400", 0) == 0 || r.rfind("HTTP/1.1 404", 0) == 0)
        << target << ": " << r;
  }
  EXPECT_EQ(get(server_->port(), "/missing.js").rfind("HTTP/1.1 404", 0), 0U);
  EXPECT_EQ(request(server_->port(),
                    "POST / HTTP/1.1\r\nHost: x\r\nContent-Length: 0\r\n"
                    "Connection: close\r\n\r\n")
                .rfind("HTTP/1.1 405", 0),
            0U);
}

TEST_F(HttpTest, JsonEndpointsCarryTheSceneAndTheState) {
  const auto scene = nlohmann::json::parse(body_of(get(server_->port(), "/api/scene")));
  EXPECT_EQ(scene["type"], "scene");
  ASSERT_TRUE(world_
                  ->with_simulation([](sim::Simulation& s) {
                    return s.spawn_cube(CubeColor::kGreen, 0.15, 0.05);
                  })
                  .ok());
  const auto state = nlohmann::json::parse(body_of(get(server_->port(), "/api/state")));
  EXPECT_EQ(state["type"], "state");
  ASSERT_EQ(state["cubes"].size(), 1U);
  EXPECT_EQ(state["cubes"][0]["color"], "green");
}

// The status line of a WebSocket upgrade to `target` with the given Host and Origin (no
// Origin header when empty); the connection is closed after the response's head.
std::string upgrade(std::uint16_t port, const std::string& target, const std::string& host,
                    const std::string& origin) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(port);
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
    ::close(fd);
    return "connect failed";
  }
  timeval tv{5, 0};
  ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
  std::string text = "GET " + target + " HTTP/1.1\r\nHost: " + host +
                     "\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
                     "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n";
  if (!origin.empty()) text += "Origin: " + origin + "\r\n";
  text += "\r\n";
  EXPECT_EQ(::send(fd, text.data(), text.size(), 0), static_cast<ssize_t>(text.size()));
  std::string out;
  char buf[4096];
  while (out.find("\r\n") == std::string::npos) {
    const ssize_t n = ::recv(fd, buf, sizeof buf, 0);
    if (n <= 0) break;
    out.append(buf, static_cast<std::size_t>(n));
  }
  ::close(fd);
  return out.substr(0, out.find("\r\n"));
}

// issue 17: a WebSocket upgrade with `Origin: http://evil.example` was accepted, so any web
// page could reset the scene, spawn cubes and take pictures through the visitor's browser.
TEST_F(HttpTest, WebSocketFromAnotherSiteIsRefused) {
  const std::uint16_t port = server_->port();
  const std::string self = "127.0.0.1:" + std::to_string(port);
  EXPECT_EQ(upgrade(port, "/ws", self, "http://evil.example"), "HTTP/1.1 403 Forbidden");
  EXPECT_EQ(upgrade(port, "/ws", self, "null"), "HTTP/1.1 403 Forbidden");
  // DNS rebinding: a hostile name resolving to 127.0.0.1 is its own origin, but not this host
  const std::string evil = "evil.example:" + std::to_string(port);
  EXPECT_EQ(upgrade(port, "/ws", evil, "http://" + evil), "HTTP/1.1 403 Forbidden");
  // the page's own origin, and clients that are not browsers (no Origin)
  EXPECT_EQ(upgrade(port, "/ws", self, "http://" + self), "HTTP/1.1 101 Switching Protocols");
  const std::string local = "localhost:" + std::to_string(port);
  EXPECT_EQ(upgrade(port, "/ws", local, "http://" + local), "HTTP/1.1 101 Switching Protocols");
  EXPECT_EQ(upgrade(port, "/ws", self, ""), "HTTP/1.1 101 Switching Protocols");
}

// A page folder holding an index.html of "page", and a world without a camera, removed at the
// end of the test.
struct PageAndWorld {
  explicit PageAndWorld(const std::string& name)
      : root(std::filesystem::temp_directory_path() /
             ("scaratwin-web-" + name + "-" + std::to_string(::getpid()))) {
    std::filesystem::create_directories(root);
    std::ofstream(root / "index.html") << "page";
    auto robot = load_robot_config_or_default("");
    EXPECT_TRUE(robot.ok());
    sim::WorldOptions wo;
    wo.camera = false;
    auto w = sim::World::create(*robot, {}, wo);
    EXPECT_TRUE(w.ok());
    if (w) world = std::move(*w);
    options.port = 0;
    options.root_dir = root.string();
  }
  ~PageAndWorld() { std::filesystem::remove_all(root); }
  std::filesystem::path root;
  std::unique_ptr<sim::World> world;
  WebOptions options;
};

// With a token (a simulator serving beyond this machine), the socket and the JSON endpoints
// need it on every connection; the page's files do not (they hold nothing secret).
TEST(WebServer, TokenIsNeededForTheSocketAndTheApi) {
  PageAndWorld pw("token");
  ASSERT_TRUE(pw.world);
  WebOptions o = pw.options;
  o.token = "t0ken";
  auto server = WebServer::create(*pw.world, o);
  ASSERT_TRUE(server.ok()) << server.error().message;
  const std::uint16_t port = (*server)->port();
  const std::string lan = "192.168.1.20:" + std::to_string(port);
  const std::string page = "http://" + lan;
  EXPECT_EQ(upgrade(port, "/ws", lan, page), "HTTP/1.1 403 Forbidden");
  EXPECT_EQ(upgrade(port, "/ws?token=wrong", lan, page), "HTTP/1.1 403 Forbidden");
  EXPECT_EQ(upgrade(port, "/ws?token=t0ken", lan, "http://evil.example"), "HTTP/1.1 403 Forbidden");
  EXPECT_EQ(upgrade(port, "/ws?token=t0ken", lan, page), "HTTP/1.1 101 Switching Protocols");
  EXPECT_EQ(get(port, "/api/state").rfind("HTTP/1.1 403", 0), 0U);
  EXPECT_EQ(get(port, "/api/state?token=t0k").rfind("HTTP/1.1 403", 0), 0U);
  EXPECT_EQ(get(port, "/api/state?token=t0ken").rfind("HTTP/1.1 200", 0), 0U);
  EXPECT_EQ(body_of(get(port, "/?token=t0ken")), "page");
  EXPECT_EQ(body_of(get(port, "/")), "page");
  server->reset();
}

// The fleet page's data: served only by a server given a fleet, behind the same token, and the
// scene tells the page whether there is one (so it links to the fleet page).
TEST(WebServer, FleetDataOnlyWithAFleetAndBehindTheToken) {
  PageAndWorld pw("fleet");
  ASSERT_TRUE(pw.world);
  WebOptions o = pw.options;
  {
    auto plain = WebServer::create(*pw.world, o);
    ASSERT_TRUE(plain.ok()) << plain.error().message;
    const std::string r = get((*plain)->port(), "/api/fleet");
    EXPECT_EQ(r.rfind("HTTP/1.1 404", 0), 0U) << r;
    EXPECT_EQ(body_of(r),
              "this simulator watches no fleet: start it with --mqtt mqtt://HOST[:PORT]\n");
    EXPECT_EQ(nlohmann::json::parse(body_of(get((*plain)->port(), "/api/scene")))["fleet"], false);
  }
  o.token = "t0ken";
  o.fleet = [] { return std::string(R"({"robots": [{"name": "r1"}]})"); };
  auto server = WebServer::create(*pw.world, o);
  ASSERT_TRUE(server.ok()) << server.error().message;
  const std::uint16_t port = (*server)->port();
  EXPECT_EQ(get(port, "/api/fleet").rfind("HTTP/1.1 403", 0), 0U);
  const std::string r = get(port, "/api/fleet?token=t0ken");
  EXPECT_EQ(r.rfind("HTTP/1.1 200", 0), 0U) << r;
  EXPECT_EQ(body_of(r), R"({"robots": [{"name": "r1"}]})");
  EXPECT_EQ(nlohmann::json::parse(body_of(get(port, "/api/scene?token=t0ken")))["fleet"], true);
  server->reset();
}

// issue 17: a browser that asks for pictures and never reads them made the server queue
// them without a bound (300 unread pictures: +60 MB). Beyond max_unread_bytes (16 MiB by
// default; 1 MiB here, some 50 pictures of this empty scene) the connection is cut, and says
// so.
TEST(WebServer, BrowserThatNeverReadsItsRepliesIsCut) {
  const auto root = std::filesystem::temp_directory_path() /
                    ("scaratwin-web-unread-" + std::to_string(::getpid()));
  std::filesystem::create_directories(root);
  std::ofstream(root / "index.html") << "page";
  auto robot = load_robot_config_or_default("");
  ASSERT_TRUE(robot.ok());
  auto world = sim::World::create(*robot);  // with the camera: pictures of ~0.1-0.3 MB
  ASSERT_TRUE(world.ok()) << world.error().message;
  WebOptions o;
  o.port = 0;
  o.root_dir = root.string();
  o.max_unread_bytes = std::size_t{1} << 20;
  auto server = WebServer::create(**world, o);
  ASSERT_TRUE(server.ok()) << server.error().message;
  const std::uint16_t port = (*server)->port();

  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  const int small = 4096;
  ::setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &small, sizeof small);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(port);
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ASSERT_EQ(::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0);
  const std::string hs =
      "GET /ws HTTP/1.1\r\nHost: 127.0.0.1\r\nUpgrade: websocket\r\n"
      "Connection: Upgrade\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n"
      "Sec-WebSocket-Version: 13\r\n\r\n";
  ASSERT_EQ(::send(fd, hs.data(), hs.size(), 0), static_cast<ssize_t>(hs.size()));
  testing::internal::CaptureStderr();
  // masked text frames (mask key 0), never a byte read back
  const std::string cmd = R"({"cmd":"shoot"})";
  std::string frame = {static_cast<char>(0x81), static_cast<char>(0x80 | cmd.size()), 0, 0, 0, 0};
  frame += cmd;
  for (int i = 0; i < 1000; ++i) {
    if (::send(fd, frame.data(), frame.size(), MSG_NOSIGNAL) < 0) break;
    if (i > 10 && (*server)->clients() == 0) break;  // cut
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while ((*server)->clients() > 0 && std::chrono::steady_clock::now() < end) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  const std::string log = testing::internal::GetCapturedStderr();
  EXPECT_EQ((*server)->clients(), 0U) << "the browser that never reads is still served";
  EXPECT_NE(log.find("bytes of replies unread (limit 1048576): connection closed"),
            std::string::npos)
      << log;
  ::close(fd);
  server->reset();
  std::filesystem::remove_all(root);
}

TEST(WebServer, RefusesAMissingPageABadAddressAndABusyPort) {
  auto robot = load_robot_config_or_default("");
  ASSERT_TRUE(robot.ok());
  sim::WorldOptions wo;
  wo.camera = false;
  auto world = sim::World::create(*robot, {}, wo);
  ASSERT_TRUE(world.ok());
  WebOptions o;
  o.port = 0;
  o.root_dir = "/nonexistent-web-root";
  auto r = WebServer::create(**world, o);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("/nonexistent-web-root"), std::string::npos);

  const auto root = std::filesystem::temp_directory_path() /
                    ("scaratwin-web-refuse-" + std::to_string(::getpid()));
  std::filesystem::create_directories(root);
  std::ofstream(root / "index.html") << "x";
  o.root_dir = root.string();
  o.bind_address = "localhost:80";
  r = WebServer::create(**world, o);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("localhost:80"), std::string::npos);

  o.bind_address = "127.0.0.1";
  auto first = WebServer::create(**world, o);
  ASSERT_TRUE(first.ok());
  o.port = (*first)->port();
  r = WebServer::create(**world, o);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, static_cast<int>(WebError::kBind));
  EXPECT_NE(r.error().message.find(std::to_string(o.port)), std::string::npos);
  std::filesystem::remove_all(root);
}

}  // namespace
}  // namespace scaratwin::web
