// A plugin built against an older interface: only the version entry point
// matters (the loader checks it before anything else).
extern "C" __attribute__((visibility("default"))) const char* palpa_device_interface(void) {
  return "palpa.device/0";
}
