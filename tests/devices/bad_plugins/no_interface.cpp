// A shared library that is not a device plugin at all.
extern "C" __attribute__((visibility("default"))) int some_other_library_function(void) { return 42; }
