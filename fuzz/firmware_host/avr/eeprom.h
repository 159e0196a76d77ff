// The firmware built for the host: the EEPROM as 1 KiB of memory (erased: 0xff).
#pragma once

#include <stddef.h>
#include <stdint.h>

extern uint8_t fw_host_eeprom[1024];

inline void eeprom_read_block(void* dst, const void* src, size_t n) {
  const size_t at = (size_t)(uintptr_t)src;
  for (size_t i = 0; i < n; ++i) ((uint8_t*)dst)[i] = fw_host_eeprom[(at + i) % 1024];
}

inline void eeprom_update_block(const void* src, void* dst, size_t n) {
  const size_t at = (size_t)(uintptr_t)dst;
  for (size_t i = 0; i < n; ++i) fw_host_eeprom[(at + i) % 1024] = ((const uint8_t*)src)[i];
}
