// The web server's HTTP side over real loopback sockets: static files from the web root only,
// the JSON endpoints, refusals. (The WebSocket feed is exercised by the browser test.)
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

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
