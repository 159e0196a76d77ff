// Included first into every firmware source built for the host (-include). Under clang (the
// libFuzzer build) the firmware's variables go to sections of their own, so that the harness
// can give every input a firmware fresh from reset by copying back their first image
// (firmware_host.cpp); the corpus replay (g++) runs each input in a child process instead.
#pragma once

#if defined(__clang__)
#pragma clang section bss = "fw_host_bss" data = "fw_host_data"
#endif
