// Runs parsed statements (hub/script.hpp) on a connected hub: the CLI one-liners and
// `scaratwin run FILE`. The first failing statement stops the script; its error names the
// line, and nothing after it is sent.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "scaratwin/hub/hub.hpp"
#include "scaratwin/hub/script.hpp"

namespace scaratwin {

// Called after each statement with a line for the user.
using StatementLog = std::function<void(const Statement&, const std::string&)>;

Status execute(Hub& hub, const Statement& statement, const StatementLog& log = nullptr);
Status run_script(Hub& hub, const std::vector<Statement>& script, const std::string& name,
                  const StatementLog& log = nullptr);

}  // namespace scaratwin
