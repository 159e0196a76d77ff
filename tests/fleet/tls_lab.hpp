// Test helpers for MQTT over TLS: certificates made by the test with the openssl command (a CA,
// another CA, a broker certificate for localhost and 127.0.0.1, one that expired in 2020, one
// for another host, a client certificate) and a real Mosquitto with four TLS listeners, every
// one asking for a user and password (a password file made by mosquitto_passwd).
#pragma once

#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>

#include <fmt/format.h>

#include "mqtt_peer.hpp"
#include "scaratwin/hub/process.hpp"

namespace scaratwin::test {

struct TlsLab {
  std::filesystem::path dir;
  std::filesystem::path ca, other_ca, client_cert, client_key, password_file;
  std::string user = "fleet-user";
  std::string password = "pw-7f3c9a1e";  // the secret no process argument may show
  int port_ok = 0;                       // the broker's certificate for localhost and 127.0.0.1
  int port_expired = 0;                  // a certificate that expired on 2020-02-01
  int port_other_host = 0;               // a certificate for other.lab only
  int port_client_cert = 0;              // asks for a client certificate signed by the CA
  std::unique_ptr<ChildProcess> broker;
};

// Runs a shell command in `dir`; its output goes to dir/openssl.log. False when it fails.
inline bool run_in(const std::filesystem::path& dir, const std::string& command) {
  const std::string line =
      fmt::format("cd '{}' && ( {} ) >>openssl.log 2>&1", dir.string(), command);
  return std::system(line.c_str()) == 0;
}

// Makes the certificates and starts the broker; the error says which step failed.
inline Result<TlsLab> start_tls_lab(const std::filesystem::path& dir,
                                    const std::filesystem::path& mosquitto,
                                    const std::filesystem::path& mosquitto_passwd) {
  TlsLab lab;
  lab.dir = dir;
  std::filesystem::create_directories(dir);
  const auto fail = [&](const std::string& what) {
    std::ifstream log(dir / "openssl.log");
    std::string text((std::istreambuf_iterator<char>(log)), std::istreambuf_iterator<char>());
    return Error{1, fmt::format("{} failed: {}", what, text)};
  };
  const char* key = "-newkey rsa:2048 -nodes";
  if (!run_in(dir, fmt::format("openssl req -x509 {} -keyout ca.key -out ca.crt -days 2 "
                               "-subj '/CN=scaratwin test CA'",
                               key)) ||
      !run_in(dir, fmt::format("openssl req -x509 {} -keyout other-ca.key -out other-ca.crt "
                               "-days 2 -subj '/CN=another CA'",
                               key))) {
    return fail("the CAs");
  }
  // broker certificates signed by the CA; `openssl ca` sets any dates, the past included
  {
    std::ofstream cnf(dir / "ca.cnf");
    cnf << "[ca]\ndefault_ca = lab\n[lab]\ndir = ./cadb\ndatabase = $dir/index.txt\n"
           "serial = $dir/serial\nnew_certs_dir = $dir\ndefault_md = sha256\n"
           "policy = any\nunique_subject = no\n[any]\ncommonName = supplied\n"
           "[local]\nsubjectAltName = DNS:localhost,IP:127.0.0.1\n"
           "[other]\nsubjectAltName = DNS:other.lab\n"
           "[client]\nextendedKeyUsage = clientAuth\n";
  }
  const auto sign = [&](const std::string& name, const std::string& cn, const std::string& ext,
                        const std::string& dates) {
    return run_in(dir, fmt::format("openssl req {} -keyout {}.key -out {}.csr -subj '/CN={}'", key,
                                   name, name, cn)) &&
           run_in(dir, fmt::format("openssl ca -batch -config ca.cnf -cert ca.crt -keyfile ca.key "
                                   "-in {}.csr -out {}.crt -extensions {} {}",
                                   name, name, ext, dates));
  };
  if (!run_in(dir, "mkdir -p cadb && : >cadb/index.txt && echo 1000 >cadb/serial") ||
      !sign("broker", "localhost", "local", "-days 2") ||
      !sign("expired", "localhost", "local",
            "-startdate 20200101000000Z -enddate 20200201000000Z") ||
      !sign("other", "other.lab", "other", "-days 2") ||
      !sign("client", "fleet-client", "client", "-days 2")) {
    return fail("the certificates");
  }
  lab.ca = dir / "ca.crt";
  lab.other_ca = dir / "other-ca.crt";
  lab.client_cert = dir / "client.crt";
  lab.client_key = dir / "client.key";
  // the password: in a file, hashed in place for the broker by mosquitto_passwd -U
  lab.password_file = dir / "password";
  {
    std::ofstream pw(lab.password_file);
    pw << lab.password << "\n";
    std::ofstream broker_pw(dir / "broker.passwd");
    broker_pw << lab.user << ":" << lab.password << "\n";
  }
  std::filesystem::permissions(
      lab.password_file, std::filesystem::perms::owner_read | std::filesystem::perms::owner_write);
  if (!run_in(dir, fmt::format("'{}' -U broker.passwd", mosquitto_passwd.string()))) {
    return fail("mosquitto_passwd");
  }
  lab.port_ok = free_loopback_port();
  lab.port_expired = free_loopback_port();
  lab.port_other_host = free_loopback_port();
  lab.port_client_cert = free_loopback_port();
  {
    std::ofstream conf(dir / "mosquitto.conf");
    // as root, Mosquitto would drop to its own user, who cannot read this test's files
    if (::geteuid() == 0) conf << "user root\n";
    conf << fmt::format(
        "per_listener_settings false\nallow_anonymous false\n"
        "password_file {}\npersistence false\nlog_dest stderr\n"
        "log_type all\n",
        (dir / "broker.passwd").string());
    const auto listener = [&](int port, const std::string& cert, bool client_cert) {
      conf << fmt::format("listener {} 127.0.0.1\ncafile {}\ncertfile {}\nkeyfile {}\n", port,
                          (dir / "ca.crt").string(), (dir / (cert + ".crt")).string(),
                          (dir / (cert + ".key")).string());
      if (client_cert) conf << "require_certificate true\n";
    };
    listener(lab.port_ok, "broker", false);
    listener(lab.port_expired, "expired", false);
    listener(lab.port_other_host, "other", false);
    listener(lab.port_client_cert, "broker", true);
  }
  auto b =
      ChildProcess::start(mosquitto, {"-c", (dir / "mosquitto.conf").string()}, dir / "broker.log");
  if (!b) return b.error();
  if (auto l = (*b)->wait_for_line(" running", std::chrono::seconds(20)); !l) {
    return Error{1, fmt::format("mosquitto with TLS: {}", l.error().message)};
  }
  lab.broker = std::move(*b);
  return lab;
}

}  // namespace scaratwin::test
