// A plugin of the right version that lacks palpa_device_read.
#include "devices/plugin_api.h"

#define EXPORT extern "C" __attribute__((visibility("default")))
EXPORT const char* palpa_device_interface(void) { return PALPA_DEVICE_INTERFACE; }
EXPORT const PalpaDeviceOption* palpa_device_options(size_t* count) {
  *count = 0;
  return nullptr;
}
EXPORT PalpaDevice* palpa_device_create(const char*, char*, size_t) { return nullptr; }
EXPORT void palpa_device_destroy(PalpaDevice*) {}
EXPORT int palpa_device_spec(PalpaDevice*, PalpaDeviceSpec*) { return PALPA_DEVICE_OK; }
EXPORT int palpa_device_start(PalpaDevice*, char*, size_t) { return PALPA_DEVICE_OK; }
EXPORT void palpa_device_stop(PalpaDevice*) {}
EXPORT int palpa_device_write(PalpaDevice*, const PalpaForceCommand*) { return PALPA_DEVICE_OK; }
EXPORT int palpa_device_message(PalpaDevice*, char*, size_t) { return PALPA_DEVICE_OK; }
