#include "settings_store.h"

#include <avr/eeprom.h>

namespace fw {

bool settings_load(Settings& s) {
  eeprom_read_block(&s, (const void*)0, sizeof(Settings));
  if (settings_valid(s)) return true;
  settings_defaults(s);
  settings_save(s);
  return false;
}

void settings_save(const Settings& s) { eeprom_update_block(&s, (void*)0, sizeof(Settings)); }

}  // namespace fw
