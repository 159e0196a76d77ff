// What the fleet's two broker clients (mqtt_bridge.cpp, fleet_watch.cpp) share to reach a
// broker: the credentials read from outside the URL, TLS set up on a libmosquitto client, and a
// failed connection said in words a user can act on (docs/fleet.md, "A broker over TLS").
#pragma once

#include <string>

#include "scaratwin/core/result.hpp"
#include "scaratwin/fleet/topics.hpp"

struct mosquitto;

namespace scaratwin::fleet::detail {

// The address with its secrets: the password from `password_file` (its first line), else from
// $SCARATWIN_MQTT_PASSWORD; the user from $SCARATWIN_MQTT_USERNAME when the URL names none.
// The TLS files must be readable. Errors (kBadUrl) name the file or variable and why; none
// holds the password.
Result<BrokerAddress> load_credentials(BrokerAddress a);

// Applies the credentials and, for mqtts://, TLS (peer and host name checked) to a client.
Status configure_client(mosquitto* m, const BrokerAddress& a);

// Words for libmosquitto's code `rc` from a connection that failed or was lost. `answered`:
// the broker had sent its CONNACK on this connection. A TLS failure is probed again with
// OpenSSL alone to name the certificate's problem (expired, unknown CA, another host); a
// plain connection closed before any answer suggests a TLS port.
std::string explain_failure(int rc, int saved_errno, const BrokerAddress& a, bool answered);

}  // namespace scaratwin::fleet::detail
