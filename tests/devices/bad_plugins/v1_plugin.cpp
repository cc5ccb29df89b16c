// A complete plugin of interface palpa.device/1 (every entry point of that
// version, no palpa_device_options): the host of palpa.device/2 must refuse
// it by its version, naming both, before it looks for anything else.
#include <stddef.h>
#include <stdint.h>

#define EXPORT extern "C" __attribute__((visibility("default")))
struct PalpaDevice;
struct PalpaDeviceSpec;
struct PalpaDeviceSample;
struct PalpaForceCommand;
EXPORT const char* palpa_device_interface(void) { return "palpa.device/1"; }
EXPORT PalpaDevice* palpa_device_create(const char*, char*, size_t) { return nullptr; }
EXPORT void palpa_device_destroy(PalpaDevice*) {}
EXPORT int palpa_device_spec(PalpaDevice*, PalpaDeviceSpec*) { return 0; }
EXPORT int palpa_device_start(PalpaDevice*, char*, size_t) { return 0; }
EXPORT void palpa_device_stop(PalpaDevice*) {}
EXPORT int palpa_device_read(PalpaDevice*, PalpaDeviceSample*) { return 0; }
EXPORT int palpa_device_write(PalpaDevice*, const PalpaForceCommand*) { return 0; }
EXPORT int palpa_device_message(PalpaDevice*, char*, size_t) { return 0; }
