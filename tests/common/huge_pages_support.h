#pragma once
// What the tests of core/huge_pages.h read back from the kernel: the
// system's THP setting and /proc/self/smaps (Linux).

#include "core/huge_pages.h"

#include <cstdint>
#include <fstream>
#include <string>

namespace palpa::test {

using core::kHugePageBytes;

// The address of the first 2 MiB page boundary at or after p.
inline std::uintptr_t first_whole_huge_page(const void* p) {
  const std::uintptr_t a = reinterpret_cast<std::uintptr_t>(p);
  return (a / kHugePageBytes + (a % kHugePageBytes != 0)) * kHugePageBytes;
}

// The whole 2 MiB pages inside [p, p + bytes), in bytes.
inline std::size_t whole_huge_pages(const void* p, std::size_t bytes) {
  const std::uintptr_t first = first_whole_huge_page(p);
  const std::uintptr_t last = (reinterpret_cast<std::uintptr_t>(p) + bytes) / kHugePageBytes * kHugePageBytes;
  return last > first ? last - first : 0;
}

// The system's THP setting ("always", "madvise", "never"), or "" where the
// kernel has no THP. Read here on its own, not with core::huge_page_setting,
// so that the tests check that one against a second reading.
inline std::string thp_setting() {
  std::ifstream in("/sys/kernel/mm/transparent_hugepage/enabled");
  std::string line;
  std::getline(in, line);
  const auto open = line.find('['), close = line.find(']');
  return open != std::string::npos && close != std::string::npos ? line.substr(open + 1, close - open - 1) : "";
}

// AnonHugePages (kB) of the mapping of /proc/self/smaps that holds all of
// [begin, end), or -1 when none does.
inline long huge_kb_of_mapping_holding(std::uintptr_t begin, std::uintptr_t end) {
  std::ifstream in("/proc/self/smaps");
  std::string line;
  bool inside = false;
  while (std::getline(in, line)) {
    const auto dash = line.find('-');
    if (dash != std::string::npos && dash > 0 && line.find_first_not_of("0123456789abcdef") == dash) {
      const auto space = line.find(' ', dash);
      const std::uintptr_t lo = std::stoull(line.substr(0, dash), nullptr, 16);
      const std::uintptr_t hi = std::stoull(line.substr(dash + 1, space - dash - 1), nullptr, 16);
      inside = lo <= begin && end <= hi;
      continue;
    }
    if (inside && line.rfind("AnonHugePages:", 0) == 0) return std::stol(line.substr(14));
  }
  return -1;
}

}  // namespace palpa::test
