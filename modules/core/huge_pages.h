#pragma once
// Transparent huge pages for the large arrays the tick and the step read
// at random (per vertex and per triangle, tens of MB at 1M vertices). With
// 4 KiB pages a 1M-vertex organ spans tens of thousands of pages, far more
// than the processor's translation cache holds, so a tick that reads a few
// vertices here and there also waits on page-table walks; 2 MiB pages cut
// the pages to a few hundred (docs/PERFORMANCE.md, round 37).
//
// Linux only; elsewhere, where the system's setting is "never", or where the
// kernel refuses, nothing happens. The contents never change: this only asks
// how they are mapped.

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace palpa::core {

/// The huge page size asked for (bytes): 2 MiB, x86-64's and AArch64's usual.
inline constexpr std::size_t kHugePageBytes = std::size_t{2} << 20;

/// What prefer_huge_pages asked and got, in bytes.
struct HugePageAdvice {
  std::size_t advised = 0;    ///< bytes: the whole 2 MiB pages inside the range, given MADV_HUGEPAGE
  std::size_t collapsed = 0;  ///< bytes: of those, what MADV_COLLAPSE put in huge pages at once (all or none)
};

/// The system's transparent huge page setting, the word in brackets in
/// /sys/kernel/mm/transparent_hugepage/enabled ("always", "madvise" or
/// "never"); "" where the kernel has none or not Linux. Reads the file.
inline std::string huge_page_setting() {
#if defined(__linux__)
  std::FILE* f = std::fopen("/sys/kernel/mm/transparent_hugepage/enabled", "r");
  if (f == nullptr) return "";
  char line[128] = {};
  const bool read = std::fgets(line, sizeof line, f) != nullptr;
  std::fclose(f);
  const char* open = read ? std::strchr(line, '[') : nullptr;
  const char* close = open != nullptr ? std::strchr(open, ']') : nullptr;
  return close != nullptr ? std::string(open + 1, close) : "";
#else
  return "";
#endif
}

/// Whether the system's administrator allows transparent huge pages: false
/// where huge_page_setting() is "never" (the kernel would still collapse on
/// request, but the setting says not to) or the kernel has none. Read once
/// per process.
inline bool huge_pages_allowed() {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
  static const bool allowed = [] {
    const std::string setting = huge_page_setting();
    return !setting.empty() && setting != "never";
  }();
  return allowed;
#else
  return false;
#endif
}

/// Asks the kernel to map the whole 2 MiB pages inside [data, data + bytes)
/// with transparent huge pages (madvise MADV_HUGEPAGE), and to do it now
/// (MADV_COLLAPSE, Linux 6.1 and later; older kernels leave it to their
/// background thread, khugepaged). `advised` is 0 when the range holds no
/// whole huge page, huge_pages_allowed() is false, or the kernel refused
/// the advice (or not Linux); `collapsed` is 0 when the collapse was refused
/// (an older kernel, or no free huge page). The contents are never changed.
/// Takes milliseconds per hundred MB (the collapse copies): call it where
/// an array is made, before another thread reads it, never on the haptic
/// thread.
inline HugePageAdvice prefer_huge_pages(const void* data, std::size_t bytes) {
  HugePageAdvice advice;
#if defined(__linux__) && defined(MADV_HUGEPAGE)
  if (data == nullptr || !huge_pages_allowed()) return advice;
  const auto begin = reinterpret_cast<std::uintptr_t>(data);
  const std::uintptr_t mask = ~std::uintptr_t{kHugePageBytes - 1};
  const std::uintptr_t first = (begin + kHugePageBytes - 1) & mask;
  const std::uintptr_t last = (begin + bytes) & mask;
  if (last <= first) return advice;
  void* start = reinterpret_cast<void*>(first);
  const std::size_t length = last - first;
  if (madvise(start, length, MADV_HUGEPAGE) != 0) return advice;
  advice.advised = length;
#if defined(MADV_COLLAPSE)
  constexpr int kCollapse = MADV_COLLAPSE;
#else
  constexpr int kCollapse = 25;  // MADV_COLLAPSE in Linux's uapi (6.1), newer than some libc headers
#endif
  if (madvise(start, length, kCollapse) == 0) advice.collapsed = length;
#else
  (void)data;
  (void)bytes;
#endif
  return advice;
}

/// prefer_huge_pages over a vector's elements (bytes: size() * sizeof(T)).
template <class T, class A>
HugePageAdvice prefer_huge_pages(const std::vector<T, A>& v) {
  return prefer_huge_pages(v.data(), v.size() * sizeof(T));
}

}  // namespace palpa::core
