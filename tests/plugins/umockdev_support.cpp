#include "umockdev_support.h"

#include <fcntl.h>
#include <unistd.h>

#include <cstdlib>
#include <cstring>
#include <stdexcept>

namespace palpa::test {

bool umockdev_preloaded() {
  const char* p = std::getenv("LD_PRELOAD");
  return p != nullptr && std::strstr(p, "libumockdev-preload") != nullptr;
}

std::filesystem::path fixture_dir() { return PALPA_FIXTURE_DIR; }

Testbed::Testbed() : tb_(umockdev_testbed_new()) {}

Testbed::~Testbed() {
  if (tb_ != nullptr) g_object_unref(tb_);
}

void Testbed::add_from_file(const std::filesystem::path& file) {
  GError* error = nullptr;
  if (!umockdev_testbed_add_from_file(tb_, file.c_str(), &error)) {
    const std::string m = file.string() + ": " + (error ? error->message : "unknown error");
    if (error) g_error_free(error);
    throw std::runtime_error(m);
  }
}

void Testbed::load_script(const std::string& devnode, const std::filesystem::path& script) {
  GError* error = nullptr;
  if (!umockdev_testbed_load_script(tb_, devnode.c_str(), script.c_str(), &error)) {
    const std::string m = script.string() + ": " + (error ? error->message : "unknown error");
    if (error) g_error_free(error);
    throw std::runtime_error(m);
  }
}

void Testbed::attach_ioctl(const std::string& devnode, UMockdevIoctlBase* handler) {
  GError* error = nullptr;
  if (!umockdev_testbed_attach_ioctl(tb_, devnode.c_str(), handler, &error)) {
    const std::string m = devnode + ": " + (error ? error->message : "unknown error");
    if (error) g_error_free(error);
    throw std::runtime_error(m);
  }
}

void Testbed::remove_device(const std::string& syspath) { umockdev_testbed_remove_device(tb_, syspath.c_str()); }

// The testbed keeps the device end of a scripted node; pointing that
// descriptor at /dev/null drops the connection (the client sees POLLHUP)
// and leaves the testbed a valid descriptor to close later.
void Testbed::hang_up(const std::string& devnode) {
  const int fd = umockdev_testbed_get_dev_fd(tb_, devnode.c_str());
  if (fd < 0) throw std::runtime_error(devnode + ": not a scripted device node");
  const int null_fd = open("/dev/null", O_RDWR | O_CLOEXEC);
  dup2(null_fd, fd);
  close(null_fd);
}

}  // namespace palpa::test
