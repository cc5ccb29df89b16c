#pragma once
// Shared helpers for Palpa's tests: named tolerances and access to the shared
// organ meshes, with a clear skip message when they are not present.

#include <gtest/gtest.h>

#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

namespace palpa::test {

/// Tolerances named by what they guard.
inline constexpr double kRoundoff = 1e-12;     ///< double arithmetic on O(1) values
inline constexpr double kFloatRoundoff = 1e-6; ///< float32 stream values

/// Folder of the shared real organ meshes (../shared/data/organs).
inline std::filesystem::path shared_organs_dir() {
  return std::filesystem::path(PALPA_SHARED_DATA_DIR) / "organs";
}

/// The project's own data folder.
inline std::filesystem::path project_data_dir() {
  return std::filesystem::path(PALPA_SOURCE_DIR) / "data";
}

/// True when the shared organs are present; otherwise the caller should
/// GTEST_SKIP() << shared_data_missing_message().
inline bool have_shared_organs() { return std::filesystem::is_directory(shared_organs_dir()); }

inline std::string shared_data_missing_message() {
  return "shared organ meshes not found at " + shared_organs_dir().string() +
         " (../shared/data is not beside this checkout); this test needs them";
}

/// Skips the current test, saying why, when the shared organs are absent.
#define PALPA_REQUIRE_SHARED_ORGANS()                                   \
  do {                                                                  \
    if (!::palpa::test::have_shared_organs())                           \
      GTEST_SKIP() << ::palpa::test::shared_data_missing_message();     \
  } while (0)

/// The folders temp_dir has made in this process, removed when the process
/// exits normally (not by a forked child, whose exit would take them from
/// its parent; a process that is killed leaves them). Set
/// PALPA_KEEP_TEST_FILES to keep them, to look at what a test wrote.
class TempDirs {
 public:
  static TempDirs& instance() {
    static TempDirs dirs;
    return dirs;
  }
  void add(const std::filesystem::path& d) {
    for (const auto& p : paths_)
      if (p == d) return;
    paths_.push_back(d);
  }
  ~TempDirs() {
    if (::getpid() != owner_ || std::getenv("PALPA_KEEP_TEST_FILES") != nullptr) return;
    std::error_code ec;
    for (const auto& p : paths_) std::filesystem::remove_all(p, ec);
  }

 private:
  TempDirs() : owner_(::getpid()) {}
  pid_t owner_;
  std::vector<std::filesystem::path> paths_;
};

/// A fresh empty folder under the system temp dir, for files a test writes,
/// removed when the test process exits (TempDirs).
/// The process id is part of its name: builds in several checkouts on one
/// machine run the same tests at once, and a shared folder let one run
/// delete another's files (PalpaHeadless failed "cannot read PNG" so).
inline std::filesystem::path temp_dir(const std::string& name) {
  auto d = std::filesystem::temp_directory_path() /
           ("palpa_test_" + name + "_" + std::to_string(static_cast<long>(::getpid())));
  std::filesystem::remove_all(d);
  std::filesystem::create_directories(d);
  TempDirs::instance().add(d);
  return d;
}

}  // namespace palpa::test
