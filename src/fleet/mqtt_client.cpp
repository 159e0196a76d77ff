#include "mqtt_client.hpp"

#include "scaratwin/fleet/mqtt_bridge.hpp"

#include <arpa/inet.h>
#include <mosquitto.h>
#include <netdb.h>
#include <openssl/err.h>
#include <openssl/ssl.h>
#include <openssl/x509v3.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <memory>

#include <fmt/format.h>

namespace scaratwin::fleet::detail {
namespace {

Status readable(const std::string& file, std::string_view what) {
  if (file.empty()) return Ok{};
  std::ifstream in(file);
  if (!in) {
    return Error{kBadUrl, fmt::format("--mqtt: {} '{}': {}", what, file, std::strerror(errno))};
  }
  return Ok{};
}

// A TCP connection to host:port with 3 s timeouts, or -1.
int dial(const std::string& host, int port) {
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  addrinfo* found = nullptr;
  if (::getaddrinfo(host.c_str(), std::to_string(port).c_str(), &hints, &found) != 0) return -1;
  int fd = -1;
  for (addrinfo* ai = found; ai != nullptr && fd < 0; ai = ai->ai_next) {
    fd = ::socket(ai->ai_family, ai->ai_socktype | SOCK_CLOEXEC, ai->ai_protocol);
    if (fd < 0) continue;
    timeval tv{3, 0};
    ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
    ::setsockopt(fd, SOL_SOCKET, SO_SNDTIMEO, &tv, sizeof tv);
    if (::connect(fd, ai->ai_addr, ai->ai_addrlen) != 0) {
      ::close(fd);
      fd = -1;
    }
  }
  ::freeaddrinfo(found);
  return fd;
}

std::string openssl_reason() {
  const unsigned long e = ERR_get_error();
  ERR_clear_error();
  if (e == 0) return "the connection closed during the handshake";
  const char* r = ERR_reason_error_string(e);
  return r != nullptr ? r : fmt::format("OpenSSL error {:#x}", e);
}

// The handshake libmosquitto failed, made again with OpenSSL alone and the same settings, to
// learn why: the certificate check's own words, or the handshake's error.
std::string probe_tls(const BrokerAddress& a) {
  const std::string checked_with =
      a.ca_file.empty() ? "the system's CAs" : fmt::format("ca={}", a.ca_file);
  std::unique_ptr<SSL_CTX, decltype(&SSL_CTX_free)> ctx(SSL_CTX_new(TLS_client_method()),
                                                        &SSL_CTX_free);
  if (!ctx) return "TLS error (OpenSSL cannot make a context)";
  const int loaded = a.ca_file.empty()
                         ? SSL_CTX_set_default_verify_paths(ctx.get())
                         : SSL_CTX_load_verify_locations(ctx.get(), a.ca_file.c_str(), nullptr);
  if (loaded != 1) return fmt::format("TLS: cannot load {}: {}", checked_with, openssl_reason());
  if (!a.cert_file.empty()) {
    if (SSL_CTX_use_certificate_chain_file(ctx.get(), a.cert_file.c_str()) != 1) {
      return fmt::format("TLS: client certificate cert={}: {}", a.cert_file, openssl_reason());
    }
    if (SSL_CTX_use_PrivateKey_file(ctx.get(), a.key_file.c_str(), SSL_FILETYPE_PEM) != 1 ||
        SSL_CTX_check_private_key(ctx.get()) != 1) {
      return fmt::format("TLS: client key key={} (does it belong to cert={}?): {}", a.key_file,
                         a.cert_file, openssl_reason());
    }
  }
  SSL_CTX_set_verify(ctx.get(), SSL_VERIFY_PEER, nullptr);
  const int fd = dial(a.host, a.port);
  if (fd < 0) return fmt::format("TLS error; {}:{} no longer answers", a.host, a.port);
  std::unique_ptr<SSL, decltype(&SSL_free)> ssl(SSL_new(ctx.get()), &SSL_free);
  std::string out;
  if (ssl) {
    X509_VERIFY_PARAM* param = SSL_get0_param(ssl.get());
    in6_addr ip{};
    const bool is_ip = ::inet_pton(AF_INET, a.host.c_str(), &ip) == 1 ||
                       ::inet_pton(AF_INET6, a.host.c_str(), &ip) == 1;
    if (is_ip) {
      X509_VERIFY_PARAM_set1_ip_asc(param, a.host.c_str());
    } else {
      X509_VERIFY_PARAM_set1_host(param, a.host.c_str(), 0);
      SSL_set_tlsext_host_name(ssl.get(), a.host.c_str());
    }
    SSL_set_fd(ssl.get(), fd);
    ERR_clear_error();
    const int rc = SSL_connect(ssl.get());
    const long verify = SSL_get_verify_result(ssl.get());
    if (verify != X509_V_OK) {
      out = fmt::format(
          "TLS: the broker's certificate is refused: {} (checked with {} for host "
          "'{}')",
          X509_verify_cert_error_string(verify), checked_with, a.host);
    } else if (rc != 1) {
      out = fmt::format(
          "TLS handshake failed: {} (is {}:{} a TLS listener? plain MQTT is "
          "mqtt://)",
          openssl_reason(), a.host, a.port);
    } else {
      out = "TLS error after the handshake (the broker refused this client's certificate?)";
    }
    (void)SSL_shutdown(ssl.get());
  }
  ::close(fd);
  return out;
}

const char* nullify(const std::string& s) { return s.empty() ? nullptr : s.c_str(); }

}  // namespace

}  // namespace scaratwin::fleet::detail

namespace scaratwin::fleet {

Status init_mqtt_library() {
  static const int rc = mosquitto_lib_init();
  if (rc != MOSQ_ERR_SUCCESS) {
    return Error{kBadUrl, fmt::format("libmosquitto: {}", mosquitto_strerror(rc))};
  }
  return Ok{};
}

}  // namespace scaratwin::fleet

namespace scaratwin::fleet::detail {

Result<BrokerAddress> load_credentials(BrokerAddress a) {
  if (a.username.empty()) {
    if (const char* u = std::getenv(std::string(kUsernameEnv).c_str()); u != nullptr) {
      a.username = u;
    }
  }
  if (!a.password_file.empty()) {
    std::ifstream in(a.password_file);
    if (!in) {
      return Error{kBadUrl, fmt::format("--mqtt: password-file '{}': {}", a.password_file,
                                        std::strerror(errno))};
    }
    std::getline(in, a.password);
    if (!a.password.empty() && a.password.back() == '\r') a.password.pop_back();
    if (a.password.empty()) {
      return Error{kBadUrl, fmt::format("--mqtt: password-file '{}': its first line is empty",
                                        a.password_file)};
    }
  } else if (const char* p = std::getenv(std::string(kPasswordEnv).c_str()); p != nullptr) {
    a.password = p;
  }
  if (!a.password.empty() && a.username.empty()) {
    return Error{kBadUrl, fmt::format("--mqtt: a password is given but no user: put the user in "
                                      "the URL (mqtt://USER@HOST) or in {}",
                                      kUsernameEnv)};
  }
  if (Status s = readable(a.ca_file, "ca"); !s) return s.error();
  if (Status s = readable(a.cert_file, "cert"); !s) return s.error();
  if (Status s = readable(a.key_file, "key"); !s) return s.error();
  return a;
}

Status configure_client(mosquitto* m, const BrokerAddress& a) {
  if (!a.username.empty()) {
    const int rc = mosquitto_username_pw_set(m, a.username.c_str(),
                                             a.password.empty() ? nullptr : a.password.c_str());
    if (rc != MOSQ_ERR_SUCCESS) {
      return Error{kBadUrl, fmt::format("--mqtt: user: {}", mosquitto_strerror(rc))};
    }
  }
  if (!a.tls) return Ok{};
  // the system's CAs when no ca= is given (libmosquitto then loads OpenSSL's defaults)
  int rc = MOSQ_ERR_SUCCESS;
  if (a.ca_file.empty()) {
    rc = mosquitto_int_option(m, MOSQ_OPT_TLS_USE_OS_CERTS, 1);
    if (rc == MOSQ_ERR_SUCCESS) {
      rc = mosquitto_tls_set(m, nullptr, "/etc/ssl/certs", nullify(a.cert_file),
                             nullify(a.key_file), nullptr);
    }
  } else {
    rc = mosquitto_tls_set(m, a.ca_file.c_str(), nullptr, nullify(a.cert_file), nullify(a.key_file),
                           nullptr);
  }
  if (rc != MOSQ_ERR_SUCCESS) {
    return Error{kBadUrl, fmt::format("--mqtt: TLS settings: {}", mosquitto_strerror(rc))};
  }
  // the peer's certificate and its name are checked (SSL_VERIFY_PEER, not insecure)
  rc = mosquitto_tls_opts_set(m, 1, nullptr, nullptr);
  if (rc == MOSQ_ERR_SUCCESS) rc = mosquitto_tls_insecure_set(m, false);
  if (rc != MOSQ_ERR_SUCCESS) {
    return Error{kBadUrl, fmt::format("--mqtt: TLS settings: {}", mosquitto_strerror(rc))};
  }
  return Ok{};
}

std::string explain_failure(int rc, int saved_errno, const BrokerAddress& a, bool answered) {
  if (rc == MOSQ_ERR_TLS) return probe_tls(a);
  if (rc == MOSQ_ERR_ERRNO) return std::strerror(saved_errno);
  if (rc == MOSQ_ERR_CONN_LOST || rc == MOSQ_ERR_NO_CONN) {
    if (answered) return "connection lost";
    return a.tls ? "the broker closed the connection before answering"
                 : fmt::format(
                       "the broker closed the connection before answering (if {}:{} is "
                       "a TLS listener, use mqtts://)",
                       a.host, a.port);
  }
  return mosquitto_strerror(rc);
}

}  // namespace scaratwin::fleet::detail
