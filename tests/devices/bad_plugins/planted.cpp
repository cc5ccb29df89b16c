// A planted library: its constructor runs at dlopen, before any entry point
// is looked at. It creates the file named by $PALPA_TEST_PLANTED_MARKER, so a
// test can tell whether the loader let any of its code run.
#include <cstdio>
#include <cstdlib>

__attribute__((constructor)) static void planted_constructor() {
  if (const char* marker = std::getenv("PALPA_TEST_PLANTED_MARKER"))
    if (std::FILE* f = std::fopen(marker, "w")) std::fclose(f);
}

extern "C" __attribute__((visibility("default"))) const char* palpa_device_interface(void) {
  return "palpa.device/0";
}
