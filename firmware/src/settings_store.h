// Settings persistence: the Settings block of settings.h in EEPROM at address 0. A block with
// the wrong version or checksum (blank EEPROM, an older firmware, a corrupted write) is
// replaced by the defaults, which are written back.
#pragma once

#include "settings.h"

namespace fw {

// Loads the stored settings into s; returns false if the defaults had to be used.
bool settings_load(Settings& s);
void settings_save(const Settings& s);

}  // namespace fw
